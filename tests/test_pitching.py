"""Pitching and yawing model (chapter 6): lag exactness, superposition, and the paper's trends."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import stickslip_jax as ss
from stickslip_jax import pitching as pt

W, K = jnp.asarray(36.0), jnp.asarray(86.9)  # Table 1, W2 and k2
SPEEDS = jnp.asarray([0.03, 0.3, 1.0, 3.0, 10.0, 30.0]) / 60.0  # mm/s
C2 = pt.PAPER_DRIVE_POINTS["C2"]


@pytest.fixture(scope="module")
def friction():
    return ss.lubricant("A")


@pytest.fixture(scope="module")
def model():
    return pt.default_model()


@pytest.fixture(scope="module")
def sweep(model, friction):
    return pt.tilt_against_speed(model, friction, W, K, SPEEDS, C2)


@pytest.fixture(scope="module")
def batch(friction):
    """One compiled batch of 6 steady cycles: heights, offsets, W, k, v (all length 6)."""

    @eqx.filter_jit
    def run(m, h, o, w, k, v):
        def one(h, o, w, k, v):
            return pt.steady_tilt(m, friction, w, k, v, pt.DrivePoint(h, o))

        return jax.vmap(one)(h, o, w, k, v)

    return run


def full(x):
    return jnp.full(6, x, dtype=float)


# ---------------------------------------------------------------- the lag itself


def test_lag_matches_scipy_ode_on_uneven_samples():
    lag = pt.LinearLag(time_constants=[0.3, 2.0], weights=[0.5, 0.3])  # 20 % instantaneous
    rng = np.random.default_rng(1)
    ts = np.cumsum(rng.uniform(0.01, 0.2, 80))
    ts -= ts[0]
    u = np.sin(ts) + 0.3 * rng.standard_normal(ts.size)
    out = np.asarray(pt.lag_response(lag, u, ts))

    def rhs(t, th):
        ui = np.interp(t, ts, u)  # first-order hold, as the model assumes
        return (np.array([0.5, 0.3]) * ui - th) / np.array([0.3, 2.0])

    sol = solve_ivp(rhs, (0, ts[-1]), [0.5 * u[0], 0.3 * u[0]], t_eval=ts, rtol=1e-11,
                    atol=1e-13, max_step=0.005)
    ref = 0.2 * u + sol.y.sum(axis=0)
    np.testing.assert_allclose(out, ref, atol=1e-8)


def test_periodic_solution_is_the_limit_of_a_long_run():
    lag = pt.first_order(1.5)
    ts1 = jnp.linspace(0.0, 2.0, 41)
    u1 = jnp.where(ts1 < 1.6, ts1, 1.6 - 4.0 * (ts1 - 1.6))  # sawtooth back to 0 at t = 2
    periodic = pt.lag_response(lag, u1, ts1, periodic=True)
    reps = 30
    ts = jnp.concatenate([ts1[:-1] + 2.0 * i for i in range(reps)] + [ts1[-1:] + 2.0 * (reps - 1)])
    u = jnp.concatenate([u1[:-1]] * reps + [u1[-1:]])
    long = pt.lag_response(lag, u, ts)
    np.testing.assert_allclose(long[-41:], periodic, atol=1e-10)


def test_first_order_rise_and_recovery_have_their_closed_forms():
    tau, rate, drop = 0.8, 3.0, 2.5
    ts = jnp.linspace(0.0, 5.0, 51)
    rise = pt.rise_curve(pt.first_order(tau), rate, ts)
    np.testing.assert_allclose(rise, rate * (ts - tau * (1 - jnp.exp(-ts / tau))), atol=1e-12)
    rec = pt.recovery_curve(pt.first_order(tau), drop, ts)
    np.testing.assert_allclose(rec, drop * jnp.exp(-ts / tau), atol=1e-12)
    # tau grows with viscosity: the recovery at twice the viscosity is twice as slow
    slow = pt.recovery_curve(pt.first_order(tau), drop, 2.0 * ts, time_scale=2.0)
    np.testing.assert_allclose(slow, rec, atol=1e-12)


def test_section_6_3_superposition_of_rise_and_recovery():
    """Force held at F0, dropped to F1 at t = 0, then ramped: the tilt is F1 + eps_u + eps_d."""
    lag = pt.LinearLag(time_constants=[0.4, 3.0], weights=[0.6, 0.3])
    f0, f1, rate = 12.0, 5.0, 1.5
    ts = jnp.linspace(0.0, 6.0, 121)
    t_all = jnp.concatenate([jnp.zeros(1), ts])
    force = jnp.concatenate([jnp.full(1, f0), f1 + rate * ts])
    whole = pt.lag_response(lag, force, t_all)[1:]
    parts = f1 + pt.rise_curve(lag, rate, ts) + pt.recovery_curve(lag, f0 - f1, ts)
    np.testing.assert_allclose(whole, parts, atol=1e-11)
    # and the tilt lags below the static line during the stick (eps_u < eps_s, Figs 54-55)
    assert jnp.all(pt.rise_curve(lag, rate, ts)[1:] < rate * ts[1:])


def test_tilt_history_runs_on_any_trace_and_starts_in_equilibrium(model):
    ts = jnp.linspace(0.0, 3.0, 301)
    force = 8.0 + 2.0 * jnp.sin(5 * ts)
    tr = pt.tilt_history(model, ts, force, C2)
    arm = C2.height - model.pitch.neutral
    assert float(tr.pitch[0]) == pytest.approx(float(model.pitch.compliance * arm * 8.0), rel=1e-12)
    lever = model.points.positions[0] - model.pitch.pivot
    np.testing.assert_allclose(tr.displacement[:, 0], tr.pitch * lever, rtol=1e-12)
    lever4 = model.points.positions[3] - model.yaw.pivot
    np.testing.assert_allclose(tr.displacement[:, 3], tr.yaw * lever4, rtol=1e-12)
    # lagged: the swing is smaller than the static line's
    assert np.ptp(tr.pitch) < 0.5 * np.ptp(tr.static_pitch)


def test_bad_structure_is_rejected():
    with pytest.raises(ValueError, match="same length"):
        pt.LinearLag(time_constants=[1.0, 2.0], weights=[1.0])
    with pytest.raises(ValueError, match="pitch' or 'yaw"):
        pt.MeasuringPoints(positions=[1.0], planes=("roll",), names=("r",))
    with pytest.raises(ValueError, match="equal length"):
        pt.lag_response(pt.first_order(1.0), jnp.ones(3), jnp.arange(4.0))


# ---------------------------------------------------------------- the paper's trends


def test_tilt_and_variation_fall_with_speed_and_vp_is_below_v0(sweep, model, friction):
    """Figs 48-49: eps' and d_eps fall as v rises; d_eps vanishes at v_p < v_0."""
    peak = np.asarray(sweep.points.peak[:, 0])
    var = np.asarray(sweep.points.variation[:, 0])
    assert np.all(peak > 0) and np.all(np.diff(peak) < 0)
    assert np.all(np.diff(var) < 0)
    # at low speed the variation almost equals eps' (Fig 49 text)
    assert var[0] > 0.8 * peak[0]
    crit = pt.critical_pitch_speed(model, friction, W, K, C2)
    assert bool(crit.bracketed)
    assert float(crit.v_p) < 0.5 * float(crit.v_0)
    at = pt.steady_tilt(model, friction, W, K, crit.v_p, C2).points
    assert float(at.variation[0] / at.peak[0]) == pytest.approx(0.05, rel=1e-4)


def test_why_tilt_falls_with_speed(sweep, model, friction):
    """Mechanism: without lag eps' follows F0 (which falls as the stick shortens, eq 1) and
    d_eps follows dF; with the lag, d_eps/dF falls further as the cycle gets faster."""
    quick = eqx.tree_at(lambda m: (m.pitch.lag.time_constants, m.yaw.lag.time_constants), model,
                        (jnp.asarray([1e-6]), jnp.asarray([1e-6])))
    static = pt.tilt_against_speed(quick, friction, W, K, SPEEDS, C2)
    g = model.pitch.compliance * (C2.height - model.pitch.neutral) * (
        model.points.positions[0] - model.pitch.pivot)
    f0, df = static.cycle.f0, static.cycle.force_drop
    np.testing.assert_allclose(static.points.peak[:, 0], g * f0, rtol=1e-4)
    np.testing.assert_allclose(static.points.variation[:, 0], g * df, rtol=1e-4)
    assert np.all(np.diff(np.asarray(f0)) < 0)  # the friction law's share of the fall
    passed = np.asarray(sweep.points.variation[:, 0] / (g * sweep.cycle.force_drop))
    assert np.all(np.diff(passed) < 0) and passed[0] > 0.9 and passed[-1] < 0.05  # the filter


def test_tilt_grows_with_height_and_with_F0(model, batch):
    """Figs 52-53: eps' and d_eps grow with h (above M_v) and with F0 (heavier slider)."""
    v = full(0.3 / 60)
    by_h = batch(model, jnp.linspace(40.0, 70.0, 6), full(0.0), full(W), full(K), v).points
    assert np.all(np.diff(np.asarray(by_h.peak[:, 0])) > 0)
    assert np.all(np.diff(np.asarray(by_h.variation[:, 0])) > 0)
    # Table 1's three (W, k) pairs and three between them: F0 = mu_0 W rises with W
    weights = jnp.asarray([11.3, 20.0, 36.0, 44.0, 53.2, 60.0])
    stiff = weights * (86.9 / 36.0)
    by_w = batch(model, full(C2.height), full(0.0), weights, stiff, v)
    assert np.all(np.diff(np.asarray(by_w.cycle.f0)) > 0)
    assert np.all(np.diff(np.asarray(by_w.points.peak[:, 0])) > 0)
    assert np.all(np.diff(np.asarray(by_w.points.variation[:, 0])) > 0)


def test_sign_change_across_neutral_points_and_proportional_to_offset(model, batch):
    """Figs 52, 62: the tilt reverses across M_v and M_h; eps' is proportional to l - l_Mh."""
    offsets = jnp.linspace(-40.0, 40.0, 6)
    heights = jnp.linspace(10.0, 70.0, 6)
    out = batch(model, heights, offsets, full(W), full(K), full(0.3 / 60))
    yaw = np.asarray(out.points.peak[:, 3])
    pitch = np.asarray(out.points.peak[:, 0])
    slope, icpt = np.polyfit(np.asarray(offsets), yaw, 1)
    np.testing.assert_allclose(yaw, slope * np.asarray(offsets) + icpt, atol=1e-12)
    assert -icpt / slope == pytest.approx(float(model.yaw.neutral), rel=1e-9)
    assert np.all(np.sign(yaw) == np.sign(np.asarray(offsets) - float(model.yaw.neutral)))
    assert np.all(np.sign(pitch) == np.sign(np.asarray(heights) - float(model.pitch.neutral)))
    # opposite ends move in opposite directions (points 1 and 3; 4 and 5)
    assert np.all(np.sign(out.points.peak[:, 0]) == -np.sign(out.points.peak[:, 2]))
    assert np.all(np.sign(out.points.peak[:, 3]) == -np.sign(out.points.peak[:, 4]))


def test_viscosity_lowers_variation_more_than_tilt(sweep, model, friction):
    """Fig 51: a more viscous lubricant (C: ~1010 cSt against A's 195) cuts d_eps more than eps'."""
    thick = model.with_viscosity(5.0 * model.viscosity)
    out = pt.tilt_against_speed(thick, friction, W, K, SPEEDS, C2)
    rel_peak = np.asarray(out.points.peak[:, 0] / sweep.points.peak[:, 0])
    rel_var = np.asarray(out.points.variation[:, 0] / sweep.points.variation[:, 0])
    mid = slice(1, 5)  # where the cycle time is comparable with the lag
    assert np.all(rel_var[mid] < rel_peak[mid])
    assert np.all(rel_var[mid] < 0.9)
    assert np.all(rel_peak <= 1.0 + 1e-12)


def test_drive_at_neutral_point_gives_no_tilt_and_is_the_design_optimum(model, friction, batch):
    """Fig 63: driving at (M_v, M_h) (the paper's C1*) leaves almost no pitching or yawing."""
    best = pt.best_drive_point(model, height_range=(20.0, 70.0), offset_range=(-40.0, 40.0))
    assert float(best.drive.height) == float(model.pitch.neutral)
    assert float(best.drive.offset) == float(model.yaw.neutral)
    c1 = pt.PAPER_DRIVE_POINTS["C1"]
    h = jnp.asarray([best.drive.height, c1.height] * 3)
    o = jnp.asarray([best.drive.offset, c1.offset] * 3)
    out = batch(model, h, o, full(W), full(K), jnp.repeat(SPEEDS[:3], 2)).points
    assert np.max(np.abs(out.peak[0::2])) < 1e-12 * np.max(np.abs(out.peak[1::2]))
    # a box that excludes M_v: the optimum is the nearest feasible height, found on a grid too
    box = pt.best_drive_point(model, height_range=(35.0, 70.0))
    heights = jnp.linspace(35.0, 70.0, 8)
    grid = pt.variation_map(model, friction, W, K, SPEEDS, heights)
    assert float(box.drive.height) == 35.0
    assert np.all(np.argmin(np.asarray(grid.variation), axis=1) == 0)
    direct = batch(model, heights[:6], full(model.yaw.neutral), full(W), full(K), SPEEDS).points
    np.testing.assert_allclose(np.diag(grid.variation[:, :6]), direct.variation[:, 0], rtol=1e-9)
    np.testing.assert_allclose(np.diag(grid.peak[:, :6]), direct.peak[:, 0], rtol=1e-9)


def test_yaw_varies_less_than_pitch_with_a_slow_sideways_recovery(sweep):
    """Fig 61: the yawing variation is much smaller than its eps' (slow recovery sideways)."""
    ratio_yaw = np.abs(np.asarray(sweep.yaw.variation / sweep.yaw.peak))
    ratio_pitch = np.abs(np.asarray(sweep.pitch.variation / sweep.pitch.peak))
    assert np.all(ratio_yaw[1:] < ratio_pitch[1:])


# ---------------------------------------------------------------- JAX transformations


def test_gradients_match_finite_differences(model, friction):
    cycle = pt.steady_force_cycle(friction, W, K, jnp.asarray(1.0 / 60), 32, 8)

    def f(params):
        c, hmv, tau = params
        m = eqx.tree_at(lambda m: (m.pitch.compliance, m.pitch.neutral,
                                   m.pitch.lag.time_constants), model, (c, hmv, tau[None]))
        p = pt.cycle_tilt(m, cycle, C2).points
        return p.peak[0] * 1e3 + p.variation[0] * 1e3  # um

    x = (jnp.asarray(8e-8), jnp.asarray(30.0), jnp.asarray(1.0))
    f_jit = jax.jit(f)
    g = jax.jit(jax.grad(f))(x)
    for i, step in enumerate((1e-11, 1e-3, 1e-4)):
        up = list(x)
        dn = list(x)
        up[i] = x[i] + step
        dn[i] = x[i] - step
        fd = (f_jit(tuple(up)) - f_jit(tuple(dn))) / (2 * step)
        assert float(g[i]) == pytest.approx(float(fd), rel=1e-5)


def test_no_recompilation_for_new_values(model, friction):
    @eqx.filter_jit
    @eqx.debug.assert_max_traces(max_traces=1)
    def peak(m, v, drive):
        return pt.cycle_tilt(m, pt.steady_force_cycle(friction, W, K, v, 32, 8), drive).points.peak

    peak(model, jnp.asarray(0.01), C2)
    peak(model.with_viscosity(1e-7), jnp.asarray(0.02), pt.DrivePoint(60.0, 3.0))
