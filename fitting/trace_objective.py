r"""Trace objective: every sample of the deflection against the exact simulator, cycle by cycle.

A small error in a stick time shifts every later slip, so a record simulated from its
start drifts out of phase with the measurement and the residuals stop carrying
information. Here the simulation is **restarted at the end of every slip**: cycle $j$
of a record is the window from the measured end of slip $j-1$ ($t_{e,j-1}$, from
`fitting.features`) to the end of slip $j$. In it the exact simulator
(`stickslip_jax.simulation.simulate_exact`, chapters 2-5: stick while
$k x < \mu_0(T_1) W$ (eq 1), slip with $\mu_m$ (eq 3) on eq (10)) starts at
$t_{e,j-1}$ with the slider at rest, stick time 0 and the measured slip-end deflection
$x_{1,j-1} - c$ ($c$ the record's gauge offset), and predicts the stick (the spring
follows the drive), the breakaway time and the slip. Nothing accumulates from cycle to
cycle.

Residual of sample $i$ of window $w$: $(x_i - c - x_\mathrm{sim}(t_i)) / s_i$ with
$s_i^2 = \sigma^2 + (\dot x_\mathrm{sim}(t_i)\,\sigma_B)^2$: $\sigma$ the record's noise
level (robust estimate from the second differences of the deflection,
`RecordFeatures.noise`) and $\sigma_B$ the standard error of the predicted breakaway
time caused by the errors of the restart state (the measured $x_{1,j-1}$ and
$t_{e,j-1}$): breakaway is where the stick line $k(x_1 + v T_1)$ meets $W\mu_0(T_1)$, so
$\sigma_B^2 = [(k\,\mathrm{sd}\,x_1)^2 + (W\mu_0'\,\mathrm{sd}\,t_e)^2] / (k v - W\mu_0')^2$, large
at slow speeds where the two cross at a shallow angle ("effective variance" weights,
held fixed in the derivative like those of the features objective). So the sum of
squares is about $-2\log$ likelihood. All windows of a campaign are padded to one length (a multiple of
256 samples) and their number to a multiple of 8, and simulated in one `vmap`, so a
campaign compiles once. Units: mm, s, kgf, kgf/mm, mm/s.

Only constant drive speeds (`drive_speed` records) are supported here; records with a
drive program or a measured drive column are refused with a ValueError.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

import stickslip_jax as ss
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.simulation import SimulationResult, simulate_exact

from .features import RecordFeatures
from .params import CampaignParams

__all__ = ["TraceData", "trace_data", "trace_residuals", "trace_simulation", "window_failures"]

MAX_EVENTS = 6
"""Stick and slip phases simulated per window (stick, slip, and room for an early extra cycle)."""


class TraceData(eqx.Module):
    """Cycle windows of a campaign, padded to [N windows, L samples] (mm, s).

    Per window: `record` (index of its record: gauge offset), `weight` W (kgf),
    `stiffness` k (kgf/mm), `speed` v (mm/s), `start_time` (s, the measured end of the
    previous slip), `start_level` (mm, the measured slip-end deflection there, offset
    included), `start_level_sd` (mm) and `start_time_sd` (s) their standard errors,
    `stick_time` (s, the measured stick time of the window), `sigma` (mm, the record's
    noise); per sample `time` (s), `deflection`
    (mm), `mask` (False on padding).
    """

    record: Int[Array, " N"]
    weight: Float[Array, " N"]
    stiffness: Float[Array, " N"]
    speed: Float[Array, " N"]
    start_time: Float[Array, " N"]
    start_level: Float[Array, " N"]
    start_level_sd: Float[Array, " N"]
    start_time_sd: Float[Array, " N"]
    stick_time: Float[Array, " N"]
    sigma: Float[Array, " N"]
    time: Float[Array, "N L"]
    deflection: Float[Array, "N L"]
    mask: Bool[Array, "N L"]

    def n_residuals(self) -> int:
        """Samples that carry data (the padded rest of the residual vector is zero)."""
        return int(np.asarray(self.mask).sum())


def trace_data(records, features: list[RecordFeatures], *, pad_length: int = 0,
               pad_windows: int = 0) -> TraceData:
    """Cut every record into its complete cycles (module doc) and pad them into a `TraceData`.

    `records`: `stickslip_jax.records.Record`s with constant drive speeds; `features`:
    their `RecordFeatures` (same order). `pad_length`, `pad_windows`: pad to at least
    these sizes (campaigns of other sizes reuse the compilation). Raises ValueError for
    a record without stick-slip or without a constant drive speed.
    """
    if len(records) != len(features):
        raise ValueError("trace_data: give one RecordFeatures per record")
    rows = []
    for r, (rec, f) in enumerate(zip(records, features)):
        if not f.stick_slip:
            raise ValueError(f"{f.name}: no usable stick-slip ({f.message})")
        if rec.drive_source != "speed":
            raise ValueError(
                f"{f.name}: the trace objective needs a constant drive speed (drive_speed); "
                "this record has a drive program or a drive column; use --objective features")
        t = np.asarray(rec.time, float)
        x = np.asarray(rec.deflection, float)
        sigma = max(float(f.noise), 1e-12)
        for j in range(1, len(f.peak)):
            if not f.complete[j]:
                continue
            t_s, t_stop = float(f.end_time[j - 1]), float(f.end_time[j])
            sel = (t >= t_s) & (t < t_stop)
            if np.count_nonzero(sel) < 2:
                continue
            rows.append((r, f.weight, f.stiffness, float(rec.drive_speed), t_s,
                         float(f.trough[j - 1]), float(f.trough_sd[j - 1]),
                         float(f.stick_time_sd[j]) / np.sqrt(2.0), float(f.stick_time[j]),
                         sigma, t[sel], x[sel]))
    if not rows:
        raise ValueError("trace objective: no complete stick-slip cycle in the campaign")
    L = max(max(row[-2].size for row in rows), int(pad_length))
    L = -(-L // 256) * 256
    N = max(len(rows), int(pad_windows))
    N = -(-N // 8) * 8
    time = np.zeros((N, L))
    defl = np.zeros((N, L))
    mask = np.zeros((N, L), bool)
    cols = [[row[i] for row in rows] for i in range(10)]
    for i, row in enumerate(rows):
        n = row[-2].size
        time[i, :n], time[i, n:] = row[-2], row[-2][-1]
        defl[i, :n] = row[-1]
        mask[i, :n] = True
    for i in range(len(rows), N):  # dummy windows: copies of the first, fully masked
        time[i] = time[0]
        for c in cols:
            c.append(c[0])
    j = jnp.asarray
    return TraceData(
        record=j(np.asarray(cols[0], np.int32)), weight=j(cols[1]), stiffness=j(cols[2]),
        speed=j(cols[3]), start_time=j(cols[4]), start_level=j(cols[5]),
        start_level_sd=j(cols[6]), start_time_sd=j(cols[7]), stick_time=j(cols[8]),
        sigma=j(cols[9]),
        time=j(time), deflection=j(defl), mask=j(mask),
    )


def trace_simulation(params: CampaignParams, data: TraceData, slip_time: str = "paper"):
    """The exact simulator restarted in every window: a batched `Trace` [N, L] (deflection in mm,
    without the gauge offset)."""
    friction = params.friction.friction()
    offset = params.offset[data.record]

    def one(w, k, v, t0, x0, ts, m):
        sw = ss.Slideway(friction, w, k)
        return simulate_exact(sw, ConstantSpeed(v), ts, initial_deflection=x0, start_time=t0,
                              mask=m, max_events=MAX_EVENTS, slip_time=slip_time)

    return jax.vmap(one)(data.weight, data.stiffness, data.speed, data.start_time,
                         data.start_level - offset, data.time, data.mask)


def trace_residuals(params: CampaignParams, data: TraceData,
                    slip_time: str = "paper") -> Float[Array, " NL"]:
    """Whitened sample residuals $(x - c - x_\\mathrm{sim})/\\sigma$, shape (N L,); padding gives 0."""
    trace = trace_simulation(params, data, slip_time)
    offset = params.offset[data.record]
    static = params.friction.friction().static
    _, slope = jax.jvp(static, (data.stick_time,), (jnp.ones_like(data.stick_time),))
    k, W = data.stiffness, data.weight
    gap = jnp.maximum(jnp.abs(k * data.speed - W * slope), 1e-3 * k * data.speed)
    sd_b = jnp.sqrt((k * data.start_level_sd) ** 2 + (W * slope * data.start_time_sd) ** 2) / gap
    xdot = data.speed[:, None] - trace.slider_velocity
    sd = jnp.sqrt(data.sigma[:, None] ** 2 + (xdot * sd_b[:, None]) ** 2)
    sd = jax.lax.stop_gradient(sd)
    r = (data.deflection - offset[:, None] - trace.deflection) / sd
    return jnp.where(data.mask, r, 0.0).ravel()


@eqx.filter_jit
def _window_ok(params, data, slip_time):
    return trace_simulation(params, data, slip_time).result == SimulationResult.successful


def window_failures(params: CampaignParams, data: TraceData, slip_time: str = "paper") -> int:
    """Number of real windows whose simulation did not report success (e.g. too many events)."""
    ok = np.asarray(_window_ok(params, data, slip_time))
    real = np.asarray(data.mask).any(axis=1)
    return int(np.count_nonzero(real & ~ok))
