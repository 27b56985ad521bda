"""Inverse design (stickslip_fitting.design.inverse): Newton through the steady analysis against a
brute-force grid, gradients against central finite differences, jit/vmap."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest

import stickslip_jax as ss
from stickslip_fitting.design import maximum_weight, minimum_stiffness
from stickslip_fitting.design.inverse import _design

FEED = 10.0 / 60  # mm/s


@pytest.fixture(scope="module")
def lub_a():
    return ss.lubricant("A")


@pytest.fixture(scope="module")
def k_grid():
    return np.linspace(20.0, 600.0, 5801)  # spacing 0.1 kgf/mm


@pytest.fixture(scope="module")
def w_grid():
    return np.linspace(1.0, 120.0, 11901)  # spacing 0.01 kgf


def _ok(r):
    assert r.result == optx.RESULTS.successful


@pytest.mark.parametrize("tol", [None, 0.005, 0.05])
def test_minimum_stiffness_matches_brute_force(lub_a, k_grid, tol):
    r = minimum_stiffness(lub_a, 36.0, FEED, tol)
    _ok(r)
    m = ss.steady_map(lub_a, 36.0, k_grid, FEED)
    ok = ~np.asarray(m.stick_slip)
    if tol is not None:
        ok |= np.asarray(m.amplitude) <= tol
    assert not ok[0] and ok[-1]
    k_brute = k_grid[np.argmax(ok)]  # first acceptable grid stiffness
    spacing = k_grid[1] - k_grid[0]
    assert k_brute - spacing <= float(r.value) <= k_brute
    assert ok[k_grid >= float(r.value) + 1e-9].all()  # the feasible set is k >= k_min
    if tol is None:
        np.testing.assert_allclose(r.critical_speed, FEED, rtol=1e-10)
    elif bool(r.limited_by_amplitude):
        np.testing.assert_allclose(r.amplitude, tol, rtol=1e-9)


@pytest.mark.parametrize("tol", [None, 0.05])
def test_maximum_weight_matches_brute_force(lub_a, w_grid, tol):
    r = maximum_weight(lub_a, 86.9, FEED, tol)
    _ok(r)
    m = ss.steady_map(lub_a, w_grid, 86.9, FEED)
    ok = ~np.asarray(m.stick_slip)
    if tol is not None:
        ok |= np.asarray(m.amplitude) <= tol
    assert ok[0] and not ok[-1]
    w_brute = w_grid[len(ok) - 1 - np.argmax(ok[::-1])]  # last acceptable grid weight
    spacing = w_grid[1] - w_grid[0]
    assert w_brute <= float(r.value) <= w_brute + spacing
    assert ok[w_grid <= float(r.value) - 1e-9].all()


def test_tight_tolerance_is_set_by_the_critical_speed(lub_a):
    # a tolerance below the amplitude at the stick-slip edge (v T0 / 2) cannot be met
    # inside the stick-slip region: the answer is the smooth-sliding stiffness
    plain = minimum_stiffness(lub_a, 36.0, FEED)
    tight = minimum_stiffness(lub_a, 36.0, FEED, 1e-6)
    assert not bool(tight.limited_by_amplitude)
    np.testing.assert_allclose(tight.value, plain.value, rtol=1e-12)
    # new float values of W, feed and tolerance reuse the compiled solver
    compiled = _design._cached
    before = compiled._cache_size()
    minimum_stiffness(lub_a, 40.0, 2 * FEED, 2e-6)
    minimum_stiffness(lub_a, 41.0, 3 * FEED)
    assert compiled._cache_size() == before


def test_gradients_match_finite_differences(lub_a):
    def k_min(mu_s, weight, tol):
        f = eqx.tree_at(lambda f: f.static.mu_s, lub_a, mu_s)
        return minimum_stiffness(f, weight, FEED, tol).value

    for tol in (0.02,):  # both Newton solves (v_c and amplitude) are on the path
        args = (jnp.asarray(0.56), jnp.asarray(36.0))
        grads = jax.grad(lambda a, b: k_min(a, b, tol), argnums=(0, 1))(*args)
        for i, g in enumerate(grads):
            h = 1e-6 * float(args[i])
            lo = list(args)
            hi = list(args)
            lo[i] = args[i] - h
            hi[i] = args[i] + h
            fd = (k_min(*hi, tol) - k_min(*lo, tol)) / (2 * h)
            np.testing.assert_allclose(g, fd, rtol=1e-5)


def test_vmap_over_feeds(lub_a):
    feeds = jnp.array([1.0, 10.0, 40.0]) / 60
    batched = jax.vmap(lambda v: minimum_stiffness(lub_a, 36.0, v).value)(feeds)
    single = [float(minimum_stiffness(lub_a, 36.0, v).value) for v in feeds]
    np.testing.assert_allclose(batched, single, rtol=1e-12)
    assert np.all(np.diff(np.asarray(batched)) < 0)  # faster feed -> softer drive suffices
