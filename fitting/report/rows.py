"""One typed row per estimated parameter, shared by the reports (`stickslip fit`, `mcmc`,
`pitch`, `discover`, `plan`): dicts only when writing JSON.

`ParameterEstimate`: units are the internal ones (`AbstractFrictionParams.UNITS`);
`stderr` and `ci95` are None for a fixed or unidentifiable parameter, or where only a
value is reported; `truth` only when the records carry the values they were made from;
`log_sd` the standard deviation of log(value) for an estimate made in log coordinates
(`from_log`); `reason` why the data do not determine it; `bounds` (low, high) its
support, when it has one (`PRIOR_BOUNDS`).

**Unknowns look unknown.** A free parameter the data do not determine keeps the
optimiser's last point in `value` (a placeholder for code that restarts from it), but
JSON writes `"value": null` with `"identifiable": false` and `"reason"`, and tables and
figures show "-" with the reason (`value_text`, `note_text`). A value within a relative
1e-6 of a bound of its support is "at bound": its standard error says nothing about the
parameter, only about the bound.
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["DiscoveryEstimates", "ParameterEstimate", "Z95", "estimate_text", "note_text",
           "text_table", "value_text"]

Z95 = 1.959963984540054
"""The standard normal's 97.5 % quantile (two-sided 95 % intervals)."""


@dataclasses.dataclass(frozen=True)
class ParameterEstimate:
    """One parameter's estimate (module doc)."""

    name: str
    unit: str
    value: float
    stderr: float | None
    ci95: tuple[float, float] | None
    fixed: bool = False
    identifiable: bool = True
    truth: float | None = None
    log_sd: float | None = None
    reason: str | None = None
    bounds: tuple[float, float] | None = None

    @classmethod
    def from_log(cls, name: str, unit: str, log_value: float, log_sd: float | None = None,
                 **kwargs) -> ParameterEstimate:
        """An estimate made in log coordinates: value exp(u), stderr value * sd (first
        order), 95 % interval exp(u -+ Z95 sd) (asymmetric); no sd: a value only."""
        u = float(log_value)
        value = float(np.exp(u))
        if log_sd is None:
            return cls(name=name, unit=unit, value=value, stderr=None, ci95=None, **kwargs)
        s = float(log_sd)
        return cls(name=name, unit=unit, value=value, stderr=value * s,
                   ci95=(float(np.exp(u - Z95 * s)), float(np.exp(u + Z95 * s))),
                   log_sd=s, **kwargs)

    @classmethod
    def from_normal(cls, name: str, unit: str, value: float, sd: float | None = None,
                    **kwargs) -> ParameterEstimate:
        """An estimate with a Gaussian error: stderr sd, 95 % interval value -+ Z95 sd; no
        sd: a value only."""
        value = float(value)
        if sd is None:
            return cls(name=name, unit=unit, value=value, stderr=None, ci95=None, **kwargs)
        s = float(sd)
        return cls(name=name, unit=unit, value=value, stderr=s,
                   ci95=(value - Z95 * s, value + Z95 * s), **kwargs)

    @property
    def determined(self) -> bool:
        """The value means something: identifiable from the data, or fixed (given)."""
        return bool(self.identifiable or self.fixed)

    @property
    def at_bound(self) -> str | None:
        """"lower" or "upper" when the value lies within a relative 1e-6 of that bound of
        `bounds` (beyond it counts too), None otherwise or without bounds."""
        if self.bounds is None or self.fixed or not self.determined:
            return None
        lo, hi = (float(b) for b in self.bounds)
        tol = 1e-6 * max(abs(lo), abs(hi), hi - lo)
        if self.value <= lo + tol:
            return "lower"
        if self.value >= hi - tol:
            return "upper"
        return None

    def with_bounds(self, bounds: dict | None) -> ParameterEstimate:
        """This row with the support `bounds[name]` ({name: (low, high)}) when given."""
        if not bounds or self.name not in bounds:
            return self
        lo, hi = bounds[self.name]
        return dataclasses.replace(self, bounds=(float(lo), float(hi)))

    @property
    def relative_error(self) -> float | None:
        if self.truth is None or not self.determined:
            return None
        return (self.value - self.truth) / self.truth

    @property
    def truth_in_ci95(self) -> bool | None:
        if self.truth is None or self.ci95 is None:
            return None
        return bool(self.ci95[0] <= self.truth <= self.ci95[1])

    def with_truth(self, truth: dict | None) -> ParameterEstimate:
        return self if not truth else dataclasses.replace(self, truth=float(truth[self.name]))

    def to_json(self, keys: tuple[str, ...] | None = None) -> dict:
        """The entry of a report's "parameters" (keys of the `--json` contract); `keys`:
        only these, in this order. A parameter the data do not determine has "value" null
        and a "reason"; "reason" is null for a determined one, and says so for a value at
        a bound ("at_bound" true)."""
        if keys is not None:
            full = self.to_json()
            return {k: full[k] for k in keys}
        side = self.at_bound
        if not self.determined:
            reason = "not identifiable: " + (self.reason or "the data do not determine it")
        elif side is not None:
            b = self.bounds[0 if side == "lower" else 1]
            reason = f"at the {side} bound {b:g} of its support"
        else:
            reason = None
        out = {"value": self.value if self.determined else None, "stderr": self.stderr,
               "ci95": None if self.ci95 is None else [self.ci95[0], self.ci95[1]],
               "unit": self.unit, "identifiable": self.identifiable, "fixed": self.fixed,
               "reason": reason, "at_bound": side is not None}
        if self.truth is not None:
            out["truth"] = self.truth
            out["relative_error"] = self.relative_error  # null without a value
            if self.ci95 is not None:
                out["truth_in_ci95"] = self.truth_in_ci95
        return out


class DiscoveryEstimates:
    """Mixin of the discovery results (`stickslip discover`): the dicts of the `--json`
    contract derived from typed rows. The result dataclass holds `estimates_before` and
    `estimates_after` (the friction parameters of the base fit and of the final fit;
    values only on the smoothed base), `effect_estimates` (the refitted effect's
    parameters, unprefixed names) and `effect_of` (that effect's name)."""

    EFFECT_KEYS = ("value", "stderr", "unit")
    """The keys of an `effect_size` entry."""

    @staticmethod
    def value_rows(values: dict[str, float], units: dict[str, str]) -> list[ParameterEstimate]:
        """Rows of values only ({name: value}, units by name)."""
        return [ParameterEstimate.from_normal(n, units[n], v) for n, v in values.items()]

    def estimates(self) -> list[ParameterEstimate]:
        """The rows after: the friction parameters, then the effect's as "effect.name"."""
        return list(self.estimates_after) + [
            dataclasses.replace(e, name=f"{self.effect_of}.{e.name}")
            for e in self.effect_estimates]

    @property
    def parameters_before(self) -> dict[str, float | None]:
        """{name: value}, null for a value the data do not determine."""
        return {e.name: e.to_json()["value"] for e in self.estimates_before}

    @property
    def parameters_after(self) -> dict[str, float | None]:
        return {e.name: e.to_json()["value"] for e in self.estimates()}

    @property
    def effect_size(self) -> dict[str, dict]:
        return {e.name: e.to_json(self.EFFECT_KEYS) for e in self.effect_estimates}


def estimate_text(e: ParameterEstimate) -> str:
    """"name = value +- stderr unit", "name = value unit (at bound)" or "name = -
    (reason)" for a value the data do not determine: never "+- 0"."""
    unit = f" {e.unit}" if e.unit and e.unit != "-" else ""
    if not e.determined:  # the reason's head: "no standard error", "the fit left ..."
        return f"{e.name} = - ({(e.reason or 'not identifiable').split(':')[0]})"
    if e.at_bound is not None:
        return f"{e.name} = {e.value:.3g}{unit} (at bound)"
    if e.stderr is None or not e.stderr > 0:
        return f"{e.name} = - (no standard error)"
    return f"{e.name} = {e.value:.3g} +- {e.stderr:.2g}{unit}"


def value_text(entry: dict, fmt: str = ".5g") -> str:
    """A parameter's value for a text table, from its JSON entry (`ParameterEstimate.
    to_json`): "-" when it has none (not identifiable), else formatted with `fmt`."""
    v = entry.get("value")
    return "-" if v is None else format(float(v), fmt)


def note_text(entry: dict) -> str:
    """What a table says beside a parameter's value (its JSON entry): "fixed", the reason
    it is not identifiable ("not identifiable: ..."), "at lower/upper bound B", or ""."""
    if entry.get("fixed"):
        return "fixed"
    if entry.get("value") is None or not entry.get("identifiable", True):
        reason = entry.get("reason") or "not identifiable"
        return reason if reason.startswith("not identifiable") else \
            "not identifiable: " + reason
    if entry.get("at_bound"):
        return (entry.get("reason") or "at bound").replace("at the ", "at ").replace(
            " of its support", "")
    return ""


def text_table(header, rows, align: str | None = None) -> str:
    """Lines of a table: columns padded to their widest cell and separated by two spaces,
    `align` one letter per column ("l", "r"; default: the first left, the others right),
    a rule of dashes under the header. Runs of spaces inside a cell collapse to one, so a
    row splits back into its cells at two spaces or more."""
    import re

    def clean(c) -> str:
        return re.sub(r"\s{2,}", " ", str(c)).strip()

    header = [clean(h) for h in header]
    rows = [[clean(c) for c in r] for r in rows]
    ncol = len(header)
    if any(len(r) != ncol for r in rows):
        raise ValueError(f"every row needs {ncol} cells (the header's)")
    align = align or "l" + "r" * (ncol - 1)
    if len(align) != ncol:
        raise ValueError(f"align needs one letter per column ({ncol})")
    widths = [max(len(c) for c in col) for col in zip(header, *rows)]

    def line(cells) -> str:
        return "  ".join(c.ljust(w) if a == "l" else c.rjust(w)
                         for c, w, a in zip(cells, widths, align)).rstrip()

    out = [line(header), "-" * (sum(widths) + 2 * (ncol - 1))]
    out += [line(r) for r in rows]
    return "\n".join(out)
