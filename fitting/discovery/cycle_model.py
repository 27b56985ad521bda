r"""The per-cycle model with effects: the discovery base (`cycle_workflow`).

Same windows as the trace objective (`stickslip_fitting.objectives.trace`): cycle $j$ of a record
runs from the measured end of slip $j-1$ to the measured end of slip $j$, the slider at
rest at the measured slip-end level. Nothing accumulates from cycle to cycle, so a long
record's slips cannot drift away from the data. With every effect at zero this is the
paper's model (chapters 2-5) and equals `trace_objective.trace_simulation` (tested);
the effects of `cycle_effects` enter as parts of it:

- **stick** (closed form): the deflection follows the drive,
  $x(t) = x_0 + u(t) - u(t_0)$, with the drive $u$ of the drive effects (screw error,
  speed drift); breakaway where $k x = N \mu_0(T_1)$ (eq 1) with $N = N_0 + \kappa k x$
  ($N_0$ the record's normal load, W unless it gives one; load coupling $\kappa$) and
  $\mu_s$, $\mu_d$ shifted by friction drift; found by a bracketed
  Newton iteration whose last step carries the derivative (implicit function theorem);
- **slip** (RK4, fixed step, `N_STEPS` over 2.5 $\pi/\omega_0$):
  $m\ddot y = k x - N(\mu_m + b_S s(\dot y/v_s) + a \ln(1 + \dot y/V_\mathrm{ref})
  + b \ln(\theta/\theta_b)) - c\dot y$ with the Dieterich-Ruina state $\theta$ (aging
  law $\dot\theta = 1 - \dot y\theta/D_c$, $\theta_b = T_1 + D_c/V_\mathrm{ref}$ at the
  breakaway, `DR_V_REF`) and the Stribeck curve $s(w) = e^{-w^p}$, $-\ln(1 + w)$ or $-w$,
  $x = x_b + \dot u(t_b)(t - t_b) - y$, $\mu_m$ from eq (3) with $T_2 = \pi/\omega_0$ (eq 7);
  the slider stops where $\dot y$ first returns to 0 (interpolated), and sticks again;
- **measurement**: the gauge reads $c_r + (K * x)(t) + r_g (t - t_\mathrm{mid})$ with gauge
  drift $r_g$ and a low-pass kernel $K$ of mean delay $\tau$ (order 1 or 2, `kernel_cdf`).
  With $x = L - D$ (stick line $L$, slip displacement $D$: 0 before breakaway, $y$ in the
  slip, $y_\mathrm{stop}$ after), $K * L = L(t - \tau)$ (exact for a steady drive) and
  $K * D$ is a discrete convolution on the RK4 grid with the kernel's bin masses, over
  `TAIL_STEPS` nodes (the slip and the gauge's settling). The gauge still settles from
  the previous slip when a window starts: that tail's decay after $t_0$ is added
  (`previous_rows`), the slip placed where the features put its breakaway as read: their
  half-sine centre (`_centre`) less half the duration they give it (`_slip_time`, an
  undamped slip's). A damped slip is not symmetric: at a damping ratio of 0.2 that
  centre comes 0.077/omega_0 (0.23-0.67 ms on the campaigns' sliders) before the middle
  of the slip, so placing the slip by the model's own centre of it put every tail that
  much early: with a 20 Hz sensor at its truth a damping ratio of 0.2 refitted to 0 (12
  records, seed 610); placed so, to 0.21. A
  window without a previous one takes its own slip's tail, placed where the slip before
  began (`tail_sources`: without it the first windows of a 7 Hz sensor missed by 30 um,
  60 times the noise). The measured restart state is itself a
  reading, so the slider's clock starts at $t_0 - \tau$: a pure delay is invisible, and
  the sensor changes the shape of the slips (second order in $\tau$; the score test
  probes it with a secant). With `sensor=False` the parameter is ignored.

Between the RK4 nodes the slip is a cubic Hermite interpolant (error ~(h omega_0)^4).
Residuals are whitened by the trace objective's standard errors (`trace_sd`, held
fixed). Units: mm, s, kgf, kgf/mm, mm/s.

Coordinates `z`: the 6 `EmpiricalFriction` logs, one gauge offset per record (mm), the
effect parameters over their `SCALES` in `FAMILIES` order (per-record families:
record-major), then the stick terms' coefficients over `STICK_SCALE`
(`cycle_effects.stick_terms`). `CycleModel.evaluate` gives residuals and the Jacobian of
any coordinates (forward mode, `BLOCK` tangents per compiled call; a record's rows depend
only on its own offset and per-record coefficients, so those share one tangent: the base
model's 6 + R columns cost 7 tangents).
"""

from __future__ import annotations

import concurrent.futures
import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from stickslip_jax.numerics import safe_power
from stickslip_jax.units import G_MM_S2

from ..objectives.trace import TraceData
from ..params import EmpiricalFriction
from ..solve.fit import COMPILER_OPTIONS
from .cycle_effects import (DAMPING_FORMS, FAMILIES, STICK_SCALE, STICK_TERMS, STRIBECK_FORMS,
                            Family, Shape, drive_error, stick_terms)
from .later import Later

__all__ = ["BLOCK", "CycleModel", "Later", "N_STEPS", "TAIL_STEPS", "kernel_cdf",
           "per_sample", "previous_rows", "tail_sources", "window_rows"]

N_STEPS = 128
"""RK4 steps per slip (over 2.5 pi/omega_0: room for slips lengthened by the effects)."""
BLOCK = 8
"""Tangents per compiled forward-mode call (`CycleModel.evaluate`). Without the sensor, once
64 evaluations padded their last call (its compilation, ~9 s CPU, pays back over hundreds), a
call of at most `BLOCK // 2` takes that width (a call costs about its width: 11 tangents as
8 + 4, not 16; the lanes are identical)."""
NEWTON = 40
"""Bracketed Newton iterations for the breakaway time."""
DR_V_REF = 1.0
"""mm/s: reference speed of the rate-and-state direct effect a ln(1 + V / V_REF)."""
TAIL_STEPS = 512
"""Nodes of the sensor kernel's convolution: the slip grid and 3 times it after (10
pi/omega_0), where the gauge settles. A 7 Hz sensor on a 20 ms slip still owes 8 % of it
80 ms later: with 256 nodes the model at the truth missed by 1.30 um (noise 0.5 um), with
512 by 0.68 um (1024: the same)."""
FFT_SIZE = 1024
"""FFT length of the sensor kernel's convolution (at least 2 TAIL_STEPS - 1)."""


def kernel_cdf(s, tau, order, zeta=1.0):
    """Fraction of the sensor kernel's weight at delays below s (s, tau in s; module
    doc): order 1, $1 - e^{-s/\\tau}$; order 2, the step response of a second-order
    sensor of damping ratio `zeta` (<= 1) and natural frequency $\\omega_n = 2\\zeta/\\tau$
    (mean delay tau): $1 - e^{-\\zeta\\omega_n s}(\\cos\\omega_d s + \\zeta\\omega_n s\\,
    \\mathrm{sinc}(\\omega_d s))$, $\\omega_d = \\omega_n\\sqrt{1-\\zeta^2}$ (at zeta = 1 the
    critically damped $1 - (1 + 2s/\\tau) e^{-2s/\\tau}$)."""
    tau = jnp.maximum(tau, 1e-9)
    zeta = jnp.clip(zeta, 0.05, 1.0)
    wn = 2.0 * zeta / tau
    wd = wn * jnp.sqrt(1.0 - zeta * zeta)
    a = zeta * wn * s
    second = 1.0 - jnp.exp(-a) * (jnp.cos(wd * s) + a * jnp.sinc(wd * s / jnp.pi))
    return jnp.where(order == 1, 1.0 - jnp.exp(-s / tau), second)


def _hermite(y0, y1, m0, m1, f):
    f2, f3 = f * f, f * f * f
    return ((2 * f3 - 3 * f2 + 1) * y0 + (f3 - 2 * f2 + f) * m0 + (-2 * f3 + 3 * f2) * y1
            + (f3 - f2) * m1)


def _hermite_slope(y0, y1, m0, m1, f):
    f2 = f * f
    return ((6 * f2 - 6 * f) * y0 + (3 * f2 - 4 * f + 1) * m0 + (-6 * f2 + 6 * f) * y1
            + (3 * f2 - 2 * f) * m1)


class _Eff(eqx.Module):
    """Natural effect values of one row (its record's drive coefficients gathered)."""

    c: jax.Array
    b_st: jax.Array
    a_rs: jax.Array
    b_rs: jax.Array
    drive: jax.Array  # [4]
    s: jax.Array
    tau: jax.Array
    r_s: jax.Array
    r_d: jax.Array
    r_g: jax.Array
    kappa: jax.Array
    stick: jax.Array  # [len(STICK_TERMS)] mm (`cycle_effects.stick_terms`)


def _drive(eff: _Eff, v, tref, tw, poly, pitch):
    """The drive u(t) (mm, arbitrary origin) of one window: speed v (mm/s) with the speed
    drift about `tref`, the screw error, and a measured drive's cubic from the window's
    measured start `tw` (s)."""
    def u(t):
        dt = t - tref
        sw = t - tw
        return (v * dt + 0.5 * v * eff.s * dt * dt + drive_error(eff.drive, t, v, pitch)
                + sw * (poly[0] + sw * (poly[1] + sw * poly[2])))
    return u


class _Slip(eqx.Module):
    """One window's stick and slip (`_slip`), shared by the window's rows (`_render`)."""

    t0: jax.Array  # the slider's clock origin (s; tau before the measured start with sensor)
    x0: jax.Array  # restart deflection (mm, without offset)
    u0: jax.Array  # u(t0) (mm)
    t_b: jax.Array  # breakaway (s)
    x_b: jax.Array  # deflection at the breakaway (mm)
    u_b: jax.Array  # u(t_b) (mm)
    h: jax.Array  # RK4 step (s)
    Y: jax.Array  # [N_STEPS + 1] slip displacement (mm)
    YD: jax.Array  # [N_STEPS + 1] slip velocity (mm/s)
    t_stop: jax.Array  # slip end (s)
    x_stop: jax.Array  # deflection at the slip end (mm)
    u_stop: jax.Array  # u(t_stop) (mm)
    ok: jax.Array  # breakaway found and the slip ended
    F: jax.Array  # [TAIL_STEPS] the kernel-filtered slip displacement (sensor; else [0])
    Fd: jax.Array  # its slope (mm/s)
    tau: jax.Array  # the sensor's mean delay (s)
    T1m: jax.Array  # the measured stick time (s)
    delay: jax.Array  # how late the features put the breakaway as read (s; `_centre`)


def _stick_line(sl_or_x0, eff: _Eff, u, t0, u0, tw, T1m, v):
    """The stick line at slider time t with the stick terms' displacement (module doc of
    `cycle_effects`): x0 + u(t) - u0 + q(t - tw) (mm)."""
    def line(t):
        xl = sl_or_x0 + u(t) - u0
        return xl + stick_terms(t - tw, T1m, xl, v) @ eff.stick
    return line


def _grid(W, k):
    """(mass W / g, T2 = pi / omega_0 (s), the RK4 step h (s)) of a slideway."""
    mass = W / G_MM_S2
    T2 = jnp.pi / jnp.sqrt(k / mass)
    return mass, T2, 2.5 * T2 / N_STEPS


def _centre(X, t, omega0, T2):
    r"""Where `stickslip_fitting.data.features` puts the centre of a slip whose fraction
    done is X [n] at the times t [n] (s, step h): its half-sine fit (`_cycle_row`), the
    weighted mean of $t - \arcsin(s)/\omega_0$, $s = 2X - 1$, weights $1 - s^2$ over
    $|s| < 0.75$ and within 0.3 T2 of the centre, refined 4 times.
    The features sample at random phases of the model's grid, so a node at a band's edge
    counts with the fraction of its cell inside the band (with hard edges the delay of a
    20 Hz sensor jumped by up to 0.05 ms between mean delays 0.05 ms apart; with the ramp
    by 0.002 ms, and it stays within 0.04 ms of the hard edges' value)."""
    s = 2.0 * X - 1.0
    ds = jnp.maximum(jnp.abs(jnp.gradient(s)), 1e-12)  # a node's cell, in s
    w0 = (1.0 - s * s) * jnp.clip((0.75 - jnp.abs(s)) / ds + 0.5, 0.0, 1.0)
    est = t - jnp.arcsin(jnp.clip(s, -0.75, 0.75)) / omega0
    h = t[1] - t[0]

    def mean(w):
        return jnp.sum(w * est) / jnp.maximum(jnp.sum(w), 1e-30)

    c = mean(w0)
    for _ in range(4):
        c = mean(w0 * jnp.clip((0.3 * T2 - jnp.abs(t - c)) / h + 0.5, 0.0, 1.0))
    return c


def _slip_time(omega0, v, jump, iterations=40):
    r"""The duration the features give a slip of displacement `jump` (mm) under the drive
    speed v (`stickslip_fitting.data.sticks.slip_duration`): the fixed point of
    $\omega_0 T = \pi + 2\arctan(v/(\omega_0 a))$, $a = (\mathrm{jump} - v T)/2$, by
    plain iterations from $\pi/\omega_0$: each contracts the error by $q^2/(1 + q^2)$,
    $q = v/(\omega_0 a)$ (0.59 near the stick-slip boundary, q 1.2: 7e-10 after 40)."""
    def step(_, T):
        a = 0.5 * (jump - v * T)
        return jnp.where(a > 0, (jnp.pi + 2.0 * jnp.arctan(v / (omega0 * jnp.maximum(a, 1e-12))))
                         / omega0, 2.0 * jnp.pi / omega0)
    return jax.lax.fori_loop(0, iterations, step, jnp.pi / omega0 + 0.0 * jump)


def _kernel_spectrum(h, tau, order, zeta):
    """The sensor kernel's bin masses on a slip grid of step h (s; their CDF at the bin
    edges, `kernel_cdf`) over `TAIL_STEPS` nodes, as their FFT of `FFT_SIZE`."""
    cdf = kernel_cdf(jnp.maximum((jnp.arange(TAIL_STEPS + 1) - 0.5) * h, 0.0), tau, order,
                     zeta)
    return jnp.fft.rfft(jnp.diff(cdf), FFT_SIZE)


def _slip(friction, eff: _Eff, shape, sensor, W, k, v, t0, x0, T1m, tref, tstart, poly, N0,
          wf):
    """One cycle window's stick and slip (module doc; `sensor` static: the kernel
    convolution of the slip on its grid, with the kernel's spectrum `wf`,
    `_kernel_spectrum`): friction under the normal load N0 (kgf), inertia W / g."""
    vs, p, length, pitch, _, _, form, damping = (shape[i] for i in range(8))  # order, zeta: in wf
    tw = t0  # the window's measured start: origin of a measured drive's cubic
    tau = jnp.maximum(eff.tau, 1e-7)
    if sensor:
        # the measured restart state is a reading: the slider's own clock is tau earlier
        t0 = t0 - tau
    mass, T2, h = _grid(W, k)
    # viscous damping: one dashpot c, or one damping ratio (c = 2 zeta sqrt(k m))
    c = eff.c * jnp.where(damping == 1, 2.0 * jnp.sqrt(k * mass), 1.0)
    static = friction.static
    mu_s, mu_d = static.mu_s, static.mu_d
    drift = t0 - tstart  # friction drifts from the record's start
    d_s, d_d = eff.r_s * drift, eff.r_d * drift

    def mu0(T):  # eq (1) with mu_s, mu_d shifted by friction drift
        base = static(T)
        return base + d_d + (d_s - d_d) * (base - mu_d) / (mu_s - mu_d)

    u = _drive(eff, v, tref, tw, poly, pitch)  # speed drift, screw error, measured drive
    u0 = u(t0)

    line = _stick_line(x0, eff, u, t0, u0, tw, T1m, v)

    def g(T):
        x = line(t0 + T)
        return k * x - (N0 + eff.kappa * k * x) * mu0(T)

    def g_and_slope(T):
        return jax.jvp(g, (T,), (jnp.ones_like(T),))

    hi0 = 4.0 * T1m + 1.0
    lo0 = jnp.zeros_like(T1m)
    found = g(hi0) > 0

    def newton(_, state):
        T, lo, hi = state
        gv, gd = g_and_slope(T)
        lo = jnp.where(gv < 0, T, lo)
        hi = jnp.where(gv < 0, hi, T)
        step = T - gv / jnp.where(gd > 0, gd, 1.0)
        inside = (gd > 0) & (step > lo) & (step < hi)
        return jnp.where(inside, step, 0.5 * (lo + hi)), lo, hi

    T, _, _ = jax.lax.fori_loop(
        0, NEWTON, newton,
        (jnp.clip(T1m, 1e-6, hi0 * 0.999), lo0, hi0))
    T = jax.lax.stop_gradient(jnp.maximum(T, 1e-9))
    gv, gd = g_and_slope(T)
    T = jnp.maximum(T - gv / jnp.where(gd > 0, gd, 1.0), 1e-9)  # carries dT/dtheta
    t_b = t0 + T
    x_b = line(t_b)
    mu_0 = mu0(T)
    mu_m = friction.kinetic(mu_0, mu_d + d_d, T2)  # eq (3), T2 = pi / omega0 (eq 7)
    vdrive = jax.jvp(u, (t_b,), (jnp.ones_like(t_b),))[1]

    # rate-and-state (Dieterich-Ruina, aging law): the state theta grew through the stick
    # (theta_b = T1 + D_c / V_REF at the breakaway) and relaxes towards D_c / V in the
    # slip; carried as l = ln(theta / theta_b), dl/dt = theta_b^-1 e^-l - V / D_c
    theta_b = T + length / DR_V_REF

    def rhs(tau, y, yd, lth):
        x = x_b + vdrive * tau - y
        N = N0 + eff.kappa * k * x
        V = jnp.abs(yd)
        # the Stribeck curve (`cycle_effects.STRIBECK_FORMS`), 0 at rest: mu_m (eq 3) is
        # the friction the slip starts against (anchored at speed instead, a drop of 0.2
        # on lubricant A drove mu_d -> 0, where log mu_d has no gradient: gap 18.5x the
        # noise); `form` is the same in every window, so the switch computes one curve
        fall = jax.lax.switch(form.astype(jnp.int32), (
            lambda x: jnp.exp(-safe_power(x, p)) - 1.0, lambda x: -jnp.log1p(x),
            lambda x: -x, lambda x: 1.0 / (1.0 + safe_power(x, p)) - 1.0), V / vs)
        mu = (mu_m + eff.b_st * fall
              + eff.a_rs * jnp.log1p(V / DR_V_REF) + eff.b_rs * lth)
        dl = jnp.exp(-jnp.maximum(lth, -30.0)) / theta_b - V / length
        return (k * x - N * mu - c * yd) / mass, dl

    def rk4(state, i):
        y, yd, lth = state
        tau = i * h
        k1v, k1l = rhs(tau, y, yd, lth)
        k1y = yd
        k2y = yd + 0.5 * h * k1v
        k2v, k2l = rhs(tau + 0.5 * h, y + 0.5 * h * k1y, k2y, lth + 0.5 * h * k1l)
        k3y = yd + 0.5 * h * k2v
        k3v, k3l = rhs(tau + 0.5 * h, y + 0.5 * h * k2y, k3y, lth + 0.5 * h * k2l)
        k4y = yd + h * k3v
        k4v, k4l = rhs(tau + h, y + h * k3y, k4y, lth + h * k3l)
        new = (y + h / 6 * (k1y + 2 * k2y + 2 * k3y + k4y),
               yd + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v),
               lth + h / 6 * (k1l + 2 * k2l + 2 * k3l + k4l))
        return new, new[:2]

    zero = jnp.zeros_like(x_b)
    _, (Y, YD) = jax.lax.scan(rk4, (zero, zero, zero), jnp.arange(N_STEPS, dtype=float))
    Y = jnp.concatenate([zero[None], Y])
    YD = jnp.concatenate([zero[None], YD])
    stopped = YD[1:] <= 0
    stops = jnp.any(stopped)
    i = jnp.where(stops, jnp.argmax(stopped) + 1, N_STEPS)
    yd_a, yd_b = YD[i - 1], YD[i]
    frac = jnp.where(stops, yd_a / jnp.where(yd_a - yd_b > 0, yd_a - yd_b, 1.0), 1.0)
    frac = jnp.clip(frac, 0.0, 1.0)
    t_stop = t_b + (i - 1 + frac) * h
    y_stop = _hermite(Y[i - 1], Y[i], YD[i - 1] * h, YD[i] * h, frac)
    x_stop = x_b + u(t_stop) - u(t_b) - y_stop

    if sensor:
        # the slip displacement D on the RK4 grid, held at y_stop after the stop and
        # beyond the slip grid (TAIL_STEPS nodes in all), convolved with the kernel's bin
        # masses over the same span
        n = jnp.arange(TAIL_STEPS)
        pad = TAIL_STEPS - (N_STEPS + 1)
        Yx = jnp.concatenate([Y, jnp.full(pad, y_stop)])
        YDx = jnp.concatenate([YD, jnp.zeros(pad)])
        moving = n * h < t_stop - t_b
        D = jnp.where(moving, Yx, y_stop)
        Dd = jnp.where(moving, YDx, 0.0)
        # causal convolution F[n] = sum_{l <= n} w[l] D[n - l] with the kernel's bin
        # masses w by FFT (zero-padded to FFT_SIZE >= 2 TAIL_STEPS - 1: no wrap-around):
        # a matrix of lags would carry a [TAIL_STEPS]^2 tangent per row and Jacobian column
        F = jnp.fft.irfft(jnp.fft.rfft(D, FFT_SIZE) * wf, FFT_SIZE)[:TAIL_STEPS]
        Fd = jnp.fft.irfft(jnp.fft.rfft(Dd, FFT_SIZE) * wf, FFT_SIZE)[:TAIL_STEPS]
        # how late the features put this slip's breakaway as read: their half-sine
        # centre of the filtered slip (`_centre`: the mean delay tau plus what the
        # kernel's rounding adds, +0.6 ms at 20 Hz, damping ratio 0.7; +3 ms at 0.4)
        # less half the slip duration they assume (`_slip_time`), not less the
        # unfiltered slip's own centre, which a damped slip reaches early (module doc)
        omega0 = jnp.pi / T2
        ys = jnp.maximum(y_stop, 1e-12)
        delay = _centre(F / ys, n * h, omega0, T2) - 0.5 * _slip_time(omega0, v, y_stop)
    else:
        F = Fd = jnp.zeros(1)
        delay = tau
    return _Slip(t0=t0, x0=x0, u0=u0, t_b=t_b, x_b=x_b, u_b=u(t_b), h=h, Y=Y, YD=YD,
                 t_stop=t_stop, x_stop=x_stop, u_stop=u(t_stop), ok=found & stops, F=F,
                 Fd=Fd, tau=tau, T1m=T1m, delay=delay)


def _render(sl: _Slip, w, eff: _Eff, shape, sensor, v, tref, tw, poly, ts):
    """One sample of window `w` at the time ts (s): (the deflection as read by the gauge,
    without offset (mm); slider velocity (mm/s)). `sl`: the window's `_Slip` numbers, its
    grids (Y, YD, F, Fd) those of every window [W, K], read at row `w`."""
    u = _drive(eff, v, tref, tw, poly, shape[3])
    t0, t_b, h, t_stop = sl.t0, sl.t_b, sl.h, sl.t_stop
    Y, YD = (lambda j: sl.Y[w, j]), (lambda j: sl.YD[w, j])  # a node, not the row
    line = _stick_line(sl.x0, eff, u, t0, sl.u0, tw, sl.T1m, v)

    def render(t):
        t = jnp.maximum(t, t0)
        tau = (t - t_b) / h
        j = jnp.clip(jnp.floor(tau), 0, N_STEPS - 1).astype(jnp.int32)
        f = jnp.clip(tau - j, 0.0, 1.0)
        y0, y1, m0, m1 = Y(j), Y(j + 1), YD(j) * h, YD(j + 1) * h
        y = _hermite(y0, y1, m0, m1, f)
        yd = _hermite_slope(y0, y1, m0, m1, f) / h
        ut = u(t)
        x = jnp.where(t < t_b, line(t),
                      jnp.where(t < t_stop, sl.x_b + ut - sl.u_b - y,
                                sl.x_stop + ut - sl.u_stop))
        yd = jnp.where((t >= t_b) & (t < t_stop), yd, 0.0)
        return x, yd

    if sensor:
        F, Fd, last = (lambda j: sl.F[w, j]), (lambda j: sl.Fd[w, j]), TAIL_STEPS - 1
        s_ = (ts - t_b) / h
        j = jnp.clip(jnp.floor(s_), 0, last - 1).astype(jnp.int32)
        f = jnp.clip(s_ - j, 0.0, 1.0)
        Fv = _hermite(F(j), F(j + 1), Fd(j) * h, Fd(j + 1) * h, f)
        Fv = jnp.where(ts < t_b, 0.0, jnp.where(s_ > last, F(last), Fv))
        q_b = sl.x_b - (sl.x0 + sl.u_b - sl.u0)  # the stick terms' part at the breakaway
        x = jnp.where(ts < t_b, line(ts - sl.tau), sl.x0 + u(ts - sl.tau) - sl.u0 + q_b) - Fv
        yd = render(ts)[1]
    else:
        x, yd = render(ts)
    return x + eff.r_g * (ts - tref), yd


class _Layout(eqx.Module):
    """Where each family's parameters live in the full coordinate vector (static)."""

    n_records: int = eqx.field(static=True)
    starts: tuple = eqx.field(static=True)  # ((family name, first index), ...)

    def first(self, name: str) -> int:
        return dict(self.starts)[name]

    @property
    def n_base(self) -> int:
        return 6 + self.n_records

    @property
    def size(self) -> int:
        return self.n_base + sum(f.n_params(self.n_records) for f in FAMILIES) + len(STICK_TERMS)

    def stick_cols(self) -> np.ndarray:
        """The stick terms' coordinates (the last `len(STICK_TERMS)`)."""
        return np.arange(self.size - len(STICK_TERMS), self.size)

    def cols(self, fam: Family) -> np.ndarray:
        a = self.first(fam.name)
        return np.arange(a, a + fam.n_params(self.n_records))


def _layout(n_records: int) -> _Layout:
    start, a = [], 6 + n_records
    for f in FAMILIES:
        start.append((f.name, a))
        a += f.n_params(n_records)
    return _Layout(n_records, tuple(start))


def _effects_of(layout: _Layout, theta, record):
    """Natural effect values for one row (`record`: its record index)."""
    def one(name, j=0):
        return theta[layout.first(name) - layout.n_base + j]

    a = layout.first("drive_periodic_error") - layout.n_base
    drive = jax.lax.dynamic_slice(theta, (a + 4 * record,), (4,))
    return _Eff(c=one("viscous_damping"), b_st=one("stribeck"), a_rs=one("rate_state"),
                b_rs=one("rate_state", 1),
                drive=drive, s=one("drive_speed_drift"), tau=one("sensor_lowpass"),
                r_s=one("friction_drift"), r_d=one("friction_drift", 1),
                r_g=one("gauge_drift"), kappa=one("load_coupling"),
                stick=theta[theta.shape[0] - len(STICK_TERMS):])


def _model(z, scales, shape, sensor, data: TraceData, tref, prev, layout: _Layout, idx):
    """(gauge reading incl. offset [n], slider velocity [N, L] (0 at the padding), ok [N])
    at the samples `idx` (flat indices of the unpadded entries of [N, L]). `prev`:
    ([N] the row whose slip's tail the gauge still owes at the window's start, or -1;
    [N] where that slip began, s) (`tail_sources`), then ([W] the first row of every
    window; [N] every row's window among them) (`window_rows`): a window's stick and
    slip are solved once (`_slip`) and rendered at each of its samples (`_render`), the
    unpadded ones only (the padding: up to a third of a thinned campaign's entries)."""
    prev, began, first, slot = prev
    tref, tstart = tref[0], tref[1]
    nat = z * scales
    fr = EmpiricalFriction(*[nat[i] for i in range(6)]).friction()
    offset = nat[6:layout.n_base]
    theta = nat[layout.n_base:]
    x0 = data.start_level - offset[data.record]

    def one_window(rec, W, k, v, t0, x0, T1m, poly, N0):
        eff = _effects_of(layout, theta, rec)
        return _slip(fr, eff, shape, sensor, W, k, v, t0, x0, T1m, tref[rec], tstart[rec],
                     poly, N0, wf[rec])

    wf = jnp.zeros((layout.n_records, 1))
    if sensor:
        # the kernel's spectrum depends on the slip grid (a record's W and k) and the
        # sensor alone: computed per record, not per window
        h = _grid(jnp.zeros(layout.n_records).at[data.record].set(data.weight),
                  jnp.ones(layout.n_records).at[data.record].set(data.stiffness))[2]
        tau = jnp.maximum(_effects_of(layout, theta, 0).tau, 1e-7)
        wf = jax.vmap(_kernel_spectrum, in_axes=(0, None, None, None))(h, tau, shape[4],
                                                                        shape[5])
    slips = jax.vmap(one_window)(*(a[first] for a in (
        data.record, data.weight, data.stiffness, data.speed, data.start_time, x0,
        data.stick_time, data.drive_poly, data.normal_load)))

    N, L = data.time.shape
    row = idx // L
    rec_e = data.record[row]

    def one_sample(s, rec, v, tw, poly, ts):
        sl = jax.tree.map(lambda a: a[s] if a.ndim == 1 else a, slips)  # grids: whole
        eff = _effects_of(layout, theta, rec)
        return _render(sl, s, eff, shape, sensor, v, tref[rec], tw, poly, ts)

    read, yd = jax.vmap(one_sample)(slot[row], rec_e, data.speed[row],
                                    data.start_time[row], data.drive_poly[row],
                                    data.time.ravel()[idx])
    bad = jnp.zeros(N, bool).at[row].max(~jnp.isfinite(read))
    ok = slips.ok[slot] & ~bad
    yd = jnp.zeros(N * L).at[idx].set(yd).reshape(N, L)
    if sensor:
        # the gauge still settles from the previous slip when a window starts: the
        # measured restart level is the settled stick line (`features`: the plateau
        # after the slip), so the reading is that line plus what the gauge still owes
        # (placed at the previous slip's measured breakaway less how late the features
        # put it as read, `_Slip.delay`: the model's breakaway may miss it by
        # the stick time's scatter; at tau instead, 0.6 ms late at 20 Hz, +0.5..1.3 um
        # at every window's start, noise 0.5 um, taken up by damping or load coupling)
        p = slot[jnp.maximum(prev, 0)][row]  # per sample: the window of that slip
        E = slips.F[:, -1:] - slips.F  # [W, TAIL_STEPS]: what each slip still owes after it
        s_ = (data.time.ravel()[idx] - (began[row] - slips.delay[p])) / slips.h[p]
        j = jnp.clip(jnp.floor(s_), 0, TAIL_STEPS - 2).astype(jnp.int32)
        f = jnp.clip(s_ - j, 0.0, 1.0)
        owed = jnp.where((s_ >= 0) & (s_ <= TAIL_STEPS - 1),
                         (1 - f) * E[p, j] + f * E[p, j + 1], 0.0)
        read = read + jnp.where(prev[row] >= 0, owed, 0.0)
    return read + offset[rec_e], yd, ok


def per_sample(data: TraceData, *fields: str) -> list[np.ndarray]:
    """The row attributes `fields` of `data` at its masked samples (flat, row by row)."""
    mask = np.asarray(data.mask)
    return [np.broadcast_to(np.asarray(getattr(data, f))[:, None], mask.shape)[mask]
            for f in fields]


def window_rows(data: TraceData) -> tuple[np.ndarray, np.ndarray]:
    """([W] the first row of every cycle window of `data`, in order; [N] the position of
    every row's window among them). The rows of one window share its restart state
    (`trace_data`), so its stick and slip are solved once."""
    win = np.asarray(data.window)
    _, first, slot = np.unique(win, return_index=True, return_inverse=True)
    return first.astype(np.int32), slot.astype(np.int32)


def previous_rows(data: TraceData) -> np.ndarray:
    """[N]: for every row, the first row of the previous cycle window of its record
    (its slip ends where this window starts), or -1 (first window, or a cycle left out
    between them)."""
    rec = np.asarray(data.record)
    win = np.asarray(data.window)
    prev = np.full(rec.shape, -1)
    first = {}
    for i, (r, w) in enumerate(zip(rec, win)):
        first.setdefault((int(r), int(w)), i)
    for i, (r, w) in enumerate(zip(rec, win)):
        j = first.get((int(r), int(w) - 1))
        if j is not None:
            prev[i] = j
    return prev


def tail_sources(data: TraceData) -> tuple[np.ndarray, np.ndarray]:
    """Where the gauge's settling at each window's start comes from (module doc):
    ([N] the first row of the window whose slip the gauge still settles from, or -1 if
    the window holds no slip; [N] the measured time that slip began, s). After a
    previous window of the record: that window and its measured breakaway
    (start time + stick time). Otherwise (a record's first window, a cycle left out
    before it) the window's own slip, placed its measured length before the start."""
    prev = previous_rows(data)
    rec = np.asarray(data.record)
    win = np.asarray(data.window)
    t0 = np.asarray(data.start_time, float)
    T1 = np.asarray(data.stick_time, float)
    t = np.where(np.asarray(data.mask), np.asarray(data.time, float), -np.inf)
    first, end = {}, {}
    for i, (r, w) in enumerate(zip(rec, win)):
        key = (int(r), int(w))
        first.setdefault(key, i)
        end[key] = max(end.get(key, -np.inf), float(t[i].max()))
    rows = prev.copy()
    began = np.zeros(len(rec))
    for i, (r, w) in enumerate(zip(rec, win)):
        if prev[i] >= 0:
            began[i] = t0[prev[i]] + T1[prev[i]]
            continue
        key = (int(r), int(w))
        length = end[key] - (t0[i] + T1[i])  # the window's own slip, as measured
        if np.isfinite(length) and length > 0:
            rows[i] = first[key]
            began[i] = t0[i] - length
    return rows, began


@eqx.filter_jit(compiler_options=COMPILER_OPTIONS)
def _value(z, scales, shape, sensor, data, tref, prev, sd, layout, idx):
    read, yd, ok = _model(z, scales, shape, sensor, data, tref, prev, layout, idx)
    return (data.deflection.ravel()[idx] - read) / sd.ravel()[idx], yd, ok


@eqx.filter_jit(compiler_options=COMPILER_OPTIONS)
def _value_and_block(z, T, scales, shape, sensor, data, tref, prev, sd, layout, idx):
    """(r [n], J [n, B], ok [N], slider velocity [N, L]): the residuals of the samples
    `idx` (flat indices of the unpadded samples) and their derivatives along the B
    tangents T [size, B]."""
    def f(zz):
        read, yd, ok = _model(zz, scales, shape, sensor, data, tref, prev, layout, idx)
        return (data.deflection.ravel()[idx] - read) / sd.ravel()[idx], (ok, yd)

    def col(t):
        return jax.jvp(f, (z,), (t,), has_aux=True)

    # the primal does not depend on the tangent: computed once, not per column
    r, J, (ok, yd) = jax.vmap(col, in_axes=1, out_axes=(None, -1, None))(T)
    return r, J, ok, yd


class CycleModel:
    """The per-cycle model of one campaign (module doc): residuals and Jacobians.

    `data`: the `TraceData` windows (without the features' drive correction: a drive
    error stays for the drive effects to explain); `tref`: `drift_origins`; `sd`:
    per-sample standard errors [N, L] (mm).
    """

    def __init__(self, data: TraceData, tref: np.ndarray, sd, n_records: int):
        self.data = data
        self.tref = jax.device_put(np.asarray(tref, float))
        self.sd = jax.device_put(np.asarray(sd, float))
        self._prev = tuple(jax.device_put(a) for a in (*tail_sources(data),
                                                      *window_rows(data)))
        self.layout = _layout(n_records)
        self.scales = np.ones(self.layout.size)
        for f in FAMILIES:
            reps = n_records if f.per_record else 1
            self.scales[self.layout.cols(f)] = np.tile(f.scales, reps)
        self.scales[self.layout.stick_cols()] = STICK_SCALE
        self._scales = jax.device_put(self.scales)
        self.mask = np.asarray(data.mask).ravel()
        self._record = per_sample(data, "record")[0]
        self._idx = jax.device_put(np.flatnonzero(self.mask).astype(np.int32))
        self._real_rows, self._grouped, self._tails = np.asarray(data.mask).any(1), {}, 0
        # every record's samples: one contiguous span of the residuals (`trace_data`'s order)
        self._span = np.zeros((n_records, 2), int)
        for g in range(n_records):
            where = np.flatnonzero(self._record == g)
            if where.size:
                if where[-1] - where[0] + 1 != where.size:
                    raise ValueError("CycleModel: a record's samples are not contiguous "
                                     "in the cycle windows (trace_data order)")
                self._span[g] = where[0], where[-1] + 1
        self.n_records = n_records

    @property
    def n_base(self) -> int:
        return self.layout.n_base

    def cols(self, fam: Family) -> np.ndarray:
        return self.layout.cols(fam)

    @staticmethod
    @functools.lru_cache(maxsize=256)
    def _shape(shape: Shape):
        return jnp.asarray([shape.vs, shape.p, shape.length, shape.pitch, shape.order,
                            shape.zeta, float(STRIBECK_FORMS.index(shape.form)),
                            float(DAMPING_FORMS.index(shape.damping))])

    def z0(self, friction: EmpiricalFriction, offsets) -> np.ndarray:
        z = np.zeros(self.layout.size)
        z[:6] = [float(x) for x in (friction.log_mu_d, friction.log_gap, friction.log_gamma,
                                    friction.log_m, friction.log_delta, friction.log_n)]
        z[6:self.n_base] = np.asarray(offsets, float)
        return z

    def breakaway_offsets(self, logs, current) -> np.ndarray:
        """[R]: the gauge offset of every record (mm) that puts the paper's breakaway at
        the measured stick times at the friction `logs` (the six `EmpiricalFriction`
        coordinates): the median over the record's windows of the measured breakaway
        reading (start level + v T1) minus the breakaway deflection $N \\mu_0(T_1)/k$
        (eq 1). A fit's offsets belong to its friction: with another friction the model's
        breakaways fall outside the windows, where the residual no longer depends on the
        offset (measured: a Stribeck drop of 0.2 on A refitted from the true friction
        with the bent base's offsets, 3.48 um, noise 0.5 um; with these, 0.508 um).
        `current`: kept for a record without a window."""
        d = self.data
        has = np.asarray(d.mask).any(1)
        static = EmpiricalFriction(*[float(x) for x in logs]).friction().static
        T1 = np.asarray(d.stick_time, float)
        x_b = (np.asarray(d.normal_load) * np.asarray(static(jnp.asarray(T1)))
               / np.asarray(d.stiffness))
        est = np.asarray(d.start_level) + np.asarray(d.speed) * T1 - x_b
        rec, win = np.asarray(d.record), np.asarray(d.window)
        out = np.array(current, float)
        for g in range(self.n_records):
            sel = has & (rec == g)
            _, first = np.unique(win[sel], return_index=True)
            if first.size:
                out[g] = float(np.median(est[sel][first]))
        return out

    def warm(self) -> dict:
        """Compile the programs of `evaluate` and of `residuals` with the sensor in a
        background thread while the caller works (XLA compiles without the GIL; 1.5-5 s
        each on 0.4 M samples), in the order discovery needs them; the sensor's Jacobian
        program (a refit with the sensor, which many campaigns never make) from its first
        `start()` or `result()` (`Later`). Returns {("evaluate" | "residuals", sensor):
        Future}; wait for a future before the program's first call (a call while it
        compiles compiles it again)."""
        z = np.zeros(self.layout.size)
        pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="stickslip-warm")
        futures = {("residuals", False): pool.submit(self.evaluate, z, [0])}
        futures["evaluate", False] = futures["residuals", False]  # one program
        futures["residuals", True] = pool.submit(self.residuals, z, sensor=True)
        futures["evaluate", True] = Later(self.evaluate, z, [0], sensor=True)
        pool.shutdown(wait=False)
        return futures

    def residuals(self, z, shape: Shape = Shape(), sensor: bool = False):
        """(whitened residuals flat [n], slider velocity [N, L], ok [N]); `sensor`: the
        kernel convolution. Without it, `evaluate`'s program with no tangent (few calls:
        a program of their own took 7 s of CPU to compile to save 0.04 s a call); with it
        (the secant probes: 48 calls) a program of its own."""
        if sensor:
            r, yd, ok = _value(jnp.asarray(z), self._scales, self._shape(shape), True,
                               self.data, self.tref, self._prev, self.sd, self.layout,
                               self._idx)
            return np.asarray(r), np.asarray(yd), np.asarray(ok)
        r, _, ok, yd = self._block(jnp.asarray(z), np.zeros((self.layout.size, 1)),
                                   self._shape(shape), False)
        return np.asarray(r), np.asarray(yd), np.asarray(ok)

    def _block(self, zj, part, sh, sensor: bool):
        """`_value_and_block` along the tangents `part`, padded to its width (`BLOCK`)."""
        narrow = part.shape[1] <= BLOCK // 2 and not sensor and self._tails > 64
        T = np.zeros((self.layout.size, BLOCK // 2 if narrow else BLOCK))
        T[:, :part.shape[1]] = part
        return _value_and_block(zj, jax.device_put(T), self._scales, sh, bool(sensor),
                                self.data, self.tref, self._prev, self.sd, self.layout,
                                self._idx)

    def _tangents(self, cols):
        """Group `cols` into tangents (module doc: the same per-record coordinate of every
        record shares one, exact since a record's rows see only their own). Returns (T
        [size, n_tangents], tangent of each col, record of each col or -1)."""
        lay = self.layout
        per = {lay.first(f.name): (f.name, len(f.params), f.n_params(self.n_records))
               for f in FAMILIES if f.per_record}
        keys, tangent, record = {}, [], []
        for c in cols:
            key, rec = ("col", c), -1
            if 6 <= c < lay.n_base:
                key, rec = ("offset", 0), c - 6
            for a, (name, k, size) in per.items():
                if a <= c < a + size:
                    key, rec = (name, (c - a) % k), (c - a) // k
            tangent.append(keys.setdefault(key, len(keys)))
            record.append(rec)
        T = np.zeros((lay.size, len(keys)))
        T[cols, tangent] = 1.0
        return T, np.asarray(tangent, int), np.asarray(record, int)

    def evaluate(self, z, cols, shape: Shape = Shape(), sensor: bool = False):
        """(r [n], J [n, len(cols)], ok) at z (module doc, `_tangents`)."""
        cols = np.asarray(cols, int)
        if (key := cols.tobytes()) not in self._grouped:
            self._grouped[key] = self._tangents(cols)
        (T_all, tangent, record), blocks, ok = self._grouped[key], [], True
        sh, zj = self._shape(shape), jnp.asarray(z)
        for a in range(0, max(T_all.shape[1], 1), BLOCK):
            part = T_all[:, a:a + BLOCK]
            self._tails += part.shape[1] <= BLOCK // 2 and not sensor and a > 0  # `BLOCK`
            r, J_, ok_, _ = self._block(zj, part, sh, sensor)
            blocks.append(np.asarray(J_)[:, :part.shape[1]])
            ok = ok and bool(np.all(np.asarray(ok_)[self._real_rows]))
        Jt = blocks[0] if len(blocks) == 1 else np.concatenate(blocks, axis=1)
        J = np.zeros((Jt.shape[0], cols.size), order="F")  # each column written, read at once
        for i, (t, g) in enumerate(zip(tangent, record)):  # a record's coefficient: its rows
            a, b = self._span[g] if g >= 0 else (0, Jt.shape[0])
            J[a:b, i] = Jt[a:b, t]
        return np.asarray(r), J, ok


def drift_origins(records) -> np.ndarray:
    """[2, R]: the middle of every record's time span (s: the origin of the drive speed
    drift and the gauge drift) and its start (s: the origin of the friction drift)."""
    return np.array([[0.5 * (float(r.time[0]) + float(r.time[-1])) for r in records],
                     [float(r.time[0]) for r in records]])

