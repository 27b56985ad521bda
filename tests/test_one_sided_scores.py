"""One-sided score tests of effects with a physical sign (fitting/discovery/flips.py,
decision.py): the Gauss-Newton step has the sign of the parameter change that lowers
chi-square, a one-coordinate test of a signed effect has half the two-sided p-value where
its score points to the physical side, and the family-wise level of the sign flips stays
alpha with one-sided tests among the others."""

import numpy as np
import pytest

from stickslip_fitting.discovery.decision import hotelling, window_scores
from stickslip_fitting.discovery.flips import family_wise_p, one_sided


def _linear(rng, size, n=400, windows=40):
    """Residuals r = data - model of a linear model at z = 0 whose data hold the
    coordinate `size`: J = dr/dz = -a (the residuals' derivative, as the per-cycle
    model's), and the window starts."""
    a = rng.normal(size=(n, 1)) + 1.0
    r = (a[:, 0] * size + rng.normal(size=n))
    return -a, r, np.arange(0, n, n // windows)


def test_the_gauss_newton_step_moves_the_coordinate_towards_the_data():
    rng = np.random.default_rng(0)
    for size in (0.5, -0.5):
        J, r, starts = _linear(rng, size)
        _, p, _, step, predicted = hotelling(J, r, starts)
        assert step[0] == pytest.approx(size, abs=0.15) and predicted > 0
        # the step's chi-square drop is the predicted one
        assert np.sum(r ** 2) - np.sum((r + J[:, 0] * step[0]) ** 2) == pytest.approx(
            predicted, rel=1e-9)


def test_a_signed_effect_is_tested_one_sided():
    rng = np.random.default_rng(1)
    J, r, starts = _linear(rng, 0.1)
    two = hotelling(J, r, starts)[1]
    up = hotelling(J, r, starts, side=1)[1]
    down = hotelling(J, r, starts, side=-1)[1]
    assert up == pytest.approx(two / 2) and down == pytest.approx(1 - two / 2)
    # two columns: no side
    J2 = np.hstack([J, rng.normal(size=J.shape)])
    assert hotelling(J2, r, starts, side=1)[1] == hotelling(J2, r, starts)[1]
    assert one_sided(0.3, 2.0, 0) == 0.3


def test_one_sided_flips_keep_the_family_wise_level():
    """Null windows, four one-sided one-column tests among two-column ones: the
    family-wise false-alarm rate stays alpha, and a one-sided test on the physical side
    has about half its two-sided family-wise p-value alone."""
    rng = np.random.default_rng(5)
    alpha, trials, alarms = 0.1, 200, 0
    for i in range(trials):
        E = rng.standard_t(5, size=(40, 4))
        tests = [E[:, :1] + 0.3 * rng.normal(size=(40, 1)) for _ in range(4)]
        tests += [E[:, 2:] @ rng.normal(size=(2, 2)) for _ in range(2)]
        adj = family_wise_p(tests, sides=[1, -1, 1, 1, 1, 1], flips=800, seed=i)
        alarms += adj.min() < alpha
    # binomial sd at 200 trials: 0.021
    assert 0.04 <= alarms / trials <= 0.17, alarms / trials
    J, r, starts = _linear(np.random.default_rng(2), 0.12)
    g = window_scores(J, r, starts)
    two = family_wise_p([g], flips=4000)[0]
    one = family_wise_p([g], sides=[1], flips=4000)[0]
    assert one == pytest.approx(two / 2, abs=0.02)
    assert family_wise_p([g], sides=[-1], flips=4000)[0] > 0.5
