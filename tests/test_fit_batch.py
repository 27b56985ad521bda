"""Batches of campaign fits (`stickslip_fitting.solve.batch`, `stickslip fit-batch`): shares,
failures that stay local, the one-process path, and 2 `jax.distributed` processes on
localhost giving the one-process results."""

from __future__ import annotations

import csv
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from ports import free_port

from stickslip_fitting.solve.batch import (ERROR, FAILED, FITTED, NOT_CONVERGED, campaign_name,
                                     fit_batch, shares)
from stickslip_jax.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "data" / "examples"
CAMPAIGNS = [str(EXAMPLES / "A_W36_k128.5_*.csv"), str(EXAMPLES / "A_W36_k27.3_*.csv"),
             str(EXAMPLES / "A_W36_k86.9_*.csv")]
TRUTH = json.loads((EXAMPLES / "truth.json").read_text())["friction"]["static"]


def test_shares_cover_every_campaign_once_and_balance_the_work():
    sizes = [10, 1, 1, 1, 9, 2, 2]
    out = shares(sizes, 3)
    assert sorted(i for s in out for i in s) == list(range(len(sizes)))
    loads = [sum(sizes[i] for i in s) for s in out]
    assert max(loads) == 10  # largest first to the least loaded: the optimum here
    assert out == shares(sizes, 3)  # every process computes the same shares
    assert shares(sizes, 1) == [list(range(len(sizes)))]
    assert shares([], 2) == [[], []]
    with pytest.raises(ValueError, match="n_processes"):
        shares(sizes, 0)


def test_campaign_names():
    assert campaign_name("runs/lubA/") == "lubA"
    assert campaign_name("runs/A_*.csv") == "A_*.csv"
    assert campaign_name(["a/x.csv", "a/y.csv", "a/z.csv"]) == "x.csv+2"
    with pytest.raises(ValueError, match="no records"):
        campaign_name([])


def test_a_failing_campaign_does_not_stop_the_batch():
    """A ValueError (the user's data) is FAILED with its message, any other exception
    ERROR; the campaigns after it are still fitted, in the order given."""

    def fit_one(spec):
        if spec == "bad":
            raise ValueError("bad: no usable stick-slip\nsecond line")
        if spec == "bug":
            raise ZeroDivisionError("oops")
        return {"converged": spec != "slow", "value": spec}

    lines = []
    batch = fit_batch(["a", "bad", "bug", "slow", "b"], fit_one, progress=lines.append)
    assert [e.status for e in batch.entries] == [FITTED, FAILED, ERROR, NOT_CONVERGED, FITTED]
    assert batch.entries[1].message == "bad: no usable stick-slip"
    assert batch.entries[2].message == "ZeroDivisionError: oops"
    assert batch.entries[4].report == {"converged": True, "value": "b"}
    assert batch.processes == 1 and not batch.all_fitted and batch.count(FITTED) == 2
    assert len(lines) == 5 and "bad: no usable stick-slip" in lines[1]
    with pytest.raises(ValueError, match="no campaigns"):
        fit_batch([], fit_one)


def test_fit_batch_command(tmp_path, capsys):
    """Three campaigns of the shipped records and one that does not exist: the three are
    fitted as `stickslip fit` fits them, the fourth is listed with the reason (exit 3);
    JSON, long CSV and figure are written."""
    out, table, fig = tmp_path / "b.json", tmp_path / "b.csv", tmp_path / "b.png"
    missing = str(tmp_path / "nowhere")
    code = main(["fit-batch", *CAMPAIGNS, missing, "-q", "--json", str(out), "--csv",
                 str(table), "--plot", str(fig)])
    text = capsys.readouterr().out
    assert code == 3
    assert "3 of 4 campaigns fitted, 1 could not be fitted; 1 process" in text
    # the table: every row has the header's cells (columns two spaces or more apart)
    lines = text.splitlines()
    header = re.split(r"\s{2,}", lines[0].strip())
    assert header[:3] == ["campaign", "status", "records"] and header[-2:] == ["chi2/dof", "s"]
    assert "gamma [s^-m]" in header and "delta [s^-n]" in header
    body = [re.split(r"\s{2,}", line.strip()) for line in lines[2:6]]
    assert [len(r) for r in body] == [len(header)] * 4, body
    assert body[3][1] == "failed" and "nowhere: failed: " in text
    delta_n = [header.index("delta [s^-n]"), header.index("n")]
    for row in body[:3]:
        # one spring each: one slip time, delta and n not determined, printed as "-"
        assert [row[i] for i in delta_n] == ["-", "-"], row
        for cell in row[3:]:
            assert cell == "-" or float(cell) == float(cell)  # one number per cell
    assert text.count("delta, n not identifiable (-): one slip time T2") == 3
    doc = json.loads(out.read_text())
    assert doc["schema_version"] >= 1 and doc["processes"] == 1
    rows = doc["campaigns"]
    assert [r["status"] for r in rows] == [FITTED] * 3 + [FAILED]
    assert "no file matches this pattern" in rows[3]["message"] or "no such" in rows[3]["message"]
    for r in rows[:3]:
        p = r["result"]["parameters"]
        assert abs(p["mu_d"]["value"] - TRUTH["mu_d"]) < 1e-3  # what `fit` finds
        assert len(r["result"]["records"]) == 4
    # the same numbers as `stickslip fit` on one of the campaigns
    single = tmp_path / "one.json"
    assert main(["fit", CAMPAIGNS[1], "-q", "--json", str(single)]) == 0
    capsys.readouterr()
    one = json.loads(single.read_text())["parameters"]
    assert rows[1]["result"]["parameters"]["mu_s"]["value"] == pytest.approx(
        one["mu_s"]["value"], rel=1e-9)
    with open(table) as fh:
        long = list(csv.DictReader(fh))
    assert len(long) == 3 * 6 + 1
    assert {r["unit"] for r in long if r["parameter"] == "gamma"} == {"s^-m"}
    assert long[-1]["status"] == FAILED and long[-1]["parameter"] == ""
    assert fig.stat().st_size > 10_000


def test_fit_batch_refuses_half_the_distributed_options(capsys):
    assert main(["fit-batch", CAMPAIGNS[0], "--num-processes", "2"]) == 2
    assert "give all three" in capsys.readouterr().err


@pytest.mark.slow
def test_two_processes_give_the_one_process_batch(tmp_path):
    """`stickslip fit-batch` started on 2 processes (jax.distributed on localhost, gloo)
    fits each campaign once, and process 0 writes the results of one process."""
    exe = str(Path(sys.executable).with_name("stickslip"))
    port = str(free_port())
    outs = [tmp_path / f"b{i}.json" for i in range(2)]
    procs = [subprocess.Popen([exe, "fit-batch", *CAMPAIGNS, "--json", str(outs[i]),
                               "--coordinator", f"localhost:{port}", "--num-processes", "2",
                               "--process-id", str(i)], stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True) for i in range(2)]
    logs = [p.communicate(timeout=600)[0] for p in procs]
    for p, log in zip(procs, logs):
        assert p.returncode == 0, log[-3000:]
    assert outs[0].exists() and not outs[1].exists()  # process 0 writes
    assert "2 processes" in logs[0]
    two = json.loads(outs[0].read_text())
    assert sorted(r["process"] for r in two["campaigns"]) == [0, 0, 1] or \
        sorted(r["process"] for r in two["campaigns"]) == [0, 1, 1]
    one_out = tmp_path / "one.json"
    run = subprocess.run([exe, "fit-batch", *CAMPAIGNS, "-q", "--json", str(one_out)],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    one = json.loads(one_out.read_text())
    for a, b in zip(one["campaigns"], two["campaigns"]):
        assert a["campaign"] == b["campaign"] and a["status"] == b["status"] == FITTED
        for name, p in a["result"]["parameters"].items():
            value = b["result"]["parameters"][name]["value"]
            if p["value"] is None:  # a parameter the campaign cannot determine
                assert value is None, name
            else:
                assert value == pytest.approx(p["value"], rel=1e-9), name
