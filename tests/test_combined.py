"""The combined objective's residual layout (stickslip_fitting.objectives.combined.residual_cycles) and the
cluster-robust intervals of `--objective both` (coverage check: slow)."""

import os

import numpy as np
import pytest

import stickslip_jax as ss
from stickslip_fitting.objectives.combined import make_objective, residual_cycles
from stickslip_fitting.data.features import record_features
from stickslip_fitting.solve.fit import fit_features
from stickslip_fitting.modes import Covariance, Objective, Padding
from stickslip_fitting.params import NAMES
from stickslip_fitting.data.synthetic import draw_prior_friction, synthetic_campaign, truth_values
from stickslip_fitting.objectives.trace import trace_data
from stickslip_fitting.uncertainty.laplace import laplace


@pytest.fixture(scope="module")
def campaign():
    recs = synthetic_campaign(ss.lubricant("A"), speed_fractions=(0.05, 0.3), cycles=4, seed=2,
                              pad_to=40_000)
    feats = [record_features(r) for r in recs]
    return recs, feats, fit_features(feats)


def test_every_residual_is_labelled_with_its_stick_phase(campaign):
    recs, feats, fit = campaign
    td = trace_data(recs, feats)
    obj = make_objective(Objective.BOTH, fit.data, td)
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
    rt, ct = residual_cycles(make_objective(Objective.TRACE, fit.data, td), feats)
    assert np.array_equal(rt, rec[2 * R * C + R:]) and np.array_equal(ct, cyc[2 * R * C + R:])


def test_sandwich_agrees_with_fisher_on_the_features_objective(campaign):
    """The features residuals are independent and whitened: the robust covariance estimates
    the same thing as F^-1 (within its sampling noise, ~25 clusters)."""
    _, _, fit = campaign
    fisher = laplace(fit)
    robust = laplace(fit, covariance=Covariance.SANDWICH)
    assert fisher.covariance == "fisher" and robust.covariance == "sandwich"
    ratio = robust.log_se / fisher.log_se
    assert np.all((ratio > 0.5) & (ratio < 2.0)), ratio
    np.testing.assert_allclose(robust.value, fisher.value)
    with pytest.raises(ValueError, match="covariance"):
        Covariance.parse("bootstrap")
    with pytest.raises(TypeError, match=r"covariance: a member of Covariance.*Covariance\.parse"):
        laplace(fit, covariance="sandwich")


BOTH_CAMPAIGNS = 20


@pytest.mark.slow
def test_both_interval_calibration(request):
    """90 % intervals of `--objective both` and `trace` (cluster-robust sandwich) cover the
    truth in 80-97 % of cases over campaigns drawn from a prior; F^-1 alone does not (the
    samples of a stick phase share their restart error; "both" reads them twice). 2.5 min
    (lightly loaded) to 13 min on 2 shared cores: runs with `-m slow` or STICKSLIP_SLOW=1.
    Measured: both 92 % (F^-1: 55 %), trace 89 % (F^-1: 62 %), 18 of 20 campaigns counted.

    Campaigns: lubricant-A layout (3 k/W x 0.05, 0.3 v_c, 4 cycles, 1 kHz, 0.5 um noise);
    draws whose records do not all show stick-slip are redrawn; fits whose chi2/dof > 2
    (a local minimum of the features fit, which the CLI warns about) are not counted.
    """
    if "slow" not in (request.config.getoption("markexpr") or "") and not os.environ.get(
            "STICKSLIP_SLOW"):
        pytest.skip("slow calibration: run with -m slow or STICKSLIP_SLOW=1")
    z90 = 1.6448536269514722
    rng = np.random.default_rng(2025)
    camps, draw = [], 0
    while len(camps) < BOTH_CAMPAIGNS:
        draw += 1
        fr = draw_prior_friction(rng)
        recs = synthetic_campaign(fr, speed_fractions=(0.05, 0.3), cycles=4,
                                  seed=499 + draw, pad_to=60_000)
        feats = [record_features(r) for r in recs]
        if all(f.stick_slip for f in feats):
            camps.append((fr, recs, feats, trace_data(recs, feats).time.shape))
    pad_l, pad_n = max(c[3][1] for c in camps), max(c[3][0] for c in camps)
    hits = {(obj, kind): [] for obj in ("both", "trace") for kind in ("sandwich", "fisher")}
    for fr, recs, feats, _ in camps:
        truth = truth_values(fr)
        for obj in ("both", "trace"):
            fit = fit_features(feats, objective=Objective(obj), records=recs,
                               padding=Padding(cycles=8, length=pad_l, windows=pad_n))
            if not (fit.converged and fit.reduced_chi2 < 2.0):
                continue
            for kind in ("sandwich", "fisher"):
                unc = laplace(fit, covariance=Covariance.AUTO if kind == "sandwich"
                              else Covariance.FISHER)
                assert unc.covariance == kind
                hits[obj, kind].append([
                    abs(np.log(truth[n] / unc.value[j])) <= z90 * unc.log_se[j]
                    for j, n in enumerate(NAMES) if unc.identifiable[n]])
    cover = {k: float(np.mean(np.concatenate(v))) for k, v in hits.items()}
    counted = {k: len(v) for k, v in hits.items()}
    print(f"of {BOTH_CAMPAIGNS} campaigns counted {counted}; 90 % coverage: {cover}")
    for obj in ("both", "trace"):
        assert counted[obj, "sandwich"] >= 0.75 * BOTH_CAMPAIGNS
        assert 0.80 <= cover[obj, "sandwich"] <= 0.97, cover
        assert cover[obj, "fisher"] < 0.75, cover  # what the sandwich corrects
