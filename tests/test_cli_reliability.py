"""Commands that must not lose data, answer wrongly, fail with a traceback or hang: an
existing record kept, a command's outputs written all or none, options that cannot act
refused, priors checked, the steady amplitude never negative, a job that waits for its
processes saying so and giving up with one line."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from cli_safety import EXAMPLES, copy_records, one_line, run_checked
from stickslip_jax.cli import main
from stickslip_jax.output import outputs_together, write_json, write_text

SIM = ["simulate", "--weight", "36", "--stiffness", "86.9", "--speed", "20",
       "--duration", "0.5"]


def test_simulate_keeps_an_existing_record_unless_force(tmp_path, capsys):
    out = tmp_path / "rec.csv"
    out.write_text("keep me")
    _, err = run_checked([*SIM, "--out", out], capsys, tmp_path, 2)
    one_line(err, "--out", "exists", "--force")
    assert out.read_text() == "keep me"
    assert main([*SIM, "--out", str(out), "--force"]) == 0
    assert out.read_text().startswith("# stickslip-record: 1")


def test_outputs_of_one_command_are_all_or_none(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.txt"
    with pytest.raises(RuntimeError):
        with outputs_together():
            write_json(str(a), {"x": 1})
            write_text(str(b), "text")
            assert not a.exists() and not b.exists()  # not yet: renamed at the end
            raise RuntimeError("the figure failed")
    assert not a.exists() and not b.exists() and os.listdir(tmp_path) == []
    with outputs_together():
        write_json(str(a), {"x": 1})
        write_text(str(b), "text")
    assert json.loads(a.read_text()) == {"x": 1} and b.read_text() == "text"


def test_a_figure_name_is_checked_before_the_fit(tmp_path, capsys):
    copy_records(tmp_path, EXAMPLES[:2])
    _, err = run_checked(["fit", tmp_path, "--json", tmp_path / "out.json", "--plot",
                          tmp_path / "fit.xyz"], capsys, tmp_path, 2)
    one_line(err, "--plot", ".xyz", ".png")


@pytest.mark.parametrize("argv, words", [
    (["fit", "{d}", "--surface", "S2G2"], ["--surface", "--model microsqueeze"]),
    (["mcmc", "{d}", "--surface", "S2G2"], ["--surface", "--model microsqueeze"]),
    (["fit-batch", "{d}", "--fix", "mu_s=5"], ["--fix", "mu_s", "physical range"]),
    (["fit-batch", "{d}", "--surface", "S1G1"], ["--surface", "--model microsqueeze"]),
    (["discover", "{d}", "--threshold", "5"], ["--threshold", "--base smooth"]),
    (["discover", "{d}", "--crop", "none"], ["--crop", "--base smooth"]),
])
def test_options_that_cannot_act_or_are_out_of_range_exit_2(tmp_path, capsys, argv, words):
    copy_records(tmp_path, EXAMPLES[:2])
    _, err = run_checked([a.format(d=tmp_path) for a in argv], capsys, tmp_path, 2)
    one_line(err, *words)


def test_steady_tolerance_and_huge_speeds(capsys):
    base = ["steady", "--weight", "36", "--stiffness", "86.9"]
    assert main([*base, "--speed", "5", "--tolerance", "1"]) == 0  # 1 mm: every speed
    out, err = capsys.readouterr()
    assert "at every drive speed" in out and "Traceback" not in err
    assert main([*base, "--speed", "1e300", "--json", "-"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert all(r["cycle_amplitude_mm"] >= 0 for r in doc["results"])


@pytest.fixture
def plan_dir(tmp_path):
    good = {"mu_s": 0.5, "mu_d": 0.2, "gamma": 0.4, "m": 0.4, "delta": 67, "n": 1}
    for name, change in {"huge": {"delta": 2e12, "n": 2.4e116}, "text": {"n": "one"},
                         "null": {"gamma": None}}.items():
        (tmp_path / f"{name}.json").write_text(json.dumps({"mean": {**good, **change}}))
    (tmp_path / "nan.json").write_text(json.dumps({"mean": good}).replace("1}", "NaN}"))
    (tmp_path / "ragged.json").write_text(json.dumps(
        {k: [v, v] if k != "mu_d" else [v] for k, v in good.items()}))
    copy_records(tmp_path, EXAMPLES[:1])
    return tmp_path


@pytest.mark.parametrize("argv, words", [
    (["{d}/huge.json"], ["huge.json", "delta = 2e+12", "physical range"]),
    (["{d}/nan.json"], ["nan.json", "n is NaN"]),
    (["{d}/text.json"], ["text.json", "n is \"one\""]),
    (["{d}/null.json"], ["null.json", "gamma is null"]),
    (["{d}/ragged.json"], ["ragged.json"]),
    (["A", "{rec}", "{rec}"], ["named twice"]),
    (["A", "{rec}", "--json", "{rec}"], ["--json", "record file"]),
])
def test_plan_refuses_bad_priors_and_records_named_twice(plan_dir, capsys, argv, words):
    rec = plan_dir / EXAMPLES[0].name
    argv = ["plan", *[a.format(d=plan_dir, rec=rec) for a in argv], "--budget", "1"]
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse: --json naming a record
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2, err
    one_line(err, *words)


def test_fit_batch_says_it_waits_and_gives_up_with_one_line(tmp_path):
    copy_records(tmp_path, EXAMPLES[:2])
    from ports import free_port

    got = subprocess.run(
        [sys.executable, "-m", "stickslip_jax.cli", "fit-batch", str(tmp_path),
         "--coordinator", f"localhost:{free_port()}", "--num-processes", "2",
         "--process-id", "0", "--join-timeout", "3"],
        capture_output=True, text=True, timeout=120)
    assert got.returncode == 2, got.stderr
    lines = got.stderr.strip().splitlines()
    assert "waiting for the others" in lines[0]
    assert "not all 2 processes joined within 3 s" in lines[-1] and len(lines) == 2


def test_a_fixed_value_is_reported_exactly(tmp_path, capsys):
    """A held value is stored as its logarithm; the report gives back the value given."""
    copy_records(tmp_path, EXAMPLES[:2])
    out = tmp_path / "fit.json"
    assert main(["fit", str(tmp_path), "--fix", "delta=67", "--json", str(out)]) == 0
    row = json.loads(out.read_text())["parameters"]["delta"]
    assert row["fixed"] and row["value"] == 67.0


def test_ctrl_c_while_drawing_leaves_neither_output(tmp_path, capsys, monkeypatch):
    """`fit --json out.json --plot fit.png` interrupted while the figure is drawn: exit 130
    and no output at all (an existing out.json kept), not a new JSON without its figure."""
    import stickslip_fitting.report.plots as plots

    copy_records(tmp_path, EXAMPLES[:3])
    old = tmp_path / "out.json"
    old.write_text('{"previous": true}')

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(plots, "fit_figure", interrupted)
    run_checked(["fit", tmp_path, "--json", old, "--plot", tmp_path / "fit.png"], capsys,
                tmp_path, 130)
    assert old.read_text() == '{"previous": true}'


def test_plan_counts_a_copy_of_a_record_once(tmp_path, capsys):
    rec = copy_records(tmp_path, EXAMPLES[:1])[0]
    copy = tmp_path / "copy.csv"
    copy.write_bytes(rec.read_bytes().replace(b"\n", b"\r\n"))
    assert main(["plan", "A", str(rec), str(copy), "--budget", "1", "--weights", "36",
                 "--stiffnesses", "86.9", "--speeds", "1,5"]) == 0
    assert "1 existing record(s)" in capsys.readouterr().out
