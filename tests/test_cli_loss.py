"""`--loss` on the command line and the report keys it adds (`loss`, `adequacy`)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from stickslip_jax.cli import main

EXAMPLES = sorted(str(p) for p in (Path(__file__).parents[1] / "data/examples").glob("*.csv"))


def test_fit_with_student_t_loss_reports_loss_and_adequacy(tmp_path, capsys):
    out = tmp_path / "fit.json"
    assert main(["fit", *EXAMPLES, "--loss", "student-t:5", "--json", str(out)]) == 0
    text = capsys.readouterr()
    assert "loss student-t:5" in text.err  # the progress line says what is fitted
    assert "adequacy: " in text.out and "likelihood: student-t:5 loss" in text.out
    rep = json.loads(out.read_text())
    assert rep["loss"] == "student-t:5" and rep["covariance"] == "two_level"
    assert rep["adequacy"]["verdict"] == "describes"
    assert {r["phase"] for r in rep["adequacy"]["rows"]} == {"levels", "stick_times"}
    for name in ("mu_s", "mu_d"):
        p = rep["parameters"][name]
        assert p["ci95"][0] <= p["truth"] <= p["ci95"][1]


@pytest.mark.parametrize("spec, words", [("cauchy", "--loss: expected one of"),
                                         ("huber:-2", "positive"),
                                         ("student-t:nu", "not a number")])
def test_bad_loss_is_one_line_before_any_work(spec, words, capsys):
    assert main(["fit", *EXAMPLES, "--loss", spec]) == 2
    err = capsys.readouterr().err
    assert words in err and len(err.strip().splitlines()) == 1
    assert "fitting" not in err  # refused before the records were fitted
