"""The adequacy report (`stickslip_fitting.uncertainty.adequacy`): silent on records the model
describes, specific (record, phase, hint) on records it does not."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from stickslip_fitting.uncertainty.adequacy import (BAD, PhaseRow, _sentences, adequacy,
                                                   model_text)


@pytest.fixture(scope="module")
def features():
    from stickslip_jax.records import read_record
    from stickslip_fitting.data.features import record_features

    paths = sorted(Path(__file__).parents[1].glob("data/examples/A_W36_k*.csv"))
    return [record_features(read_record(p)) for p in paths]


def test_clean_campaign_is_described(features):
    from stickslip_fitting.solve.fit import fit_features

    rep = adequacy(fit_features(features))
    assert rep.verdict == "describes", rep.sentences
    assert {r.phase for r in rep.rows} == {"levels", "stick_times"}
    assert len({r.record for r in rep.rows}) == len(features)
    assert rep.to_json()["verdict"] == "describes"


def test_scattered_record_is_named_with_its_phase(features):
    """One record's levels scattered by 20 noise standard deviations per cycle: that
    record and phase are named, in the records' own errors (not the scaled ones)."""
    from stickslip_fitting.solve.fit import fit_features

    rng = np.random.default_rng(3)
    f = features[2]
    bad = list(features)
    bad[2] = dataclasses.replace(
        f, peak=np.asarray(f.peak) + 20 * np.asarray(f.peak_sd) * rng.standard_normal(
            np.size(f.peak)))
    fit = fit_features(bad)
    assert fit.record_scale is not None  # the fit scaled that record's errors
    rep = adequacy(fit)
    assert rep.verdict == "misses"
    assert rep.worst().record == f.name  # (the levels enter eq (6) too: both phases miss)
    levels = {r.record: r.chi2_per_n for r in rep.rows if r.phase == "levels"}
    assert levels[f.name] > 50 and max(v for k, v in levels.items() if k != f.name) < BAD
    text = " ".join(rep.sentences)
    assert f.name in text and "plateau levels" in text
    assert "--loss student-t" not in text  # a scatter of every cycle: not heavy-tailed


def test_one_far_cycle_is_heavy_tailed_and_points_to_student_t(features):
    from stickslip_fitting.solve.fit import fit_features
    from stickslip_fitting.objectives.losses import StudentT

    i = max(range(len(features)), key=lambda i: np.size(features[i].peak))  # most cycles
    f = features[i]
    peak = np.array(f.peak, float)
    peak[2] += 200 * float(f.peak_sd[2])
    bad = list(features)
    bad[i] = dataclasses.replace(f, peak=peak)
    rep = adequacy(fit_features(bad))
    row = [r for r in rep.rows if r.record == f.name and r.phase == "levels"][0]
    assert row.heavy_tailed and rep.verdict == "misses"
    assert "--loss student-t" in " ".join(rep.sentences)
    # under that loss it is not suggested again
    assert "--loss student-t" not in " ".join(adequacy(fit_features(bad, loss=StudentT()))
                                               .sentences)


def test_sentences_need_more_than_chance():
    # chi2/n of 6 over 3 residuals is not improbable enough among 40 rows; over 300 it is
    few = [PhaseRow("a", "levels", 3, 6.0)] + [PhaseRow("b", "levels", 10, 1.0)] * 39
    many = [PhaseRow("a", "levels", 300, 6.0)] + [PhaseRow("b", "levels", 10, 1.0)] * 39
    assert _sentences(few, 1.1, 2)[0] == "describes"
    verdict, text = _sentences(many, 1.1, 2)
    assert verdict == "misses" and "1 of 2 records" in text[0]
    assert _sentences([PhaseRow("a", "trace_slip", 500, 3.0)], 3.0, 1)[0] == "marginal"
    assert BAD > 2


def test_sentences_name_the_law_fitted():
    """The verdict's sentence names the law the fit fitted (its friction parameters): the
    paper's model for eq (1), another law by the name `stickslip fit --law` gives it."""
    from stickslip_fitting.law_params import LogAgingFriction, RateStateAgingFriction
    from stickslip_fitting.microsqueeze_params import MicrosqueezeFriction
    from stickslip_fitting.params import EmpiricalFriction

    missed = [PhaseRow(r, "levels", 300, 40.0) for r in "abc"]
    clean = [PhaseRow(r, "levels", 300, 1.0) for r in "abc"]
    laws = ((EmpiricalFriction.from_values(0.4, 0.3, 1.0, 0.5, 2.0, 1.3), "The paper's model"),
            (MicrosqueezeFriction.from_values(0.4, 0.2, 0.01, 1.0, 50.0, 1.0, eta=2.2e-8),
             "The paper's microsqueeze model"),
            (LogAgingFriction(*[0.0] * 5), "The log_aging law"),
            (RateStateAgingFriction(*[0.0] * 4), "The rate_state_aging law"))
    for friction, name in laws:
        assert model_text(friction) == name
        verdict, text = _sentences(missed, 40.0, 3, name=name)
        assert verdict == "misses"
        assert text[0].startswith(f"{name} does not describe these records")
        verdict, text = _sentences(clean, 1.0, 3, name=name)
        assert verdict == "describes" and text[0].startswith(f"{name} describes every record")
    assert "paper" not in " ".join(_sentences(missed, 40.0, 3, name="The log_aging law")[1])


def test_correlated_stick_times_p_value_is_calibrated():
    """The stick-time residuals are close to second differences of independent timing
    errors: `PhaseRow.p_value` with `STICK_LAGS` keeps the false-alarm rate near its level
    where the independent chi2 more than doubles it (Monte Carlo, 4 and 6 residuals)."""
    from scipy.stats import chi2

    from stickslip_fitting.uncertainty.adequacy import STICK_LAGS

    rng = np.random.default_rng(0)
    level = 0.01
    for n in (4, 6):
        e = rng.standard_normal((200_000, n + 2))
        r = (e[:, 2:] - 2 * e[:, 1:-1] + e[:, :-2]) / np.sqrt(6.0)  # unit variance
        q = np.sum(r ** 2, axis=1)
        naive = np.mean(chi2.sf(q, n) < level)
        cut = [PhaseRow("r", "stick_times", n, float(x) / n, False, STICK_LAGS).p_value()
               for x in np.quantile(q, [1 - level])]
        # the Satterthwaite p-value at the true 1 % quantile of q is close to 1 %
        assert 0.6 * level < cut[0] < 1.6 * level, (n, cut)
        assert naive > 2 * level, (n, naive)
    row = PhaseRow("r", "levels", 4, 2.0)
    assert row.p_value() == pytest.approx(chi2.sf(8.0, 4))
    assert PhaseRow("r", "stick_times", 4, 2.0, False, STICK_LAGS).p_value() > row.p_value()


def test_law_fit_is_judged_on_its_own_residuals():
    """A law other than the paper's is judged on its whole-records objective's own
    residuals, split at the records' detected slips (breakaway to slip end), padding left
    out; its hints cite none of the paper's equations. A stand-in fit: no simulation."""
    from types import SimpleNamespace as NS

    time = np.tile(np.arange(10.0), (2, 1))  # from each record's first slip end
    mask = np.ones((2, 10), bool)
    mask[1, 8:] = False  # padding of the shorter record
    r = np.ones((2, 10))
    r[0, 3:5] = 10.0  # record a's slip, 11 s up to 13 s on its own clock (8 s on)
    r[1, 8:] = 1e3  # padding's value never counts
    obj = NS(data=NS(time=time, mask=mask), residuals=lambda params: r.ravel())
    feats = [NS(name="a", breakaway_time=np.array([0.0, 11.0]), end_time=np.array([8.0, 13.0])),
             NS(name="b", breakaway_time=np.array([1.0]), end_time=np.array([2.0]))]
    from stickslip_fitting.law_params import LogAgingFriction

    law = LogAgingFriction(*[0.0] * 5)  # a law other than the paper's
    fit = NS(params=type("Params", (), {"friction": law}), features=feats, objective=obj,
             record_scale=None, reduced_chi2=20.0)
    rep = adequacy(fit)
    rows = {(row.record, row.phase): (row.n, row.chi2_per_n) for row in rep.rows}
    assert rows == {("a", "stick"): (8, 1.0), ("a", "slip"): (2, 100.0),
                    ("b", "stick"): (8, 1.0)}
    assert rep.verdict == "misses"
    text = " ".join(rep.sentences)
    assert "1 of 2 records" in rep.sentences[0] and "slip: chi2/n above" in text
    assert "eq (" not in text and "paper" not in text
