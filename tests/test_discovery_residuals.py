"""Residual analysis: the misspecification test is calibrated on white noise and sees
structure; phases; the sparse regression of the learned correction."""

import numpy as np

from stickslip_fitting.discovery.learned import FEATURES, feature_matrix, stlsq
from stickslip_fitting.discovery.residuals import (analyse_residuals, misspecification_test,
                                                   phase_labels)


def test_misspecification_test_is_calibrated_on_white_noise():
    rng = np.random.default_rng(1)
    p = np.array([misspecification_test([rng.normal(size=400) for _ in range(5)])["p_value"]
                  for _ in range(300)])
    # uniform under the null: 5 % level rejects about 5 % (binomial sd 1.3 %)
    assert 0.015 < np.mean(p < 0.05) < 0.09
    assert 0.4 < np.median(p) < 0.6


def test_misspecification_test_sees_a_small_smooth_misfit():
    rng = np.random.default_rng(2)
    t = np.linspace(0, 1, 1000)
    r = [rng.normal(size=1000) + 0.5 * np.sin(2 * np.pi * 5 * t) for _ in range(4)]
    assert misspecification_test(r)["p_value"] < 1e-6
    assert misspecification_test([x - np.sin(0) for x in r[:1]])["p_value"] < 0.05


def test_phase_labels():
    s = np.array([1] * 10 + [0] * 6 + [1] * 10, bool)
    lab = phase_labels(s, edge=2)
    assert lab[0] == 0 and lab[8] == 1 and lab[10] == 1 and lab[12] == 2
    assert lab[14] == 3 and lab[17] == 3 and lab[25] == 0


def test_residuals_by_phase_over_the_masked_samples():
    s = np.array([1] * 10 + [0] * 6 + [1] * 10, bool)
    mask = np.ones((2, 26), bool)
    mask[1, 20:] = False  # the second record is shorter
    sign = (-1.0) ** np.arange(26)
    rep = analyse_residuals([sign, 2.0 * sign[:20]], mask, np.stack([s, s]))
    assert sum(ph["n"] for ph in rep.phases.values()) == 46
    assert rep.phases["slip"]["n"] == 4  # samples 12, 13 of both records
    assert np.isclose(rep.phases["slip"]["rms"], np.sqrt(2.5))
    assert 0.0 <= rep.p_value <= 1.0 and rep.worst_phase() in rep.phases


def test_stlsq_names_the_true_terms():
    rng = np.random.default_rng(3)
    x = rng.uniform(0, 0.1, 2000)
    v = rng.normal(0, 3, 2000)
    t = rng.uniform(0, 1, 2000)
    kw = rng.choice([2.4, 3.2, 5.6], 2000)  # k/W of three records (1/mm)
    A = feature_matrix(x, v, t, 0.1, kw)
    y = 2.0 * x ** 3 / 0.1 ** 3 * 1e-3 + 1e-3 * t + rng.normal(0, 1e-6, 2000)
    coef, active = stlsq(A, y, threshold=0.1)
    named = {FEATURES[i] for i in range(1, len(FEATURES)) if active[i]}
    assert named == {"x^3", "t"}
    assert coef[FEATURES.index("x^3")] * 0.1 ** 3 == pytest_approx(2e-3, 0.05)
    # a hardening spring per unit weight, k beta x^3 / W, is the k x^3/W column
    y = 3.0 * kw * x ** 3 + rng.normal(0, 1e-7, 2000)
    coef, active = stlsq(A, y, threshold=0.1)
    assert {FEATURES[i] for i in range(1, len(FEATURES)) if active[i]} == {"k x^3/W"}
    assert coef[FEATURES.index("k x^3/W")] == pytest_approx(3.0, 0.02)


def pytest_approx(value, rel):
    import pytest

    return pytest.approx(value, rel=rel)
