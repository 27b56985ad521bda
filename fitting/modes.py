r"""The fitting package's mode options, str-valued enums like `stickslip_jax.modes`
(`AbstractMode`): plain strings work too (`Objective("trace") is Objective.TRACE`,
`Objective.TRACE == "trace"`, hashed, printed and JSON-encoded as the string), a value is
validated once where it enters (`Objective.parse(value)`, or `choices=Objective.choices()`
on the command line) and compared with the members inside. No JAX import: the command
parsers use them.

- `Objective`: what a campaign fit minimises (`--objective`).
- `DesignCriterion`: what the experiment design optimises (`stickslip plan --criterion`).
- `MapMethod`: how a design map computes each point (`stickslip design --method`).
- `Covariance`: how a fit's covariance is computed (`laplace(covariance=...)`).
- `DiscoveryBase`: the base model of missing-physics discovery (`stickslip discover --base`).

```python
Objective.parse("both")            # Objective.BOTH
Objective.parse("samples")         # ValueError: objective must be one of ('features', ...)
```
"""

from __future__ import annotations

from stickslip_jax.modes import AbstractMode

__all__ = ["Covariance", "DesignCriterion", "DiscoveryBase", "MapMethod", "Objective"]


class Objective(AbstractMode):
    """What a campaign fit minimises (`stickslip_fitting.combined`, `.smooth_objective`).

    - `FEATURES` ("features", the default): plateau levels and eq (6) per cycle.
    - `TRACE` ("trace"): every sample against the exact simulator restarted at every
      measured slip end.
    - `BOTH` ("both"): the features and the trace, weights 1/2 each (`WeightedSum`).
    - `SMOOTH` ("smooth"): whole records against the smoothed simulator.

    All but `FEATURES` read the records' samples (`needs_records`) and start from the
    features fit's optimum.
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
    r"""The optimality criterion of the experiment design (`stickslip_fitting.design.
    experiment.greedy_design`), over the posterior precision $P$ of the log parameters.

    - `D` ("D", the default): maximise $\log\det P$ (the volume of the credible region).
    - `A` ("A"): minimise $\operatorname{tr} P^{-1}$ (the mean posterior variance).
    """

    D = "D"
    A = "A"

    @classmethod
    def option(cls) -> str:
        return "criterion"


class MapMethod(AbstractMode):
    """How a design map computes each point (`stickslip_fitting.design.maps`).

    - `STEADY` ("steady", the default): the paper's steady-state analysis, eqs (5)-(7)
      and (12).
    - `EXACT` ("exact"): the exact simulator run to its limit cycle.
    - `CYCLE` ("cycle"): the fixed point of the one-cycle map (`stickslip_jax.limit_cycle`;
      the only one with a damping ratio).
    """

    STEADY = "steady"
    EXACT = "exact"
    CYCLE = "cycle"

    @classmethod
    def option(cls) -> str:
        return "method"


class Covariance(AbstractMode):
    """How a fit's covariance is computed (`stickslip_fitting.uncertainty.laplace`).

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


class DiscoveryBase(AbstractMode):
    """The base model of missing-physics discovery (`stickslip discover --base`).

    - `CYCLE` ("cycle", the default): the per-cycle exact model of `stickslip fit
      --objective trace` (`stickslip_fitting.discovery.cycle_workflow`; seconds).
    - `SMOOTH` ("smooth"): the smoothed simulator over whole records
      (`stickslip_fitting.discovery.workflow`; minutes).
    """

    CYCLE = "cycle"
    SMOOTH = "smooth"

    @classmethod
    def option(cls) -> str:
        return "base"
