r"""The fitting package's mode options and option groups. No JAX import: the command
parsers use them.

Modes are str-valued enums like `stickslip_jax.modes` (`AbstractMode`): hashed, printed
and JSON-encoded as their value (`Objective.TRACE == "trace"`). A user's string becomes a
member once, where it enters (`Objective.parse(value)`); inside the package members are
passed and compared. The option groups of a campaign fit (`solve.fit.fit_features`) are
frozen dataclasses with defaults: `ModelModes`, `Weighting`, `Padding`, `SolverOptions`.

```python
Objective.parse("both")            # Objective.BOTH
Objective.parse("samples")         # ValueError: objective must be one of ('features', ...)
fit_features(features, modes=ModelModes(offset=GaugeOffset.START),
             solver=SolverOptions(max_steps=100))
```
"""

from __future__ import annotations

import dataclasses

from stickslip_jax.modes import AbstractMode, GaugeOffset, SlipTime

__all__ = ["Covariance", "Crop", "DesignCriterion", "DiscoveryBase", "FrictionLaw",
           "MapMethod", "ModelModes",
           "Objective", "Padding", "SmallSample", "SolverOptions", "Weighting", "When",
           "check_member"]


class Objective(AbstractMode):
    """What a campaign fit minimises (`--objective`; `objectives.combined`, `.smooth`).

    - `FEATURES` ("features", the default): plateau levels and eq (6) per cycle.
    - `TRACE` ("trace"): every sample against the exact simulator restarted at every
      measured slip end.
    - `BOTH` ("both"): the features and the trace, weights 1/2 each (`WeightedSum`).
    - `SMOOTH` ("smooth"): whole records against the smoothed simulator.
    """

    FEATURES = "features"
    TRACE = "trace"
    BOTH = "both"
    SMOOTH = "smooth"

    @property
    def needs_records(self) -> bool:
        """True when the objective reads the records' samples, not only their features."""
        return self is not Objective.FEATURES


class DesignCriterion(AbstractMode):
    r"""The optimality criterion of the experiment design (`stickslip plan --criterion`,
    `design.experiment.greedy_design`), over the posterior precision $P$ of the log
    parameters.

    - `D` ("D", the default): maximise $\log\det P$ (the volume of the credible region).
    - `A` ("A"): minimise $\operatorname{tr} P^{-1}$ (the mean posterior variance).
    """

    D = "D"
    A = "A"
    option = classmethod(lambda cls: "criterion")


class MapMethod(AbstractMode):
    """How a design map computes each point (`stickslip design --method`, `design.maps`).

    - `STEADY` ("steady", the default): the paper's steady-state analysis, eqs (5)-(7)
      and (12).
    - `EXACT` ("exact"): the exact simulator run to its limit cycle.
    - `CYCLE` ("cycle"): the fixed point of the one-cycle map (`stickslip_jax.limit_cycle`;
      the only one with a damping ratio).
    """

    STEADY = "steady"
    EXACT = "exact"
    CYCLE = "cycle"
    option = classmethod(lambda cls: "method")


class Covariance(AbstractMode):
    """How a fit's covariance is computed (`uncertainty.laplace.laplace`).

    - `AUTO` ("auto", the default): chosen from the objective and the fit (`laplace`).
    - `FISHER` ("fisher"): the Gauss-Newton information, scaled by max(1, chi2/dof).
    - `SANDWICH` ("sandwich"): cluster-robust, one cluster per stick phase.
    - `TWO_LEVEL` ("two_level"): the larger of the stick-phase and record-level sandwiches.
    """

    AUTO = "auto"
    FISHER = "fisher"
    SANDWICH = "sandwich"
    TWO_LEVEL = "two_level"

    @property
    def robust(self) -> bool:
        """True for the cluster-robust covariances."""
        return self in (Covariance.SANDWICH, Covariance.TWO_LEVEL)


class SmallSample(AbstractMode):
    """The small-sample correction of the cluster-robust covariance
    (`uncertainty.laplace.sandwich_covariance`).

    - `JACKKNIFE` ("jackknife", the default): leave-one-cluster-out scores (CR3).
    - `CR2` ("cr2"): Bell-McCaffrey, each cluster's residuals scaled by
      $(I - P_{cc})^{-1/2}$.
    - `NONE` ("none"): the plain scores times G/(G-1).
    """

    JACKKNIFE = "jackknife"
    CR2 = "cr2"
    NONE = "none"


class DiscoveryBase(AbstractMode):
    """The base model of missing-physics discovery (`stickslip discover --base`):
    `CYCLE` ("cycle", the default), the per-cycle exact model of `--objective trace`
    (`discovery.cycle_workflow`; seconds), or `SMOOTH` ("smooth"), the smoothed simulator
    over whole records (`discovery.workflow`; minutes).
    """

    CYCLE = "cycle"
    SMOOTH = "smooth"
    option = classmethod(lambda cls: "base")


class Crop(AbstractMode):
    """Where each record starts for the smoothed whole-record base of discovery
    (`stickslip discover --crop`, `discovery.model.campaign_traces`).

    - `SLIP_END` ("slip_end", the command's default): at its first slip end.
    - `NONE` ("none"): the whole record (it must start just after a slip).
    """

    SLIP_END = "slip_end"
    NONE = "none"


class FrictionLaw(AbstractMode):
    """The base friction law of a fit (`stickslip fit --law`, `solve.laws`).

    - `PAPER` ("paper", the default): eqs (1) and (3) (or `--model microsqueeze`).
    - `RATE_STATE_AGING` ("rate_state_aging"): Dieterich-Ruina, aging evolution law.
    - `RATE_STATE_SLIP` ("rate_state_slip"): Dieterich-Ruina, slip evolution law.
    - `LOG_AGING` ("log_aging"): static friction growing with the log of the stick time,
      kinetic friction falling with the log of the speed.

    All but `PAPER` are fitted through whole records (the smoothed simulator).
    """

    PAPER = "paper"
    RATE_STATE_AGING = "rate_state_aging"
    RATE_STATE_SLIP = "rate_state_slip"
    LOG_AGING = "log_aging"
    option = classmethod(lambda cls: "law")


class When(AbstractMode):
    """Which estimates of a discovery (`api.discovery.CampaignDiscovery.parameters`):
    `BEFORE` ("before"), the paper's model alone, or `AFTER` ("after", the default), with
    the named effects.
    """

    BEFORE = "before"
    AFTER = "after"


def check_member(name: str, value, kind: type) -> None:
    """TypeError naming the argument `name` unless `value` is a member of the mode `kind`
    (a user's string becomes one at the edge, `kind.parse`)."""
    if not isinstance(value, kind):
        raise TypeError(f"{name}: a member of {kind.__name__}, got {value!r} (a string "
                        f"becomes one with {kind.__name__}.parse)")


@dataclasses.dataclass(frozen=True)
class ModelModes:
    """How a campaign fit models the records."""

    offset: GaugeOffset = GaugeOffset.ZERO
    """ZERO: trust the gauge zero; START: fit one offset per record from its first plateau."""
    slip_time: SlipTime = SlipTime.PAPER
    r"""$T_2$ in eq (3): PAPER ($\pi/\omega_0$) or SELF_CONSISTENT."""
    reslip: bool | None = None
    """Model re-slips (`objectives.cycle_features.feature_data`); None: detected."""

    def __post_init__(self):
        check_member("offset", self.offset, GaugeOffset)
        check_member("slip_time", self.slip_time, SlipTime)


@dataclasses.dataclass(frozen=True)
class Weighting:
    """Weights of a campaign fit's residuals."""

    features: float = 0.5
    """Weight of the features objective in `Objective.BOTH`."""
    trace: float = 0.5
    """Weight of the trace objective in `Objective.BOTH`."""
    rescale_records: bool = True
    """Scale the errors of records the model describes worse than their noise
    (`solve.fit.RECORD_CHI2`) to their scatter and refit."""

    @property
    def pair(self) -> tuple[float, float]:
        """(w_features, w_trace), as `objectives.combined.make_objective` takes them."""
        return (self.features, self.trace)


@dataclasses.dataclass(frozen=True)
class Padding:
    """Shapes padded so that campaigns of other sizes reuse a compilation."""

    cycles: int = 0
    """Cycle axis of the features data at least this long."""
    length: int = 0
    """Trace rows at least this long (`objectives.trace.trace_data`)."""
    windows: int = 0
    """Trace rows at least this many."""


@dataclasses.dataclass(frozen=True)
class SolverOptions:
    """Tolerances and step cap of the Levenberg-Marquardt solves
    (`stickslip_jax.lsq.least_squares`): a run stops when a step would lower chi2 by less
    than `atol + rtol * chi2`."""

    rtol: float = 1e-10
    """Relative tolerance on the chi2 decrease."""
    atol: float = 1e-10
    """Absolute tolerance on the chi2 decrease."""
    max_steps: int = 400
    """Levenberg-Marquardt steps per reweighting round at most."""

    def refine(self) -> SolverOptions:
        """The options of a solve over hundreds of thousands of residuals (trace, both,
        smooth): tolerances not tighter than 1e-8 (root mean squares: a step that moves
        the whitened residuals by 1e-8 RMS), at most 100 steps per round."""
        return SolverOptions(max(self.rtol, 1e-8), max(self.atol, 1e-8),
                             min(self.max_steps, 100))
