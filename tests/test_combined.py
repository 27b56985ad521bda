"""The combined objective's residual layout (fitting.combined.residual_cycles) and the
cluster-robust intervals of `--objective both` (coverage check: slow)."""

import os

import numpy as np
import pytest

import stickslip_jax as ss
from fitting.combined import CampaignObjective, residual_cycles
from fitting.features import record_features
from fitting.fit import fit_features
from fitting.params import NAMES
from fitting.synthetic import synthetic_campaign, truth_values
from fitting.trace_objective import trace_data
from fitting.uncertainty import laplace


@pytest.fixture(scope="module")
def campaign():
    recs = synthetic_campaign(ss.lubricant("A"), speed_fractions=(0.05, 0.3), cycles=4, seed=2,
                              pad_to=40_000)
    feats = [record_features(r) for r in recs]
    return recs, feats, fit_features(feats)


def test_every_residual_is_labelled_with_its_stick_phase(campaign):
    recs, feats, fit = campaign
    td = trace_data(recs, feats)
    obj = CampaignObjective(fit.data, td, kind="both")
    rec, cyc = residual_cycles(obj, feats)
    fd = fit.data
    R, C = fd.t1.shape
    N, L = td.mask.shape
    assert rec.shape == cyc.shape == (2 * R * C + R + N * L,)
    # features part: level and eq (6) residuals of (r, j) carry the label (r, j) when they
    # hold data; padding and the unused start residuals are -1
    lv_rec, lv_cyc = rec[: R * C].reshape(R, C), cyc[: R * C].reshape(R, C)
    has = np.asarray(fd.has_end | fd.has_next)
    assert np.all(lv_rec[has] == np.nonzero(has)[0]) and np.all(lv_cyc[has] == np.nonzero(has)[1])
    assert np.all(lv_rec[~has] == -1)
    st = rec[R * C: 2 * R * C].reshape(R, C)
    assert np.array_equal(st >= 0, np.asarray(fd.has_end & fd.has_next))
    assert np.all(rec[2 * R * C: 2 * R * C + R] == -1)
    # trace part: a window restarts from the slip-end level of the cycle it is labelled with
    tr_rec = rec[2 * R * C + R:].reshape(N, L)
    tr_cyc = cyc[2 * R * C + R:].reshape(N, L)
    mask = np.asarray(td.mask)
    assert np.array_equal(tr_rec >= 0, mask)
    for w in np.flatnonzero(mask.any(axis=1)):
        r, j = tr_rec[w, 0], tr_cyc[w, 0]
        assert r == int(td.record[w])
        assert float(td.start_level[w]) == pytest.approx(feats[r].trough[j], abs=1e-12)
        assert has[r, j]  # the same stick phase has feature residuals
    # kind "trace" and "features" give the matching slices
    rt, ct = residual_cycles(CampaignObjective(fit.data, td, kind="trace"), feats)
    assert np.array_equal(rt, rec[2 * R * C + R:]) and np.array_equal(ct, cyc[2 * R * C + R:])


def test_sandwich_agrees_with_fisher_on_the_features_objective(campaign):
    """The features residuals are independent and whitened: the robust covariance estimates
    the same thing as F^-1 (within its sampling noise, ~25 clusters)."""
    _, _, fit = campaign
    fisher = laplace(fit)
    robust = laplace(fit, covariance="sandwich")
    assert fisher.covariance == "fisher" and robust.covariance == "sandwich"
    ratio = robust.log_se / fisher.log_se
    assert np.all((ratio > 0.5) & (ratio < 2.0)), ratio
    np.testing.assert_allclose(robust.value, fisher.value)
    with pytest.raises(ValueError, match="covariance"):
        laplace(fit, covariance="bootstrap")
