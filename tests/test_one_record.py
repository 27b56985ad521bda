"""`stickslip fit` of a single record: it exits 0 and gives mu_s and mu_d intervals with
the rise of eq (1) and the decay of eq (3) held, said in a note (one stick time and one
slip time cannot determine them)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from stickslip_jax.cli import main

EXAMPLES = Path(__file__).parents[1] / "data" / "examples"
TRUTH = json.loads((EXAMPLES / "truth.json").read_text())


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("one") / "fit.json"
    record = EXAMPLES / "A_W36_k86.9_v5mm-min.csv"
    assert main(["fit", str(record), "--json", str(out), "--quiet"]) == 0
    return json.loads(out.read_text())


def test_one_record_gives_mu_s_and_mu_d_with_intervals(report):
    p = report["parameters"]
    truth = {**TRUTH["friction"]["static"], **TRUTH["friction"]["kinetic"]}
    for name in ("mu_s", "mu_d"):
        lo, hi = p[name]["ci95"]
        assert p[name]["identifiable"] and lo < truth[name] < hi, (name, p[name])
    for name in ("gamma", "m", "delta", "n"):
        assert p[name]["fixed"], (name, p[name])
    assert [r["status"] for r in report["records"]] == ["used"]


def test_one_record_says_what_it_holds(tmp_path, capsys):
    record = EXAMPLES / "A_W36_k27.3_v5mm-min.csv"
    assert main(["fit", str(record), "--fix", "n=1.0", "--quiet"]) == 0
    out = capsys.readouterr().out
    note = [ln for ln in out.splitlines() if ln.startswith("note: one record:")]
    assert len(note) == 1 and "gamma = 0.38" in note[0] and "Table 6" in note[0], out


def test_the_python_api_fits_one_record_and_says_what_it_cannot_determine():
    """`sf.fit` of one record (a path or a `Record`): mu_s and mu_d with intervals holding
    the truth; gamma, m, delta, n held, not identifiable, each with its reason."""
    import stickslip_fitting as sf

    from stickslip_jax.records import read_record

    path = EXAMPLES / "A_W36_k86.9_v5mm-min.csv"
    for given in (path, read_record(path)):
        result = sf.fit(given)
        table = result.summary()
        for name in ("mu_s", "mu_d"):
            row = table.loc[name]
            assert row["identifiable"] and row["low"] < TRUTH_FLAT[name] < row["high"], row
        for name in ("gamma", "m", "delta", "n"):
            row = table.loc[name]
            assert not row["identifiable"] and row["reason"].startswith(
                "not identifiable from one record: one s"), row
        assert set(result.report["identifiability"]["not_identifiable"]) == {
            "gamma", "m", "delta", "n"}
        assert any(n.startswith("one record:") for n in result.notes)


def test_mcmc_samples_one_record(tmp_path, capsys):
    """`stickslip mcmc` of one record samples mu_s and mu_d (the others held, said in a
    note and in the JSON's "fixed" and "notes")."""
    out = tmp_path / "post.json"
    record = EXAMPLES / "A_W36_k86.9_v5mm-min.csv"
    assert main(["mcmc", str(record), "--steps", "60", "--walkers", "12", "--quiet",
                 "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["names"] == ["mu_s", "mu_d"] and set(doc["fixed"]) == {"gamma", "m", "delta", "n"}
    assert any(n.startswith("one record:") for n in doc["notes"])
    assert "note: one record:" in capsys.readouterr().out


TRUTH_FLAT = {**TRUTH["friction"]["static"], **TRUTH["friction"]["kinetic"]}
