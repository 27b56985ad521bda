"""One typed row per estimated parameter, shared by the reports (`stickslip fit`, `mcmc`,
`pitch`, `discover`, `plan`): dicts only when writing JSON.

`ParameterEstimate(name, unit, value, stderr, ci95, fixed, identifiable, truth, log_sd)`:
units are the internal ones (`AbstractFrictionParams.UNITS`); `stderr` and `ci95` are None
for a fixed or unidentifiable parameter, or where only a value is reported (discovery's
parameters); `truth` only when the records carry the values they were made from;
`log_sd` the standard deviation of log(value) (a relative error) for an estimate made in
log coordinates (`from_log`: pitching, `stickslip plan`).

- `ParameterEstimate.from_log(name, unit, u, sd)`: value exp(u), interval
  exp(u -+ 1.96 sd); `from_normal(name, unit, value, sd)`: value -+ 1.96 sd.
- `to_json()`: the fit report's entry; `to_json(keys)` only those keys (e.g. discovery's
  effect sizes: value, stderr, unit).
- `DiscoveryEstimates`: the rows of the discovery results and the dicts of their JSON.
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["DiscoveryEstimates", "ParameterEstimate", "Z95"]

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
    def relative_error(self) -> float | None:
        return None if self.truth is None else (self.value - self.truth) / self.truth

    @property
    def truth_in_ci95(self) -> bool | None:
        if self.truth is None or self.ci95 is None:
            return None
        return bool(self.ci95[0] <= self.truth <= self.ci95[1])

    def with_truth(self, truth: dict | None) -> ParameterEstimate:
        return self if not truth else dataclasses.replace(self, truth=float(truth[self.name]))

    def to_json(self, keys: tuple[str, ...] | None = None) -> dict:
        """The entry of a report's "parameters" (keys of the `--json` contract); `keys`:
        only these, in this order."""
        if keys is not None:
            full = self.to_json()
            return {k: full[k] for k in keys}
        out = {"value": self.value, "stderr": self.stderr,
               "ci95": None if self.ci95 is None else [self.ci95[0], self.ci95[1]],
               "unit": self.unit, "identifiable": self.identifiable, "fixed": self.fixed}
        if self.truth is not None:
            out["truth"] = self.truth
            out["relative_error"] = self.relative_error
            if self.ci95 is not None:
                out["truth_in_ci95"] = self.truth_in_ci95
        return out


class DiscoveryEstimates:
    """Mixin of the discovery results (`stickslip discover`): the parameter rows are typed,
    the dicts of the `--json` contract are derived from them.

    The result dataclass holds `estimates_before` and `estimates_after` (the friction
    parameters of the base fit and of the final fit, values only), `effect_estimates`
    (the refitted effect's parameters, unprefixed names, with standard errors and units)
    and `effect_of` (that effect's name)."""

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
    def parameters_before(self) -> dict[str, float]:
        return {e.name: e.value for e in self.estimates_before}

    @property
    def parameters_after(self) -> dict[str, float]:
        return {e.name: e.value for e in self.estimates()}

    @property
    def effect_size(self) -> dict[str, dict]:
        return {e.name: e.to_json(self.EFFECT_KEYS) for e in self.effect_estimates}
