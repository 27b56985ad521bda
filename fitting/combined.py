r"""The objective of a campaign fit: features, trace, or a weighted combination of both.

`CampaignObjective(kind, features, trace, weight_features, weight_trace, slip_time)`
is an `eqx.Module` (data arrays as leaves, the choices static), and
`objective.residuals(params)` the whitened residual vector whose sum of squares the
Levenberg-Marquardt fit minimises:

- `"features"`: `fitting.objectives.feature_residuals` (plateau levels and eq (6) per
  cycle; robust, fast);
- `"trace"`: `fitting.trace_objective.trace_residuals` (every sample against the exact
  simulator restarted per cycle);
- `"both"`: the two vectors concatenated, scaled by $\sqrt{w_f}$ and $\sqrt{w_t}$, so
  that the sum of squares is $w_f \chi^2_f + w_t \chi^2_t$. Both objectives read the
  same samples, so the default weights are $w_f = w_t = 1/2$ (if they carried the same
  information the combined Fisher information would equal either one's); the intervals
  come from the cluster-robust covariance of `fitting.uncertainty` (per stick phase,
  see `residual_cycles`), which measures the overlap instead of assuming it.

`dof()` is the weighted number of residuals with data ($w_f N_f + w_t N_t$).

`residual_cycles(objective, features)` labels every residual with the stick phase
whose samples it reads, (record, cycle $j$) = the stick after slip $j$ (and the slip
that ends it): the level and eq (6) residuals of cycle $j$ and the trace window that
starts at the end of slip $j$. Residuals of different stick phases share no samples
(only the timing of the slip between neighbours), which is what the cluster-robust
(sandwich) covariance of `fitting.uncertainty` needs for the combined objective.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .objectives import SLIP_TIME_MODES, FeatureData, feature_residuals
from .trace_objective import TraceData, trace_residuals

__all__ = ["OBJECTIVES", "CampaignObjective", "residual_cycles"]

OBJECTIVES = ("features", "trace", "both")


class CampaignObjective(eqx.Module):
    """What a fit minimises (module doc). `trace` may be None for kind "features"."""

    features: FeatureData
    trace: TraceData | None
    kind: str = eqx.field(static=True, default="features")
    weight_features: float = eqx.field(static=True, default=0.5)
    weight_trace: float = eqx.field(static=True, default=0.5)
    slip_time: str = eqx.field(static=True, default="paper")

    def __check_init__(self):
        if self.kind not in OBJECTIVES:
            raise ValueError(f"--objective must be one of {', '.join(OBJECTIVES)}, got {self.kind!r}")
        if self.slip_time not in SLIP_TIME_MODES:
            raise ValueError(f"slip_time must be one of {SLIP_TIME_MODES}, got {self.slip_time!r}")
        if self.kind != "features" and self.trace is None:
            raise ValueError(f"objective {self.kind!r} needs the records' traces (TraceData)")
        if self.kind == "both" and not (self.weight_features > 0 and self.weight_trace > 0):
            raise ValueError("--weights: both weights must be positive")

    def residuals(self, params):
        """Whitened residuals (sum of squares = -2 log likelihood up to a constant)."""
        if self.kind == "features":
            return feature_residuals(params, self.features, self.slip_time)
        rt = trace_residuals(params, self.trace, self.slip_time)
        if self.kind == "trace":
            return rt
        rf = feature_residuals(params, self.features, self.slip_time)
        return jnp.concatenate([math.sqrt(self.weight_features) * rf,
                                math.sqrt(self.weight_trace) * rt])

    def dof(self) -> float:
        """Weighted number of residuals that carry data."""
        if self.kind == "features":
            return float(self.features.n_residuals())
        if self.kind == "trace":
            return float(self.trace.n_residuals())
        return (self.weight_features * self.features.n_residuals()
                + self.weight_trace * self.trace.n_residuals())

    def describe(self) -> str:
        if self.kind == "features":
            return "cycle features (plateau levels and eq (6) per cycle)"
        if self.kind == "trace":
            return "full trace (exact simulator restarted at every slip end)"
        return (f"cycle features (weight {self.weight_features:g}) + full trace "
                f"(weight {self.weight_trace:g})")


def residual_cycles(objective: CampaignObjective, features) -> tuple[np.ndarray, np.ndarray]:
    """(record, cycle) of every entry of `objective.residuals(...)` (module doc); -1 for both
    on padding. The gauge-offset residual of `--offset start` (first plateau) gets cycle -2.

    `features`: the campaign's `RecordFeatures` (their slip-end times place the trace windows).
    """
    fd = objective.features
    R, C = fd.t1.shape
    has = np.asarray(fd.has_end | fd.has_next)
    rec_lv = np.where(has, np.arange(R)[:, None], -1)
    cyc_lv = np.where(has, np.arange(C)[None, :], -1)
    both = np.asarray(fd.has_end & fd.has_next)
    rec_st = np.where(both, np.arange(R)[:, None], -1)
    cyc_st = np.where(both, np.arange(C)[None, :], -1)
    use = np.asarray(fd.use_start)
    rec_f = np.concatenate([rec_lv.ravel(), rec_st.ravel(), np.where(use, np.arange(R), -1)])
    cyc_f = np.concatenate([cyc_lv.ravel(), cyc_st.ravel(), np.where(use, -2, -1)])
    if objective.kind == "features":
        return rec_f, cyc_f
    td = objective.trace
    N, L = td.mask.shape
    mask = np.asarray(td.mask)
    rec_w = np.asarray(td.record).astype(int)
    cyc_w = np.full(N, -1)
    for w in range(N):
        if mask[w].any():
            ends = np.asarray(features[rec_w[w]].end_time, float)
            cyc_w[w] = int(np.nanargmin(np.abs(ends - float(td.start_time[w]))))
    rec_t = np.where(mask, rec_w[:, None], -1).ravel()
    cyc_t = np.where(mask, cyc_w[:, None], -1).ravel()
    if objective.kind == "trace":
        return rec_t, cyc_t
    return np.concatenate([rec_f, rec_t]), np.concatenate([cyc_f, cyc_t])
