"""`laplace(fit, jacobian=LogJacobian(...))`: the residuals and Jacobian of another model
of the same parameters, by named fields, give the same answer as the fit's own when they
are the fit's own, and their cluster labels drive the robust covariance."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import stickslip_jax as ss


@pytest.fixture(scope="module")
def fit():
    from stickslip_fitting.data.features import record_features
    from stickslip_fitting.data.synthetic import synthetic_campaign
    from stickslip_fitting.solve.fit import fit_features

    recs = synthetic_campaign(ss.lubricant("A"), speed_fractions=(0.05, 0.3), cycles=4,
                              seed=11, pad_to=40_000)
    return fit_features([record_features(r) for r in recs])


def test_the_fits_own_jacobian_gives_the_same_answer(fit):
    from stickslip_fitting.uncertainty.laplace import LogJacobian, jacobian_log, laplace

    jac = jacobian_log(fit)
    assert isinstance(jac, LogJacobian) and jac.record is None and jac.cycle is None
    offsets = np.asarray(fit.params.offset).size if fit.spec.offset else 0  # free offsets
    assert jac.J.shape == (jac.r.size, jac.idx.size + offsets)
    with pytest.raises(dataclasses.FrozenInstanceError):
        jac.r = jac.r * 2  # type: ignore[misc]
    plain, given = laplace(fit), laplace(fit, jacobian=jac)
    np.testing.assert_allclose(given.stderr, plain.stderr, rtol=1e-12)
    assert given.identifiable == plain.identifiable


def test_cluster_labels_of_the_jacobian_are_used(fit):
    from stickslip_fitting.modes import Covariance
    from stickslip_fitting.objectives.combined import residual_cycles
    from stickslip_fitting.uncertainty.laplace import jacobian_log, laplace

    jac = jacobian_log(fit)
    record, cycle = residual_cycles(fit.objective, fit.features)
    own = laplace(fit, covariance=Covariance.SANDWICH)
    same = laplace(fit, covariance=Covariance.SANDWICH,
                   jacobian=dataclasses.replace(jac, record=record, cycle=cycle))
    np.testing.assert_allclose(same.stderr, own.stderr, rtol=1e-12)
    # one cluster for every residual of a record: another covariance
    whole = laplace(fit, covariance=Covariance.SANDWICH, jacobian=dataclasses.replace(
        jac, record=np.asarray(record), cycle=np.zeros_like(np.asarray(cycle))))
    assert not np.allclose(whole.stderr, own.stderr, rtol=1e-3)
