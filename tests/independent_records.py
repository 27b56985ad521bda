r"""An independent stick-slip record generator (SciPy), for testing on data we did not make.

Shares no code with `stickslip_jax` (not even its units or tables): the slip is
integrated numerically with `scipy.integrate.solve_ivp` (DOP853, a terminal event when the
slider stops) instead of the package's closed-form half cosine, the stick ends where
`scipy.optimize.brentq` finds the spring force reaching eq (1)'s static friction, and
the instrument and drive imperfections are written in forms the package does not use:

- drive: lead-screw periodic error with a second harmonic, a slow linear drift of the
  speed (the drive is then *not* u = v t);
- slider: creep before breakaway (an exponential pre-slide of `creep_mm` over
  `creep_tau_s`), irregular slips (mu_s drawn per cycle, relative spread `mu_s_jitter`, Gaussian or
  heavy-tailed Student-t with `mu_s_jitter_df` degrees of freedom: sporadic large slips);
- measurement chain: first-order (time constant) or second-order (natural frequency and
  damping ratio) sensor dynamics, Gaussian noise, impulsive spikes, quantisation, a
  logger whose time stamps jitter about the (uniform) sampling instants;
- records without stick-slip: steady sliding with a decaying start-up transient.

Physics (units kgf, mm, s; g = 9806.65 mm/s^2): the slider of weight W on a spring k is
pulled by the drive u(t); at rest it sticks while k(u - y) < W mu_0(T_1) with
mu_0 = mu_s - (mu_s - mu_d) exp(-gamma T_1^m) (the paper's eq 1), and slips with the
constant kinetic friction mu_m = mu_d + (mu_0 - mu_d) exp(-delta T_2^n), T_2 = pi/omega_0
(eq 3), obeying (W/g) y'' = k (u - y) - mu_m W until the slider stops; a slider that
stops above mu_d W (it cannot stick, eq 1 at T_1 = 0) slips again from rest.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import integrate, optimize, signal

G = 9806.65  # mm/s^2


@dataclasses.dataclass(frozen=True)
class Friction:
    mu_s: float
    mu_d: float
    gamma: float
    m: float
    delta: float
    n: float


LUBRICANT_A = Friction(0.56, 0.21, 0.38, 0.4, 67.0, 1.0)
LUBRICANT_C = Friction(0.33, 0.17, 0.31, 0.5, 60.0, 0.9)
"""Parameters written down here, not read from the package: lubricant A as in the paper's
Table 6 and a second, lower-friction set standing in for lubricant C."""


@dataclasses.dataclass(frozen=True)
class Imperfections:
    noise_mm: float = 0.0005
    spike_rate: float = 0.0  # fraction of samples hit by an impulsive spike
    spike_mm: float = 0.0  # spike size (random sign, size uniform in [0.5, 1] x this)
    quantum_mm: float = 0.0  # quantisation step of the logger
    screw_amp_mm: float = 0.0  # lead-screw periodic error of the drive
    screw_pitch_mm: float = 5.0
    screw_harmonic: float = 0.3  # second harmonic relative to the first
    speed_drift: float = 0.0  # relative change of the speed over the record
    sensor_order: int = 0  # 0: ideal, 1: first order, 2: second order
    sensor_hz: float = 0.0  # corner (1st order) or natural frequency (2nd order)
    sensor_zeta: float = 0.7
    creep_mm: float = 0.0
    creep_tau_s: float = 0.05
    mu_s_jitter: float = 0.0
    mu_s_jitter_df: float = 0.0  # > 0: the per-cycle spread is Student-t with these dof
    clock_jitter: float = 0.0  # logger's time stamps off the sampling instants, uniform in
    # +- this fraction of the step (the samples themselves are taken on a uniform clock)


@dataclasses.dataclass(frozen=True)
class Physics:
    """Physics the paper's model leaves out, in forms of our own choosing (not the
    package's): viscous damping as a damping *ratio* zeta (force 2 zeta m omega_0 ydot);
    a Stribeck curve as a rational drop of the kinetic friction with slip speed,
    mu_m - b q / (1 + q), q = (ydot/v_s)^2 (mu_m at rest, b lower at speed); friction drift as linear rates of mu_s and mu_d per
    second (from the record's start); a hardening spring F = k x (1 + h x^2 / x_ref^2),
    x_ref = mu_s W / k, and backlash in the drive: the jerk of each slip sets the drive's
    nut back across its play `backlash_mm`, so the spring's far end stands still for the
    first `backlash_mm` of drive travel of every stick (lost motion; both outside the
    package's library; the gauge reads the spring's deflection)."""

    damping_ratio: float = 0.0
    stribeck_b: float = 0.0
    stribeck_vs: float = 10.0  # mm/s
    drift_mu_s: float = 0.0  # 1/s
    drift_mu_d: float = 0.0  # 1/s
    hardening: float = 0.0
    backlash_mm: float = 0.0


@dataclasses.dataclass(frozen=True)
class Truth:
    time: np.ndarray
    deflection: np.ndarray  # measured (with every imperfection)
    clean: np.ndarray  # true deflection, before the measurement chain
    drive: np.ndarray  # true drive displacement u(t)
    breakaways: np.ndarray  # times of the true slips' starts (s)
    slip_ends: np.ndarray


def _drive(speed, duration, imp: Imperfections, phase):
    def u(t):
        t = np.asarray(t, float)
        base = speed * t * (1.0 + 0.5 * imp.speed_drift * t / duration)
        if imp.screw_amp_mm:
            q = 2 * np.pi * base / imp.screw_pitch_mm
            base = base + imp.screw_amp_mm * (
                np.sin(q + phase) + imp.screw_harmonic * np.sin(2 * q + 1.7 * phase))
        return base
    return u


def simulate(friction: Friction, *, weight, stiffness, speed_mm_min, duration, rate_hz,
             imp: Imperfections = Imperfections(), seed=0, steady=False,
             physics: Physics = Physics()) -> Truth:
    """One record. `steady=True` draws steady sliding at mu_d with a decaying transient;
    `physics`: effects the paper's model leaves out (`Physics`)."""
    rng = np.random.default_rng(seed)
    W, k, v = float(weight), float(stiffness), speed_mm_min / 60.0
    mass = W / G
    w0 = math.sqrt(k / mass)
    t2 = math.pi / w0
    u = _drive(v, duration, imp, rng.uniform(0, 2 * np.pi))
    over = 8 if imp.sensor_order else 1
    t_hi = np.arange(int(round(duration * rate_hz)) * over) / (rate_hz * over)
    y_hi = np.full(t_hi.shape, np.nan)
    lag_hi = np.zeros(t_hi.shape)  # play of the drive not yet taken up (backlash), mm
    breaks, ends = [], []
    if steady:
        x_ss = friction.mu_d * W / k
        amp = 0.3 * x_ss
        x_hi = x_ss - amp * np.exp(-0.05 * w0 * t_hi) * np.cos(w0 * t_hi)
        x_hi = x_hi + (u(t_hi) - v * t_hi)  # the drive error shows while sliding
    else:
        y, ts = 0.0, 0.0  # slider at rest, stick started at t = 0
        def jitter():
            z = (rng.standard_t(imp.mu_s_jitter_df) if imp.mu_s_jitter_df
                 else rng.standard_normal())
            return 1.0 + imp.mu_s_jitter * z
        ph = physics
        x_ref = friction.mu_s * W / k
        u_raw, lost = u, 0.0  # the drive; its motion lost to the backlash so far (mm)

        def spring(x):
            return k * x * (1.0 + ph.hardening * (x / x_ref) ** 2)

        while ts < duration:
            if ph.backlash_mm:  # the spring's far end: the drive less the motion it lost
                def u(t, u_ts=float(u_raw(ts)), lost=lost):
                    return u_raw(t) - lost - np.clip(u_raw(t) - u_ts, 0.0, ph.backlash_mm)
            f = dataclasses.replace(friction, mu_s=friction.mu_s + ph.drift_mu_s * ts,
                                    mu_d=friction.mu_d + ph.drift_mu_d * ts)
            mu_s = f.mu_s * jitter()

            def margin(t, ts=ts, y=y, mu_s=mu_s, f=f):
                T1 = max(t - ts, 0.0)
                mu0 = mu_s - (mu_s - f.mu_d) * math.exp(-f.gamma * T1 ** f.m)
                return spring(float(u(t)) - y) - W * mu0

            def margins(t, ts=ts, y=y, mu_s=mu_s, f=f):  # `margin` on an array of times
                mu0 = mu_s - (mu_s - f.mu_d) * np.exp(-f.gamma * (t - ts) ** f.m)
                return spring(u(t) - y) - W * mu0

            # the grid's first sign change brackets the breakaway for brentq; the grid in
            # one array operation (a Python call per point takes three times as long: 124.5
            # against 41.7 s of CPU time over 71 records, the same records bit for bit)
            grid = ts + np.geomspace(1e-6, 2.0 * duration, 4000)
            pos = np.flatnonzero(margins(grid) >= 0)
            if pos.size == 0:
                break
            j = int(pos[0])
            if j == 0 and margin(ts) >= 0:  # a drive error moving the far end at once
                tb = ts
            else:
                tb = optimize.brentq(margin, grid[j - 1] if j else ts, grid[j], xtol=1e-13)
            T1 = tb - ts
            mu0 = mu_s - (mu_s - f.mu_d) * math.exp(-f.gamma * T1 ** f.m)
            mum = f.mu_d + (mu0 - f.mu_d) * math.exp(-f.delta * t2 ** f.n)
            stick = (t_hi >= ts) & (t_hi < tb)
            y_hi[stick] = y
            if imp.creep_mm:  # pre-slide creep: the slider moves before it breaks away
                e0 = math.exp((ts - tb) / imp.creep_tau_s)  # starts from 0 at the stick's start
                c = np.exp((t_hi[stick] - tb) / imp.creep_tau_s)
                y_hi[stick] += imp.creep_mm * (c - e0) / (1.0 - e0)
                y += imp.creep_mm
            breaks.append(tb)
            t0 = tb
            while True:  # slip (again, if the slider stops above mu_d W)
                def rhs(t, s, mum=mum):
                    q = (s[1] / ph.stribeck_vs) ** 2
                    fr = mum - ph.stribeck_b * q / (1.0 + q)
                    return [s[1], (spring(float(u(t)) - s[0]) - fr * W
                                   - 2.0 * ph.damping_ratio * mass * w0 * s[1]) / mass]

                def stop(t, s):
                    return s[1]
                stop.terminal, stop.direction = True, -1
                sol = integrate.solve_ivp(rhs, (t0, t0 + 50 * t2), [y, 0.0], method="DOP853",
                                          rtol=1e-10, atol=1e-13, events=stop,
                                          dense_output=True, first_step=1e-7)
                te = float(sol.t_events[0][0]) if sol.t_events[0].size else float(sol.t[-1])
                sl = (t_hi >= t0) & (t_hi < te)
                if sl.any():
                    y_hi[sl] = sol.sol(t_hi[sl])[0]
                y = float(sol.sol(te)[0])
                t0 = te
                if spring(float(u(te)) - y) <= f.mu_d * W * (1 + 1e-9) or te > duration:
                    break
                mum = f.mu_d  # slipping on from rest at the kinetic level
            ends.append(t0)
            cyc = t_hi >= ts
            lag_hi[cyc] = u_raw(t_hi[cyc]) - u(t_hi[cyc])
            lost += ph.backlash_mm
            u = u_raw
            ts = t0
        y_hi[np.isnan(y_hi)] = y
        u = u_raw
        x_hi = u(t_hi) - lag_hi - y_hi
    clean_hi = x_hi
    if imp.sensor_order:
        wc = 2 * np.pi * imp.sensor_hz
        if imp.sensor_order == 1:
            num, den = [1.0], [1.0 / wc, 1.0]
        else:
            num, den = [wc**2], [1.0, 2 * imp.sensor_zeta * wc, wc**2]
        b, a = signal.bilinear(num, den, fs=rate_hz * over)
        zi = signal.lfilter_zi(b, a) * x_hi[0]
        x_hi, _ = signal.lfilter(b, a, x_hi, zi=zi)
    t = t_hi[::over]
    x = x_hi[::over].copy()
    clean = clean_hi[::over]
    x += imp.noise_mm * rng.standard_normal(x.size)
    if imp.spike_rate:
        hit = rng.random(x.size) < imp.spike_rate
        x[hit] += rng.choice([-1, 1], hit.sum()) * imp.spike_mm * rng.uniform(0.5, 1, hit.sum())
    if imp.quantum_mm:
        x = np.round(x / imp.quantum_mm) * imp.quantum_mm
    if imp.clock_jitter:  # the stamps a jittery logger writes (t stays the true instants)
        t = t + imp.clock_jitter * rng.uniform(-1.0, 1.0, t.size) / rate_hz
        t -= t[0]
    keep = np.asarray(breaks) < t[-1] - 2 * t2
    return Truth(t, x, clean, u(t), np.asarray(breaks)[keep], np.asarray(ends)[keep])


def write_record(path, truth: Truth, *, friction: Friction, weight, stiffness, speed_mm_min,
                 lubricant="A", drive_column=False, extra=None):
    """The record file format of the package's README (version 1), written by hand here."""
    tj = {"mu_s": friction.mu_s, "mu_d": friction.mu_d, "gamma": friction.gamma,
          "m": friction.m, "delta": friction.delta, "n": friction.n}
    import json

    lines = [
        "# stickslip-record: 1",
        f"# stiffness: {stiffness!r} kgf/mm",
        f"# slider_weight: {weight!r} kgf",
        f"# drive_speed: {speed_mm_min!r} mm/min",
        f"# lubricant: {lubricant}",
        "# note: independent SciPy generator (tests/independent_records.py)",
        f"# truth: {json.dumps({'friction': tj, **(extra or {})})}",
    ]
    cols = ["time [s]", "deflection [mm]"] + (["drive [mm]"] if drive_column else [])
    lines.append(",".join(cols))
    data = [truth.time, truth.deflection] + ([truth.drive] if drive_column else [])
    body = "\n".join(",".join(repr(float(c)) for c in row) for row in zip(*data))
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n" + body + "\n")


RUNS = ((36.0, 86.9), (20.0, 27.3), (11.3, 128.5))
"""(W kgf, k kgf/mm) of a discovery campaign (3 (W, k) x 4 speeds)."""


def campaign(friction: Friction = LUBRICANT_A, *, physics: Physics = Physics(),
             imp: Imperfections = Imperfections(), seed: int = 0, cycles: float = 6.0,
             rate_hz: float = 1000.0, runs=RUNS, speeds=(2.0, 5.0, 10.0, 20.0)):
    """Records (the package's `Record`, the input format only) of a campaign: every
    (W, k) of `runs` at every speed (mm/min), about `cycles` cycles each (at least 3 s,
    at most 300 s). The fastest runs of the stiff, light slider sit near the boundary
    of stick-slip (marginal or re-stick-failing records, as in a real campaign)."""
    from stickslip_jax.records import Record

    out, i = [], 0
    for W, k in runs:
        for v in speeds:
            amp = 2.0 * (friction.mu_s - friction.mu_d) * W / k  # slip size, mm
            T = min(max(cycles * amp / (v / 60.0) * 0.8, 3.0), 300.0)
            tr = simulate(friction, weight=W, stiffness=k, speed_mm_min=v, duration=T,
                          rate_hz=rate_hz, imp=imp, seed=1000 * seed + i, physics=physics)
            # from_arrays: jittered time stamps are resampled to a uniform step there, as
            # the package reads a jittery logger's file
            out.append(Record.from_arrays(tr.time, tr.deflection, stiffness=k, weight=W,
                                          drive_speed=v / 60.0, note=f"W{W:g} k{k:g} v{v:g}"))
            i += 1
    return out
