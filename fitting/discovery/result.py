"""The result of a discovery: `Discovery` and its final subclasses `CycleDiscovery` and
`SmoothDiscovery` (one per base), their JSON (`stickslip discover --json`) and texts."""

from __future__ import annotations

import abc
import dataclasses
from typing import ClassVar

import numpy as np

from stickslip_jax.lsq import LeastSquaresSolution as Solution

from ..data.campaign import Campaign
from ..modes import DiscoveryBase
from ..report.rows import DiscoveryEstimates, ParameterEstimate, estimate_text
from .cycle_effects import Shape
from .cycle_learned import CycleLearned
from .cycle_model import CycleModel
from .options import DEFAULTS

__all__ = ["NO_STDERR", "CycleDiscovery", "Discovery", "SmoothDiscovery", "effect_estimate",
           "effect_rows", "estimate_text", "friction_rows", "phase_misfit", "phase_text",
           "steps_text"]

FIT_CRITERION = ("converged when a full Gauss-Newton step would lower chi-square by < 0.05, "
                 "or the last 4 accepted steps lowered it by < 0.5 together")
"""When the base fit counts as converged (`subproblems.AbstractProblem.solve`'s defaults)."""


@dataclasses.dataclass(kw_only=True)
class Discovery(DiscoveryEstimates, abc.ABC):
    """The answer of `stickslip discover`: the `effect` named (a name, "none" or
    "unexplained"), its `confidence` and `explanation`, the gaps (residual RMS, mm)
    before and after against the `noise` (mm), the `candidates` tested, the fits and the
    parameter rows (`report.rows.ParameterEstimate`). `to_json` is the `--json` contract:
    the keys of every base, with the base's own (`base_json`) after "effect_size"."""

    effect: str
    explanation: str
    confidence: str
    gap_before: float
    gap_after: float
    noise: float
    criterion: str
    candidates: list
    estimates_before: list[ParameterEstimate]
    estimates_after: list[ParameterEstimate]
    effect_estimates: list[ParameterEstimate]
    timings: dict
    base_fit: Solution
    final_fit: Solution
    indistinguishable_from: list = dataclasses.field(default_factory=list)
    effect_of: str = ""
    learned: object = None
    """The learned correction, where one was fitted (None otherwise)."""
    BASE: ClassVar[DiscoveryBase]
    """The base model (its value the document's "base": "cycle" or "smooth")."""

    @abc.abstractmethod
    def base_json(self) -> dict:
        """The keys of this base's document after "effect_size"."""

    @abc.abstractmethod
    def figure(self):
        """The figure of `stickslip discover --plot` (`discovery.plots`)."""

    def gaps_json(self) -> dict:
        """The keys of this base's document after "gap_unit"."""
        return {}

    def to_json(self) -> dict:
        return {
            "effect": self.effect, "explanation": self.explanation,
            "confidence": self.confidence,
            "indistinguishable_from": self.indistinguishable_from, "base": self.BASE.value,
            "base_fit": {"converged": self.base_fit.converged,
                         "evaluations": self.base_fit.n_evals, "criterion": FIT_CRITERION},
            "final_fit": {"converged": self.final_fit.converged,
                          "evaluations": self.final_fit.n_evals},
            "gap_before": self.gap_before, "gap_after": self.gap_after, "gap_unit": "mm",
            **self.gaps_json(), "noise": self.noise, "criterion": self.criterion,
            "candidates": self.candidates,
            "parameters_before": self.parameters_before,
            "parameters_after": self.parameters_after,
            **{f"estimates_{when}": {e.name: e.to_json() for e in rows} for when, rows in
               (("before", self.estimates_before), ("after", self.estimates()))},
            "effect_size": self.effect_size, **self.base_json(), "timings_s": self.timings,
        }


@dataclasses.dataclass(kw_only=True)
class CycleDiscovery(Discovery):
    """The answer on the per-cycle base: with the residuals by phase, the `campaign`, the
    `model` and its coordinates before and after, the records weighed by their scatter
    and the windows set aside; `learned`: the phase correction (`CycleLearned`), if any."""

    phases_before: dict
    phases_after: dict
    campaign: Campaign
    model: CycleModel
    z_before: np.ndarray
    z_after: np.ndarray
    shape: Shape
    sensor: bool
    records_scaled: list = dataclasses.field(default_factory=list)
    windows_set_aside: list = dataclasses.field(default_factory=list)
    learned: CycleLearned | None = None
    sparse_form: object = None
    """The sparse form of the residual (`sparse.SparseForm`), where one was fitted."""
    misfit_left: object = None
    """The misfit the final model leaves by phase and form (`misfit.MisfitLeft`), where
    it leaves more than `misfit.LEFT` x the noise."""
    gap_all_before: float = float("nan")
    gap_all_after: float = float("nan")
    """The residual RMS (mm) over every record used, `records_scaled` included
    (`gap_before`, `gap_after`: over the records the decision uses)."""
    steps: list = dataclasses.field(default_factory=list)
    """The sequential search's staircase (`Step.to_json`): every effect named, in order,
    with its values, the gap after it, its family-wise p-value and confidence. With
    several kept, `effect` is the first; the others' parameters (`more_estimates`,
    "family.parameter") follow its in `parameters_after`."""
    more_estimates: list = dataclasses.field(default_factory=list)
    BASE: ClassVar[DiscoveryBase] = DiscoveryBase.CYCLE

    def estimates(self) -> list[ParameterEstimate]:
        return super().estimates() + list(self.more_estimates or ())

    @property
    def effect_size(self) -> dict[str, dict]:
        """The named effect's parameters: `EFFECT_KEYS`, "at_bound" (an end of its
        physical range, `Family.support`) and the "reason" (value null: undetermined)."""
        return {e.name: e.to_json(self.EFFECT_KEYS + ("at_bound", "reason"))
                for e in self.effect_estimates}

    def figure(self):
        from .plots import plot_cycle_discovery

        return plot_cycle_discovery(self)

    def gaps_json(self) -> dict:
        return {"gap_all_records_before_mm": self.gap_all_before,
                "gap_all_records_after_mm": self.gap_all_after}

    def base_json(self) -> dict:
        return {"residuals_by_phase_before": self.phases_before,
                "residuals_by_phase_after": self.phases_after,
                "records": [s.to_json() for s in self.campaign.screening],
                "records_scaled": self.records_scaled,
                "windows_set_aside": self.windows_set_aside,
                "learned_correction": (self.learned.to_json() if self.learned is not None
                                       else None),
                "sparse_form": (self.sparse_form.to_json() if self.sparse_form is not None
                                else None),
                "misfit_left": (self.misfit_left.to_json() if self.misfit_left is not None
                                else None),
                "steps": self.steps}


@dataclasses.dataclass(kw_only=True)
class SmoothDiscovery(Discovery):
    """The answer on the smoothed base: with the residual analyses before and after, the
    problems of the base and final fits, the `campaign`; `learned`: the MLP correction."""

    residuals_before: object
    residuals_after: object
    test_before: dict  # the misspecification test of the base fit's residuals
    test_after: dict  # ... of the final fit's
    base_problem: object
    final_problem: object
    campaign: Campaign
    BASE: ClassVar[DiscoveryBase] = DiscoveryBase.SMOOTH

    def figure(self):
        from .plots import plot_discovery

        return plot_discovery(self)

    def base_json(self) -> dict:
        out = {"misspecification_before": self.test_before,
               "misspecification_after": self.test_after,
               "residuals_by_phase_before": self.residuals_before.phases,
               "residuals_by_phase_after": self.residuals_after.phases,
               "records_screened": [s.to_json() for s in self.campaign.screening]}
        if self.learned is not None:
            out["learned_correction"] = self.learned.to_json()
        return out


NO_STDERR = ("no standard error: the refit's derivatives do not determine it (the "
             "covariance gives it no variance)")


def effect_estimate(name: str, unit: str, value: float, stderr: float,
                    bounds: tuple[float, float]) -> ParameterEstimate:
    """A named effect's parameter with its physical range (`Family.support`); a standard
    error of zero or none (a direction the Jacobian does not see) leaves the value
    undetermined (`NO_STDERR`) unless it sits on an end of the range."""
    s = float(stderr)
    if np.isfinite(s) and s > 0:
        return ParameterEstimate.from_normal(name, unit, value, s, bounds=bounds)
    at = ParameterEstimate.from_normal(name, unit, value, None, bounds=bounds)
    if at.at_bound is not None:  # the value the range stopped at: said as such
        return at
    return dataclasses.replace(at, identifiable=False, reason=NO_STDERR)


def effect_rows(refit, G: int) -> list[ParameterEstimate]:
    """The parameters of an effect fitted in a refit or a step (per record: `name[g]`
    over the `G` records), each with its physical range (`effect_estimate`)."""
    if refit is None:
        return []
    f = refit.family
    params, f_units = f.named(refit.shape)
    names = ([f"{p}[{i}]" for i in range(G) for p in params] if f.per_record
             else list(params))
    reps = G if f.per_record else 1
    units = [u for _ in range(reps) for u in f_units]
    support = [b for _ in range(reps) for b in f.support()]
    return [effect_estimate(nm, u, v, s, b)
            for nm, v, s, u, b in zip(names, refit.values, refit.stderr, units, support)]


def friction_rows(fit: Solution, features, clusters, *, chi2: float,
                  dof: int) -> list[ParameterEstimate]:
    """The friction parameters of a per-cycle fit (its first six coordinates are the
    `EmpiricalFriction` logs) with the one covariance path (`uncertainty.laplace`: the
    cluster-robust sandwich, `clusters` = (record, window) of every data residual, the
    other coordinates marginalised; `chi2` over `dof` for its warnings). A value the
    records do not determine is a row without one: "-" and the reason."""
    from ..modes import Covariance
    from ..params import CampaignParams, EmpiricalFriction
    from ..solve.fit import FitResult
    from ..uncertainty.laplace import LogJacobian, laplace

    z, J = np.asarray(fit.z, float), np.array(fit.J, float)
    friction = EmpiricalFriction(*z[:6])
    values = np.asarray(friction.values(), float)
    if not (np.all(np.isfinite(J)) and np.all(np.isfinite(fit.r))):  # no covariance
        return [ParameterEstimate(name, friction.UNITS[name], float(v), None, None,
                                  identifiable=False, reason="the fit's derivatives are "
                                  "not finite") for name, v in zip(friction.NAMES, values)]
    mu_s, mu_d = values[:2]
    # (log mu_d, log(mu_s - mu_d)) -> laplace's coordinates (log mu_s, log mu_d)
    J[:, :2] = np.stack([J[:, 1] * mu_s / (mu_s - mu_d),
                         J[:, 0] - J[:, 1] * mu_d / (mu_s - mu_d)], axis=1)
    extra = J.shape[0] - len(clusters[0])  # a prior's rows: in no cluster
    record, window = (np.r_[np.asarray(c), -np.ones(extra, int)] for c in clusters)
    as_fit = FitResult(params=CampaignParams(friction, np.zeros(0)), spec=None, data=None,
                       features=list(features), chi2=float(chi2), dof=int(dof),
                       result=fit.result, converged=fit.converged,
                       n_steps=fit.n_evals, slip_time=None)
    return laplace(as_fit, covariance=Covariance.SANDWICH, jacobian=LogJacobian(
        J, np.asarray(fit.r, float), np.ones(6, bool), np.arange(6), values, record,
        window)).estimates()


def phase_text(phases: dict, noise: float, explained_gap: float = DEFAULTS.explained_gap,
               phase_chi2: float = DEFAULTS.phase_chi2, by: str = "any family") -> str:
    """The residual of every phase larger than `explained_gap` x the noise, in words:
    within its own standard errors (a slip's timing error moves the fast trace) when its
    chi2/n is at most `phase_chi2`, else not explained `by`; "" when all are at the noise."""
    um, said = 1e3, []
    for name, ph in phases.items():
        rms = ph.get("rms")
        if rms is None or not rms > explained_gap * noise:
            continue
        chi2 = ph.get("chi2_per_sample")
        head = (f"{name} phases {rms * um:.3g} um, {rms / noise:.2g} x the noise "
                f"({ph.get('samples', 0)} samples)")
        if chi2 is None:
            said.append(head)
        elif chi2 <= phase_chi2:
            said.append(f"{head}, within their own standard errors (RMS "
                        f"{ph['expected_rms'] * um:.3g} um, chi2/n {chi2:.2g}: a slip's "
                        "timing error moves the fast trace)")
        else:
            said.append(f"{head}, beyond their own standard errors (RMS "
                        f"{ph['expected_rms'] * um:.3g} um, chi2/n {chi2:.2g}): not explained "
                        f"by {by}")
    if not said:
        return ""
    return " Residual by phase: " + "; ".join(said) + "."


def phase_misfit(phases: dict, phase_chi2: float = DEFAULTS.phase_chi2) -> list[str]:
    """The phases whose residuals exceed their own standard errors (chi2/n above
    `phase_chi2`)."""
    return [n for n, ph in phases.items()
            if (ph.get("chi2_per_sample") or 0.0) > phase_chi2]


def steps_text(steps, decision, gap_before, gap_after, noise,
               explained_gap: float = DEFAULTS.explained_gap) -> str:
    """The answer of the sequential search in words (several effects kept)."""
    um = 1e3
    named = " + ".join(s.family.name for s in steps)
    text = (f"{len(steps)} effects named one after another ({named}). "
            + " ".join(s.family.explanation for s in steps) + " The residual RMS goes from "
            f"{gap_before * um:.3g} um with the paper's model to " + ", then ".join(
                f"{s.gap_after * um:.3g} um with {s.family.name} ("
                + (s.shape.label(s.family) + "; " if s.shape.label(s.family) else "")
                + (", ".join(map(estimate_text, effect_rows(s, 1)))
                   if not s.family.per_record else "per record") + ")" for s in steps)
            + f" (noise {noise * um:.3g} um; {gap_after * um:.3g} um in the final fit).")
    gone = [d for s in steps for d in s.dropped]
    if gone:
        text += (f" Dropped as a shadow of a later effect (no longer significant given "
                 f"it): {', '.join(gone)}.")
    text += _still(gap_after, noise, explained_gap)
    if decision is not None and decision.unbeaten:
        text += (" Not certain: " + "; ".join(
            f"{c.name}{'' if c.physical else ' (unphysical)'} lowers chi-square by "
            f"{c.drop:.0f} and is not clearly beaten" for c in decision.unbeaten) + ".")
    return text


def _still(gap_after, noise, explained_gap) -> str:
    """The sentence that the residual is still above the noise, or ""."""
    return (f" The residual is still {gap_after / noise:.2g} x the noise: something else is "
            "missing too." if gap_after > explained_gap * noise else "")


def explanation_text(effect, chosen, decision, gap_before, gap_after, noise, pattern, phases,
             explained_gap: float = DEFAULTS.explained_gap) -> str:
    """The answer in words: the effect named (and its partners, `decision`), the gaps
    before and after against the noise, or the unexplained residual's phase."""
    um = 1e3
    if effect == "none":
        return ("The paper's model explains the records to the noise level: no effect "
                f"family passes the robust score test (gap {gap_before * um:.3g} um, noise "
                f"{noise * um:.3g} um).")
    if effect == "unexplained":
        text = ("Unexplained residual: the paper's model leaves a gap of "
                f"{gap_before * um:.3g} um (noise {noise * um:.3g} um), largest in the "
                f"{pattern} phase (RMS {phases[pattern]['rms'] * um:.3g} um), that no library "
                "family explains")
        if chosen is not None:
            text += (f"; the best, {chosen.family.name}, only lowers it to "
                     f"{gap_after * um:.3g} um")
        return text + "."
    f = chosen.family
    sizes = ", ".join(map(estimate_text, effect_rows(chosen, 1)))
    text = (f"{f.explanation} Adding {f.name} ({chosen.shape.label(f) or 'no shape'}"
            f"{'; ' + sizes if not f.per_record else ''}) lowers chi-square by "
            f"{chosen.drop:.0f} and the residual RMS from {gap_before * um:.3g} um to "
            f"{gap_after * um:.3g} um (noise {noise * um:.3g} um).")
    text += _still(gap_after, noise, explained_gap)
    if decision is not None and decision.joint:
        names = " or ".join([f.name] + [c.name for c in decision.joint])
        text = (f"{names}: these records cannot tell them apart ("
                + "; ".join(f"{c.name}: chi-square drop {c.drop:.0f}, direction cosine "
                            f"{c.cosine:.2f}, {f.name} ahead by {c.z:.2g} standard errors"
                            for c in decision.joint) + "). " + text)
    if decision is not None and decision.unbeaten:
        text += (" Not certain: " + "; ".join(
            f"{c.name}{'' if c.physical else ' (unphysical)'} lowers chi-square by "
            f"{c.drop:.0f}, {f.name} is ahead by only {c.z:.2g} standard errors"
            for c in decision.unbeaten) + ".")
    return text
