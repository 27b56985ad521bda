"""The standard errors of a discovery's named effects: the cluster-robust sandwich of the
final model's fit, one cluster per cycle window (`fitting.discovery.stages.errors`)."""

import dataclasses
from types import SimpleNamespace

import numpy as np

from stickslip_fitting.discovery.stages.errors import robust_errors
from stickslip_fitting.uncertainty.laplace import sandwich_covariance
from stickslip_jax.lsq import gauss_newton_covariance


@dataclasses.dataclass
class _Step:
    family: object
    kept: bool
    stderr: np.ndarray


def _problem(seed=0, windows=40, per=200):
    """A linear model of 4 coordinates (a base coordinate, a first effect's one, the
    named effect's two) over `windows` windows of 2 records, whose noise has a share
    common to each window (so the samples of a window are correlated)."""
    rng = np.random.default_rng(seed)
    n = windows * per
    window = np.repeat(np.arange(windows), per)
    record = (window >= windows // 2).astype(int)
    t = np.tile(np.linspace(0, 1, per), windows)
    J = np.stack([np.ones(n), t, np.sin(6 * t) + 0.3 * rng.normal(size=n),
                  np.cos(5 * t) + 0.3 * rng.normal(size=n)], axis=1)
    # a window-level nuisance the model does not have, besides the white noise
    r = rng.normal(size=n) + 2.0 * rng.normal(size=windows)[window] * J[:, 2]
    J = np.vstack([J, np.diag([1e-3, 0, 0, 0])[:1]])  # a prior's row: in no cluster
    r = np.r_[r, 0.0]
    mask = np.ones((windows, per), bool)
    data = SimpleNamespace(mask=mask, record=record.reshape(windows, per)[:, 0],
                           window=np.arange(windows))
    first, named = object(), object()
    cols = {first: np.array([1]), named: np.array([2, 3])}
    scales = np.array([1.0, 2.0, 0.5, 0.5])
    model = SimpleNamespace(data=data, cols=lambda f: cols[f], scales=scales)
    sub = SimpleNamespace(cols=np.arange(4),
                          family_part=lambda z, cov, k: (z[-k:], cov[-k:, -k:]))
    fit = SimpleNamespace(J=J, r=r, z=np.zeros(4))
    chosen = dataclasses.make_dataclass("Refit", ["family", "fit", "sub", "stderr"])(
        named, fit, sub, np.zeros(2))
    steps = [_Step(first, True, np.zeros(1)), _Step(named, True, np.zeros(2)),
             _Step(object(), False, np.zeros(1))]
    return model, chosen, steps, record, window


def test_the_named_effects_take_the_sandwich_of_the_final_fit():
    model, chosen, steps, record, window = _problem()
    chosen2, steps2 = robust_errors(model, chosen, steps)
    cov = sandwich_covariance(chosen.fit.J, chosen.fit.r, np.r_[record, -1], np.r_[window, -1])
    se = np.sqrt(np.diag(cov)) * model.scales
    np.testing.assert_allclose(chosen2.stderr, se[2:], rtol=1e-12)
    np.testing.assert_allclose(steps2[1].stderr, se[2:], rtol=1e-12)
    np.testing.assert_allclose(steps2[0].stderr, se[1:2], rtol=1e-12)
    assert np.all(steps2[2].stderr == 0)  # a step not in the final model keeps its own


def test_window_correlated_noise_widens_the_errors_beyond_gauss_newton():
    """Noise shared by a window's samples: the independent-sample covariance understates
    the named effect's error, the sandwich does not."""
    model, chosen, steps, _, _ = _problem(seed=1)
    plain = np.sqrt(np.diag(gauss_newton_covariance(chosen.fit.J, 1.0)))[2] * 0.5
    robust = robust_errors(model, chosen, steps)[0].stderr[0]
    assert robust > 3 * plain


def test_errors_of_the_noise_they_stand_for():
    """Over many draws of the window-correlated noise, the sandwich's error of the named
    effect's first coordinate is within 25 % of the scatter of its least-squares estimate."""
    estimates, errors = [], []
    for seed in range(60):
        model, chosen, steps, _, _ = _problem(seed=seed, windows=30, per=60)
        J, r = chosen.fit.J, chosen.fit.r
        beta = np.linalg.lstsq(J, r, rcond=None)[0]
        fit = SimpleNamespace(J=J, r=r - J @ beta, z=beta)
        refit = dataclasses.replace(chosen, fit=fit)
        estimates.append(beta[2] * model.scales[2])
        errors.append(robust_errors(model, refit, steps)[0].stderr[0])
    assert abs(np.median(errors) / np.std(estimates) - 1) < 0.25


def test_no_finite_derivatives_leave_the_errors_as_they_are():
    model, chosen, steps, _, _ = _problem()
    chosen.fit.J[0, 0] = np.nan
    out, steps2 = robust_errors(model, chosen, steps)
    assert out is chosen and steps2 is steps
    assert robust_errors(model, None, steps) == (None, steps)
