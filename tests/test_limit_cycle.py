"""The limit cycle as the fixed point of the one-cycle map (`stickslip_jax.limit_cycle`),
against the exact event-driven simulator on both sides of eq (12)'s critical speed, for
both regimes, with gradients against finite differences."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest

import stickslip_jax as ss
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.limit_cycle import cycle_map, limit_cycle, tolerance_speed
from stickslip_jax.simulation import simulate_exact
from stickslip_jax.steady import RESTICK_FAILURE, STICK_SLIP, critical_speed, steady_state

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
    cycles = [limit_cycle(fr, W, k, v) for v in speeds]
    exact = _exact_cycles(fr, W, k, speeds, [float(c.stick_time) for c in cycles])
    for v, lc, (t1, amp, t2) in zip(speeds, cycles, exact):
        assert lc.result == optx.RESULTS.successful
        np.testing.assert_allclose(float(lc.stick_time), t1, rtol=1e-6)
        np.testing.assert_allclose(float(lc.amplitude), amp, rtol=1e-6)
        np.testing.assert_allclose(float(lc.slip_time), t2, rtol=1e-6)
        # and it is the one-cycle map's fixed point
        nxt, _ = cycle_map(fr, W, k, v, lc.trough)
        assert abs(float(nxt - lc.trough)) < 1e-12 * float(lc.peak)
    expect = RESTICK_FAILURE if (lub, W) == ("C", 11.3) else STICK_SLIP
    assert int(lc.regime) == expect


def test_below_v_c_it_is_eq_6_and_above_it_goes_on():
    fr = ss.lubricant("A")
    W, k = 36.0, 86.9
    vc = float(critical_speed(fr, W, k))
    below = limit_cycle(fr, W, k, 0.5 * vc)
    st = steady_state(fr, W, k, 0.5 * vc)
    np.testing.assert_allclose(float(below.amplitude), float(st.amplitude), rtol=1e-10)
    np.testing.assert_allclose(float(below.stick_time), float(st.stick_time), rtol=1e-10)
    above = [float(limit_cycle(fr, W, k, f * vc).amplitude) for f in (1.06, 1.23, 1.84)]
    # the measurement: 8.0, 7.3 and 5.7 um at 52, 60 and 90 mm/min
    np.testing.assert_allclose(above, [8.0e-3, 7.3e-3, 5.7e-3], atol=0.06e-3)
    assert above[0] > above[1] > above[2] > 0


def test_tolerance_speed_and_gradients():
    fr = ss.lubricant("A")
    W, k = 36.0, 86.9
    v, res = tolerance_speed(fr, W, k, 0.005)
    assert res == optx.RESULTS.successful
    np.testing.assert_allclose(float(limit_cycle(fr, W, k, v).amplitude), 0.005, rtol=1e-9)
    # d amplitude / d k by the implicit function theorem against central differences
    amp = lambda kk: limit_cycle(fr, W, kk, 0.5).amplitude  # noqa: E731
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
    with pytest.raises(Exception, match="drive speed v must be positive"):
        limit_cycle(fr, 36.0, 86.9, -1.0)
    with pytest.raises(Exception, match="amplitude tolerance"):
        tolerance_speed(fr, 36.0, 86.9, 0.0)
