"""The chance of a row's chi2 for correlated residuals (`stickslip_fitting.uncertainty.
adequacy.effective_samples`): a correct model's p-values are uniform whether the noise is
white or strongly correlated, where the independent-sample chi2 rejects far too often;
a wrong model still gets small p-values. A cheap model: a straight line fitted by least
squares through four stretches of 2,000 samples, the residuals in units of the noise sd."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter
from scipy.stats import binom, chi2

from stickslip_fitting.uncertainty.adequacy import (BAD, GOOD, LEVEL, PhaseRow,
                                                   effective_samples, series_row)

DRAWS, STRETCHES, SAMPLES = 1000, 4, 2000
ALPHA = 0.05


def _noise(rng, phi: float, draws: int) -> np.ndarray:
    """AR(1) noise of lag-1 correlation `phi` and unit variance [draws, STRETCHES, SAMPLES]."""
    burn = 400  # forgets the filter's zero start (0.9**400 ~ 5e-19)
    w = rng.standard_normal((draws, STRETCHES, SAMPLES + burn))
    return lfilter([np.sqrt(1.0 - phi ** 2)], [1.0, -phi], w, axis=-1)[..., burn:]


def _line_residuals(y: np.ndarray) -> np.ndarray:
    """Residuals of one line a + b s (s the time in a stretch, 0 ... 1) fitted by least
    squares to all of a draw's stretches [draws, STRETCHES, SAMPLES]."""
    s = np.tile(np.linspace(0.0, 1.0, SAMPLES), STRETCHES)
    A = np.stack([np.ones_like(s), s], axis=1)
    flat = y.reshape(y.shape[0], -1)
    beta = np.linalg.lstsq(A, flat.T, rcond=None)[0]
    return (flat - (A @ beta).T).reshape(y.shape)


def _p_values(residuals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Independent-sample chi2 p-values and the rows' own, one per draw."""
    keep = np.ones(residuals.shape[1:], bool)
    rows = [series_row("r", "trace_stick", x, keep) for x in residuals]
    naive = np.array([chi2.sf(r.chi2_per_n * r.n, r.n) for r in rows])
    return naive, np.array([r.p_value() for r in rows])


def _interval(draws: int) -> tuple[float, float]:
    """99.9 % binomial interval of the rejection rate at `ALPHA` over `draws` draws."""
    lo, hi = binom.interval(0.999, draws, ALPHA)
    return lo / draws, hi / draws


def test_white_noise_p_values_are_uniform():
    """White noise, a correct model: p < 0.05 in about 5 % of draws (4.0 %), as the
    independent chi2 (4.0 %; the correlations measured are chance: n_effective stays
    near n)."""
    rng = np.random.default_rng(11)
    x = _line_residuals(0.3 + _noise(rng, 0.0, DRAWS))
    naive, ours = _p_values(x)
    lo, hi = _interval(DRAWS)
    assert lo <= np.mean(ours < ALPHA) <= hi, np.mean(ours < ALPHA)
    assert lo <= np.mean(naive < ALPHA) <= hi
    # uniform beyond the one level: every decile holds about a tenth of the draws
    counts = np.histogram(ours, bins=10, range=(0.0, 1.0))[0]
    assert counts.min() > 0.07 * DRAWS and counts.max() < 0.13 * DRAWS, counts
    n_eff = effective_samples(x[0], np.ones(x.shape[1:], bool))[0]
    assert 0.9 * x[0].size <= n_eff <= x[0].size


def test_ar1_noise_p_values_stay_uniform_where_independent_ones_do_not():
    """AR(1) noise of lag-1 correlation 0.9, a correct model: the independent chi2 rejects
    in about a quarter of the draws (23 %), the rows' p-value in about 5 % (3.3 %). The effective samples are
    near n / (1 + 2 phi^2 / (1 - phi^2)) = n / 9.5."""
    rng = np.random.default_rng(12)
    phi = 0.9
    x = _line_residuals(0.3 + _noise(rng, phi, DRAWS))
    naive, ours = _p_values(x)
    lo, hi = _interval(DRAWS)
    assert lo <= np.mean(ours < ALPHA) <= hi, np.mean(ours < ALPHA)
    assert np.mean(naive < ALPHA) > 0.2, np.mean(naive < ALPHA)
    c = 1.0 + 2.0 * phi ** 2 / (1.0 - phi ** 2)
    n_eff = np.median([effective_samples(d, np.ones(d.shape, bool))[0] for d in x[:50]])
    assert n_eff == pytest.approx(x[0].size / c, rel=0.15)
    row = series_row("r", "trace_stick", x[0], np.ones(x.shape[1:], bool))
    assert row.lag_correlation[0] == pytest.approx(phi, abs=0.03)
    assert row.to_json()["n_effective"] == row.n_effective


def test_wrong_model_still_gets_small_p_values():
    """Data with a slow bend the line cannot follow, white or AR(1) noise: the p-values
    stay far below the adequacy level once chi2/n is past `GOOD` (amplitude 2 noise sd,
    chi2/n near 3) and `BAD` (3.2 sd, near 6). The bend is as correlated as the noise can
    be, so it enters the measured correlation (n_effective falls to about 5 per stretch):
    such a misfit is judged first by its chi2/n, the p-value saying it is not chance."""
    rng = np.random.default_rng(13)
    s = np.sin(2 * np.pi * 3 * np.linspace(0.0, 1.0, SAMPLES))
    for amp, chi2_per_n in ((2.0, GOOD), (3.2, BAD)):
        for phi in (0.0, 0.9):
            x = _line_residuals(amp * s + _noise(rng, phi, 20))
            keep = np.ones(x.shape[1:], bool)
            rows = [series_row("r", "trace_slip", d, keep) for d in x]
            assert min(r.chi2_per_n for r in rows) > chi2_per_n
            p = max(r.p_value() for r in rows)
            assert p < LEVEL / 40, (amp, phi, p)


def test_pairs_count_within_a_stretch_only():
    """Lags are counted along a stretch between selected samples only: unselected samples
    (a slip between two sticks) neither enter the correlation nor its mean; a fully
    correlated stretch counts about one residual, wherever its samples lie."""
    rng = np.random.default_rng(14)
    x = rng.standard_normal((1, 1000))
    stick = np.ones_like(x, bool)
    stick[0, 400:600] = False
    x[0, 400:600] = 50.0  # a missed slip: not of this row
    assert effective_samples(x, stick)[0] == pytest.approx(800, rel=0.05)
    halves = np.stack([np.full(50, 1.0), np.full(50, -1.0)])  # two constant stretches
    assert effective_samples(halves, np.ones_like(halves, bool))[0] == pytest.approx(2, rel=0.1)
    assert effective_samples(halves.reshape(1, -1), np.ones((1, 100), bool))[0] < 100 / 4


def test_independent_rows_keep_the_chi2_of_n_degrees_of_freedom():
    """A row without correlation is the chi2 with n degrees of freedom; the stick times'
    lag correlations (Satterthwaite, module doc) give fewer effective residuals."""
    row = PhaseRow("r", "levels", 4, 2.0)
    assert row.n_effective == 4 and row.p_value() == pytest.approx(chi2.sf(8.0, 4))
    assert row.to_json()["n_effective"] == 4
    stick = PhaseRow("r", "stick_times", 6, 2.0, False, (-2.0 / 3.0, 1.0 / 6.0))
    c = 1.0 + 2.0 * (5 * (2.0 / 3.0) ** 2 + 4 * (1.0 / 6.0) ** 2) / 6
    assert stick.n_effective == pytest.approx(6 / c)
