r"""The stick-slip model and the trace residuals written as a SciPy user would: NumPy + SciPy only.

An independent reference for the benchmarks (`simulate.py`, `fit.py`) and the tests:
it shares no code with `stickslip_jax.simulation` or `stickslip_fitting.objectives.trace`.

Model (the paper's chapters 2-5, as `simulate_exact` with `slip_time="paper"` and a
constant drive speed v): the slider starts at rest at time $t_0$ with spring
deflection $x_0$ and stick time 0.

- Stick: $x(t) = x_s + v (t - t_s)$ until $k x = W \mu_0(T_1)$, $T_1 = t - t_s$
  (eq 1, $\mu_0 = \mu_s - (\mu_s - \mu_d) e^{-\gamma T_1^m}$); breakaway by `brentq`.
  If $k x_s \ge W \mu_0(0) = W \mu_d$ the slider breaks away at once (re-slip).
- Slip: eq (2) $M \ddot y = k x - \mu_m W$ with $x = x_b + v (t - t_b) - y$ and eq (3)
  $\mu_m = \mu_d + (\mu_0(T_1) - \mu_d) e^{-\delta T_2^n}$, $T_2 = \pi/\omega_0$ (eq 7),
  integrated by `solve_ivp` (DOP853, rtol 1e-10; 1e-12 for the trace residuals) until
  the slider speed $\dot y$ returns to zero (a terminal event), or (`slip="closed_form"`)
  evaluated from its closed-form solution and closed-form end time in NumPy. Then the
  next stick starts.

Two SciPy baselines, then: "ode" is what a SciPy user writes for a slip law in general
(any friction during the slip); "closed_form" is a plain NumPy version of
this particular model (constant $\mu_m$ during the slip, as the paper and
`simulate_exact` use), with no ODE solver.

Units: kgf, mm, s (speeds mm/s, stiffness kgf/mm, mass W/g with g = 9806.65 mm/s^2).

- `scipy_record(friction, W, k, v, ts)`: one record from rest at t = 0 (the simulators
  benchmark's baseline).
- `simulate_window(values, W, k, v, ts, t0=, x0=)`: deflection and slider velocity.
- `reference_windows(tdata)`: a `stickslip_fitting.objectives.trace.TraceData` converted once to
  NumPy, one entry per cycle window; `scipy_trace_residuals(values, windows, sd)`: the
  whitened trace residuals (the layout of `stickslip_fitting.objectives.trace.trace_residuals`),
  each cycle window simulated once; `scipy_trace_simulation` the simulations behind them.
- `values_from_free(v)`: the fit's flat free vector (log coordinates,
  `stickslip_fitting.params`) to the natural parameters.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

G_MM_S2 = 9806.65
"""Standard gravity (mm/s^2): slider mass M = W / g."""

TRACE_MAX_SLIPS = 3
"""Slips simulated per cycle window, as `stickslip_fitting.objectives.trace` (its `MAX_EVENTS` = 6 stick
and slip phases): after the last one the slip's motion is continued to the window's end."""

TRACE_RTOL, TRACE_ATOL = 1e-12, 1e-15
"""solve_ivp tolerances of the trace residuals (relative, absolute mm). Finite-difference
Jacobians (2-point steps of ~1.5e-8) need residuals far smoother than the records need:
with rtol 1e-10 the integration noise stalled least_squares in the weakly determined
delta, n direction (log delta 2e-4 from the optimum, reweighting rounds never settled);
with 1e-12 it reaches the JAX fit's optimum to 1e-7 in fewer evaluations (measured on
the benchmark campaign of benchmarks/fit.py)."""

__all__ = ["G_MM_S2", "TRACE_ATOL", "TRACE_MAX_SLIPS", "TRACE_RTOL", "ReferenceWindows",
           "friction_values", "reference_windows", "scipy_record", "scipy_trace_residuals",
           "scipy_trace_simulation", "simulate_window", "values_from_free"]


def friction_values(friction) -> tuple[float, ...]:
    """(mu_s, mu_d, gamma, m, delta, n) of an eq (1) + eq (3) `stickslip_jax.Friction`."""
    s, kin = friction.static, friction.kinetic
    return tuple(float(q) for q in (s.mu_s, s.mu_d, s.gamma, s.m, kin.delta, kin.n))


def values_from_free(v) -> np.ndarray:
    """Natural (mu_s, mu_d, gamma, m, delta, n) from the flat free vector of the fit.

    The fit (`stickslip_fitting.solve.fit`) flattens the free part of `CampaignParams` with
    `jax.flatten_util.ravel_pytree`: the `EmpiricalFriction` leaves in field order
    (log mu_d, log(mu_s - mu_d), log gamma, log m, log delta, log n), then the gauge
    offsets (mm) if they are free. Entries after the sixth are ignored here.
    """
    v = np.asarray(v, float)
    mu_d = math.exp(v[0])
    return np.array([mu_d + math.exp(v[1]), mu_d, math.exp(v[2]), math.exp(v[3]),
                     math.exp(v[4]), math.exp(v[5])])


def simulate_window(values, W, k, v, ts, *, t0=0.0, x0=0.0, max_slips=None,
                    rtol=1e-10, atol=1e-13, slip="ode"):
    r"""Deflection x (mm) and slider velocity (mm/s, 0 while sticking) at the sorted times
    `ts` (s) of the model in the module doc, started at rest at `t0` (s) with deflection
    `x0` (mm) and stick time 0, up to `max(ts)`.

    `values`: (mu_s, mu_d, gamma s^-m, m, delta s^-n, n); W kgf, k kgf/mm, v mm/s.
    `max_slips`: simulate at most this many slips; the last one is then integrated to
    `max(ts)` without its end event (what `simulate_exact` renders when its event
    budget runs out). Samples before `t0` get the first stick's line.
    `slip`: "ode" integrates eq (2) with solve_ivp (`rtol`, `atol`); "closed_form" uses
    its solution from rest, $x = c + (x_b - c)\cos\omega_0\tau + (v/\omega_0)\sin\omega_0\tau$
    with $c = \mu_m W / k$, ending at $\omega_0\tau^* = 2\pi - 2\arctan(\omega_0 (x_b - c)/v)$
    (NumPy, vectorised over the samples of the slip; what a user who has read the
    paper's chapter 3 would write).
    """
    if slip not in ("ode", "closed_form"):
        raise ValueError(f"slip must be 'ode' or 'closed_form', not {slip!r}")
    mu_s, mu_d, gam, m, delta, n = (float(q) for q in values)
    W, k, v = float(W), float(k), float(v)
    ts = np.asarray(ts, float)
    M, omega = W / G_MM_S2, math.sqrt(G_MM_S2 * k / W)
    decay = math.exp(-delta * (math.pi / omega) ** n)  # eq (3) with T2 = pi / omega0
    gap = mu_s - mu_d

    def mu0(T):
        return mu_s - gap * math.exp(-gam * max(T, 0.0) ** m)

    x = np.empty_like(ts)
    yd = np.zeros_like(ts)
    if ts.size == 0:
        return x, yd
    t_end = float(ts[-1])
    t, xs, i, slips = float(t0), float(x0), 0, 0
    while True:
        def r(tt, t=t, xs=xs):
            return k * (xs + v * (tt - t)) - W * mu0(tt - t)

        if r(t) >= 0:  # k x >= W mu_d at the start of the stick: slips on at once
            tb = t
        elif t < t_end and r(t_end) >= 0:
            hi = min(t + 1e-3, t_end)
            while r(hi) < 0:
                hi = min(t + 2 * (hi - t), t_end)
            tb = brentq(r, t, hi, xtol=1e-14, rtol=4 * np.finfo(float).eps)
        else:  # sticks to the end
            x[i:] = xs + v * (ts[i:] - t)
            return x, yd
        j = int(np.searchsorted(ts, tb, side="left"))
        x[i:j] = xs + v * (ts[i:j] - t)
        i = j
        xb = xs + v * (tb - t)
        mum = mu_d + (mu0(tb - t) - mu_d) * decay
        slips += 1
        if tb >= t_end:
            x[i:] = xb
            return x, yd

        last = max_slips is not None and slips >= max_slips
        if slip == "closed_form":
            c = mum * W / k
            z0 = xb - c  # >= 0: k x_b = W mu_0 >= W mu_m
            te = tb + (2 * math.pi - 2 * math.atan(omega * z0 / v)) / omega
            ended = not last and te <= t_end
            j = int(np.searchsorted(ts, te, side="right")) if ended else ts.size
            if j > i:
                cs, sn = np.cos(omega * (ts[i:j] - tb)), np.sin(omega * (ts[i:j] - tb))
                x[i:j] = c + z0 * cs + (v / omega) * sn
                yd[i:j] = v * (1.0 - cs) + omega * z0 * sn
            i = j
            if not ended or i >= ts.size:
                return x, yd
            th = omega * (te - tb)
            t, xs = te, c + z0 * math.cos(th) + (v / omega) * math.sin(th)
            continue

        def rhs(tt, z, xb=xb, tb=tb, mum=mum):  # z = (slip distance mm, slider speed mm/s)
            return [z[1], (k * (xb + v * (tt - tb) - z[0]) - mum * W) / M]

        def stop(tt, z):
            return z[1]

        stop.terminal, stop.direction = True, -1
        sol = solve_ivp(rhs, (tb, t_end), [0.0, 0.0], method="DOP853", rtol=rtol, atol=atol,
                        events=None if last else stop, dense_output=True, first_step=1e-6)
        ended = not last and sol.t_events[0].size > 0
        te = float(sol.t_events[0][0]) if ended else t_end
        j = int(np.searchsorted(ts, te, side="right"))
        if j > i:
            z = sol.sol(ts[i:j])
            x[i:j] = xb + v * (ts[i:j] - tb) - z[0]
            yd[i:j] = z[1]
        i = j
        if not ended or i >= ts.size:
            return x, yd
        x_e = xb + v * (te - tb) - float(sol.y_events[0][0][0])
        t, xs = te, x_e


def scipy_record(friction, W, k, v, ts, slip="ode"):
    """One record of the model from rest (x = 0 at t = 0), x(ts) in mm: the SciPy baselines of
    `benchmarks/simulate.py`. `friction`: eq (1) + eq (3) `stickslip_jax.Friction`; `slip`:
    see `simulate_window`."""
    return simulate_window(friction_values(friction), W, k, v, ts, slip=slip)[0]


@dataclasses.dataclass(frozen=True)
class ReferenceWindows:
    """A `TraceData` in NumPy, grouped by cycle window (mm, s, kgf).

    `shape` (N, L) of the residual layout; `record` [N] (record of each row),
    `deflection` and `mask` [N, L]; per window: `weight`, `stiffness`, `speed`,
    `start_time`, `start_level` (offset included), `window_record`, `index` (the flat
    positions in N * L of its real samples, in time order) and `time` (their times).
    """

    shape: tuple[int, int]
    record: np.ndarray
    deflection: np.ndarray
    mask: np.ndarray
    weight: np.ndarray
    stiffness: np.ndarray
    speed: np.ndarray
    start_time: np.ndarray
    start_level: np.ndarray
    window_record: np.ndarray
    index: list
    time: list


def reference_windows(tdata) -> ReferenceWindows:
    """Convert a `stickslip_fitting.objectives.trace.TraceData` to NumPy once (before fitting)."""
    a = {f.name: np.asarray(getattr(tdata, f.name)) for f in dataclasses.fields(tdata)}
    mask = a["mask"].astype(bool)
    real = mask.any(axis=1)
    first, index, time = [], [], []
    for w in np.unique(a["window"][real]):
        rows = np.flatnonzero(real & (a["window"] == w))
        flat = np.concatenate([r * mask.shape[1] + np.flatnonzero(mask[r]) for r in rows])
        t = a["time"].ravel()[flat]
        order = np.argsort(t, kind="stable")
        first.append(rows[0])
        index.append(flat[order])
        time.append(t[order])
    first = np.asarray(first)
    return ReferenceWindows(
        shape=mask.shape, record=a["record"].astype(int), deflection=a["deflection"],
        mask=mask, weight=a["weight"][first], stiffness=a["stiffness"][first],
        speed=a["speed"][first], start_time=a["start_time"][first],
        start_level=a["start_level"][first], window_record=a["record"][first].astype(int),
        index=index, time=time,
    )


def scipy_trace_simulation(values, windows: ReferenceWindows, offsets=None, *,
                           rtol=TRACE_RTOL, atol=TRACE_ATOL, slip="ode"):
    """Deflection (mm, without the gauge offset) and slider velocity (mm/s), both [N, L]
    (0 on padding): every cycle window simulated once from its start (at rest, stick time
    0, deflection `start_level - offset`), at most `TRACE_MAX_SLIPS` slips.
    `values`: (mu_s, mu_d, gamma, m, delta, n); `offsets`: per record (mm), default 0;
    `rtol`, `atol`: solve_ivp tolerances (see `TRACE_RTOL`); `slip`: see `simulate_window`."""
    N, L = windows.shape
    off = np.zeros(int(windows.record.max()) + 1) if offsets is None else np.asarray(offsets)
    x = np.zeros(N * L)
    yd = np.zeros(N * L)
    for w, (idx, ts) in enumerate(zip(windows.index, windows.time)):
        xw, ydw = simulate_window(
            values, windows.weight[w], windows.stiffness[w], windows.speed[w], ts,
            t0=windows.start_time[w],
            x0=windows.start_level[w] - off[windows.window_record[w]],
            max_slips=TRACE_MAX_SLIPS, rtol=rtol, atol=atol, slip=slip)
        x[idx], yd[idx] = xw, ydw
    return x.reshape(N, L), yd.reshape(N, L)


def scipy_trace_residuals(values, windows: ReferenceWindows, sd, offsets=None, *,
                          rtol=TRACE_RTOL, atol=TRACE_ATOL, slip="ode") -> np.ndarray:
    """Whitened trace residuals $(x - c - x_\\mathrm{sim}) / s$, flat (N L,), 0 on padding
    (the layout of `stickslip_fitting.objectives.trace.trace_residuals`).

    `values`: (mu_s, mu_d, gamma, m, delta, n); `sd`: the standard errors s (mm, [N, L]),
    frozen (e.g. `trace_sd` at the previous optimum); `offsets`: gauge offsets per record
    (mm), default 0; `rtol`, `atol`: solve_ivp tolerances; `slip`: see `simulate_window`."""
    x_sim, _ = scipy_trace_simulation(values, windows, offsets, rtol=rtol, atol=atol,
                                      slip=slip)
    off = np.zeros(int(windows.record.max()) + 1) if offsets is None else np.asarray(offsets)
    sd = np.asarray(sd, float)
    r = np.zeros(windows.shape)
    m = windows.mask
    r[m] = ((windows.deflection - off[windows.record][:, None] - x_sim)[m]) / sd[m]
    return r.ravel()
