"""The smoothed-simulator objective (stickslip_fitting.objectives.smooth): whole records,
the simulator run freely from the first slip end, fitted by `--objective smooth`."""

from __future__ import annotations

import json

import numpy as np
import pytest

import stickslip_jax as ss
from stickslip_fitting.data.features import record_features
from stickslip_fitting.solve.fit import fit_features
from stickslip_fitting.modes import Objective
from stickslip_fitting.params import CampaignParams, EmpiricalFriction
from stickslip_fitting.objectives.smooth import SmoothObjective, smooth_data
from stickslip_fitting.data.synthetic import synthetic_campaign, truth_values
from stickslip_fitting.uncertainty.laplace import laplace
from record_files import record_files

FR = ss.lubricant("A")


@pytest.fixture(scope="module")
def campaign():
    recs = synthetic_campaign(FR, speed_fractions=(0.05, 0.3), cycles=4, seed=2,
                              pad_to=40_000)
    return recs, [record_features(r) for r in recs]


@pytest.fixture(scope="module")
def smooth_fit(campaign):
    recs, feats = campaign
    return fit_features(feats, objective=Objective.SMOOTH, records=recs)


def test_residuals_at_truth_are_noise(campaign):
    # exact-simulator records against the smoothed simulator at the truth: whitened
    # residuals of unit scatter (smoothing 1e-4 moves the slips by less than the noise)
    recs, feats = campaign
    obj = SmoothObjective(smooth_data(recs, feats))
    params = CampaignParams(EmpiricalFriction.from_friction(FR), np.zeros(len(recs)))
    r, (ok, vel) = obj.residuals_and_aux(params)
    r = np.asarray(r)[np.asarray(obj.data.mask).ravel()]
    assert np.asarray(ok).all() and vel is None
    assert 0.85 < np.std(r) < 1.25 and abs(np.mean(r)) < 0.2
    rec, cyc = obj.clusters(feats)
    assert rec.size == r.size + np.count_nonzero(~np.asarray(obj.data.mask))
    assert set(np.unique(rec[rec >= 0])) == set(range(len(recs)))


def test_smooth_fit_recovers_truth(smooth_fit):
    fit = smooth_fit
    unc = laplace(fit)
    truth = truth_values(FR)
    assert fit.converged and fit.trace_failures == 0 and fit.objective.kind == "smooth"
    assert 0.8 < fit.reduced_chi2 < 1.4 and unc.covariance == "sandwich"
    for i, n in enumerate(fit.params.friction.NAMES):
        assert unc.ci95[i, 0] <= truth[n] <= unc.ci95[i, 1], n
    assert abs(fit.values["mu_d"] / truth["mu_d"] - 1) < 0.01


def test_smooth_needs_slips_and_drives_through_a_program(campaign):
    import dataclasses

    recs, feats = campaign
    v = recs[0].drive_speed
    prog = dataclasses.replace(recs[0], drive_program=((0.0, v),))
    knots = np.asarray(smooth_data([prog], feats[:1]).drive_knots)[0]  # the drive from t_e
    np.testing.assert_allclose(knots[:, 1], v * knots[:, 0], rtol=1e-12, atol=1e-12)
    assert smooth_data(recs[:1], feats[:1]).drive_knots is None
    flat = dataclasses.replace(feats[0], stick_slip=False, message="no stick-slip")
    with pytest.raises(ValueError, match="slip to start from"):
        smooth_data(recs[:1], [flat])


def test_cli_objective_smooth(campaign, tmp_path, capsys):
    from stickslip_jax.cli import main

    recs, _ = campaign
    paths = record_files(recs, tmp_path)
    out = tmp_path / "s.json"
    assert main(["fit", *paths, "--objective", "smooth", "--json", str(out)]) == 0
    rep = json.loads(out.read_text())
    assert "smoothed simulator" in rep["objective"] and rep["converged"]
    assert all(p["truth_in_ci95"] for p in rep["parameters"].values() if p["ci95"])
