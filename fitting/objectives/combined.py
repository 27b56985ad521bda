r"""The objective of a campaign fit, `AbstractObjective` (a `solve.lsq.AbstractResiduals`),
with final subclasses `FeaturesObjective` (`cycle_features.feature_residuals`: plateau
levels and eq (6) per cycle; robust, fast), `TraceObjective` (`trace.trace_residuals`:
every sample against the exact simulator restarted per cycle) and `WeightedSum` (terms
concatenated, each scaled by $\sqrt{w}$). `--objective both` is the features and the
trace at weights 1/2: both read the same samples, and the cluster-robust covariance of
`uncertainty.laplace` measures that overlap instead of assuming it.

Beside the residuals: `residuals_and_aux` (aux: the simulations' success flags and the
slider velocity), `clusters(features)` (`residual_cycles`: the stick phase (record, cycle
$j$) whose samples each residual reads; phases share no samples, as the sandwich
covariance needs), `robust` (the default covariance is the cluster sandwich), `kind` (a
`modes.Objective`) and `slip_time`. `make_objective(kind, features, trace, ...)` builds one.
"""

from __future__ import annotations

import abc
import math
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from stickslip_jax.modes import SlipTime

from ..modes import Objective, check_member
from ..solve.lsq import AbstractResiduals
from .cycle_features import FeatureData, feature_residuals
from .trace import TraceData, failed_windows, trace_residuals_and_flags

__all__ = ["OBJECTIVES", "AbstractObjective", "FeaturesObjective",
           "TraceObjective", "WeightedSum", "make_objective", "residual_cycles",
           "slip_time_field"]

OBJECTIVES = (Objective.FEATURES.value, Objective.TRACE.value, Objective.BOTH.value)
"""The objectives `make_objective` builds (values of `stickslip_fitting.modes.Objective`;
"smooth" is `stickslip_fitting.objectives.smooth.SmoothObjective`, built from the records)."""


def slip_time_field():
    """An objective's `slip_time` field: a `SlipTime`, or its value converted once."""
    return eqx.field(static=True, default=SlipTime.PAPER, converter=SlipTime.parse)


class AbstractObjective(AbstractResiduals):
    """What a campaign fit minimises (module doc), over `CampaignParams`."""

    kind: ClassVar[Objective]
    robust: ClassVar[bool]

    @abc.abstractmethod
    def residuals_and_aux(self, params, weights_at=None, slider_velocity=None):
        """(whitened residuals, (success flags, slider velocity at `params` or None))."""

    def velocity_shape(self) -> tuple[int, ...] | None:
        """Shape of the slider velocity the residuals take (None: they take none)."""
        return None

    @abc.abstractmethod
    def clusters(self, features) -> tuple[np.ndarray, np.ndarray]:
        """(record, cycle) of every residual (`residual_cycles`)."""

    @abc.abstractmethod
    def describe(self) -> str:
        """One line for reports."""

    def trace_data(self) -> TraceData | None:
        """The trace data the residuals read (None: none)."""
        return None

    def failures(self, ok) -> int:
        """How many simulations failed, from the success flags of `residuals_and_aux`
        (cycle windows of a trace, records of a whole-record simulation; 0: none run)."""
        return 0

    def residuals(self, params):
        """Whitened residuals (sum of squares = -2 log likelihood up to a constant)."""
        return self.residuals_and_aux(params)[0]


class FeaturesObjective(AbstractObjective):
    """The cycle features: plateau levels and eq (6) per cycle (`stickslip_fitting.objectives.cycle_features`)."""

    features: FeatureData
    slip_time: SlipTime = slip_time_field()
    kind: ClassVar[Objective] = Objective.FEATURES
    robust: ClassVar[bool] = False

    def residuals_and_aux(self, params, weights_at=None, slider_velocity=None):
        r = feature_residuals(params, self.features, self.slip_time, weights_at=weights_at)
        return r, (jnp.ones((1,), bool), None)

    def dof(self) -> float:
        return float(self.features.n_residuals())

    def blocks(self) -> dict[str, int]:
        """"levels" (the plateau levels of every cycle, [R, C]), "stick_times" (eq (6)
        per cycle, [R, C]) and "start_levels" (the first plateau, [R])."""
        fd = self.features
        R, C = fd.t1.shape
        return {"levels": R * C, "stick_times": R * C, "start_levels": R}

    def clusters(self, features):
        fd = self.features
        R, C = fd.t1.shape
        end, nxt = np.asarray(fd.has_end), np.asarray(fd.has_next)  # on the host
        has, both = end | nxt, end & nxt
        use = np.asarray(fd.use_start)
        rec = np.concatenate([np.where(has, np.arange(R)[:, None], -1).ravel(),
                              np.where(both, np.arange(R)[:, None], -1).ravel(),
                              np.where(use, np.arange(R), -1)])
        cyc = np.concatenate([np.where(has, np.arange(C)[None, :], -1).ravel(),
                              np.where(both, np.arange(C)[None, :], -1).ravel(),
                              np.where(use, -2, -1)])
        return rec, cyc

    def describe(self) -> str:
        return "cycle features (plateau levels and eq (6) per cycle)"


class TraceObjective(AbstractObjective):
    """Every sample against the exact simulator restarted at every measured slip end
    (`stickslip_fitting.objectives.trace`)."""

    trace: TraceData
    slip_time: SlipTime = slip_time_field()
    kind: ClassVar[Objective] = Objective.TRACE
    robust: ClassVar[bool] = True

    def residuals_and_aux(self, params, weights_at=None, slider_velocity=None):
        r, ok, vel = trace_residuals_and_flags(params, self.trace, self.slip_time,
                                               weights_at=weights_at,
                                               slider_velocity=slider_velocity)
        return r, (ok, vel)

    def velocity_shape(self):
        return tuple(self.trace.mask.shape)

    def dof(self) -> float:
        return float(self.trace.n_residuals())

    def blocks(self) -> dict[str, int]:
        return {"trace": int(np.prod(self.trace.mask.shape))}

    def clusters(self, features):
        td = self.trace
        N, _ = td.mask.shape
        mask = np.asarray(td.mask)
        rec_w = np.asarray(td.record).astype(int)
        start = np.asarray(td.start_time)  # on the host: no device indexing per window
        cyc_w = np.full(N, -1)
        for w in range(N):
            if mask[w].any():
                ends = np.asarray(features[rec_w[w]].end_time, float)
                cyc_w[w] = int(np.nanargmin(np.abs(ends - start[w])))
        return (np.where(mask, rec_w[:, None], -1).ravel(),
                np.where(mask, cyc_w[:, None], -1).ravel())

    def describe(self) -> str:
        return "full trace (exact simulator restarted at every slip end)"

    def trace_data(self):
        return self.trace

    def failures(self, ok) -> int:
        return failed_windows(ok, self.trace)


class WeightedSum(AbstractObjective):
    """Terms concatenated, each scaled by the square root of its weight (module doc); at
    most one term reads a trace (the slider velocity is that term's)."""

    terms: tuple[AbstractObjective, ...]
    weights: tuple[float, ...] = eqx.field(static=True)
    robust: ClassVar[bool] = True

    def __check_init__(self):
        if len(self.terms) != len(self.weights) or not self.terms:
            raise ValueError("WeightedSum: one weight per term, at least one term")
        if not all(w > 0 for w in self.weights):
            raise ValueError(f"--weights: every weight must be positive, got {self.weights}")
        if sum(t.velocity_shape() is not None for t in self.terms) > 1:
            raise ValueError("WeightedSum: at most one term may read a trace")

    @property
    def kind(self) -> Objective | str:
        kinds = [t.kind for t in self.terms]
        if kinds == [Objective.FEATURES, Objective.TRACE]:
            return Objective.BOTH
        return "+".join(kinds)

    @property
    def slip_time(self) -> SlipTime:
        return self.terms[0].slip_time

    def residuals_and_aux(self, params, weights_at=None, slider_velocity=None):
        rs, oks, vel_out = [], [], None
        for t, w in zip(self.terms, self.weights):
            v_in = slider_velocity if t.velocity_shape() is not None else None
            r, (ok, vel) = t.residuals_and_aux(params, weights_at, v_in)
            rs.append(math.sqrt(w) * r)
            if t.velocity_shape() is not None:
                oks.append(ok)
                vel_out = vel
        ok = jnp.concatenate(oks) if oks else jnp.ones((1,), bool)
        return jnp.concatenate(rs), (ok, vel_out)

    def velocity_shape(self):
        shapes = [t.velocity_shape() for t in self.terms if t.velocity_shape() is not None]
        return shapes[0] if shapes else None

    def dof(self) -> float:
        return float(sum(w * t.dof() for t, w in zip(self.terms, self.weights)))

    def blocks(self) -> dict[str, int]:
        out = {}
        for t in self.terms:
            out.update(t.blocks())
        return out

    def clusters(self, features):
        parts = [t.clusters(features) for t in self.terms]
        return (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]))

    def describe(self) -> str:
        return " + ".join(f"{t.describe().split(' (')[0]} (weight {w:g})"
                          for t, w in zip(self.terms, self.weights))

    def trace_data(self):
        for t in self.terms:
            if t.trace_data() is not None:
                return t.trace_data()
        return None

    def failures(self, ok) -> int:
        for t in self.terms:  # the flags are those of the one term that reads a trace
            if t.velocity_shape() is not None:
                return t.failures(ok)
        return 0

    def weight_of(self, kind: Objective) -> float:
        """The weight of the term `kind` (an `Objective`; 0 when there is none)."""
        check_member("kind", kind, Objective)
        return float(sum(w for t, w in zip(self.terms, self.weights) if t.kind == kind))


def make_objective(kind: Objective, features: FeatureData,
                   trace: TraceData | None = None, *,
                   weights: tuple[float, float] = (0.5, 0.5),
                   slip_time: SlipTime = SlipTime.PAPER) -> AbstractObjective:
    """The objective `kind`: `Objective.FEATURES`, `.TRACE` or `.BOTH` (`OBJECTIVES`)."""
    check_member("kind", kind, Objective)
    if kind is Objective.SMOOTH:
        raise ValueError(f"make_objective builds the objectives {OBJECTIVES}; 'smooth' "
                         "reads the records: objectives.smooth.SmoothObjective(smooth_data("
                         "records, features))")
    if kind is Objective.FEATURES:
        return FeaturesObjective(features, slip_time)
    if trace is None:
        raise ValueError(f"objective {kind.value!r} needs the records' traces (TraceData)")
    if kind is Objective.TRACE:
        return TraceObjective(trace, slip_time)
    return WeightedSum((FeaturesObjective(features, slip_time), TraceObjective(trace, slip_time)),
                       (float(weights[0]), float(weights[1])))


def residual_cycles(objective: AbstractObjective, features) -> tuple[np.ndarray, np.ndarray]:
    """(record, cycle) of every residual (module doc); -1 for both on padding, cycle -2 for
    the first plateau's gauge offset (`--offset start`). `features`: the campaign's
    `RecordFeatures` (their slip-end times place the trace windows)."""
    return objective.clusters(features)
