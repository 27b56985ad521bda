"""Friction laws (stickslip_jax.friction): eq (1), the Table 3 laws and eq (3)."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stickslip_jax as ss

TIMES = (0.0, 1e-3, 0.02, 0.5, 3.0, 60.0, 1e4)


def hand_kato(t, mu_s, mu_d, gamma, m):
    return mu_s - (mu_s - mu_d) * math.exp(-gamma * t**m)


def hand(law, lub, t):
    """Table 3 formulas, written out from the paper with math (independent of the package)."""
    if law == "kato":
        p = {"A": (0.56, 0.21, 0.38, 0.40), "C": (0.46, 0.20, 0.067, 0.45)}[lub]
        return hand_kato(t, *p)
    if law == "howe":
        mu_s, mu_d, c = {"A": (0.56, 0.21, 0.99), "C": (0.56, 0.20, 0.0058)}[lub]
        return mu_d + (mu_s - mu_d) * (1 - math.exp(-c * t))
    if law == "derjaguin":
        mu_d, c1, c2 = {"A": (0.21, 0.32, 2.0), "C": (0.20, 0.26, 200.0)}[lub]
        return mu_d + c1 * t / (c2 + t)
    if law == "power_law":
        mu_d, c1, c2 = {"A": (0.21, 0.11, 0.23), "C": (0.20, 0.021, 0.33)}[lub]
        return mu_d + c1 * t**c2
    mu_s, mu_d, c = {"A": (0.56, 0.21, 5.0), "C": (0.45, 0.20, 1.0)}[lub]
    return mu_s / ((mu_s / mu_d - 1) / math.sqrt(c * t + 1) + 1)


LAWS = ("kato", "howe", "derjaguin", "power_law", "okamura")


@pytest.mark.parametrize("lub", ("A", "C"))
@pytest.mark.parametrize("law", LAWS)
def test_static_laws_match_hand_formulas(law, lub):
    f = ss.static_law(law, lub)
    got = jax.vmap(f)(jnp.asarray(TIMES))  # vmap over stick time
    want = [hand(law, lub, t) for t in TIMES]
    np.testing.assert_allclose(np.asarray(got), want, rtol=1e-13, atol=1e-15)
    assert float(f(0.0)) == pytest.approx(float(f.mu_d), abs=1e-15)  # mu_0(0) = mu_d
    if law != "power_law":  # bounded laws approach their asymptote
        assert float(f.asymptote()) >= float(f(1e4)) - 1e-12


def test_kato_asymptote_and_monotone():
    f = ss.static_law("kato", "A")
    assert float(f.asymptote()) == 0.56
    t = jnp.logspace(-4, 6, 200)
    mu = np.asarray(f(t))
    assert np.all(np.diff(mu) >= 0) and np.all(np.diff(mu[:100]) > 0)
    assert mu[-1] == pytest.approx(0.56, abs=1e-6)


@pytest.mark.parametrize("law", LAWS)
def test_static_gradients_finite_at_zero_stick_time(law):
    """jit(grad) wrt every parameter and T1, at T1 = 0 and nearby: no NaN or inf."""
    f = ss.static_law(law, "A")
    params, rest = eqx.partition(f, eqx.is_inexact_array)

    @jax.jit
    def grads(params, t):
        return jax.grad(lambda p, t: eqx.combine(p, rest)(t), argnums=(0, 1))(params, t)

    for t in (0.0, 1e-300, 1e-12, 1.0):
        gp, gt = grads(params, jnp.asarray(t))
        leaves = jax.tree_util.tree_leaves(gp) + [gt]
        assert len(leaves) == len(jax.tree_util.tree_leaves(params)) + 1
        assert all(bool(jnp.isfinite(x)) for x in leaves), (law, t, leaves)
    # value and gradient also fine under vmap(grad) over T1 including 0
    gt = jax.vmap(jax.grad(lambda t: f(t)))(jnp.asarray([0.0, 0.5, 2.0]))
    assert bool(jnp.all(jnp.isfinite(gt)))
    assert np.all(np.asarray(gt[1:]) > 0)  # mu_0 rises with T1


def test_kato_gradient_matches_analytic():
    mu_s, mu_d, gamma, m, t = 0.56, 0.21, 0.38, 0.40, 2.5
    f = ss.KatoStatic(mu_s, mu_d, gamma, m)
    g = jax.grad(lambda f: f(t))(f)
    e = math.exp(-gamma * t**m)
    assert float(g.mu_s) == pytest.approx(1 - e, rel=1e-13)
    assert float(g.mu_d) == pytest.approx(e, rel=1e-13)
    assert float(g.gamma) == pytest.approx((mu_s - mu_d) * e * t**m, rel=1e-13)
    assert float(g.m) == pytest.approx((mu_s - mu_d) * e * gamma * t**m * math.log(t), rel=1e-13)


def test_kinetic_law_eq3():
    kin = ss.KatoKinetic(delta=67.0, n=1.0)
    for mu_0, t2 in ((0.4, 0.02), (0.3, 0.05), (0.21, 0.03)):
        want = 0.21 + (mu_0 - 0.21) * math.exp(-67.0 * t2)
        assert float(kin(mu_0, 0.21, t2)) == pytest.approx(want, rel=1e-14)
    assert float(kin(0.4, 0.21, 0.0)) == pytest.approx(0.4)  # no slip, no decay
    assert float(kin(0.4, 0.21, 1e3)) == pytest.approx(0.21)  # mu_m -> mu_d as T2 -> inf
    kin_c = ss.KatoKinetic(delta=43.0, n=0.7)
    g = jax.grad(lambda k, t: k(0.4, 0.2, t), argnums=(0, 1))(kin_c, 0.0)
    assert all(bool(jnp.isfinite(x)) for x in jax.tree_util.tree_leaves(g))


def test_friction_eq4_and_drop():
    fr = ss.lubricant("A")
    t1, t2 = 3.0, 0.02
    mu_0 = hand_kato(t1, 0.56, 0.21, 0.38, 0.40)
    # eq (4) with the exponent m on T1 (NOTES.md item 1)
    mu_m = 0.21 + 0.35 * (1 - math.exp(-0.38 * t1**0.40)) * math.exp(-67 * t2)
    assert float(fr.mean_kinetic(t1, t2)) == pytest.approx(mu_m, rel=1e-14)
    assert float(fr.drop(t1, t2)) == pytest.approx(mu_0 - mu_m, rel=1e-12)
    assert float(fr.mu_d) == 0.21
    drops = jax.jit(jax.vmap(fr.drop, in_axes=(0, None)))(jnp.asarray([0.0, 1.0, 10.0]), t2)
    assert float(drops[0]) == 0.0 and np.all(np.diff(np.asarray(drops)) > 0)


def test_positional_order_is_the_papers():
    # mu_s first, as in eq (1) and Table 3 (the inherited mu_d must not take first place)
    f = ss.KatoStatic(0.56, 0.21, 0.38, 0.40)
    assert (float(f.mu_s), float(f.mu_d), float(f.gamma), float(f.m)) == (0.56, 0.21, 0.38, 0.40)
    h = ss.HoweStatic(0.56, 0.21, 0.99)
    assert (float(h.mu_s), float(h.mu_d), float(h.C)) == (0.56, 0.21, 0.99)
    o = ss.OkamuraStatic(0.45, 0.20, 1.0)
    assert (float(o.mu_s), float(o.mu_d), float(o.C)) == (0.45, 0.20, 1.0)
    d = ss.DerjaguinStatic(0.21, 0.32, 2.0)
    assert (float(d.mu_d), float(d.C1), float(d.C2)) == (0.21, 0.32, 2.0)
    assert ss.KatoStatic(mu_d=0.21, mu_s=0.56, gamma=0.38, m=0.4).mu_s == 0.56


def test_friction_structure_checked_at_construction():
    with pytest.raises(ValueError, match="static"):
        ss.Friction(static=ss.KatoKinetic(1.0, 1.0), kinetic=ss.KatoKinetic(1.0, 1.0))
    with pytest.raises(ValueError, match="kinetic"):
        ss.Friction(static=ss.static_law("kato"), kinetic=ss.static_law("kato"))
    with pytest.raises(TypeError):
        ss.AbstractStaticFriction()  # abstract


def test_friction_vmaps_over_parameters():
    fr = ss.lubricant("A")
    gammas = jnp.asarray([0.1, 0.38, 1.0])
    batch = jax.vmap(lambda g: eqx.tree_at(lambda f: f.static.gamma, fr, g))(gammas)
    out = eqx.filter_vmap(lambda f: f.static(2.0))(batch)
    want = [hand_kato(2.0, 0.56, 0.21, g, 0.40) for g in (0.1, 0.38, 1.0)]
    np.testing.assert_allclose(np.asarray(out), want, rtol=1e-14)
