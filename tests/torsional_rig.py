r"""An independent generator of a torsional stick-slip rig with a fluctuating motor.

Shares no code with `stickslip_jax` or `stickslip_fitting` (its own constants, friction
law, integrator and file writer). The rig: a motor turns a flexible shaft whose end, of
inertia J, rubs on a stator; written in equivalent linear coordinates (the friction
radius r maps the angle to a displacement, the torsional stiffness to k = k_t / r^2, the
inertia to a weight W = g J / r^2), so the records are plain linear records: deflection
x = u - y in mm, the motor's measured position u (a `drive` column) or its measured speed
(a `drive_speed` column, mm/s).

Physics (kgf, mm, s; g = 9806.65 mm/s^2): the end sticks while k (u - y) < W mu_0(T_1),
mu_0 = mu_s - (mu_s - mu_d) exp(-gamma T_1^m) (T_1 the time at rest), then slips with the
constant kinetic friction mu_m = mu_d + (mu_0 - mu_d) exp(-delta T_2^n), T_2 = pi/omega_0,
(W/g) y'' = k (u - y) - mu_m W, until it stops: y' = 0, or a minimum of y' below 3 % of
the mean motor speed (the friction's rise at low speed stops a slider that all but
stops). The slip is the closed-form solution of that linear equation for the motor's
sinusoidally modulated u(t) (`simulate`), evaluated on a grid of 1/16 of the sampling
interval, the stop and the breakaway located there by linear interpolation. The motor's
speed fluctuates: v(t) = v_0 (1 + A sin(2 pi f t + phi)), A 10-50 %, f 0.2-2 Hz.
Measured channels get Gaussian noise; the deflection also gets impulsive spikes.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

G = 9806.65  # mm/s^2


@dataclasses.dataclass(frozen=True)
class Law:
    mu_s: float = 0.45
    mu_d: float = 0.30
    gamma: float = 20.0
    m: float = 0.5
    delta: float = 60.0
    n: float = 1.0

    def mu_0(self, stick):
        return self.mu_s - (self.mu_s - self.mu_d) * np.exp(
            -self.gamma * np.maximum(stick, 0.0) ** self.m)

    def mu_m(self, mu_0, omega0):
        return self.mu_d + (mu_0 - self.mu_d) * math.exp(-self.delta * (math.pi / omega0)
                                                         ** self.n)


@dataclasses.dataclass(frozen=True)
class Rig:
    """One run: natural frequency `omega0` (rad/s), weight `weight` (kgf), the wanted
    share of each cycle in stick `stick_share` (sets the mean motor speed), the motor's
    fluctuation `ripple` (fraction of its mean speed) at `ripple_hz`, sampling `rate`
    (Hz), `duration` (s), noise of the deflection `noise` (mm) and of the measured
    drive position `drive_noise` (mm) or speed `speed_noise` (fraction of the mean),
    spikes (`spike_rate` per sample, `spike_mm` in size); a slider whose speed falls to a
    minimum below `stop_speed` times the mean motor speed stops there."""

    omega0: float = 30.0
    weight: float = 10.0
    stick_share: float = 0.1
    ripple: float = 0.3
    ripple_hz: float = 2.0
    rate: float = 2000.0
    duration: float = 6.0
    noise: float = 0.002
    drive_noise: float = 0.001
    speed_noise: float = 0.002
    spike_rate: float = 5e-4
    spike_mm: float = 0.05
    stop_speed: float = 0.03
    law: Law = Law()
    seed: int = 0

    @property
    def stiffness(self) -> float:
        return self.omega0**2 * self.weight / G


def mean_speed(rig: Rig) -> float:
    """The mean motor speed (mm/s) that makes about `stick_share` of a cycle a stick at
    a steady drive: a stick of T_1 = 2a/v (a the half swing of the deflection) against a
    slip of (pi + 2 atan(q))/omega_0, q = v/(omega_0 a), iterated for mu_0(T_1)."""
    law, w0 = rig.law, rig.omega0
    f = rig.stick_share
    lo, hi = 1e-3, 1e3
    for _ in range(200):  # the share falls as q grows: bisection on q
        q = math.sqrt(lo * hi)
        share = (2.0 / q) / (2.0 / q + math.pi + 2.0 * math.atan(q))
        lo, hi = (q, hi) if share > f else (lo, q)
    t1 = 0.05
    for _ in range(50):
        mu0 = law.mu_0(t1)
        a = (mu0 - law.mu_m(mu0, w0)) * rig.weight / rig.stiffness
        v = q * w0 * a
        t1 = 2.0 * a / v
    return v


def simulate(rig: Rig) -> dict:
    """The run: time (s), true deflection x, drive u, speed v, slider y (mm, mm/s), and
    the true breakaway and stop times (s) and static friction of each slip.

    The slip is the exact solution of y'' + omega_0^2 y = omega_0^2 u(t) - mu_m g for the
    motor's u(t) = v_0 (t - (A/Omega)(cos(Omega t + phi) - cos(phi))) from rest, evaluated
    on a grid of 1/16 of the sampling interval; the stop (y' = 0) and the breakaway are
    located on that grid by linear interpolation."""
    rng = np.random.default_rng(rig.seed)
    v0, law, w0 = mean_speed(rig), rig.law, rig.omega0
    phi = rng.uniform(0.0, 2.0 * math.pi)
    om = 2.0 * math.pi * rig.ripple_hz
    amp = rig.ripple

    def u_of(t):
        return v0 * (t - amp / om * (np.cos(om * t + phi) - math.cos(phi)))

    gain = w0**2 / (w0**2 - om**2)

    def particular(t, mum):  # y_p and y_p'
        yp = (v0 * t + v0 * amp / om * math.cos(phi) - mum * G / w0**2
              - v0 * amp / om * gain * np.cos(om * t + phi))
        return yp, v0 + v0 * amp * gain * np.sin(om * t + phi)

    k, W = rig.stiffness, rig.weight
    n = int(round(rig.duration * rig.rate))
    fine = np.arange(16 * n + 1) / (16.0 * rig.rate)
    u_fine = u_of(fine)
    y = np.full_like(fine, np.nan)
    y_rest, rest_from, i = -law.mu_d * W / k, -0.05, 0
    breaks, stops, mus = [], [], []
    while i < fine.size - 1:
        # stick: y constant until k (u - y) reaches W mu_0(t - rest_from)
        excess = k * (u_fine[i:] - y_rest) - W * law.mu_0(fine[i:] - rest_from)
        over = np.flatnonzero(excess >= 0.0)
        if over.size == 0:
            y[i:] = y_rest
            break
        j = i + int(over[0])
        y[i:j] = y_rest
        if j == i:
            tb = fine[i]
        else:
            e0, e1 = excess[j - i - 1], excess[j - i]
            tb = fine[j - 1] + (fine[j] - fine[j - 1]) * (-e0) / (e1 - e0)
        mu0 = float(law.mu_0(tb - rest_from))
        mum = law.mu_m(mu0, w0)
        breaks.append(tb)
        mus.append(mu0)
        yp0, vp0 = particular(tb, mum)
        c1, c2 = y_rest - yp0, -vp0 / w0
        te, j0 = None, j
        while j0 < fine.size:  # the slip in windows of two natural periods
            s = fine[j0:j0 + 16 * int(rig.rate * 4 * math.pi / w0) + 2]
            yp, vp = particular(s, mum)
            ph = w0 * (s - tb)
            ys = yp + c1 * np.cos(ph) + c2 * np.sin(ph)
            vs = vp - c1 * w0 * np.sin(ph) + c2 * w0 * np.cos(ph)
            # a stop: y' reaches 0, or a minimum of y' below `stop_speed` (friction rises
            # at low speed: a slider that all but stops, stops)
            low = np.zeros(vs.size, bool)
            low[1:-1] = (vs[1:-1] <= vs[:-2]) & (vs[1:-1] <= vs[2:]) & (
                vs[1:-1] <= rig.stop_speed * v0)
            neg = np.flatnonzero(((vs <= 0.0) | low) & (s > tb + 1e-9))
            if neg.size == 0:
                y[j0:j0 + s.size] = ys
                j0 += s.size
                continue
            m = int(neg[0])
            y[j0:j0 + m] = ys[:m]
            if m == 0 or vs[m] > 0.0:
                te, y_stop = s[m], ys[m]
            else:
                frac = vs[m - 1] / (vs[m - 1] - vs[m])
                te = s[m - 1] + frac * (s[m] - s[m - 1])
                y_stop = ys[m - 1] + frac * (ys[m] - ys[m - 1])
            j0 += m
            break
        if te is None:
            break
        stops.append(te)
        y_rest, rest_from, i = y_stop, te, j0
    t = fine[::16]
    ys = y[::16]
    u = u_fine[::16]
    v = v0 * (1.0 + amp * np.sin(om * t + phi))
    return dict(time=t, y=ys, u=u, x=u - ys, v=v, v0=v0, breaks=np.array(breaks),
                stops=np.array(stops), mu_0=np.array(mus))


def measured(rig: Rig, run: dict) -> dict:
    """The measured channels: deflection with noise and spikes, drive with noise (mm),
    drive speed with noise (mm/s)."""
    rng = np.random.default_rng(rig.seed + 10_000)
    x = run["x"] + rng.normal(0.0, rig.noise, run["x"].size)
    hit = rng.random(x.size) < rig.spike_rate
    x[hit] += rng.choice([-1.0, 1.0], hit.sum()) * rng.uniform(0.5, 1.0, hit.sum()) * rig.spike_mm
    u = run["u"] + rng.normal(0.0, rig.drive_noise, x.size)
    v = run["v"] + rng.normal(0.0, rig.speed_noise * run["v0"], x.size)
    return dict(time=run["time"], deflection=x, drive=u, drive_speed=v)


def write(path, rig: Rig, run: dict, *, channel: str = "drive") -> Path:
    """A record file of the run (`channel`: "drive" for the measured position, "speed"
    for the measured speed)."""
    m = measured(rig, run)
    truth = dict(mu_s=rig.law.mu_s, mu_d=rig.law.mu_d, gamma=rig.law.gamma, m=rig.law.m,
                 delta=rig.law.delta, n=rig.law.n)
    col = "drive [mm]" if channel == "drive" else "drive_speed [mm/s]"
    data = m["drive"] if channel == "drive" else m["drive_speed"]
    lines = ["# stickslip-record: 1", f"# stiffness: {rig.stiffness!r} kgf/mm",
             f"# slider_weight: {rig.weight!r} kgf", "# lubricant: torsional",
             f"# truth: {json.dumps(truth)}",
             f"time [s],deflection [mm],{col}"]
    lines += [f"{a:.17g},{b:.17g},{c:.17g}" for a, b, c in zip(m["time"], m["deflection"], data)]
    path = Path(path)
    path.write_text("\n".join(lines) + "\n")
    return path


def random_rig(seed: int, **kw) -> Rig:
    """A rig drawn for `seed`: omega0 20-40 rad/s, stick 5-20 % of the cycle, motor
    ripple 10-50 % at 0.2-2 Hz."""
    rng = np.random.default_rng(seed)
    base = dict(omega0=float(rng.uniform(20.0, 40.0)), stick_share=float(rng.uniform(0.05, 0.2)),
                ripple=float(rng.uniform(0.1, 0.5)), ripple_hz=float(rng.uniform(0.2, 2.0)),
                seed=seed)
    base.update(kw)
    return Rig(**base)


def sliding(seed: int = 0, duration: float = 3.0, rate: float = 2000.0, noise: float = 0.002):
    """A run that slides continuously: the end follows a fluctuating motor with a
    viscous (velocity-strengthening) friction, never at rest. Returns (time, deflection,
    drive, W, k)."""
    rng = np.random.default_rng(seed)
    W, w0 = 10.0, 30.0
    k = w0**2 * W / G
    t = np.arange(int(duration * rate)) / rate
    v0, A, f = 80.0, 0.4, 2.5
    u = v0 * (t - A / (2 * math.pi * f) * np.cos(2 * math.pi * f * t))
    # a velocity-strengthening friction mu = 0.3 + c y': the slider follows, lagging
    c = 0.3 / v0
    y, vy = -0.3 * W / k, v0
    ys = np.empty_like(t)
    sub = 16
    hh = (t[1] - t[0]) / sub
    for i in range(t.size):
        ys[i] = y
        for s in range(sub):
            tt = t[i] + s * hh
            ui = v0 * (tt - A / (2 * math.pi * f) * math.cos(2 * math.pi * f * tt))
            a = G / W * (k * (ui - y) - (0.3 + c * vy) * W)
            vy += hh * a
            y += hh * vy
    x = u - ys + rng.normal(0.0, noise, t.size)
    return t, x, u, W, k


CAMPAIGN_LAW = Law(delta=10.0)
"""The law of `campaign`: a kinetic decay of eq (3) that the two slip times tell apart
(exp(-delta T_2) 0.24 and 0.42), so that mu_d is not tied to delta and n."""


def campaign(folder, seed: int, *, channel: str = "drive") -> list[str]:
    """Four records of one rig (`CAMPAIGN_LAW`) at two natural frequencies (22 and 36
    rad/s) and two motor speeds (sticks of about 6 % and 18 % of the cycle), each with
    its own motor ripple; written with the measured drive position (`channel` "drive")
    or speed ("speed"). Returns the file names."""
    paths = []
    for i, (w0, share) in enumerate([(22.0, 0.06), (22.0, 0.18), (36.0, 0.06), (36.0, 0.18)]):
        rig = random_rig(1000 * seed + i, omega0=w0, stick_share=share, law=CAMPAIGN_LAW)
        paths.append(str(write(Path(folder) / f"r{i}.csv", rig, simulate(rig), channel=channel)))
    return paths
