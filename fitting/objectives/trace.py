r"""Trace objective: every sample of the deflection against the exact simulator, cycle by cycle.

A small error in a stick time shifts every later slip, so a record simulated from its
start drifts out of phase with the measurement. Here the simulation is **restarted at the
end of every slip**: cycle $j$ of a record is the window from the measured end of slip
$j-1$ ($t_{e,j-1}$) to the end of slip $j$. In it the exact simulator
(`stickslip_jax.simulation.simulate_exact`: stick while $k x < \mu_0(T_1) W$ (eq 1), slip
with $\mu_m$ (eq 3) on eq (10)) starts with the slider at rest, stick time 0 and the
measured slip-end deflection $x_{1,j-1} - c$ ($c$ the gauge offset). Nothing accumulates
from cycle to cycle.

Residual of sample $i$: $(x_i - c - x_\mathrm{sim}(t_i)) / s_i$ with
$s_i^2 = \sigma^2 + (\dot x_\mathrm{sim}(t_i)\,\sigma_B)^2$: $\sigma$ the record's noise
(`RecordFeatures.noise`) and $\sigma_B$ the standard error of the predicted breakaway
time from the errors of the restart state: breakaway is where the stick line
$k(x_1 + v T_1)$ meets $W\mu_0(T_1)$, so
$\sigma_B^2 = [(k\,\mathrm{sd}\,x_1)^2 + (W\mu_0'\,\mathrm{sd}\,t_e)^2] / (k v - W\mu_0')^2$,
large at slow speeds where the two cross at a shallow angle (effective-variance weights,
held fixed in the derivative). So the sum of squares is about $-2\log$ likelihood.

Layout: stick times differ by orders of magnitude, so padding every window to the
longest would simulate mostly padding. Each window is cut into rows of `CHUNK` samples,
every row simulated from its window's start (a cycle's events are a few scalars) and
rendered on its own samples; the rows run in one `vmap`, so a campaign compiles once.
Units: mm, s, kgf, kgf/mm, mm/s.

A window after a slip with a re-slip (`RecordFeatures.slipped_on`) is left out
(`reslip_windows`): the slider comes to rest later and higher than the measured slip
end, so the restart state would be wrong (residuals up to 29 standard errors at the
truth); the features objective models those cycles.

A record whose drive is not $u = v t$ (a measured `drive` or `drive_speed` column, a
`drive_program`) drives every window with a piecewise-linear drive (`drive_knots`):
`KNOTS` - 2 knots from the window's start to its measured breakaway, one at its end, one
far beyond. Where a campaign's measured drive bends within a slip by more than the noise
(a torsional rig's motor whose speed swings), `SLIP_KNOTS` more cover every slip, so the
slider's stop follows the drive's speed profile; elsewhere the slip is driven at the
mean speed. The knots follow a 6 um lead-screw error on a 2 mm pitch to within 0.08 um
where a 60 s stick spans a pitch; at the truth the residuals of such records are the
noise (rms 0.995, tests/test_drives.py). With constant-speed drives only,
`TraceData.drive_knots` is None.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

import stickslip_jax as ss
from stickslip_jax.drives import ConstantSpeed, MeasuredDrive
from stickslip_jax.modes import SlipTime
from stickslip_jax.simulation import SimulationResult, simulate_exact

from ..data.features import RecordFeatures
from ..params import CampaignParams

__all__ = ["CHUNK", "KNOTS", "SLIP_KNOTS", "TraceData", "cycle_windows", "failed_windows",
           "reslip_windows", "trace_data", "trace_residuals", "trace_residuals_and_flags",
           "trace_sd", "trace_simulation"]

MAX_EVENTS = 6
"""Stick and slip phases simulated per window (stick, slip, and room for an early extra cycle;
2 more with `drive_knots`: a slip that starts before the breakaway knot crosses it)."""
KNOTS = 32
"""Knots of a window's piecewise-linear drive (module doc): at 32, a 6 um lead-screw error
(second harmonic 0.3) is interpolated to within 0.077 um (the largest over its phases) where a
60 s stick spans one pitch period."""
SLIP_KNOTS = 16
"""Knots added inside every window's slip when a campaign's measured drive bends within its
slips (module doc); each crossed knot costs the exact simulator 2 events."""


class TraceData(eqx.Module):
    """Cycle windows of a campaign cut into rows of L samples, padded to [N rows, L] (mm, s).

    Per row: `record`, `window` (a long window spans several rows), `weight` W and
    `normal_load` N (kgf), `stiffness` k (kgf/mm), `speed` v (mm/s), `start_time` (s, the
    measured end of the previous slip), `start_level` (mm, the slip-end deflection there,
    offset included) with standard errors `start_level_sd`, `start_time_sd`,
    `stick_time` (s), `sigma` (mm, the record's noise), `drive_poly` (a measured drive's
    cubic), `drive_knots` [N, K, 2] (knot times s, drive positions mm; None with
    constant-speed drives); per sample `time` (s), `deflection` (mm), `mask`.
    """

    record: Int[Array, " N"]
    weight: Float[Array, " N"]
    normal_load: Float[Array, " N"]
    stiffness: Float[Array, " N"]
    speed: Float[Array, " N"]
    start_time: Float[Array, " N"]
    start_level: Float[Array, " N"]
    start_level_sd: Float[Array, " N"]
    start_time_sd: Float[Array, " N"]
    stick_time: Float[Array, " N"]
    sigma: Float[Array, " N"]
    window: Int[Array, " N"]
    drive_poly: Float[Array, "N 3"]
    time: Float[Array, "N L"]
    deflection: Float[Array, "N L"]
    mask: Bool[Array, "N L"]
    drive_knots: Float[Array, "N K 2"] | None = None

    def n_residuals(self) -> int:
        """Samples that carry data (the padded rest of the residual vector is zero)."""
        return int(np.asarray(self.mask).sum())


CHUNK = 512
"""Samples per row of `TraceData`: every cycle window is cut into rows of this length."""


def trace_data(records, features: list[RecordFeatures], *, pad_length: int = 0,
               pad_windows: int = 0, chunk: int = CHUNK, drive_fix: bool = True,
               keep_reslips: bool = False) -> TraceData:
    """Cut every record into its complete cycles (module doc), the cycles into rows of
    `chunk` samples, and pad them into a `TraceData`.

    `records` and their `features` in the same order. `chunk`: samples per row (rounded
    up to a multiple of 256). `pad_length`, `pad_windows`: rows at least this long and
    this many (campaigns of other sizes reuse the compilation). `drive_fix`: take out the
    drive error the features found (False keeps it, for a model with its own drive
    error, `discovery.cycle_model`). Over each window of a measured drive, the drive is
    least-squares fitted by $u - u(t_s) = v s + c_2 s^2 + c_3 s^3$ ($s$ the time since
    the window's start), v the row's `speed`, `drive_poly` = (0, c_2, c_3) (mm/s^2,
    mm/s^3; zeros at constant speed). `keep_reslips`: keep the windows after re-slips too
    (`discovery.cycle_workflow`). ValueError for a record without stick-slip.
    """
    if len(records) != len(features):
        raise ValueError("trace_data: give one RecordFeatures per record")
    L = max(int(chunk), int(pad_length), 1)
    L = -(-L // 256) * 256
    rows = []
    n_windows = 0
    bends = False
    for r, (rec, f) in enumerate(zip(records, features)):
        if not f.stick_slip:
            raise ValueError(f"{f.name}: no usable stick-slip ({f.message})")
        t = np.asarray(rec.time, float)
        # the deflection as the features saw it (spikes replaced); a drive error the
        # features corrected is taken out window by window below (the trace model drives
        # at u = v t, or through the drive's knots, from the window's measured start)
        x = np.asarray(rec.deflection if f.deflection_used is None else f.deflection_used,
                       float)
        fix = None if f.drive_fix is None or not drive_fix else np.asarray(f.drive_fix, float)
        sigma = max(float(f.noise), 1e-12)
        u_meas = None if rec.drive_source == "speed" else np.asarray(rec.drive_position(t), float)
        v_rec = (float(rec.drive_speed) if u_meas is None
                 else float(np.polyfit(t - t[0], u_meas, 1)[0]))
        dropped = _after_reslip(f) & (not keep_reslips)
        for j in range(1, len(f.peak)):
            if not f.complete[j] or dropped[j - 1]:
                continue
            t_s, t_stop = float(f.end_time[j - 1]), float(f.end_time[j])
            sel = np.flatnonzero((t >= t_s) & (t < t_stop))
            if sel.size < 2:
                continue
            poly = np.zeros(3)
            if u_meas is not None:  # the window's own mean speed and the cubic rest
                s_ = t[sel] - t_s
                du = u_meas[sel] - np.interp(t_s, t, u_meas)
                A = np.stack([s_, s_ ** 2, s_ ** 3], axis=1)
                poly = np.linalg.lstsq(A, du, rcond=None)[0]
                v_win, poly = poly[0], np.array([0.0, poly[1], poly[2]])
            else:
                v_win = v_rec
            knots = (rec, t_s, float(f.stick_time[j]), float(t[sel[-1]]), v_win)
            bends |= u_meas is not None and _bends(t[sel], u_meas[sel], knots, sigma)
            head = (r, f.weight, f.stiffness, float(v_win), t_s,
                    float(f.trough[j - 1]), float(f.trough_sd[j - 1]),
                    float(f.stick_time_sd[j]) / np.sqrt(2.0), float(f.stick_time[j]),
                    sigma, n_windows, poly, f.load, knots)
            xw = x[sel] if fix is None else x[sel] - (fix[sel] - np.interp(t_s, t, fix))
            for a in range(0, sel.size, L):
                part = sel[a:a + L]
                rows.append(head + (t[part], xw[a:a + L]))
            n_windows += 1
    if not rows:
        n_reslip = reslip_windows(features)
        raise ValueError(
            "trace objective: no complete stick-slip cycle in the campaign"
            + (f" ({n_reslip} cycles start after a re-slip, whose restart state is not "
               "measured; use --objective features)" if n_reslip else ""))
    N = max(len(rows), int(pad_windows))
    N = -(-N // 8) * 8
    time = np.zeros((N, L))
    defl = np.zeros((N, L))
    mask = np.zeros((N, L), bool)
    cols = [[row[i] for row in rows] for i in range(14)]
    constant = all(rec.drive_source == "speed" for rec in records)  # no knot tables then
    made = {}  # one knot table per window, SLIP_KNOTS more inside the slips where they bend
    for k in [] if constant else cols[13]:
        if id(k) not in made:
            made[id(k)] = _window_knots(*k, slip=SLIP_KNOTS * bends)
    cols[13] = [made.get(id(k)) for k in cols[13]]
    for i, row in enumerate(rows):
        n = row[-2].size
        time[i, :n], time[i, n:] = row[-2], row[-2][-1]
        defl[i, :n] = row[-1]
        mask[i, :n] = True
    for i in range(len(rows), N):  # dummy rows: copies of the first, fully masked
        time[i] = time[0]
        for c in cols:
            c.append(c[0])
    def j(x):  # device_put: jnp.asarray would compile a small program per shape
        return jax.device_put(np.asarray(x))

    return TraceData(
        record=j(np.asarray(cols[0], np.int32)), weight=j(cols[1]), stiffness=j(cols[2]),
        speed=j(cols[3]), start_time=j(cols[4]), start_level=j(cols[5]),
        start_level_sd=j(cols[6]), start_time_sd=j(cols[7]), stick_time=j(cols[8]),
        sigma=j(cols[9]), window=j(np.asarray(cols[10], np.int32)),
        drive_poly=j(np.asarray(cols[11], float).reshape(-1, 3)), normal_load=j(cols[12]),
        time=j(time), deflection=j(defl), mask=j(mask),
        drive_knots=None if constant else j(np.stack(cols[13])),
    )


def _bends(t, u, knots, sigma: float) -> bool:
    """Whether the drive u (mm) at times t (s) of one window departs from its chord over the
    slip (from the measured breakaway to the window's end) by more than `sigma` (mm): the
    largest departure of the parabola fitted to it there."""
    _, t_s, stick, t_end, _ = knots
    t_b = t_s + min(max(stick, 0.0), 0.95 * (t_end - t_s))
    sel = t >= t_b
    if np.count_nonzero(sel) < 4:
        return False
    curve = np.polyfit(t[sel] - t_b, u[sel], 2)[0]
    return bool(abs(curve) * (t_end - t_b) ** 2 / 4.0 > sigma)


def _window_knots(rec, t_s: float, stick: float, t_end: float, v: float, slip: int = 0
                  ) -> np.ndarray:
    """[KNOTS + slip, 2]: knot times (s) and drive positions (mm) of one window's drive
    (module doc): from the window's start `t_s` to its measured breakaway `t_s + stick`,
    `slip` more spread evenly from there to its last sample `t_end`, that sample, and a
    knot far beyond on the last segment's line (v: mm/s, a constant-speed record's
    speed)."""
    t_b = t_s + min(max(stick, 0.0), 0.95 * (t_end - t_s))
    t_k = np.concatenate([np.linspace(t_s, t_b, KNOTS - 2),
                          np.linspace(t_b, t_end, slip + 2)[1:]])
    u = v * (t_k - t_s) if rec.drive_source == "speed" else (
        np.asarray(rec.drive_position(t_k), float) - float(rec.drive_position([t_s])[0]))
    slope = (u[-1] - u[-2]) / (t_k[-1] - t_k[-2])
    far = t_end + 1e3 * max(t_end - t_s, 1.0)
    return np.stack([np.append(t_k, far), np.append(u, u[-1] + slope * (far - t_end))], 1)


def trace_simulation(params: CampaignParams, data: TraceData,
                     slip_time: SlipTime | str = SlipTime.PAPER):
    """The exact simulator restarted in every window: a batched `Trace` [N, L] (deflection in mm,
    without the gauge offset)."""
    friction = params.friction.friction()
    offset = params.offset[data.record]

    knots = data.drive_knots

    def one(w, n, k, v, t0, x0, ts, m, kn):
        sw = ss.Slideway(friction, w, k, n)
        drive = ConstantSpeed(v) if kn is None else MeasuredDrive(kn[:, 0], kn[:, 1])
        slip_knots = 0 if kn is None else kn.shape[0] - KNOTS
        return simulate_exact(sw, drive, ts, initial_deflection=x0, start_time=t0, mask=m,
                              max_events=MAX_EVENTS + 2 * (kn is not None) + 2 * slip_knots,
                              slip_time=slip_time, cycle_table=False,
                              check=False)  # Record checked times, W, k

    return jax.vmap(one)(data.weight, data.normal_load, data.stiffness, data.speed,
                         data.start_time, data.start_level - offset, data.time, data.mask,
                         knots)


def trace_residuals(params: CampaignParams, data: TraceData,
                    slip_time: SlipTime | str = SlipTime.PAPER,
                    weights_at: CampaignParams | None = None,
                    slider_velocity=None) -> Float[Array, " NL"]:
    """Whitened sample residuals $(x - c - x_\\mathrm{sim})/s$ (module doc), shape (N L,);
    padding gives 0. `weights_at`, `slider_velocity`: see `trace_residuals_and_flags`."""
    return trace_residuals_and_flags(params, data, slip_time, weights_at, slider_velocity)[0]


def trace_sd(params: CampaignParams, data: TraceData, slider_velocity) -> Float[Array, "N L"]:
    """The standard error $s_i$ (mm) of every sample (module doc) at `params`, given the
    simulated slider velocity (mm/s, [N, L]; 0 while sticking)."""
    static = params.friction.friction().static
    _, slope = jax.jvp(static, (data.stick_time,), (jnp.ones_like(data.stick_time),))
    k, W = data.stiffness, data.normal_load
    gap = jnp.maximum(jnp.abs(k * data.speed - W * slope), 1e-3 * k * data.speed)
    sd_b = jnp.sqrt((k * data.start_level_sd) ** 2 + (W * slope * data.start_time_sd) ** 2) / gap
    xdot = data.speed[:, None] - slider_velocity
    return jnp.sqrt(data.sigma[:, None] ** 2 + (xdot * sd_b[:, None]) ** 2)


def trace_residuals_and_flags(params: CampaignParams, data: TraceData,
                              slip_time: SlipTime | str = SlipTime.PAPER,
                              weights_at: CampaignParams | None = None, slider_velocity=None):
    """`trace_residuals` and, from the same simulations, a bool per row (its simulation
    succeeded) and the simulated slider velocity [N, L] (mm/s).

    The standard errors $s_i$ are evaluated at `params` with the simulated velocity, or at
    `weights_at` with `slider_velocity` (the fit freezes the weights for one
    Levenberg-Marquardt run); they are held fixed in the derivative either way."""
    trace = trace_simulation(params, data, slip_time)
    offset = params.offset[data.record]
    if weights_at is None:
        sd = trace_sd(params, data, trace.slider_velocity)
    else:
        sd = trace_sd(weights_at, data, slider_velocity)
    sd = jax.lax.stop_gradient(sd)
    r = (data.deflection - offset[:, None] - trace.deflection) / sd
    ok = trace.result == SimulationResult.successful
    return jnp.where(data.mask, r, 0.0).ravel(), ok, trace.slider_velocity


def _after_reslip(f: RecordFeatures) -> np.ndarray:
    """Per cycle j >= 1: complete, but the slip before it had a re-slip (left out)."""
    return np.asarray(f.complete[1:], bool) & f.slipped_on[:-1]


def cycle_windows(features: list[RecordFeatures]) -> int:
    """Complete cycles after a record's first slip: the windows `trace_data` cuts with
    `keep_reslips` (without it, `reslip_windows` of them are left out)."""
    return sum(int(np.count_nonzero(np.asarray(f.complete[1:], bool)))
               for f in features if f.stick_slip)


def reslip_windows(features: list[RecordFeatures]) -> int:
    """Complete cycles that `trace_data` leaves out because the slip before them had a
    re-slip (module doc)."""
    return sum(int(np.count_nonzero(_after_reslip(f))) for f in features if f.stick_slip)


def failed_windows(ok, data: TraceData) -> int:
    """Cycle windows of `data` with a real row whose flag in `ok` (one bool per row, see
    `trace_residuals_and_flags`) is False."""
    real = np.asarray(data.mask).any(axis=1)
    return int(np.unique(np.asarray(data.window)[real & ~np.asarray(ok, bool)]).size)
