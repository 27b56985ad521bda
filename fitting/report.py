"""One typed row per estimated parameter, shared by the reports (`stickslip fit`,
`stickslip mcmc`): dicts only when writing JSON.

`ParameterEstimate(name, unit, value, stderr, ci95, fixed, identifiable, truth)`: units are
the internal ones (`AbstractFrictionParams.UNITS`); `stderr` and `ci95` are None for a
fixed or unidentifiable parameter; `truth` only when the records carry the values they
were made from.
"""

from __future__ import annotations

import dataclasses

__all__ = ["ParameterEstimate"]


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

    def to_json(self) -> dict:
        """The entry of a report's "parameters" (keys of the `--json` contract)."""
        out = {"value": self.value, "stderr": self.stderr,
               "ci95": None if self.ci95 is None else [self.ci95[0], self.ci95[1]],
               "unit": self.unit, "identifiable": self.identifiable, "fixed": self.fixed}
        if self.truth is not None:
            out["truth"] = self.truth
            out["relative_error"] = self.relative_error
            if self.ci95 is not None:
                out["truth_in_ci95"] = self.truth_in_ci95
        return out
