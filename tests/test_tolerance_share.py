"""The share of posterior draws that meet a tolerance (`stickslip_fitting.design.tolerance`)
is a count over the draws, reported exactly (float64): 19 of 20 draws is 0.95, not the
float32 0.94999999 that reads as missing a 0.95 target (the slow tolerance design
test)."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import stickslip_jax as ss
from stickslip_fitting.design.tolerance import meet_probability, required_stiffness


def _sample(n=20):
    base = ss.lubricant("A")
    scale = jnp.linspace(0.9, 1.1, n)
    # every leaf a vector of n draws; mu_s spread so that the amplitudes differ
    leaves, tree = jax.tree_util.tree_flatten(base)
    draws = [jnp.full(n, float(x)) for x in leaves]
    sample = jax.tree_util.tree_unflatten(tree, draws)
    return eqx.tree_at(lambda f: f.static.mu_s, sample, float(base.static.mu_s) * scale)


def test_shares_are_exact_fractions_of_the_draws():
    sample = _sample(20)
    k = np.linspace(50.0, 400.0, 15)
    p = meet_probability(sample, 36.0, k, 5.0 / 60.0, 0.01)
    assert p.dtype == np.float64
    counts = p * 20
    np.testing.assert_array_equal(counts, np.round(counts))
    assert np.any((p > 0) & (p < 1))  # the grid crosses the tolerance
    d = required_stiffness(sample, 36.0, 5.0 / 60.0, 0.01, meet=0.95)
    assert d.probability * 20 == round(d.probability * 20)
    assert d.probability >= 0.95
