"""Heavy-tailed likelihoods (`stickslip_fitting.objectives.losses`): the transform against the loss,
its smoothness at zero, the command-line spelling, and a fit that a far outlier cycle
pulls under least squares but not under the Student-t loss."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stickslip_fitting.objectives.losses import (Gaussian, HeavyTailed, Huber, StudentT, loss_of,
                                      parse_loss, with_loss)

R = jnp.concatenate([-jnp.logspace(-9, 3, 40), jnp.zeros(1), jnp.logspace(-9, 3, 40)])


@pytest.mark.parametrize("loss", [Gaussian(), Huber(), Huber(0.5), StudentT(), StudentT(1.0)])
def test_square_of_transform_is_twice_the_loss(loss):
    rt = loss.transform(R)
    np.testing.assert_allclose(rt**2, 2 * loss.rho(R), rtol=1e-12, atol=1e-300)
    assert np.all(np.sign(rt) == np.sign(R))


@pytest.mark.parametrize("loss", [Huber(), StudentT(), StudentT(2.5)])
def test_gradient_of_the_loss_and_slope_at_zero(loss):
    # d/dr (rt^2 / 2) = rho'(r): the solver sees the loss's own force
    grad_half_sq = jax.vmap(jax.grad(lambda r: 0.5 * loss.transform(r) ** 2))(R)
    np.testing.assert_allclose(grad_half_sq, jax.vmap(jax.grad(loss.rho))(R), rtol=1e-7,
                               atol=1e-15)
    slope = float(jax.grad(loss.transform)(0.0))
    expect = 1.0 if isinstance(loss, Huber) else np.sqrt((loss.nu + 1) / loss.nu)
    assert np.isfinite(slope) and abs(slope - expect) < 1e-12


def test_irls_weights_are_the_closed_forms():
    """`weights` (psi(r)/r, discovery's fixed weights) against Huber's min(1, c/|r|) and
    Student-t's (nu + 1)/(nu + r^2); 1 for the Gaussian."""
    r = np.array([-50.0, -3.0, -1.0, -1e-9, 0.0, 1e-9, 0.5, 1.345, 2.0, 40.0])
    np.testing.assert_allclose(Gaussian().weights(r), 1.0)
    np.testing.assert_allclose(Huber().weights(r), np.minimum(1.0, 1.345 / np.abs(
        np.where(r == 0, 1.0, r))), rtol=1e-9)
    np.testing.assert_allclose(StudentT(4.0).weights(r), 5.0 / (4.0 + r ** 2), rtol=1e-9)


def test_far_residuals_pull_less():
    big = 1e3
    force = lambda loss: float(jax.grad(loss.rho)(big))  # noqa: E731
    assert force(Gaussian()) == big
    assert abs(force(Huber()) - 1.345) < 1e-12  # constant force beyond c
    assert force(StudentT()) < 0.01  # falls as (nu + 1) / r


def test_parse_loss_spellings_and_errors():
    assert parse_loss("gaussian") == Gaussian()
    assert parse_loss("student-t") == StudentT(4.0)
    assert parse_loss("Student_T:2.5") == StudentT(2.5)
    assert parse_loss("huber:2") == Huber(2.0)
    for spec in ("student-t:3", "huber:1.345", "gaussian"):
        assert parse_loss(spec).spec() == spec
    for bad, words in (("cauchy", "expected one of"), ("huber:x", "not a number"),
                       ("student-t:-1", "positive"), ("gaussian:2", "no parameter")):
        with pytest.raises(ValueError, match=words):
            parse_loss(bad)


@pytest.fixture(scope="module")
def features():
    from pathlib import Path

    from stickslip_jax.records import read_record
    from stickslip_fitting.data.features import record_features

    paths = sorted(Path(__file__).parents[1].glob("data/examples/A_W36_k*.csv"))
    return [record_features(read_record(p)) for p in paths]


def test_heavy_tailed_objective_delegates(features):
    from stickslip_fitting.objectives.combined import FeaturesObjective
    from stickslip_fitting.objectives.cycle_features import feature_data

    inner = FeaturesObjective(feature_data(features[:2]))
    obj = with_loss(inner, StudentT())
    assert isinstance(obj, HeavyTailed) and with_loss(inner, Gaussian()) is inner
    assert obj.kind == "features" and obj.blocks() == inner.blocks()
    assert obj.dof() == inner.dof() and obj.robust and not inner.robust
    assert loss_of(obj) == StudentT() and loss_of(inner) == Gaussian()
    assert "student-t:4 loss" in obj.describe()
    with pytest.raises(ValueError, match="already has a loss"):
        HeavyTailed(obj, Huber())


def test_student_t_fit_resists_an_outlier_cycle(features):
    """One level of one cycle moved by 80 noise standard deviations (a sporadic big slip).
    Plain least squares moves mu_s by about 1 %; the Gaussian fit's per-record scaling
    (`RECORD_CHI2`) saves the estimate by down-weighting the whole record (error scale
    144). The Student-t fit stays at the clean value while keeping that record's other
    cycles: a standard error of mu_s several times smaller, and intervals (two-level
    covariance) that contain the truth."""
    import json
    from pathlib import Path

    from stickslip_fitting.modes import Weighting
    from stickslip_fitting.solve.fit import fit_features
    from stickslip_fitting.uncertainty.laplace import laplace

    friction = json.loads((Path(__file__).parents[1] / "data/examples/truth.json")
                          .read_text())["friction"]
    truth = {**friction["static"], **friction["kinetic"]}
    f0 = features[4]
    peak = np.array(f0.peak, float)
    peak[3] += 80 * float(f0.peak_sd[3])
    bad = list(features)
    bad[4] = dataclasses.replace(f0, peak=peak)
    clean = fit_features(features).values["mu_s"]
    plain = fit_features(bad, weighting=Weighting(rescale_records=False)).values["mu_s"]
    gauss = laplace(fit_features(bad))
    robust = fit_features(bad, loss=StudentT())
    unc = laplace(robust)
    assert unc.covariance == "two_level"
    assert isinstance(robust.objective, HeavyTailed) and robust.converged
    assert abs(plain / clean - 1) > 5e-3
    assert abs(robust.values["mu_s"] / clean - 1) < 0.05 * abs(plain / clean - 1)
    se = {e.name: e.stderr for e in unc.estimates()}
    se_gauss = {e.name: e.stderr for e in gauss.estimates()}
    assert se["mu_s"] < 0.5 * se_gauss["mu_s"], (se, se_gauss)
    for e in unc.estimates():
        if e.name in ("mu_s", "mu_d"):
            assert e.ci95[0] <= float(truth[e.name]) <= e.ci95[1], e
