"""Cluster-robust (sandwich) covariance of stickslip_fitting.uncertainty.laplace against independent references:
the textbook heteroscedasticity-consistent formula written here, and the exact covariance of
least squares with clustered and neighbour-correlated errors (Monte Carlo)."""

import numpy as np
import pytest

from stickslip_fitting.modes import SmallSample
from stickslip_fitting.uncertainty.laplace import sandwich_covariance


def test_singleton_clusters_reduce_to_the_hc_formula():
    rng = np.random.default_rng(0)
    J, r = rng.normal(size=(40, 3)), rng.normal(size=40)
    rec, cyc = np.zeros(40, int), np.arange(40)
    rec[-5:] = -1  # padding: left out
    keep = rec >= 0
    Jk, rk = J[keep], r[keep]
    meat = sum(np.outer(j, j) * e * e for j, e in zip(Jk, rk)) * 35 / 34
    Hinv = np.linalg.inv(J.T @ J)  # padding rows still count in H: they are zero in a fit
    ref = Hinv @ meat @ Hinv
    got = sandwich_covariance(J, r, rec, cyc, lag=0, small_sample=SmallSample.NONE)
    np.testing.assert_allclose(got, ref, rtol=1e-10)
    # the jackknife scores: g_c / (1 - h_c) for one-row clusters, h_c the leverage
    h = np.einsum("ij,jk,ik->i", Jk, Hinv, Jk)
    meat = sum(np.outer(j, j) * (e / (1 - hh)) ** 2 for j, e, hh in zip(Jk, rk, h)) * 34 / 35
    np.testing.assert_allclose(sandwich_covariance(J, r, rec, cyc, lag=0), Hinv @ meat @ Hinv,
                               rtol=1e-8)


def test_cr2_is_the_bell_mccaffrey_formula():
    # each cluster's residuals scaled by (I - P_cc)^(-1/2), written out densely here
    rng = np.random.default_rng(1)
    J, r = rng.normal(size=(90, 3)), rng.normal(size=90)
    rec, cyc = np.repeat(np.arange(3), 30), np.zeros(90, int)
    Hinv = np.linalg.inv(J.T @ J)
    g = []
    for c in range(3):
        Jc, rc = J[rec == c], r[rec == c]
        w, V = np.linalg.eigh(np.eye(30) - Jc @ Hinv @ Jc.T)
        g.append(Jc.T @ ((V / np.sqrt(w)) @ V.T @ rc))
    meat = sum(np.outer(x, x) for x in g)
    np.testing.assert_allclose(sandwich_covariance(J, r, rec, cyc, lag=0,
                                                   small_sample=SmallSample.CR2),
                               Hinv @ meat @ Hinv, rtol=1e-10)


def _clustered_design(rng, records=2, cycles=30, per=8):
    n = records * cycles * per
    rec = np.repeat(np.arange(records), cycles * per)
    cyc = np.tile(np.repeat(np.arange(cycles), per), records)
    # regressors that are partly constant within a cluster: the case where the naive
    # covariance is most wrong
    X = np.column_stack([np.ones(n), rng.normal(size=records * cycles)[rec * cycles + cyc]
                         + 0.3 * rng.normal(size=n), rng.normal(size=n)])
    return X, rec, cyc


@pytest.mark.parametrize("neighbours", [False, True])
def test_sandwich_recovers_the_covariance_of_least_squares(neighbours):
    """Errors: a shared term per cluster (and, with `neighbours`, a term shared by clusters
    c and c+1 of a record); lag=1 must recover the true covariance, lag=0 only without it."""
    rng = np.random.default_rng(1)
    X, rec, cyc = _clustered_design(rng)
    n, p = X.shape
    G = rec.max() + 1, cyc.max() + 1
    A = np.zeros((n, G[0] * (G[1] + 1)))  # error = A @ z + 0.5 e, z standard normal
    A[np.arange(n), rec * (G[1] + 1) + cyc] = 1.0
    if neighbours:
        A[np.arange(n), rec * (G[1] + 1) + cyc + 1] += 1.0
    Sigma = A @ A.T + 0.25 * np.eye(n)
    Hinv = np.linalg.inv(X.T @ X)
    exact = Hinv @ X.T @ Sigma @ X @ Hinv
    naive = Hinv * np.trace(Sigma) / n
    est = {0: [], 1: [], "none": []}
    for _ in range(300):
        err = A @ rng.normal(size=A.shape[1]) + 0.5 * rng.normal(size=n)
        b = Hinv @ X.T @ err
        r = err - X @ b  # residuals at the least-squares optimum (J = X up to sign)
        for lag in (0, 1):
            est[lag].append(np.diag(sandwich_covariance(-X, r, rec, cyc, lag=lag)))
        est["none"].append(np.diag(sandwich_covariance(-X, r, rec, cyc, small_sample=SmallSample.NONE)))
    ratio = {k: np.mean(v, axis=0) / np.diag(exact) for k, v in est.items()}
    # lag 1 is right in both cases; without the jackknife scores it is biased low (the
    # residuals are shrunk by the fit)
    assert np.all(np.abs(ratio[1] - 1) < 0.12), ratio
    assert np.all(ratio["none"] < ratio[1]), ratio
    if neighbours:
        # ignoring the neighbours: the intercept (a regressor alike in neighbouring clusters,
        # as the friction parameters are in neighbouring cycles) comes out far too narrow
        assert ratio[0][0] < 0.7, ratio
    else:
        assert np.all(np.abs(ratio[0] - 1) < 0.15), ratio
    assert np.diag(naive)[1] < 0.5 * np.diag(exact)[1]  # the case matters: F^-1 is far off


def test_null_share_finds_parameters_in_an_unseen_direction():
    """Information of three parameters where only a + b and c are seen: a and b each
    have half their weight in the null direction, c none; a nearly singular matrix
    (eigenvalue 1e-6 of 1) is not called null."""
    from stickslip_fitting.uncertainty.laplace import NULL_SHARE, _null_share

    J = np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 2.0], [1.0, 1.0, 0.0]])
    share = _null_share(J.T @ J)
    np.testing.assert_allclose(share, [0.5, 0.5, 0.0], atol=1e-12)
    assert share[0] > NULL_SHARE and share[2] < NULL_SHARE
    assert np.all(_null_share(np.diag([1.0, 1e-6, 0.5])) == 0.0)
    # badly conditioned but determined (the microsqueeze law): no null direction
    assert np.all(_null_share(np.diag([1.6e14, 3.8e11, 2.9e3])) == 0.0)
    assert _null_share(np.zeros((0, 0))).size == 0
