"""Design maps (stickslip_fitting.design.maps, chunks, uncertainty, posterior): values against the
single-point steady analysis, chunking, compile counts, posterior propagation, sample files."""

import json

import equinox as eqx
import jax
import numpy as np

from stickslip_jax.steady import RESTICK_FAILURE
import pytest

import stickslip_jax as ss
from stickslip_fitting.design import (
    PARAMETERS,
    design_map,
    friction_from_params,
    friction_params,
    iter_design_map,
    load_samples,
    outer,
    propagate,
    save_samples,
)
from stickslip_fitting.design.chunks import _jitted
from stickslip_fitting.design.maps import steady_kernel
from stickslip_fitting.modes import MapMethod

FIELDS = ("amplitude", "amplitude_ratio", "frequency", "frequency_ratio", "stick_time",
          "slip_time", "natural_frequency", "critical_speed")


@pytest.fixture(scope="module")
def lub_a():
    return ss.lubricant("A")


@pytest.fixture(scope="module")
def grid():
    # W x k x v with speeds on both sides of v_c (mm/s)
    return outer(np.array([11.3, 36.0, 53.2]), np.array([27.3, 86.9, 128.5]),
                 np.geomspace(0.0022, 92.0, 7) / 60.0)


@pytest.fixture(scope="module")
def sample():
    rng = np.random.default_rng(3)
    p = friction_params(ss.lubricant("A"))
    return friction_from_params({k: v * np.exp(0.08 * rng.standard_normal(40)) for k, v in p.items()})


def test_map_equals_single_point_steady_state(lub_a, grid):
    w, k, v = grid
    m = design_map(lub_a, w, k, v, chunk_size=16)
    assert m.amplitude.shape == (3, 3, 7)
    assert m.converged.all()
    assert 0 < m.stick_slip.mean() < 1  # both regimes are in the grid
    rng = np.random.default_rng(0)
    for idx in [(0, 0, 0), (2, 2, 6), (1, 1, 5)] + [tuple(rng.integers(0, s) for s in (3, 3, 7))
                                                   for _ in range(5)]:
        s = ss.steady_state(lub_a, w[idx[0], 0, 0], k[0, idx[1], 0], v[0, 0, idx[2]])
        for f in FIELDS:
            np.testing.assert_allclose(getattr(m, f)[idx], getattr(s, f), rtol=1e-10, atol=1e-14)
        assert m.stick_slip[idx] == bool(s.stick_slip)


def test_map_over_friction_parameters(grid, sample):
    w, k, _ = grid
    f = jax.tree_util.tree_map(lambda x: x[:, None, None], sample)  # (S, 1, 1) x W x k
    m = design_map(f, w[..., 0], k[..., 0], 1.0 / 60, chunk_size=16)
    assert m.amplitude.shape == (40, 3, 3)
    for s_i, i, j in [(0, 0, 0), (17, 2, 1), (39, 1, 2)]:
        fi = jax.tree_util.tree_map(lambda x: x[s_i], sample)
        s = ss.steady_state(fi, w[i, 0, 0], k[0, j, 0], 1.0 / 60)
        np.testing.assert_allclose(m.amplitude[s_i, i, j], s.amplitude, rtol=1e-10)
        np.testing.assert_allclose(m.critical_speed[s_i, i, j], s.critical_speed, rtol=1e-10)


def test_chunking_streams_and_compiles_once(lub_a, grid):
    w, k, v = grid
    whole = design_map(lub_a, w, k, v, chunk_size=16)
    compiled = _jitted(steady_kernel)._cached
    before = compiled._cache_size()
    chunks = list(iter_design_map(lub_a, w, k, v, chunk_size=16))
    assert [c[0] for c in chunks] == [0, 16, 32, 48] and chunks[-1][1] == 63
    flat = np.concatenate([c[2].amplitude for c in chunks])
    np.testing.assert_array_equal(flat, whole.amplitude.ravel())
    # new values, same chunk size: no new compilation (the last chunk is padded)
    design_map(lub_a, w * 1.1, k, v * 0.5, chunk_size=16)
    assert compiled._cache_size() == before


def test_bad_inputs(lub_a):
    with pytest.raises(ValueError, match="weight W"):
        design_map(lub_a, -1.0, 86.9, 0.01)
    with pytest.raises(ValueError, match="broadcast"):
        design_map(lub_a, np.ones(3) * 36, np.ones(4) * 86.9, 0.01)
    with pytest.raises(ValueError, match="method must be one of"):
        design_map(lub_a, 36.0, 86.9, 0.01, method="magic")
    with pytest.raises(TypeError, match="method: a member of MapMethod"):
        next(iter_design_map(lub_a, 36.0, 86.9, 0.01, method="exact"))
    with pytest.raises(ValueError, match="Friction"):
        design_map({"mu_s": 0.5}, 36.0, 86.9, 0.01)


def test_exact_map_matches_steady_limit_cycle(lub_a):
    # NOTES.md: the steady amplitude equals the limit cycle of the time-domain model
    # where the slider can restick (delta T2^n > ln 2, see below).
    w, k, v = outer(np.array([11.3, 36.0, 53.2]), np.array([27.3, 86.9, 128.5]),
                    np.array([0.01, 1.0]) / 60)
    st = design_map(lub_a, w, k, v, chunk_size=16)
    ex = design_map(lub_a, w, k, v, method=MapMethod.EXACT, chunk_size=18)
    assert st.stick_slip.all()
    # A slip from rest ends at x1 = 2 mu_m W/k - x2; the slider resticks only if
    # k x1 < mu_d W, i.e. exp(-delta T2^n) < 1/2. Otherwise it slips again at once and
    # then sticks (re-stick failure, double slips: W = 11.3, k = 128.5 for lubricant A):
    # still stick-slip, flagged by its regime, with another cycle than eq (6)'s.
    p = friction_params(lub_a)
    restick = np.exp(-p["delta"] * st.slip_time ** p["n"]) < 0.5
    assert not restick.all()
    assert ex.stick_slip.all()
    assert ex.converged.all()  # re-slip cycles too: 8 whole cycles each (4 events a cycle)
    np.testing.assert_array_equal(np.asarray(ex.regime) == RESTICK_FAILURE, ~restick)
    np.testing.assert_allclose(ex.amplitude[restick], st.amplitude[restick], rtol=1e-5)
    np.testing.assert_allclose(ex.stick_time[restick], st.stick_time[restick], rtol=1e-5)
    np.testing.assert_allclose(ex.frequency[restick], st.frequency[restick], rtol=0.05)


def test_propagate_against_brute_force(sample):
    w, k = outer(np.array([20.0, 45.0]), np.array([40.0, 120.0]))
    v = 30.0 / 60
    u = propagate(sample, w, k, v, level=0.8, chunk_size=50)
    assert u.probability.shape == (2, 2) and u.critical_speed.shape == (2, 2, 3)
    for i in range(2):
        for j in range(2):
            out = jax.vmap(ss.steady_state, in_axes=(0, None, None, None))(
                sample, w[i, 0], k[0, j], v)
            np.testing.assert_allclose(u.probability[i, j], np.mean(out.stick_slip), atol=1e-15)
            q = np.quantile(np.asarray(out.critical_speed), [0.1, 0.5, 0.9])
            np.testing.assert_allclose(u.critical_speed[i, j], q, rtol=1e-10)
            np.testing.assert_allclose(u.amplitude_mean[i, j], np.mean(out.amplitude), rtol=1e-10)
    assert 0 < u.probability.min() < u.probability.max() <= 1  # the map crosses the boundary


def test_propagate_point_mass_is_deterministic(lub_a):
    p = friction_params(lub_a)
    point = friction_from_params({k: np.full(40, v) for k, v in p.items()})
    w = np.array([11.3, 36.0, 53.2])
    u = propagate(point, w, 86.9, 20.0 / 60, chunk_size=50)
    m = design_map(lub_a, w, 86.9, 20.0 / 60, chunk_size=16)
    np.testing.assert_array_equal(u.probability, m.stick_slip.astype(float))
    for c in range(3):
        np.testing.assert_allclose(u.critical_speed[:, c], m.critical_speed, rtol=1e-12)


def test_sample_files_round_trip(tmp_path, sample):
    csv_path = tmp_path / "s.csv"
    save_samples(sample, csv_path)
    back = load_samples(csv_path)
    assert eqx.tree_equal(jax.tree_util.tree_map(np.asarray, back),
                          jax.tree_util.tree_map(np.asarray, sample))
    p = friction_params(sample)
    layouts = [
        {"samples": {k: v.tolist() for k, v in p.items()}},
        {"samples": [{k: float(v[i]) for k, v in p.items()} for i in range(40)]},
        {"parameters": list(PARAMETERS),
         "samples": np.column_stack([p[k] for k in PARAMETERS]).tolist()},
        {"posterior": {k: v.tolist() for k, v in p.items()}, "note": "extra keys ignored"},
        # stickslip_fitting.uncertainty.mcmc layout: a matrix of the sampled parameters, the rest held fixed
        {"names": ["mu_s", "mu_d", "gamma", "m"],
         "samples": np.column_stack([p[k] for k in ("mu_s", "mu_d", "gamma", "m")]).tolist(),
         "fixed": {"delta": 67.0, "n": 1.0}},
    ]
    for i, obj in enumerate(layouts):
        path = tmp_path / f"s{i}.json"
        path.write_text(json.dumps(obj))
        got = friction_params(load_samples(path))
        for k in PARAMETERS:
            expect = np.full(40, {"delta": 67.0, "n": 1.0}[k]) if "fixed" in obj and k in (
                "delta", "n") else p[k]
            np.testing.assert_array_equal(got[k], expect)
    bad = tmp_path / "bad.csv"
    bad.write_text("mu_s,mu_d\n0.5,0.2\n")
    with pytest.raises(ValueError, match="lacks"):
        load_samples(bad)
