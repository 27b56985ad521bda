"""The limit cycle as the fixed point of the one-cycle map (`stickslip_jax.limit_cycle`),
against the exact event-driven simulator on both sides of eq (12)'s critical speed, for
both regimes, with gradients against finite differences; with viscous damping, against
an independent SciPy integration of the damped equation of motion, and its sharp
boundary."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest

import stickslip_jax as ss
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.limit_cycle import boundary_speed, cycle_map, limit_cycle, tolerance_speed
from stickslip_jax.simulation import simulate_exact
from stickslip_jax.steady import RESTICK_FAILURE, STICK_SLIP, critical_speed, steady_state


def _lc(fr, W, k, v, zeta=None):
    """`limit_cycle` with array arguments: one compiled program serves every point (a
    Python number is compiled in as a constant, one program per value)."""
    a = jnp.asarray
    return limit_cycle(fr, a(W), a(k), a(v), damping_ratio=None if zeta is None else a(zeta))


@eqx.filter_jit
def _map(fr, W, k, v, trough, zeta=None):
    """`cycle_map` compiled once (array arguments, as `_lc`)."""
    return cycle_map(fr, W, k, v, trough, damping_ratio=zeta)


def _cycle_map(fr, W, k, v, trough, zeta=None):
    a = jnp.asarray
    return _map(fr, a(W), a(k), a(v), trough, None if zeta is None else a(zeta))


# (lubricant, W kgf, k kgf/mm): one-slip cycles for A and C, re-slips for C at 11.3 kgf
POINTS = [("A", 36.0, 86.9), ("C", 36.0, 27.3), ("C", 11.3, 86.9)]
FACTORS = (0.2, 0.5, 0.8, 1.3, 2.0, 5.0, 12.0)  # drive speed / v_c: both sides


@eqx.filter_jit
def _simulate(friction, W, k, speeds, horizons):
    """The exact simulator at every speed (one compiled, vmapped program)."""
    def one(v, horizon):
        tr = simulate_exact(ss.Slideway(friction, W, k), ConstantSpeed(v),
                            jnp.linspace(0.0, horizon, 3), max_events=240)
        return tr.cycles
    return jax.vmap(one)(speeds, horizons)


def _exact_cycles(friction, W, k, speeds, t1_guesses):
    """The exact simulator's settled cycle at every speed: (T1, amplitude (x2 - x1)/2,
    slip time), a re-slip's two slips counted as one cycle."""
    cyc = _simulate(friction, jnp.asarray(W), jnp.asarray(k), jnp.asarray(speeds),
                    60.0 * (jnp.asarray(t1_guesses) + 0.1) + 1.0)
    out = []
    for i in range(len(speeds)):
        ok = np.asarray(cyc.valid[i])
        t1 = np.asarray(cyc.stick_time[i])[ok][-6:]
        amp = np.asarray(cyc.amplitude()[i])[ok][-6:]
        t2 = np.asarray(cyc.slip_time[i])[ok][-6:]
        if np.any(t1 == 0.0):  # re-slips: pair each stick with the slip that follows
            j = int(np.flatnonzero(t1 > 0)[-2])
            out.append((t1[j], amp[j] + amp[j + 1], t2[j] + t2[j + 1]))
        else:
            out.append((t1[-1], amp[-1], t2[-1]))
    return out


@pytest.mark.parametrize("lub, W, k", POINTS)
def test_fixed_point_is_the_exact_limit_cycle(lub, W, k):
    fr = ss.lubricant(lub)
    vc = float(critical_speed(fr, W, k))
    speeds = [f * vc for f in FACTORS]
    cycles = [_lc(fr, W, k, v) for v in speeds]
    exact = _exact_cycles(fr, W, k, speeds, [float(c.stick_time) for c in cycles])
    for v, lc, (t1, amp, t2) in zip(speeds, cycles, exact):
        assert lc.result == optx.RESULTS.successful
        np.testing.assert_allclose(float(lc.stick_time), t1, rtol=1e-6)
        np.testing.assert_allclose(float(lc.amplitude), amp, rtol=1e-6)
        np.testing.assert_allclose(float(lc.slip_time), t2, rtol=1e-6)
        # and it is the one-cycle map's fixed point
        nxt, _ = _cycle_map(fr, W, k, v, lc.trough)
        assert abs(float(nxt - lc.trough)) < 1e-12 * float(lc.peak)
    expect = RESTICK_FAILURE if (lub, W) == ("C", 11.3) else STICK_SLIP
    assert int(lc.regime) == expect


def test_below_v_c_it_is_eq_6_and_above_it_goes_on():
    fr = ss.lubricant("A")
    W, k = 36.0, 86.9
    vc = float(critical_speed(fr, W, k))
    below = _lc(fr, W, k, 0.5 * vc)
    st = steady_state(fr, W, k, 0.5 * vc)
    np.testing.assert_allclose(float(below.amplitude), float(st.amplitude), rtol=1e-10)
    np.testing.assert_allclose(float(below.stick_time), float(st.stick_time), rtol=1e-10)
    above = [float(_lc(fr, W, k, f * vc).amplitude) for f in (1.06, 1.23, 1.84)]
    # reference amplitudes: 8.0, 7.3 and 5.7 um at 52, 60 and 90 mm/min
    np.testing.assert_allclose(above, [8.0e-3, 7.3e-3, 5.7e-3], atol=0.06e-3)
    assert above[0] > above[1] > above[2] > 0


def test_tolerance_speed_and_gradients():
    fr = ss.lubricant("A")
    W, k = 36.0, 86.9
    v, res = tolerance_speed(fr, W, k, 0.005)
    assert res == optx.RESULTS.successful
    np.testing.assert_allclose(float(_lc(fr, W, k, v).amplitude), 0.005, rtol=1e-9)
    # d amplitude / d k by the implicit function theorem against central differences
    amp = lambda kk: _lc(fr, W, kk, 0.5).amplitude  # noqa: E731
    g = float(jax.grad(amp)(jnp.asarray(k)))
    h = 1e-4 * k
    fd = (float(amp(k + h)) - float(amp(k - h))) / (2 * h)
    np.testing.assert_allclose(g, fd, rtol=1e-6)
    # vmapped over speeds
    vs = jnp.linspace(0.1, 3.0, 7)
    amps = jax.vmap(lambda s: limit_cycle(fr, W, k, s).amplitude)(vs)
    assert np.all(np.diff(np.asarray(amps)) < 0)


def test_bad_inputs():
    fr = ss.lubricant("A")
    with pytest.raises(ValueError, match="scalars"):
        limit_cycle(fr, 36.0, 86.9, jnp.ones(3))
    with pytest.raises(ValueError, match="drive speed v must be finite and > 0"):
        limit_cycle(fr, 36.0, 86.9, -1.0)
    with pytest.raises(ValueError, match="drive speed v must be finite and > 0"):
        limit_cycle(fr, 36.0, 86.9, jnp.asarray(-1.0))  # an array: checked before compiling
    with pytest.raises(ValueError, match="amplitude tolerance must be finite and > 0"):
        tolerance_speed(fr, 36.0, 86.9, 0.0)


# ---- viscous damping ---------------------------------------------------------------

G_MM_S2 = 9806.65  # standard gravity, mm/s^2 (kgf -> mass: M = W / g)


def _ivp_limit_cycle(p, W, k, v, zeta, max_cycles=300):
    """The damped model integrated with SciPy (no code shared with the package): from rest
    at zero deflection, sticks (breakaway by brentq: k x = W mu_0(T1), eq 1) and slips
    M y'' = k (x_b + v t - y) - mu W - c y', c = 2 zeta M omega_0, integrated by
    solve_ivp (DOP853) until the slider's velocity returns to zero (a re-slip from rest
    with mu_d while k x > W mu_d), until two cycles agree to 1e-11. Returns (amplitude mm,
    T1 s, slip time s, slips per cycle), or None when a slip never ends (steady
    sliding)."""
    import math

    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    M = W / G_MM_S2
    omega = math.sqrt(k / M)
    c, t2 = 2.0 * zeta * M * omega, math.pi / omega
    mu_s, mu_d, gamma, m, delta, n = (p[q] for q in ("mu_s", "mu_d", "gamma", "m", "delta", "n"))

    def mu0(t):
        return mu_d + (mu_s - mu_d) * -math.expm1(-gamma * t**m) if t > 0 else mu_d

    def slip(x_b, mu):
        def rhs(t, z):
            return [z[1], (k * (x_b + v * t - z[0]) - mu * W - c * z[1]) / M]

        def stop(t, z):
            return z[1]

        stop.terminal, stop.direction = True, -1
        s = solve_ivp(rhs, (0.0, 40 * t2), [0.0, 0.0], method="DOP853", rtol=1e-12,
                      atol=1e-15, events=stop, first_step=t2 * 1e-4)
        if not s.t_events[0].size:
            return None
        t = s.t_events[0][0]
        return x_b + v * t - s.y_events[0][0][0], t

    x_s, prev = 0.0, None
    for _ in range(max_cycles):
        hi = (mu_s * W / k - x_s) / v * 1.01 + 1e-9
        t1 = brentq(lambda t: k * (x_s + v * t) - W * mu0(t), 0.0, hi, xtol=1e-300, rtol=1e-15)
        x_b = x_s + v * t1
        m0 = mu0(t1)
        r = slip(x_b, mu_d + (m0 - mu_d) * math.exp(-delta * t2**n))
        if r is None:
            return None
        x, ts, slips = r[0], r[1], 1
        while k * x > W * mu_d:
            r = slip(x, mu_d)
            if r is None:
                return None
            x, ts, slips = r[0], ts + r[1], slips + 1
        cyc = (0.5 * (x_b - x_s), t1, ts, slips)
        if prev is not None and abs(cyc[0] - prev[0]) < 1e-11 * cyc[0] \
                and abs(cyc[1] - prev[1]) < 1e-11 * cyc[1]:
            return cyc
        prev, x_s = cyc, x
    raise AssertionError("the SciPy integration did not settle")


def _params(fr):
    st, kin = fr.static, fr.kinetic
    return {"mu_s": float(st.mu_s), "mu_d": float(st.mu_d), "gamma": float(st.gamma),
            "m": float(st.m), "delta": float(kin.delta), "n": float(kin.n)}


# (lubricant, W kgf, k kgf/mm, zeta, v mm/min, regime): below the boundary (one slip;
# re-slips for C at 11.3 kgf) and above it (steady sliding)
DAMPED = [("A", 36.0, 86.9, 0.01, 1.0, 1), ("A", 36.0, 86.9, 0.01, 90.0, 1),
          ("A", 36.0, 86.9, 0.05, 20.0, 1), ("A", 36.0, 86.9, 0.1, 38.0, 1),
          ("C", 11.3, 86.9, 0.01, 1.0, 2), ("A", 36.0, 86.9, 0.1, 40.0, 0),
          ("C", 11.3, 86.9, 0.01, 5.0, 0)]


@pytest.mark.parametrize("lub, W, k, zeta, v, regime", DAMPED)
def test_damped_fixed_point_is_the_damped_motion(lub, W, k, zeta, v, regime):
    fr = ss.lubricant(lub)
    lc = _lc(fr, W, k, v / 60.0, zeta)
    ref = _ivp_limit_cycle(_params(fr), W, k, v / 60.0, zeta)
    assert int(lc.regime) == regime
    if regime == 0:  # the motion ends in steady sliding
        assert ref is None and float(lc.amplitude) == 0.0
        return
    amp, t1, t2, slips = ref
    np.testing.assert_allclose(float(lc.amplitude), amp, rtol=1e-6)
    np.testing.assert_allclose(float(lc.stick_time), t1, rtol=1e-6)
    np.testing.assert_allclose(float(lc.slip_time), t2, rtol=1e-6)
    assert regime == (RESTICK_FAILURE if slips > 1 else STICK_SLIP)
    # the damped one-cycle map maps the fixed point's trough onto itself
    nxt, _ = _cycle_map(fr, W, k, v / 60.0, lc.trough, zeta)
    assert abs(float(nxt - lc.trough)) < 1e-10 * float(lc.peak)


def test_zero_damping_is_the_undamped_cycle():
    for lub, W, k in POINTS:
        fr = ss.lubricant(lub)
        for f in (0.5, 3.0):
            v = f * float(critical_speed(fr, W, k))
            a, b = _lc(fr, W, k, v), _lc(fr, W, k, v, 0.0)
            for q in ("amplitude", "stick_time", "slip_time", "peak", "regime"):
                np.testing.assert_allclose(float(getattr(b, q)), float(getattr(a, q)),
                                           rtol=1e-11)


@pytest.mark.slow  # compiles boundary_speed vmapped (a third of this module's time); the
# default run checks the boundary at zeta = 0.05 and 0 (tests/test_cli_steady.py)
def test_damping_makes_the_boundary_sharp():
    fr = ss.lubricant("A")
    W, k = 36.0, 86.9
    zetas = jnp.asarray([0.0, 0.01, 0.05, 0.1])
    vb = np.asarray(jax.vmap(lambda z: boundary_speed(fr, W, k, z))(zetas)) * 60.0
    assert np.isinf(vb[0])  # the undamped model has no boundary
    assert np.all(np.isfinite(vb[1:])) and np.all(np.diff(vb[1:]) < 0)
    np.testing.assert_allclose(vb[1:], [97.92, 54.74, 39.01], rtol=2e-3)  # README figures
    vc = float(critical_speed(fr, W, k)) * 60.0
    assert vb[3] < vc < vb[2]  # zeta = 0.1 ends stick-slip below eq (12)'s v_c
    for z, v in zip((0.01, 0.05, 0.1), vb[1:]):
        below = _lc(fr, W, k, 0.995 * v / 60.0, z)
        above = _lc(fr, W, k, 1.005 * v / 60.0, z)
        # a finite cycle (3-5 um) just below, none just above: a sharp boundary
        assert int(below.regime) == STICK_SLIP and float(below.amplitude) > 2.5e-3
        assert int(above.regime) == 0 and float(above.amplitude) == 0.0
    # ... which the SciPy integration of the motion confirms on both sides (zeta = 0.1)
    p = _params(fr)
    assert _ivp_limit_cycle(p, W, k, 0.99 * vb[3] / 60.0, 0.1) is not None
    assert _ivp_limit_cycle(p, W, k, 1.01 * vb[3] / 60.0, 0.1) is None


def test_damped_gradients():
    fr = ss.lubricant("A")
    W, k, z = 36.0, 86.9, 0.05

    def amp(v, mu_s):
        f = eqx.tree_at(lambda f: f.static.mu_s, fr, mu_s)
        return _lc(f, W, k, v, z).amplitude

    v0, m0 = 0.5, float(fr.static.mu_s)
    g = jax.grad(amp, argnums=(0, 1))(jnp.asarray(v0), jnp.asarray(m0))
    for i, (x, h) in enumerate(((v0, 1e-5), (m0, 1e-6))):
        args = [v0, m0]
        args[i] = x + h
        up = float(amp(*map(jnp.asarray, args)))
        args[i] = x - h
        fd = (up - float(amp(*map(jnp.asarray, args)))) / (2 * h)
        np.testing.assert_allclose(float(g[i]), fd, rtol=1e-5)
    with pytest.raises(Exception, match="damping ratio"):
        limit_cycle(fr, W, k, v0, damping_ratio=1.5)
