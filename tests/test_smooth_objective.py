"""The smoothed-simulator objective (stickslip_fitting.objectives.smooth): whole records,
the simulator run freely from the first slip end, fitted by `--objective smooth` (the
command's fit and document checked on one run)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import stickslip_jax as ss
from stickslip_fitting.data.features import record_features
from stickslip_fitting.params import CampaignParams, EmpiricalFriction
from stickslip_fitting.objectives.smooth import SmoothObjective, smooth_data
from stickslip_fitting.data.synthetic import synthetic_campaign, truth_values
from record_files import record_files

FR = ss.lubricant("A")


@pytest.fixture(scope="module")
def campaign():
    recs = synthetic_campaign(FR, speed_fractions=(0.05, 0.3), cycles=4, seed=2,
                              pad_to=40_000)
    return recs, [record_features(r) for r in recs]


@pytest.fixture(scope="module")
def smooth_fit(campaign, tmp_path_factory):
    """`stickslip fit FILES --objective smooth --json OUT` on the campaign's first four
    records (two of its three rigs, both speeds): the command's document (one fit serves
    the fit's checks and the command's). Measured in one process: 21 s of CPU time cold
    against 39 s for all six records, 6.5 against 22 s compiled; converged, chi2/dof 1.03,
    every interval holding the truth, mu_d within 0.03 %."""
    from stickslip_jax.cli import main

    recs, _ = campaign
    folder = tmp_path_factory.mktemp("smooth_fit")
    out = folder / "s.json"
    assert main(["fit", *record_files(recs[:4], folder), "--objective", "smooth", "--json",
                 str(out)]) == 0
    return json.loads(out.read_text())


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
    """The command fits the records through the smoothed simulator: converged, every
    simulation successful at the optimum, misfit at the noise, the robust (sandwich)
    intervals holding the truth, mu_d within 1 %."""
    rep = smooth_fit
    truth = truth_values(FR)
    assert rep["converged"] and "smoothed simulator" in rep["objective"]
    assert not [w for w in rep["identifiability"]["warnings"] if "did not succeed" in w]
    assert 0.8 < rep["reduced_chi2"] < 1.4 and rep["covariance"] == "sandwich"
    assert list(rep["parameters"]) == list(EmpiricalFriction.NAMES)
    for n, p in rep["parameters"].items():
        assert p["ci95"][0] <= truth[n] <= p["ci95"][1], n
        assert p["truth_in_ci95"], n
    assert abs(rep["parameters"]["mu_d"]["value"] / truth["mu_d"] - 1) < 0.01


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
