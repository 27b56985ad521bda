"""`stickslip fit --law`: a base law other than the paper's, fitted through whole records;
its table, adequacy sentences and JSON name the law, its adequacy rows are its own
residuals', and a wrong option is one line before any work."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from stickslip_jax.cli import main

EXAMPLES = Path(__file__).parents[1] / "data/examples"
THREE = [str(EXAMPLES / f"A_W36_{name}mm-min.csv") for name in ("k27.3_v5", "k86.9_v12",
                                                                 "k128.5_v4")]
"""One record of each spring of the shipped campaign."""


@pytest.mark.slow  # about 50 s of CPU time (the smoothed simulator through three records)
def test_fit_law_names_the_law_in_table_and_json(tmp_path, capsys):
    from stickslip_fitting.law_params import LOG_NAMES

    out = tmp_path / "fit.json"
    assert main(["fit", *THREE, "--law", "log_aging", "--json", str(out)]) in (0, 3)
    text = capsys.readouterr()
    assert "model log_aging" in text.err  # the progress line says what is fitted
    table = text.out.splitlines()
    assert [line.split()[0] for line in table[2:2 + len(LOG_NAMES)]] == list(LOG_NAMES)
    adequacy = [line for line in table if line.startswith("adequacy: ")]
    assert adequacy and adequacy[0].startswith("adequacy: The log_aging law ")
    assert "paper's" not in text.out
    rep = json.loads(out.read_text())
    assert rep["model"] == "log_aging" and "smoothed simulator" in rep["objective"]
    assert list(rep["parameters"]) == list(LOG_NAMES)
    assert rep["adequacy"]["sentences"][0].startswith("The log_aging law ")
    assert sum(r.get("status", "used") == "used" for r in rep["records"]) == 3
    # judged on the law fit's own residuals: its rows add up to its chi2/dof (the paper's
    # feature residuals at these parameters reach chi2/n 1e3-1e9), hints without eq (...)
    rows = rep["adequacy"]["rows"]
    assert {r["phase"] for r in rows} == {"stick", "slip"}
    n = sum(r["n"] for r in rows)
    pooled = sum(r["n"] * r["chi2_per_n"] for r in rows) / n
    assert pooled == pytest.approx(rep["adequacy"]["reduced_chi2"], rel=0.02)
    assert max(r["chi2_per_n"] for r in rows) < 100 * rep["adequacy"]["reduced_chi2"]
    assert "eq (" not in text.out


@pytest.mark.parametrize("extra, words", [
    (["--law", "coulomb"], ["--law", "invalid choice: 'coulomb'", "paper", "rate_state_aging",
                            "rate_state_slip", "log_aging"]),
    (["--law", "log_aging", "--model", "microsqueeze"], ["--law log_aging", "--model"]),
    (["--law", "rate_state_aging", "--objective", "trace"],
     ["--law rate_state_aging", "--objective smooth"]),
    (["--law", "rate_state_slip", "--loss", "huber"], ["--law rate_state_slip", "--loss"]),
    (["--law", "log_aging", "--fix", "gamma=1"], ["--fix", "mu_d, beta, t_c, c, v_c"])])
def test_law_option_errors_are_one_line_before_any_work(extra, words, capsys):
    try:
        code = main(["fit", THREE[0], *extra])
    except SystemExit as exc:  # argparse's usage error: the usage line, then the error
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) <= 2 and "error: " in err.strip().splitlines()[-1], err
    assert all(w in err for w in words), err
    assert "fitting" not in err  # refused before the records were read
