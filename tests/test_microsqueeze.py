"""Microsqueeze law, eq (28) with the cube: accuracy, trends, gradients, vmap, guards."""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stickslip_jax.contact import (
    BoundaryContact,
    MicrosqueezeStatic,
    default_stick_times,
    fit_kato,
    microsqueeze_curve,
    surface_pair,
    symmetric_pair,
)
from stickslip_jax.friction import AbstractStaticFriction
from stickslip_jax.lubricants import kato_static

T_GRID = jnp.geomspace(0.01, 1000.0, 41)


@pytest.fixture(scope="module")
def laws():
    return {name: MicrosqueezeStatic.from_table11(name) for name in "ABCDEFG"}


@pytest.fixture(scope="module")
def curve():
    return jax.jit(lambda law, T: microsqueeze_curve(law, T).mu_0)


@pytest.fixture(scope="module")
def fit_batch():
    """eq (1) fits (mu_s held at the theoretical asymptote) of a batch of 3 laws, compiled once."""
    return jax.jit(jax.vmap(lambda law: fit_kato(law, fix_mu_s=True)))


def _stack(items):
    return jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *items)


def test_is_a_static_friction_law(laws):
    law = laws["A"]
    assert isinstance(law, AbstractStaticFriction)
    assert float(law(0.0)) == pytest.approx(0.156, abs=1e-15)
    assert float(law.asymptote()) == pytest.approx(0.450, rel=1e-9)  # h_e - t_b > a_s for A


def test_rms_against_eq1_table9(laws, curve):
    """Fig 76: the theoretical curves stay within RMS 0.03 of eq (1) with Table 9."""
    batch = _stack([laws[n] for n in "ABCD"])
    mu = jax.vmap(curve, in_axes=(0, None))(batch, T_GRID)
    for i, name in enumerate("ABCD"):
        ref = kato_static(name, 9)(T_GRID)
        rms = float(jnp.sqrt(jnp.mean((mu[i] - ref) ** 2)))
        assert rms < 0.03, (name, rms)
        single = curve(laws[name], T_GRID)  # vmap over lubricants = one at a time
        np.testing.assert_allclose(mu[i], single, rtol=1e-9, atol=1e-12)


def test_fast_law_agrees_with_diffrax(laws, curve):
    fast = jax.jit(lambda law, T: law(T))
    for name in "AD":
        np.testing.assert_allclose(fast(laws[name], T_GRID), curve(laws[name], T_GRID), atol=2e-5)


def test_solution_reports_success_and_monotone_rise(laws):
    sol = microsqueeze_curve(laws["C"], jnp.array([0.0, 1e3, 1.0, 1e-3, 1e8, 10.0, 0.1]))  # unsorted, 0, huge
    assert sol.result == diffrax.RESULTS.successful
    assert float(sol.mu_0[0]) == pytest.approx(0.150)
    order = np.argsort(np.asarray(sol.stick_time))
    assert np.all(np.diff(np.asarray(sol.mu_0)[order]) > 0)
    assert float(sol.mu_0[4]) == pytest.approx(0.300, abs=1e-9)


@eqx.filter_jit
def _grad_sum(law, T):
    return jax.grad(lambda l: jnp.sum(l(T)))(law)


@pytest.mark.parametrize("offset", [0.05e-3, 0.0, -0.05e-3])
def test_stiff_ends_give_no_nan(laws, offset):
    """h_e - t_b above, equal to and below a_s (simple, quartic and triple roots)."""
    base = laws["A"]
    kin = base.kinematics()
    law = eqx.tree_at(lambda m: m.h_e, base, kin.a_s + base.t_b + offset)
    T = jnp.array([0.0, 1e-6, 1e-2, 1.0, 1e2, 1e4, 1e9])
    sol = microsqueeze_curve(law, T)
    assert sol.result == diffrax.RESULTS.successful
    fast = law(T)
    assert np.all(np.isfinite(sol.mu_0)) and np.all(np.isfinite(fast))
    np.testing.assert_allclose(fast, sol.mu_0, atol=2e-5)
    assert float(sol.mu_0[-1]) <= float(law.asymptote()) + 1e-12
    g = _grad_sum(law, T)
    assert all(np.all(np.isfinite(x)) for x in jax.tree_util.tree_leaves(g))


def test_gradients_match_central_differences(laws):
    base = laws["A"]
    T = jnp.array([0.05, 5.0])
    names = ("h_e", "Q", "eta", "t_b")

    def with_params(p):
        return eqx.tree_at(lambda m: (m.h_e, m.Q, m.eta, m.t_b), base, tuple(p))

    def curve(p):
        return microsqueeze_curve(with_params(p), T, adjoint=diffrax.ForwardMode()).mu_0

    # one compiled program gives the values (the central differences read them) and the
    # forward-mode derivative along a parameter (a column of the Jacobian)
    value_and_slope = jax.jit(lambda p, e: jax.jvp(curve, (p,), (e,)))
    p0 = jnp.stack([base.h_e, base.Q, base.eta, base.t_b])
    columns = []
    for j, name in enumerate(names):
        e = jnp.zeros(4).at[j].set(1.0)
        columns.append(value_and_slope(p0, e)[1])
        h = 1e-4 * p0[j]
        fd = (value_and_slope(p0 + h * e, e)[0] - value_and_slope(p0 - h * e, e)[0]) / (2 * h)
        np.testing.assert_allclose(columns[-1], fd, rtol=1e-4, err_msg=name)
    jac = jnp.stack(columns, axis=1)
    # the fast law has the same derivatives (to its interpolation accuracy)
    g_fast = jax.jacrev(lambda p: with_params(p)(T))(p0)
    np.testing.assert_allclose(g_fast, jac, rtol=2e-3)


def test_jit_traces_once_for_new_values(laws):
    @eqx.debug.assert_max_traces(max_traces=1)
    def call(law, T):
        return law(T)

    f = eqx.filter_jit(call)
    for name in "ABCD":
        f(laws[name], jnp.asarray(1.0))


def test_usable_inside_a_scan_with_scalar_stick_times(laws):
    def total(h_e):
        law = eqx.tree_at(lambda m: m.h_e, laws["B"], h_e)

        def step(carry, T1):
            return carry + law(T1), None

        return jax.lax.scan(step, 0.0, jnp.array([0.0, 0.1, 1.0, 10.0]))[0]

    v, g = jax.jit(jax.value_and_grad(total))(laws["B"].h_e)
    assert np.isfinite(float(v)) and np.isfinite(float(g)) and float(g) != 0.0


def test_trend_film_thickness(fit_batch):
    """Figs 81-82: mu_s and gamma fall as t_b rises (Q = 46, h_e = 0.83 um, eta = 3e-8)."""
    base = MicrosqueezeStatic(
        pair=surface_pair("S1G1"), contact=BoundaryContact(), t_b=0.2e-3, eta=3e-8, h_e=0.83e-3, Q=46.0, mu_d=0.156
    )
    t_b = jnp.array([0.15e-3, 0.25e-3, 0.35e-3])
    batch = jax.vmap(lambda t: eqx.tree_at(lambda m: m.t_b, base, t))(t_b)
    fits = fit_batch(batch)
    assert np.all(np.diff(np.asarray(fits.law.mu_s)) < 0)
    assert np.all(np.diff(np.asarray(fits.law.gamma)) < 0)
    assert np.all(np.asarray(fits.rms) < 0.025)


def test_trend_viscosity(fit_batch):
    """Figs 83-84: gamma falls as eta rises, mu_s unchanged, the approach to mu_s is slower."""
    base = MicrosqueezeStatic(
        pair=surface_pair("S1G1"), contact=BoundaryContact(), t_b=0.211e-3, eta=2e-8, h_e=0.83e-3, Q=31.0, mu_d=0.156
    )
    eta = jnp.array([2e-8, 6e-8, 10e-8])
    Q = jnp.array([31.0, 92.0, 153.0])
    batch = jax.vmap(lambda e, q: eqx.tree_at(lambda m: (m.eta, m.Q), base, (e, q)))(eta, Q)
    fits = fit_batch(batch)
    mu_inf = jax.vmap(lambda law: law.asymptote())(batch)
    np.testing.assert_allclose(mu_inf, mu_inf[0], rtol=1e-12)
    np.testing.assert_allclose(fits.law.mu_s, mu_inf, rtol=1e-12)
    assert np.all(np.diff(np.asarray(fits.law.gamma)) < 0)
    # stick time at which mu_0 has covered 90 % of its rise grows with eta
    T = jnp.geomspace(1e-2, 1e5, 200)
    mu = jax.vmap(lambda law: law(T))(batch)
    frac = (mu - 0.156) / (mu_inf[:, None] - 0.156)
    t90 = [float(T[np.argmax(np.asarray(f) >= 0.9)]) for f in frac]
    assert t90[0] < t90[1] < t90[2]


def test_trend_surface_topography(fit_batch):
    """Figs 94-95 with Q, h_e, mu_d of section 7.4 for xi1*xi2 = 500 and 5000 (symmetric
    pairs with H_max = R = 20 um, D = 1.5, z set by xi; t_b = 0.2 um): mu_s and gamma fall."""
    laws = []
    # 5000 twice: the batch has the shape of the other trend tests, so the fit is reused
    for xx, Q, h_e, mu_d in [(500.0, 1.4, 0.97e-3, 0.215), (5000.0, 54.0, 0.58e-3, 0.125)] * 1 + [
        (5000.0, 54.0, 0.58e-3, 0.125)
    ]:
        pair = symmetric_pair(20e-3, 20e-3, np.sqrt(xx) / 1.5, 1.5)
        assert float(pair.xi_product) == pytest.approx(xx, rel=1e-12)
        laws.append(
            MicrosqueezeStatic(pair=pair, contact=BoundaryContact(), t_b=0.2e-3, eta=2.2e-8, h_e=h_e, Q=Q, mu_d=mu_d)
        )
    fits = fit_batch(_stack(laws))
    assert fits.law.mu_s[1] < fits.law.mu_s[0]
    assert fits.law.gamma[1] < fits.law.gamma[0]
    assert fits.law.m[1] > fits.law.m[0]  # Fig 95: m increases with xi1*xi2
    # xi1*xi2 = 50000 with t_b = 0.2 um is impossible: its mu_s would be below mu_d = 0.110
    pair = symmetric_pair(20e-3, 20e-3, np.sqrt(50000.0) / 1.5, 1.5)
    with pytest.raises(ValueError, match="static limit"):
        MicrosqueezeStatic(pair=pair, contact=BoundaryContact(), t_b=0.2e-3, eta=2.2e-8, h_e=0.28e-3, Q=140.0, mu_d=0.110)


def test_impossible_parameters_are_rejected(laws):
    a = laws["A"]
    kw = dict(pair=a.pair, contact=a.contact, t_b=a.t_b, eta=a.eta, h_e=a.h_e, Q=a.Q, mu_d=a.mu_d)
    with pytest.raises(ValueError, match="h_e .* must exceed t_b \\+ a_d"):
        MicrosqueezeStatic(**dict(kw, h_e=0.5e-3))
    with pytest.raises(ValueError, match="Q must be"):
        MicrosqueezeStatic(**dict(kw, Q=-1.0))
    with pytest.raises(ValueError, match="eta must be"):
        MicrosqueezeStatic(**dict(kw, eta=-1e-8))
    with pytest.raises(ValueError, match="below mu_0\\(a=0\\)"):
        MicrosqueezeStatic(**dict(kw, mu_d=0.0001))
    with pytest.raises(ValueError, match="static limit"):
        MicrosqueezeStatic(**dict(kw, mu_d=0.6, h_e=2e-3))
    # traced values: eqx.error_if inside jit
    bad = jax.jit(lambda h: eqx.tree_at(lambda m: m.h_e, a, h)(1.0))
    with pytest.raises(Exception, match="h_e <= t_b \\+ a_d"):
        bad(0.5e-3).block_until_ready()


def test_default_stick_times():
    T = default_stick_times()
    assert float(T[0]) == pytest.approx(0.01) and float(T[-1]) == pytest.approx(1000.0)
