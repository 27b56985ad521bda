r"""The stick and the slip of one cycle window of the per-cycle model, and a sample of it
as the gauge reads it (`cycle_model`, whose module doc states the equations):
`solve_window` solves a window once, `read_sample` reads it at a sample time.

A slip still moving at the end of its grid (2.5 pi/omega_0) is taken to end there, and a
breakaway not found before 4 T1 + 1 s (T1 the measured stick time: beyond the window)
leaves the window on its stick line; `Slip.ended` tells the windows whose breakaway was
found and whose slip ended on its grid (those the paper's model reproduces) from those.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from stickslip_jax.numerics import safe_power
from stickslip_jax.units import G_MM_S2

from .cycle_effects import drive_error, stick_terms

__all__ = ["DR_V_REF", "FFT_SIZE", "NEWTON", "N_STEPS", "TAIL_STEPS", "Effects", "Slip",
           "kernel_cdf", "kernel_spectrum", "read_sample", "slip_grid", "solve_window"]

N_STEPS = 128
"""RK4 steps per slip (over 2.5 pi/omega_0: room for slips lengthened by the effects)."""
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


class Effects(eqx.Module):
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


def _drive(eff: Effects, v, tref, tw, poly, pitch):
    """The drive u(t) (mm, arbitrary origin) of one window: speed v (mm/s) with the speed
    drift about `tref`, the screw error, and a measured drive's cubic from the window's
    measured start `tw` (s)."""
    def u(t):
        dt = t - tref
        sw = t - tw
        return (v * dt + 0.5 * v * eff.s * dt * dt + drive_error(eff.drive, t, v, pitch)
                + sw * (poly[0] + sw * (poly[1] + sw * poly[2])))
    return u


class Slip(eqx.Module):
    """One window's stick and slip (`solve_window`), shared by the window's rows (`read_sample`)."""

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
    ended: jax.Array  # breakaway found and the slip ended on its grid (module doc)
    F: jax.Array  # [TAIL_STEPS] the kernel-filtered slip displacement (sensor; else [0])
    Fd: jax.Array  # its slope (mm/s)
    tau: jax.Array  # the sensor's mean delay (s)
    T1m: jax.Array  # the measured stick time (s)
    delay: jax.Array  # how late the features put the breakaway as read (s; `_centre`)


def _stick_line(sl_or_x0, eff: Effects, u, t0, u0, tw, T1m, v, stick: bool):
    """The stick line at slider time t with the stick terms' displacement (module doc of
    `cycle_effects`): x0 + u(t) - u0 + q(t - tw) (mm); `stick` False (static): q = 0,
    the stick terms' coefficients zero and not differentiated, and their columns not
    computed (`cycle_model.CycleModel.evaluate`)."""
    def line(t):
        xl = sl_or_x0 + u(t) - u0
        return xl + stick_terms(t - tw, T1m, xl, v) @ eff.stick if stick else xl
    return line


def slip_grid(W, k):
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


def kernel_spectrum(h, tau, order, zeta):
    """The sensor kernel's bin masses on a slip grid of step h (s; their CDF at the bin
    edges, `kernel_cdf`) over `TAIL_STEPS` nodes, as their FFT of `FFT_SIZE`."""
    cdf = kernel_cdf(jnp.maximum((jnp.arange(TAIL_STEPS + 1) - 0.5) * h, 0.0), tau, order,
                     zeta)
    return jnp.fft.rfft(jnp.diff(cdf), FFT_SIZE)


def solve_window(friction, eff: Effects, shape, sensor, W, k, v, t0, x0, T1m, tref, tstart,
                 poly, N0, wf, stick: bool = True):
    """One cycle window's stick and slip (module doc; `sensor` static: the kernel
    convolution of the slip on its grid, with the kernel's spectrum `wf`,
    `kernel_spectrum`; `stick` static: the stick terms, `_stick_line`): friction under
    the normal load N0 (kgf), inertia W / g."""
    vs, p, length, pitch, _, _, form, damping = (shape[i] for i in range(8))  # order, zeta: in wf
    tw = t0  # the window's measured start: origin of a measured drive's cubic
    tau = jnp.maximum(eff.tau, 1e-7)
    if sensor:
        # the measured restart state is a reading: the slider's own clock is tau earlier
        t0 = t0 - tau
    mass, T2, h = slip_grid(W, k)
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

    line = _stick_line(x0, eff, u, t0, u0, tw, T1m, v, stick)

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
    return Slip(t0=t0, x0=x0, u0=u0, t_b=t_b, x_b=x_b, u_b=u(t_b), h=h, Y=Y, YD=YD,
                 t_stop=t_stop, x_stop=x_stop, u_stop=u(t_stop), ended=found & stops, F=F,
                 Fd=Fd, tau=tau, T1m=T1m, delay=delay)


def read_sample(sl: Slip, w, eff: Effects, shape, sensor, v, tref, tw, poly, ts,
                stick: bool = True):
    """One sample of window `w` at the time ts (s): (the deflection as read by the gauge,
    without offset (mm); slider velocity (mm/s)). `sl`: the window's `Slip` numbers, its
    grids (Y, YD, F, Fd) those of every window [W, K], read at row `w`; `stick` static:
    the stick terms (`_stick_line`)."""
    u = _drive(eff, v, tref, tw, poly, shape[3])
    t0, t_b, h, t_stop = sl.t0, sl.t_b, sl.h, sl.t_stop
    Y, YD = (lambda j: sl.Y[w, j]), (lambda j: sl.YD[w, j])  # a node, not the row
    line = _stick_line(sl.x0, eff, u, t0, sl.u0, tw, sl.T1m, v, stick)

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
