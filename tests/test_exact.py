"""Exact event-driven simulator: eq (6) limit cycle, an independent SciPy reference,
gradients against finite differences, vmap over padded records, failure handling."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from stickslip_jax import Slideway, experimental_conditions, lubricant, steady_state
from stickslip_jax.drives import ConstantSpeed, SpeedProgram
from stickslip_jax.simulation import SimulationResult, pad_times, simulate_exact
from slideway_leaves import FRICTION_LEAVES

G = 9806.65
LUB_A = lubricant("A")


SAMPLES, EVENTS = 4001, 24
"""The runs at a constant speed share one compiled program (`sim`) where the test allows:
4001 samples, at most 24 events."""


@pytest.fixture(scope="module")
def sim():
    return eqx.filter_jit(simulate_exact)


# ---------------------------------------------------------------- eq (6) limit cycle
@pytest.mark.parametrize("pair", range(3))
def test_limit_cycle_matches_eq6_below_tenth_of_critical_speed(sim, pair):
    W, k = experimental_conditions()[pair]
    sw = Slideway(LUB_A, W, k)
    ss0 = steady_state(LUB_A, W, k, 1.0)
    v = 0.08 * float(ss0.critical_speed)  # below v_c / 10
    ss = steady_state(LUB_A, W, k, v)
    ts = jnp.linspace(0.0, 9.0 * float(ss.stick_time), SAMPLES)
    tr = sim(sw, ConstantSpeed(v), ts, max_events=EVENTS)
    assert tr.result == SimulationResult.successful
    assert not bool(tr.steady_sliding)
    amp, t1 = tr.limit_cycle(last=2)
    assert abs(amp / float(ss.amplitude) - 1) < 5e-3
    assert abs(t1 / float(ss.stick_time) - 1) < 5e-3
    # every complete cycle obeys eq (5): a = (mu_0 - mu_m) W / k, T2 close to pi/omega0
    c = tr.cycles
    valid = np.asarray(c.valid)
    a5 = (np.asarray(c.mu_0) - np.asarray(c.mu_m)) * W / k
    np.testing.assert_allclose(np.asarray(c.amplitude())[valid], a5[valid], rtol=1e-9)


# ---------------------------------------------------------------- SciPy reference
def _kato_np(fr):
    s, kin = fr.static, fr.kinetic
    mu_s, mu_d, gam, m = (float(v) for v in (s.mu_s, s.mu_d, s.gamma, s.m))
    delta, n = float(kin.delta), float(kin.n)

    def mu0(T):
        return mu_s - (mu_s - mu_d) * np.exp(-gam * max(T, 0.0) ** m)

    def mum(m0, T2):
        return mu_d + (m0 - mu_d) * np.exp(-delta * T2**n)

    return mu0, mum


def scipy_reference(fr, W, k, knot_t, knot_s, ts, t_end):
    """Independent event-driven solution: brentq for the breakaway, solve_ivp (DOP853)
    with a terminal event for the end of the slip. Returns x(ts) in mm."""
    mu0_f, mum_f = _kato_np(fr)
    M = W / G
    omega = np.sqrt(G * k / W)
    knot_t = np.asarray(knot_t, float)
    knot_s = np.asarray(knot_s, float)
    knot_u = np.concatenate([[0.0], np.cumsum(knot_s[:-1] * np.diff(knot_t))])

    def u(t):
        i = max(np.searchsorted(knot_t, t, side="right") - 1, 0)
        return knot_u[i] + knot_s[i] * (t - knot_t[i])

    pieces = []  # (t_a, t_b, kind, payload)
    t, x, t_stick = 0.0, 0.0, 0.0
    while t < t_end:
        # stick: first root of k x(t) - W mu0(t - t_stick) on a fine grid + knots
        x_s, t_s = x, t

        def r(tt, x_s=x_s, t_s=t_s):
            return k * (x_s + u(tt) - u(t_s)) - W * mu0_f(tt - t_stick)

        grid = np.unique(np.concatenate([np.linspace(t, t_end, 4001), knot_t[knot_t > t]]))
        grid = grid[grid <= t_end]
        vals = np.array([r(g) for g in grid])
        pos = np.flatnonzero(vals[1:] >= 0)
        if len(pos) == 0:
            pieces.append((t, t_end, "stick", (x_s, t_s)))
            break
        i = pos[0]
        t_b = brentq(r, grid[i], grid[i + 1], xtol=1e-15, rtol=1e-15)
        pieces.append((t, t_b, "stick", (x_s, t_s)))
        x_b = x_s + u(t_b) - u(t_s)
        m0 = mu0_f(t_b - t_stick)
        mm = mum_f(m0, np.pi / omega)

        # slip: y'' = (k x - mu_m W)/M with x = x_b + u(t) - u(t_b) - (y - y_b), y_b = 0
        def rhs(tt, z, x_b=x_b, t_b=t_b, mm=mm):
            return [z[1], (k * (x_b + u(tt) - u(t_b) - z[0]) - mm * W) / M]

        def stopped(tt, z):
            return z[1]

        stopped.terminal, stopped.direction = True, -1
        z = [0.0, 0.0]
        ta = t_b
        stops = sorted(set([kk for kk in knot_t if kk > t_b] + [t_end]))
        ended = False
        for tb in stops:
            if tb <= ta:
                continue
            sol = solve_ivp(rhs, (ta, tb), z, method="DOP853", rtol=1e-13, atol=1e-15,
                            events=stopped, dense_output=True, first_step=1e-6)
            t_stop = sol.t_events[0][0] if sol.t_events[0].size else None
            pieces.append((ta, t_stop if t_stop is not None else tb, "slip", (sol.sol, x_b, t_b)))
            if t_stop is not None:
                y_e = sol.sol(t_stop)[0]
                t = t_stop
                x = x_b + u(t_stop) - u(t_b) - y_e
                t_stick = t_stop
                ended = True
                break
            ta, z = tb, sol.y[:, -1]
        if not ended:
            break
    out = np.empty(len(ts))
    for j, s in enumerate(np.asarray(ts)):
        for ta, tb, kind, pl in pieces:
            if ta <= s <= tb:
                if kind == "stick":
                    out[j] = pl[0] + u(s) - u(pl[1])
                else:
                    solf, x_b, t_b = pl
                    out[j] = x_b + u(s) - u(t_b) - solf(s)[0]
                break
        else:
            raise AssertionError(f"sample {s} not covered")
    return out


@pytest.fixture(scope="module")
def setup_36():
    W, k = 36.0, 86.9
    return Slideway(LUB_A, W, k), W, k


def test_constant_speed_matches_scipy(sim, setup_36):
    sw, W, k = setup_36
    v = 0.05  # mm/s = 3 mm/min: stick time about 2 s
    ts = np.linspace(0.0, 8.0, SAMPLES)
    tr = sim(sw, ConstantSpeed(v), jnp.asarray(ts), max_events=EVENTS)
    assert int(tr.cycles.valid.sum()) >= 3
    ref = scipy_reference(LUB_A, W, k, [0.0], [v], ts, 8.0)
    np.testing.assert_allclose(np.asarray(tr.deflection), ref, atol=1e-6, rtol=0)


def test_slide_hold_slide_with_step_inside_a_slip_matches_scipy(sim, setup_36):
    sw, W, k = setup_36
    v = 0.05
    ts0 = np.linspace(0.0, 8.0, SAMPLES)
    first = sim(sw, ConstantSpeed(v), jnp.asarray(ts0), max_events=EVENTS)
    t_b1 = float(first.cycles.breakaway_time[1])
    # speed doubles 8 ms into the second slip, a 3 s hold later, then v again
    starts = [0.0, t_b1 + 0.008, t_b1 + 2.0, t_b1 + 5.0]
    speeds = [v, 2 * v, 0.0, v]
    ts = np.linspace(0.0, 16.0, 1601)
    tr = sim(sw, SpeedProgram(starts, speeds), jnp.asarray(ts), max_events=32)
    assert tr.result == SimulationResult.successful
    ref = scipy_reference(LUB_A, W, k, starts, speeds, ts, 16.0)
    np.testing.assert_allclose(np.asarray(tr.deflection), ref, atol=1e-6, rtol=0)
    # during the hold the deflection stays constant (the slider sticks)
    hold = (ts > t_b1 + 2.1) & (ts < t_b1 + 4.9)
    x_hold = np.asarray(tr.deflection)[hold]
    assert np.ptp(x_hold) < 1e-12


# ---------------------------------------------------------------- gradients
def _loss(sw, v, ts):
    tr = simulate_exact(sw, ConstantSpeed(v), ts, max_events=16)
    return jnp.mean(tr.deflection**2)


LEAVES = {
    **FRICTION_LEAVES,
    "weight": lambda s: s.weight,
    "stiffness": lambda s: s.stiffness,
}


def test_gradients_match_finite_differences(setup_36):
    sw, _, _ = setup_36
    v = jnp.asarray(0.05)
    ts = jnp.linspace(0.0, 7.0, 351)
    grad = eqx.filter_jit(eqx.filter_grad(_loss))(sw, v, ts)
    # the losses at the shifted points and the drive speed's forward-mode derivative from
    # one compiled program (a jvp in v, its primal the loss)
    value_and_dv = eqx.filter_jit(
        lambda s, vv: jax.jvp(lambda u: _loss(s, u, ts), (vv,), (jnp.ones_like(vv),)))

    def loss(s, vv):
        return value_and_dv(s, vv)[0]

    h = 1e-6
    for name, get in LEAVES.items():
        p = get(sw)
        lp = loss(eqx.tree_at(get, sw, p * (1 + h)), v)
        lm = loss(eqx.tree_at(get, sw, p * (1 - h)), v)
        fd = float((lp - lm) / (2 * h * p))
        g = float(get(grad))
        assert np.isfinite(g), name
        assert abs(g - fd) <= 1e-5 * abs(fd) + 1e-9, (name, g, fd)
    # drive speed too, through jvp (forward mode) to cover both modes
    dv = value_and_dv(sw, v)[1]
    fd_v = (loss(sw, v * (1 + h)) - loss(sw, v * (1 - h))) / (2 * h * v)
    assert abs(float(dv) - float(fd_v)) <= 1e-5 * abs(float(fd_v))


# ---------------------------------------------------------------- batches, modes, failures
def test_vmap_over_records_of_different_lengths(sim, setup_36):
    sw, _, _ = setup_36
    lengths = (2667, SAMPLES, 1779)  # 6, 9 and 4 s at 2.25 ms
    speeds = jnp.asarray([0.05, 0.08, 0.12])
    times = [np.linspace(0.0, 2.25e-3 * (n - 1), n) for n in lengths]
    ts, mask = pad_times(times)

    @eqx.filter_jit
    @eqx.debug.assert_max_traces(max_traces=1)
    def batch(sw, speeds, ts, mask):
        return jax.vmap(
            lambda v, t, m: simulate_exact(sw, ConstantSpeed(v), t, mask=m, max_events=EVENTS)
        )(speeds, ts, mask)

    out = batch(sw, speeds, ts, mask)
    out2 = batch(sw, speeds * 1.01, ts, mask)  # new values: no retrace
    assert out.deflection.shape == (3, max(lengths))
    assert np.all(np.isfinite(np.asarray(out2.deflection)))
    for i, n in enumerate(lengths):  # one compile: the padded times share a shape
        one = sim(sw, ConstantSpeed(speeds[i]), ts[i], max_events=EVENTS)
        np.testing.assert_allclose(np.asarray(out.deflection[i, :n]),
                                   np.asarray(one.deflection[:n]), atol=1e-12)
        assert bool(out.mask[i, n - 1]) and not np.any(np.asarray(out.mask[i, n:]))


def test_self_consistent_slip_time_equals_the_actual_slip(sim, setup_36):
    sw, W, k = setup_36
    tr = sim(sw, ConstantSpeed(0.5), jnp.linspace(0.0, 3.0, 601), slip_time="self_consistent",
             max_events=24)
    c = tr.cycles
    valid = np.asarray(c.valid)
    assert valid.sum() >= 3
    np.testing.assert_allclose(np.asarray(c.slip_time)[valid],
                               np.asarray(c.model_slip_time)[valid], rtol=1e-10)
    # at a finite speed the slip lasts longer than pi / omega0 (eq 7 is the v -> 0 limit)
    assert np.all(np.asarray(c.slip_time)[valid] > np.pi / np.sqrt(G * k / W))


def test_slider_that_cannot_stick_is_flagged_and_finite(sim):
    # lubricant C, light slider, stiff spring: k x1 > mu_d W after each slip
    sw = Slideway(lubricant("C"), 11.3, 128.5)
    tr = sim(sw, ConstantSpeed(0.01), jnp.linspace(0.0, 5.0, SAMPLES), max_events=EVENTS)
    assert bool(tr.steady_sliding)
    assert bool(np.any(np.asarray(tr.cycles.restick_failed)))
    assert np.all(np.isfinite(np.asarray(tr.deflection)))
    assert int(tr.num_events) <= EVENTS
    # every slip that could not stick is followed by one at mu_d that does stick
    c = tr.cycles
    failed = np.flatnonzero(np.asarray(c.restick_failed) & np.asarray(c.valid))
    nxt = failed + 1
    nxt = nxt[np.asarray(c.valid)[nxt]]
    assert np.all(np.asarray(c.stick_time)[nxt] == 0.0)
    np.testing.assert_allclose(np.asarray(c.mu_m)[nxt], 0.20, rtol=1e-12)


def test_running_out_of_events_is_reported(sim, setup_36):
    sw, _, _ = setup_36
    # about 150 events in 5 s at 0.5 mm/s (a 65 ms cycle)
    tr = sim(sw, ConstantSpeed(0.5), jnp.linspace(0.0, 5.0, SAMPLES), max_events=EVENTS)
    assert tr.result == SimulationResult.max_events_reached
    assert np.all(np.isfinite(np.asarray(tr.deflection)))


def test_bad_structure_raises():
    sw = Slideway(LUB_A, 36.0, 86.9)
    with pytest.raises(ValueError, match="slip_time"):
        simulate_exact(sw, ConstantSpeed(0.1), jnp.linspace(0, 1, 5), slip_time="bogus")
    with pytest.raises(ValueError, match="drive"):
        simulate_exact(sw, 0.1, jnp.linspace(0, 1, 5))


def test_series_cos_sin_matches_numpy_and_unsorted_times_are_rejected(setup_36):
    from stickslip_jax.simulation.exact import _cos_sin

    phi = np.linspace(-1.0, 2 * np.pi + 1.0, 20001)
    c, s = _cos_sin(jnp.asarray(phi))
    np.testing.assert_allclose(np.asarray(c), np.cos(phi), rtol=0, atol=2e-15)
    np.testing.assert_allclose(np.asarray(s), np.sin(phi), rtol=0, atol=2e-15)
    sw, _, _ = setup_36
    with pytest.raises(Exception, match="non-decreasing"):
        simulate_exact(sw, ConstantSpeed(0.1), jnp.asarray([0.0, 2.0, 1.0]), max_events=4)
