"""Family-wise p-values by sign flips (fitting/discovery/flips.py): the observed
marginal p-value is Hotelling's (computed here from its textbook formula), the
family-wise false-alarm rate is alpha on null data with correlated tests, and
correlated tests cost less power than Bonferroni charges."""

import numpy as np
import pytest
import scipy.stats

from stickslip_fitting.discovery.flips import family_wise_p, flip_p, hotelling_p_of_u


def hotelling_p(g):
    """Textbook one-sample Hotelling T^2 test that the rows of g have mean zero."""
    n, p = g.shape
    gbar = g.mean(axis=0)
    t2 = n * gbar @ np.linalg.solve(np.cov(g.T).reshape(p, p), gbar)
    return scipy.stats.f.sf((n - p) / (p * (n - 1)) * t2, p, n - p)


def test_the_self_normalised_statistic_gives_hotellings_p():
    rng = np.random.default_rng(1)
    for p in (1, 2, 5):
        g = rng.normal(size=(40, p)) + 0.2
        Q = np.linalg.qr(g)[0]
        u = np.sum(Q.sum(axis=0) ** 2)
        assert hotelling_p_of_u(u, 40, p) == pytest.approx(hotelling_p(g), rel=1e-8)


def null_tests(rng, n=50, K=12):
    """K correlated tests on n windows: each test sees two of six shared window
    effects, mixed, with mean zero (the base model is right)."""
    E = rng.standard_t(5, size=(n, 6))
    out = []
    for k in range(K):
        A = rng.normal(size=(6, 2)) * (np.arange(6)[:, None] // 2 == k % 3)
        out.append(E @ A + 0.3 * rng.normal(size=(n, 2)))
    return out


def test_the_family_wise_false_alarm_rate_is_alpha_on_null_data():
    rng = np.random.default_rng(7)
    alpha, trials = 0.1, 300
    fw = bonf = 0
    for i in range(trials):
        tests = null_tests(rng)
        adj = family_wise_p(tests, flips=1000, seed=i)
        fw += adj.min() < alpha
        bonf += min(hotelling_p(g) for g in tests) < alpha / len(tests)
    # binomial sd at 300 trials: 0.017
    assert 0.05 <= fw / trials <= 0.16, fw / trials
    assert bonf <= fw  # Bonferroni is the more conservative of the two


def test_duplicated_tests_cost_no_power():
    rng = np.random.default_rng(3)
    g = rng.normal(size=(60, 2)) + np.array([0.35, 0.0])
    one = family_wise_p([g], flips=2000)
    many = family_wise_p([g] * 10, flips=2000)
    assert np.all(many == one[0])
    # and the single test's flip p agrees with its F p-value
    assert one[0] == pytest.approx(hotelling_p(g), abs=0.025)


def test_an_untestable_test_takes_no_part():
    rng = np.random.default_rng(4)
    g = rng.normal(size=(30, 2))
    bad = np.full((30, 3), np.nan)
    few = np.zeros((30, 4))
    few[:3] = rng.normal(size=(3, 4))  # 3 windows for (rank) 3 columns
    adj = family_wise_p([g, bad, few], flips=500)
    assert np.isfinite(adj[0]) and np.isnan(adj[1]) and np.isnan(adj[2])
    assert adj[0] == family_wise_p([g], flips=500)[0]


def test_tests_on_different_windows_are_refused():
    with pytest.raises(ValueError, match="same windows"):
        family_wise_p([np.ones((10, 1)), np.ones((11, 1))])


def turning_windows(rng, amp, G=8, W=4):
    """A per-record effect of two columns (a screw's first harmonic) over W windows of
    each of G records: every window sees another phase of it, so its score turns from
    window to window; returns the window contributions and the columns' Gram matrix."""
    g, info = np.zeros((G * W, 2 * G)), np.zeros((2 * G, 2 * G))
    for rec in range(G):
        theta = amp * np.array([np.cos(rec), np.sin(rec)])
        for w in range(W):
            phase = rng.uniform(0, 2 * np.pi) + np.linspace(0, 0.6, int(rng.integers(5, 200)))
            J = np.stack([np.sin(phase), np.cos(phase)], axis=1)
            r = -J @ theta + rng.normal(size=phase.size)
            g[rec * W + w, 2 * rec:2 * rec + 2] = J.T @ r
            info[2 * rec:2 * rec + 2, 2 * rec:2 * rec + 2] += J.T @ J
    return g, info


def test_the_information_weighed_test_keeps_the_false_alarm_rate():
    rng = np.random.default_rng(11)
    alpha, trials = 0.1, 300
    alarms = 0
    for i in range(trials):
        g, info = turning_windows(rng, 0.0)
        other = rng.normal(size=(g.shape[0], 1))
        alarms += family_wise_p([g, other], metrics=[info, None], flips=500, seed=i).min() < alpha
    assert 0.05 <= alarms / trials <= 0.16, alarms / trials  # binomial sd 0.017


def test_the_information_weighed_test_finds_a_turning_per_record_effect():
    """Hotelling's test estimates the windows' covariance of 16 columns from 32 windows and
    weighs the score by it; weighed by the information the same flips find the effect
    far more often."""
    rng = np.random.default_rng(5)
    hot, informed = [], []
    for i in range(40):
        g, info = turning_windows(rng, 0.2)
        hot.append(family_wise_p([g], flips=500, seed=i)[0])
        informed.append(family_wise_p([g], metrics=[info], flips=500, seed=i)[0])
    assert np.mean(np.array(informed) < 0.01) >= 0.7
    assert np.mean(np.array(hot) < 0.01) <= 0.4


def test_a_flip_p_value_is_its_rank_among_the_flips():
    values = np.array([3.0, 1.0, 2.0, 2.0])
    p_obs, p_flips = flip_p(values, 2.0)
    assert p_obs == pytest.approx(4 / 5)  # 3, 2, 2 at least as large, and itself
    assert p_flips == pytest.approx([2 / 5, 5 / 5, 4 / 5, 4 / 5])
