"""Boundary lubrication: eqs 13-15 and 33-35, t_b of Table 11."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stickslip_jax.contact import (
    BoundaryContact,
    approach_for,
    film_from_mu_s,
    final_approach,
    load_shares,
    static_coefficient,
    static_limit,
    surface_pair,
    symmetric_pair,
)
from stickslip_jax.tables import load_table

PAIR = surface_pair("S1G1")
CONTACT = BoundaryContact()


@pytest.mark.parametrize("row", load_table(11).rows, ids=lambda r: r.lubricant)
def test_film_thickness_of_table11(row):
    est = film_from_mu_s(PAIR, CONTACT, row.mu_s)
    assert float(est.t_b) == pytest.approx(row.t_b, rel=0.02)
    # h_e ~ a_s + t_b (section 7.3): within 5 % of the printed h_e
    assert float(est.a_s + est.t_b) == pytest.approx(row.h_e, rel=0.05)
    # round trip: mu_0(a_s) = mu_s and W_s(a_s) = 0
    assert float(static_coefficient(PAIR, CONTACT, est.a_s, est.t_b)) == pytest.approx(row.mu_s, rel=1e-10)
    assert float(load_shares(PAIR, CONTACT, est.a_s, est.t_b)[2]) == pytest.approx(0.0, abs=1e-9)
    assert float(final_approach(PAIR, CONTACT, est.t_b)) == pytest.approx(float(est.a_s), rel=1e-10)


def test_film_of_lubricant_A_is_close_to_paper():
    assert float(film_from_mu_s(PAIR, CONTACT, 0.450).t_b) == pytest.approx(0.2127e-3, rel=1e-3)


def test_load_shares_sum_and_friction():
    t_b = 0.2e-3
    a = jnp.linspace(0.0, 0.6e-3, 7)
    W_m, W_b, W_s = load_shares(PAIR, CONTACT, a, t_b)
    np.testing.assert_allclose(W_m + W_b + W_s, 12.4, rtol=1e-12)
    mu = static_coefficient(PAIR, CONTACT, a, t_b)
    np.testing.assert_allclose(mu, (1.0 * W_m + 0.075 * W_b) / 12.4, rtol=1e-12)  # eq 15
    assert np.all(np.diff(np.asarray(mu)) > 0)


def test_changed_constants_are_used():
    soft = BoundaryContact(p_m=100.0, C3=0.1)
    t1 = film_from_mu_s(PAIR, CONTACT, 0.45).t_b
    t2 = film_from_mu_s(PAIR, soft, 0.45).t_b
    assert float(t1) != pytest.approx(float(t2), rel=1e-3)
    a = approach_for(PAIR, soft, 0.2, 0.2e-3)
    assert float(static_coefficient(PAIR, soft, a, 0.2e-3)) == pytest.approx(0.2, rel=1e-12)


def test_general_C2_root():
    c = BoundaryContact(C2=0.6)
    a_s = final_approach(PAIR, c, 0.2e-3)
    assert float(load_shares(PAIR, c, a_s, 0.2e-3)[2]) == pytest.approx(0.0, abs=1e-10)


def test_gradient_of_film_thickness_matches_finite_difference():
    f = jax.jit(lambda mu: film_from_mu_s(PAIR, CONTACT, mu).t_b)
    g = jax.grad(lambda mu: film_from_mu_s(PAIR, CONTACT, mu).t_b)(0.45)
    h = 1e-6
    fd = (f(0.45 + h) - f(0.45 - h)) / (2 * h)
    assert float(g) == pytest.approx(float(fd), rel=1e-6)
    ga = jax.grad(lambda t: final_approach(PAIR, CONTACT, t))(0.2e-3)
    fda = (final_approach(PAIR, CONTACT, 0.2e-3 + 1e-9) - final_approach(PAIR, CONTACT, 0.2e-3 - 1e-9)) / 2e-9
    assert float(ga) == pytest.approx(float(fda), rel=1e-6)


def test_figs_85_to_88_trends():
    """mu_s rises with H_max and falls with R, D, z (t_b = 0.2 um, section 7.4)."""
    base = dict(H_max=20e-3, R=20e-3, z=25.0, D=1.5)

    def mu_s(**kw):
        p = dict(base, **kw)
        return float(static_limit(symmetric_pair(**p), CONTACT, 0.2e-3))

    assert mu_s(H_max=15e-3) < mu_s(H_max=20e-3) < mu_s(H_max=30e-3)
    assert mu_s(R=10e-3) > mu_s(R=20e-3) > mu_s(R=40e-3)
    assert mu_s(D=1.0) > mu_s(D=1.5) > mu_s(D=2.0)
    assert mu_s(z=15.0) > mu_s(z=25.0) > mu_s(z=35.0)


def test_bad_inputs():
    with pytest.raises(ValueError, match="mu_s must lie between"):
        film_from_mu_s(PAIR, CONTACT, 0.05)
    with pytest.raises(ValueError, match="C2\\*C3"):
        BoundaryContact(C1=0.05)
    with pytest.raises(ValueError, match="p_m"):
        BoundaryContact(p_m=-1.0)
    with pytest.raises(Exception, match="outside"):
        jax.jit(lambda m: film_from_mu_s(PAIR, CONTACT, m).t_b)(1.5).block_until_ready()
