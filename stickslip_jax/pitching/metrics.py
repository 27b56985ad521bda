r"""What the paper measures: the tilt $\varepsilon'$, its variation $\Delta\varepsilon$, and $v_p$.

Definitions (Fig 47 and sections 6.2-6.4):

- `peak` $\varepsilon'$: the largest tilt over a cycle, signed (the extreme value of the
  displacement at a point; positive = the point rises / moves towards +side);
- `mean`: the time average over the cycle (the posture the slider keeps when the
  variation has gone);
- `variation` $\Delta\varepsilon$: peak-to-peak change of the tilt within a cycle.

The critical speed $v_p$ is where $\Delta\varepsilon$ "becomes zero" (Fig 49). A
measured variation never is exactly zero, so the threshold is explicit:
$\Delta\varepsilon \le$ `ratio` $\cdot|\varepsilon'|$ (default 5 %) or below the
instrument `resolution` (mm at the chosen point, default 0), whichever is larger. The
speed $v_0$ at which the stick-slip becomes small is taken as the critical speed $v_c$ of
eq (12) (corrected, NOTES.md item 3), above which the steady analysis has no stick-slip.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import Array, Bool, Float

from ..friction import Friction
from ..steady import critical_speed
from .cycle import ForceCycle, steady_force_cycle
from .model import DrivePoint, PitchingModel
from .response import filtered_force, point_displacements


class PlaneSummary(eqx.Module):
    """`peak` (signed extreme), `mean` and `variation` (peak-to-peak) of a tilt angle over a
    steady cycle, in rad; for an array of cycles the fields have that shape."""

    peak: Float[Array, "..."]
    mean: Float[Array, "..."]
    variation: Float[Array, "..."]


def _summarise(values, ts):
    hi = jnp.max(values)
    lo = jnp.min(values)
    peak = jnp.where(jnp.abs(hi) >= jnp.abs(lo), hi, lo)
    mean = jnp.trapezoid(values, ts) / (ts[-1] - ts[0])
    return PlaneSummary(peak=peak, mean=mean, variation=hi - lo)


class SteadyTilt(eqx.Module):
    """Tilt over one steady stick-slip cycle at one drive speed and drive point.

    `pitch`, `yaw`: `PlaneSummary` of the angles (rad); `points`: `PlaneSummary` of the
    measuring-point displacements (mm, one entry per point); `cycle`: the `ForceCycle`;
    `filtered_pitch`, `filtered_yaw`: the lagged force over the cycle (kgf)."""

    pitch: PlaneSummary
    yaw: PlaneSummary
    points: PlaneSummary
    cycle: ForceCycle
    filtered_pitch: Float[Array, " n"]
    filtered_yaw: Float[Array, " n"]


def _points_summary(model: PitchingModel, pitch: PlaneSummary, yaw: PlaneSummary):
    def at_points(field):
        return point_displacements(model, getattr(pitch, field), getattr(yaw, field))

    return PlaneSummary(peak=at_points("peak"), mean=at_points("mean"),
                        variation=jnp.abs(at_points("variation")))


def cycle_tilt(model: PitchingModel, cycle: ForceCycle, drive: DrivePoint) -> SteadyTilt:
    """Periodic steady tilt over a `ForceCycle` (any periodic force, kgf, ending where it
    starts) at `drive` (mm): exact periodic solution of the lag, no transient."""
    fv = filtered_force(model, "pitch", cycle.force, cycle.time, periodic=True)
    fh = filtered_force(model, "yaw", cycle.force, cycle.time, periodic=True)
    gv = model.pitch.compliance * model.pitch.arm(drive.height)
    gh = model.yaw.compliance * model.yaw.arm(drive.offset)
    pitch = _summarise(gv * fv, cycle.time)
    yaw = _summarise(gh * fh, cycle.time)
    return SteadyTilt(pitch=pitch, yaw=yaw, points=_points_summary(model, pitch, yaw), cycle=cycle,
                      filtered_pitch=fv, filtered_yaw=fh)


@eqx.filter_jit
def steady_tilt(model: PitchingModel, friction: Friction, weight, stiffness, speed,
                drive: DrivePoint, n_stick: int = 256, n_slip: int = 48) -> SteadyTilt:
    r"""Steady pitching and yawing at drive speed `speed` (mm/s) for a slider of weight
    `weight` (kgf) on a spring `stiffness` (kgf/mm) with `friction` (eqs 1, 3), driven at
    `drive` (mm). Scalars; see `tilt_against_speed` for a sweep. Section 6.3's calculation
    (Figs 57-58) with the steady cycle of chapter 5."""
    cycle = steady_force_cycle(friction, weight, stiffness, speed, n_stick, n_slip)
    return cycle_tilt(model, cycle, drive)


@eqx.filter_jit
def tilt_against_speed(model: PitchingModel, friction: Friction, weight, stiffness,
                       speeds: Float[Array, " s"], drive: DrivePoint, n_stick: int = 256,
                       n_slip: int = 48) -> SteadyTilt:
    """`steady_tilt` vmapped over drive speeds (mm/s); fields gain a leading speed axis
    (Figs 48-51, 58, 60-61, 63)."""
    speeds = jnp.asarray(speeds, dtype=float)

    def one(v):
        return steady_tilt(model, friction, weight, stiffness, v, drive, n_stick, n_slip)

    return jax.vmap(one)(speeds)


class CriticalSpeeds(eqx.Module):
    r"""`v_p` (mm/s): speed above which $\Delta\varepsilon$ vanishes (threshold in the module
    docstring); `v_0` (mm/s): speed at which the stick-slip ends ($v_c$, eq 12);
    `bracketed`: True if $\Delta\varepsilon$ was above the threshold at the lowest speed and
    below it just under $v_0$ (otherwise `v_p` is the bound where it was met, or $v_0$ if
    the variation persists up to the end of the stick-slip); `result`: the bisection's
    result code."""

    v_p: Float[Array, ""]
    v_0: Float[Array, ""]
    bracketed: Bool[Array, ""]
    result: optx.RESULTS


@eqx.filter_jit
def critical_pitch_speed(model: PitchingModel, friction: Friction, weight, stiffness,
                         drive: DrivePoint, point: str = "pitch_1", ratio: float = 0.05,
                         resolution: float = 0.0, v_low=None, n_stick: int = 256,
                         n_slip: int = 48) -> CriticalSpeeds:
    r"""Critical speed $v_p$ (Fig 49) of the measuring point `point`: the speed at which the
    per-cycle variation $\Delta\varepsilon$ falls to `ratio` $\cdot|\varepsilon'|$ or to
    `resolution` (mm), whichever is larger; found by bisection in $\log v$ between `v_low`
    (mm/s, default $10^{-4} v_0$) and just below $v_0 = v_c$."""
    idx = model.points.index(point)
    v_0 = critical_speed(friction, jnp.asarray(weight, float), jnp.asarray(stiffness, float))
    lo = jnp.log(v_0 * 1e-4 if v_low is None else jnp.asarray(v_low, dtype=float))
    hi = jnp.log(v_0 * (1.0 - 1e-6))

    def excess(logv, _):
        pts = steady_tilt(
            model, friction, weight, stiffness, jnp.exp(logv), drive, n_stick, n_slip).points
        limit = jnp.maximum(ratio * jnp.abs(pts.peak[idx]), resolution)
        return pts.variation[idx] - limit

    g_lo = excess(lo, None)
    g_hi = excess(hi, None)
    bracketed = (g_lo > 0) & (g_hi <= 0)
    sol = optx.root_find(excess, optx.Bisection(rtol=1e-10, atol=1e-6, flip="detect"),
                         0.5 * (lo + hi), options=dict(lower=lo, upper=hi), throw=False,
                         max_steps=200)
    v_p = jnp.where(bracketed, jnp.exp(sol.value), jnp.where(g_lo <= 0, jnp.exp(lo), v_0))
    return CriticalSpeeds(v_p=v_p, v_0=v_0, bracketed=bracketed, result=sol.result)


def window_summary(values, ts, start=None) -> PlaneSummary:
    r"""`peak` (signed extreme), time-`mean` and `variation` (peak-to-peak) of a sampled tilt
    or displacement history `values` (shape (n,) or (n, points)) over the samples with
    `ts >= start` (s; default: the second half of the record, to leave the start-up
    transient out). The variation over a window of whole steady cycles is the per-cycle
    $\Delta\varepsilon$. Units follow `values`."""
    values = jnp.asarray(values, dtype=float)
    ts = jnp.asarray(ts, dtype=float)
    start = 0.5 * (ts[0] + ts[-1]) if start is None else jnp.asarray(start, dtype=float)
    keep = (ts >= start).reshape((-1,) + (1,) * (values.ndim - 1))
    hi = jnp.max(jnp.where(keep, values, -jnp.inf), axis=0)
    lo = jnp.min(jnp.where(keep, values, jnp.inf), axis=0)
    peak = jnp.where(jnp.abs(hi) >= jnp.abs(lo), hi, lo)
    w = jnp.where(keep, 1.0, 0.0)
    mean = jnp.sum(w * values, axis=0) / jnp.sum(w, axis=0)
    return PlaneSummary(peak=peak, mean=mean, variation=hi - lo)
