"""Steady-state stick-slip, chapter 5 (stickslip_jax.steady): eqs (5)-(7), (11), (12).

The reference is an independent SciPy brentq solution of eq (6) written here from the
paper's formulas (with the NOTES.md corrections), not from the package.
"""

import itertools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest
from scipy.optimize import brentq

import stickslip_jax as ss
from stickslip_jax import steady
from stickslip_jax.units import from_mm_per_min, mm_per_min

G = 9806.65  # mm/s^2
TABLE6 = {  # mu_s, mu_d, gamma, m, delta, n
    "A": (0.56, 0.21, 0.38, 0.40, 67.0, 1.0),
    "C": (0.46, 0.20, 0.067, 0.45, 43.0, 1.0),
}
WEIGHTS = (11.3, 36.0, 53.2)  # Table 1, kgf
STIFFNESSES = (27.3, 86.9, 128.5)  # Table 1, kgf/mm
SPEEDS_MM_MIN = np.geomspace(0.0022, 92.0, 13)  # Table 1 range


# ---------------------------------------------------------------- independent reference
def ref_t0(W, k):
    return math.pi * math.sqrt(W / (G * k))


def ref_rhs(T1, W, k, p):
    """Right-hand side of eq (6) with the exponent m on T1 (NOTES.md item 1)."""
    mu_s, mu_d, gamma, m, delta, n = p
    T2 = ref_t0(W, k)
    return (mu_s - mu_d) * -math.expm1(-gamma * T1**m) * -math.expm1(-delta * T2**n)


def ref_vc(W, k, p):
    """Corrected eq (12) (NOTES.md item 3), in mm/s."""
    T0 = ref_t0(W, k)
    return 2 * W / (k * T0) * ref_rhs(T0, W, k, p)


def ref_t1(W, k, v, p):
    """Stick time of eq (6) by brentq; None above v_c (no stick-slip)."""
    if v >= ref_vc(W, k, p):
        return None
    f = lambda T1: k * v * T1 / (2 * W) - ref_rhs(T1, W, k, p)  # noqa: E731
    hi = 2 * W * (p[0] - p[1]) / (k * v)  # the rhs never exceeds mu_s - mu_d
    return brentq(f, ref_t0(W, k), hi, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=500)


# ---------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def grid():
    """All 9 (W, k) combinations of Table 1 x 13 speeds x lubricants A, C, solved once."""
    combos = list(itertools.product(WEIGHTS, STIFFNESSES, SPEEDS_MM_MIN))
    W, k, v = (np.asarray(c) for c in zip(*combos))
    v = from_mm_per_min(v)
    out = {name: ss.steady_map(ss.lubricant(name), W, k, v) for name in TABLE6}
    return W, k, v, out


# ---------------------------------------------------------------- eq (6), (12) vs brentq
@pytest.mark.parametrize("name", ["A", "C"])
def test_eq6_eq12_match_brentq(grid, name):
    W, k, v, out = grid
    res = out[name]
    p = TABLE6[name]
    assert bool(jnp.all(res.result == optx.RESULTS.successful))
    n_stick = 0
    for i in range(len(W)):
        vc = ref_vc(W[i], k[i], p)
        assert float(res.critical_speed[i]) == pytest.approx(vc, rel=1e-12)
        assert float(res.slip_time[i]) == pytest.approx(ref_t0(W[i], k[i]), rel=1e-14)
        t1 = ref_t1(W[i], k[i], v[i], p)
        if t1 is None:  # above v_c: no stick-slip, zeros and no NaN
            assert not bool(res.stick_slip[i])
            assert float(res.amplitude[i]) == 0.0 and float(res.stick_time[i]) == 0.0
            assert float(res.frequency[i]) == 0.0
            continue
        n_stick += 1
        assert bool(res.stick_slip[i])
        assert float(res.stick_time[i]) == pytest.approx(t1, rel=1e-8)
        a_ref = v[i] * t1 / 2  # eq (5)
        assert float(res.amplitude[i]) == pytest.approx(a_ref, rel=1e-8)
        # both forms of eq (5): a = (mu_0 - mu_m) W / k = v T1 / 2
        assert float((res.mu_0[i] - res.mu_m[i]) * W[i] / k[i]) == pytest.approx(a_ref, rel=1e-8)
        assert float(res.amplitude_ratio[i]) == pytest.approx(a_ref * k[i] / W[i], rel=1e-8)
        f0 = math.sqrt(G * k[i] / W[i]) / (2 * math.pi)
        assert float(res.frequency[i]) == pytest.approx(1 / (t1 + ref_t0(W[i], k[i])), rel=1e-8)
        f_ratio = float(res.frequency[i]) / f0
        assert float(res.frequency_ratio[i]) == pytest.approx(f_ratio, rel=1e-12)
    assert n_stick > 40 and n_stick < len(W)  # both regimes are exercised
    for leaf in jax.tree_util.tree_leaves(res):
        assert bool(jnp.all(jnp.isfinite(leaf)))


@pytest.mark.parametrize("m, n", [(1.3, 0.6), (0.15, 1.4)])
def test_eq6_off_table_exponents_match_brentq(m, n):
    """Exponents outside Table 6 (m > 1 makes eq (6) non-monotone near T1 = 0): Newton
    from above still finds the stick time T1 >= T0 that brentq brackets."""
    fr = eqx.tree_at(lambda f: (f.static.m, f.kinetic.n), ss.lubricant("A"), (m, n))
    p = (0.56, 0.21, 0.38, m, 67.0, n)  # lubricant A, Table 6, with m and n replaced
    vc = ref_vc(36.0, 86.9, p)
    v = vc * np.asarray([1e-4, 0.3, 0.999])
    res = ss.steady_map(fr, 36.0, 86.9, v)
    assert bool(jnp.all(res.stick_slip)) and bool(jnp.all(res.result == optx.RESULTS.successful))
    for i in range(3):
        assert float(res.stick_time[i]) == pytest.approx(ref_t1(36.0, 86.9, v[i], p), rel=1e-8)


def test_critical_speed_lubricant_a_near_49_mm_per_min():
    vc = float(mm_per_min(ss.critical_speed(ss.lubricant("A"), 36.0, 86.9)))
    assert vc == pytest.approx(49.0, abs=0.5)  # NOTES.md item 3: "about 49 mm/min"
    assert vc == pytest.approx(mm_per_min(ref_vc(36.0, 86.9, TABLE6["A"])), rel=1e-13)


def test_no_stick_slip_above_vc_is_finite_and_flagged():
    # (zero, finite gradients above v_c are checked in test_jit_vmap_grad_together)
    fr = ss.lubricant("A")
    vs = from_mm_per_min(jnp.asarray([60.0, 92.0, 1e4]))
    r = ss.steady_map(fr, 36.0, 86.9, vs)
    assert not bool(jnp.any(r.stick_slip)) and bool(jnp.all(r.amplitude == 0.0))
    assert bool(jnp.all(r.result == optx.RESULTS.successful))
    assert bool(jnp.all(r.frequency_ratio == 0.0)) and bool(jnp.all(jnp.isfinite(r.mu_0)))


def test_bad_inputs():
    fr = ss.lubricant("A")
    for bad in ((0.0, 86.9, 0.1), (36.0, -1.0, 0.1), (36.0, 86.9, 0.0), (float("nan"), 86.9, 0.1)):
        with pytest.raises(ValueError, match="must be finite and > 0"):
            jax.block_until_ready(ss.steady_state(fr, *bad))
    with pytest.raises(ValueError, match="scalars"):
        ss.steady_state(fr, jnp.ones(2), 86.9, 0.1)
    with pytest.raises(ValueError, match="Friction"):
        ss.steady_state(ss.static_law("kato"), 36.0, 86.9, 0.1)


# ---------------------------------------------------------------- trends of the paper
def test_amplitude_falls_as_speed_rises(grid):
    W, k, v, out = grid
    for name in TABLE6:
        for w, kk in itertools.product(WEIGHTS, STIFFNESSES):
            sel = (W == w) & (k == kk)
            res = out[name]
            a = np.asarray(res.amplitude)[sel]
            stick = np.asarray(res.stick_slip)[sel]
            assert np.all(np.diff(a[stick]) < 0), (name, w, kk)
            assert np.all(a[~stick] == 0)


def test_amplitude_ratio_rises_with_weight_falls_with_stiffness():
    for name, v_mm_min in (("A", 5.0), ("C", 0.5)):  # below v_c at every Table 1 point
        fr = ss.lubricant(name)
        v = from_mm_per_min(v_mm_min)
        by_w = ss.steady_map(fr, jnp.asarray(WEIGHTS), 86.9, v)
        by_k = ss.steady_map(fr, 36.0, jnp.asarray(STIFFNESSES), v)
        assert bool(jnp.all(by_w.stick_slip)) and bool(jnp.all(by_k.stick_slip))
        assert np.all(np.diff(np.asarray(by_w.amplitude_ratio)) > 0)
        assert np.all(np.diff(np.asarray(by_w.amplitude)) > 0)  # a itself rises with W (Fig 10)
        assert np.all(np.diff(np.asarray(by_k.amplitude_ratio)) < 0)
        assert np.all(np.diff(np.asarray(by_k.frequency)) > 0)  # f rises with k (Fig 13)


def test_frequency_ratio_tends_to_one_at_vc_lubricant_a():
    fr = ss.lubricant("A")
    vc = ss.critical_speed(fr, 36.0, 86.9)
    x = jnp.asarray([[1e-4, 1e-2, 0.5], [0.9, 0.99, 1 - 1e-6]])
    r = np.concatenate(
        [np.asarray(ss.steady_map(fr, 36.0, 86.9, vc * xi).frequency_ratio) for xi in x]
    )
    assert np.all(np.diff(r) > 0) and np.all(r < 1)
    assert r[-1] == pytest.approx(1.0, abs=1e-4)
    assert r[0] < 0.01  # far below v_c, f << f0 (T1 >> T2)


def test_vc_falls_as_natural_frequency_rises_fig36():
    for name in TABLE6:
        fr = ss.lubricant(name)
        ws, ks = np.meshgrid(np.linspace(5, 60, 7), np.linspace(20, 140, 7))
        f0 = np.sqrt(G * ks / ws) / (2 * np.pi)
        vc_fn = jax.vmap(ss.critical_speed, in_axes=(None, 0, 0))
        vc = np.asarray(vc_fn(fr, ws.ravel(), ks.ravel()))
        order = np.argsort(f0.ravel())
        assert np.all(np.diff(vc[order]) < 0), name  # v_c depends on W, k only through f0
        assert float(ss.critical_speed(fr, 53.2, 27.3)) > float(ss.critical_speed(fr, 11.3, 128.5))


@pytest.mark.parametrize(
    "where, values, sign",
    [
        (lambda f: f.static.mu_s, np.linspace(0.25, 0.9, 8), +1),  # Fig 37, mu_s - mu_d
        (lambda f: f.static.gamma, np.geomspace(0.01, 5.0, 8), +1),  # Fig 38
        (lambda f: f.static.m, np.linspace(0.1, 1.5, 8), -1),  # Fig 39
        (lambda f: f.kinetic.delta, np.geomspace(1.0, 500.0, 8), +1),  # Fig 40
        (lambda f: f.kinetic.n, np.linspace(0.2, 1.5, 8), -1),  # Fig 41
    ],
    ids=["mu_s-mu_d", "gamma", "m", "delta", "n"],
)
def test_vc_against_friction_parameters_figs37_41(where, values, sign):
    """v_c rises with mu_s - mu_d, gamma, delta and falls with m, n (all Table 1 W, k)."""
    for name in TABLE6:
        base = ss.lubricant(name)
        batch = jax.vmap(lambda x: eqx.tree_at(where, base, x))(jnp.asarray(values))
        for w, kk in ss.experimental_conditions():
            vc = np.asarray(eqx.filter_vmap(lambda f: ss.critical_speed(f, w, kk))(batch))
            assert np.all(sign * np.diff(vc) > 0), (name, w, kk)


# ---------------------------------------------------------------- eq (11)
def test_slip_trajectory_eq11():
    fr = ss.lubricant("A")
    W, k = 36.0, 86.9
    r = ss.steady_state(fr, W, k, from_mm_per_min(1.0))
    traj = ss.slip_trajectory(fr, W, k, r.stick_time, num=201)
    mu_0, mu_m = float(r.mu_0), float(r.mu_m)
    assert float(traj.deflection[0]) == pytest.approx(mu_0 * W / k, rel=1e-13)
    assert float(traj.velocity_over_omega0[0]) == 0.0
    assert float(traj.deflection[-1]) == pytest.approx((2 * mu_m - mu_0) * W / k, rel=1e-12)
    assert abs(float(traj.velocity_over_omega0[-1])) < 1e-15
    assert float(traj.time[-1]) == pytest.approx(ref_t0(W, k), rel=1e-14)
    # a circle of radius a = (mu_0 - mu_m) W / k about mu_m W / k in the phase plane
    radius = np.hypot(np.asarray(traj.deflection) - mu_m * W / k, traj.velocity_over_omega0)
    np.testing.assert_allclose(radius, float(r.amplitude), rtol=1e-8)
    assert np.all(np.asarray(traj.velocity_over_omega0)[1:-1] < 0)  # x decreases during slip
    # the spring swing during the slip is 2a, the same as the stick climbs (NOTES.md item 5)
    swing = float(traj.deflection[0] - traj.deflection[-1])
    assert swing == pytest.approx(float(r.stick_time) * from_mm_per_min(1.0), rel=1e-8)


# ---------------------------------------------------------------- gradients
def _outputs(p):
    friction, W, k, v = p
    r = ss.steady_state(friction, W, k, v)
    return jnp.stack([r.amplitude, r.stick_time, r.critical_speed])


@pytest.fixture(scope="module")
def grad_fns():
    jac = jax.jit(jax.jacrev(_outputs))
    fun = jax.jit(_outputs)
    return jac, fun


GRAD_POINTS = [  # (lubricant, W kgf, k kgf/mm, v mm/min)
    ("A", 36.0, 86.9, 1.0),
    ("A", 11.3, 27.3, 30.0),
    ("A", 53.2, 128.5, 0.01),
    ("C", 36.0, 27.3, 5.0),
    ("C", 53.2, 86.9, 0.05),
]


@pytest.mark.parametrize("point", GRAD_POINTS, ids=["-".join(map(str, p)) for p in GRAD_POINTS])
def test_gradients_match_central_differences(grad_fns, point):
    """d(a, T1, v_c)/d(every friction parameter, W, k, v) vs central finite differences."""
    jac, fun = grad_fns
    name, W, k, v_mm_min = point
    p = (ss.lubricant(name), jnp.asarray(W), jnp.asarray(k), jnp.asarray(from_mm_per_min(v_mm_min)))
    params, static = eqx.partition(p, eqx.is_inexact_array)
    leaves, treedef = jax.tree_util.tree_flatten(params)
    assert len(leaves) == 9  # mu_d, mu_s, gamma, m, delta, n, W, k, v
    J = jax.tree_util.tree_leaves(jac(p))  # one (3,) row per parameter, same order
    for i, x in enumerate(leaves):
        h = 1e-6 * abs(float(x))

        def at(dx, i=i):
            new = list(leaves)
            new[i] = leaves[i] + dx
            return np.asarray(fun(eqx.combine(jax.tree_util.tree_unflatten(treedef, new), static)))

        fd = (at(h) - at(-h)) / (2 * h)
        scale = np.abs(np.asarray(fun(p))) / abs(float(x))  # output/parameter: guards zeros
        g = np.asarray(J[i])
        assert np.all(np.abs(g - fd) <= 1e-5 * np.abs(fd) + 1e-9 * scale), (i, g, fd)
        assert np.all(np.isfinite(g))
    # every output depends on every parameter except v_c on v
    Jm = np.stack([np.asarray(j) for j in J])
    assert np.all(Jm[:8] != 0) and np.all(Jm[8, :2] != 0) and Jm[8, 2] == 0


def test_jit_vmap_grad_together():
    fr = ss.lubricant("A")
    vs = from_mm_per_min(jnp.asarray([0.01, 0.3, 3.0, 30.0, 60.0]))  # last above v_c

    @jax.jit
    @jax.vmap
    def dadv(v):
        return jax.grad(lambda f, v: ss.steady_state(f, 36.0, 86.9, v).amplitude, argnums=(0, 1))(
            fr, v
        )

    g_fr, g_v = dadv(vs)
    h = 1e-6 * vs
    up = ss.steady_map(fr, 36.0, 86.9, vs + h).amplitude
    down = ss.steady_map(fr, 36.0, 86.9, vs - h).amplitude
    fd = (up - down) / (2 * h)
    np.testing.assert_allclose(np.asarray(g_v[:4]), np.asarray(fd[:4]), rtol=1e-5)
    assert np.all(np.asarray(g_v[:4]) < 0) and float(g_v[4]) == 0.0
    assert g_fr.static.gamma.shape == (5,)
    assert all(bool(jnp.all(jnp.isfinite(x))) for x in jax.tree_util.tree_leaves(g_fr))
    # vmap over friction parameters and W at once
    gammas = jnp.asarray([0.2, 0.38, 0.8])
    batch = jax.vmap(lambda g: eqx.tree_at(lambda f: f.static.gamma, fr, g))(gammas)
    out = eqx.filter_jit(eqx.filter_vmap(lambda f, w: ss.steady_state(f, w, 86.9, 0.02).amplitude))(
        batch, jnp.asarray(WEIGHTS)
    )
    for j in range(3):
        p = TABLE6["A"][:2] + (float(gammas[j]),) + TABLE6["A"][3:]
        assert float(out[j]) == pytest.approx(0.01 * ref_t1(WEIGHTS[j], 86.9, 0.02, p), rel=1e-8)


def test_no_recompilation_for_new_values(monkeypatch):
    # 1. a user-level jit over (friction, W, k, v) traces once for many values
    @eqx.filter_jit
    @eqx.debug.assert_max_traces(max_traces=1)
    def amplitude(f, W, k, v):
        return ss.steady_state(f, W, k, v).amplitude

    fr = ss.lubricant("A")
    for i, (W, k) in enumerate(ss.experimental_conditions()):
        f = eqx.tree_at(lambda f: f.static.gamma, fr, jnp.asarray(0.3 + 0.1 * i, dtype=float))
        amplitude(f, jnp.asarray(W), jnp.asarray(k), jnp.asarray(0.01 * (i + 1)))
    amplitude(ss.lubricant("C"), jnp.asarray(36.0), jnp.asarray(86.9), jnp.asarray(0.001))
    # 2. the public steady_state itself, called with plain Python floats, traces at most once
    traces = []
    original = steady.critical_speed

    def counting(*args):
        traces.append(1)
        return original(*args)

    monkeypatch.setattr(steady, "critical_speed", counting)
    for i, W in enumerate((11.3, 20.0, 36.0, 41.5, 53.2)):
        ss.steady_state(fr, W, 86.9 + i, 0.01 * (i + 1))
        # new friction values, as Python floats or weak-typed arrays, do not retrace either
        g = 0.3 + 0.1 * i
        f = eqx.tree_at(lambda f: f.static.gamma, fr, g if i % 2 else jnp.asarray(g))
        ss.steady_state(f, W, 86.9, 0.01)
    assert len(traces) <= 1
