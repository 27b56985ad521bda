"""Nothing the user gave us is overwritten or lost (issue: output safety).

Every output path is checked before any work starts (an input record, a folder, a
missing folder, two options naming one file), and files are written atomically (a
failure while writing leaves the previous file, and no temporary file)."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import pytest

from stickslip_jax.cli import main
from stickslip_jax import output as _output

EXAMPLES = sorted(Path(__file__).resolve().parents[1].joinpath("data", "examples").glob("*.csv"))


def _hash(p) -> str:
    return hashlib.sha256(Path(p).read_bytes()).hexdigest()


@pytest.fixture
def camp(tmp_path):
    out = []
    for p in EXAMPLES[:3]:
        q = tmp_path / p.name
        q.write_bytes(p.read_bytes())
        out.append(q)
    return out


@pytest.mark.parametrize("command,option", [("fit", "--json"), ("fit", "--plot"),
                                            ("mcmc", "--json"), ("mcmc", "--corner"),
                                            ("discover", "--json"), ("discover", "--plot")])
def test_output_naming_an_input_is_refused(camp, command, option, capsys):
    before = [_hash(p) for p in camp]
    code = main([command, *map(str, camp), option, str(camp[1])])
    err = capsys.readouterr().err
    assert code == 2 and "input record" in err and option in err
    assert [_hash(p) for p in camp] == before


def test_pitch_output_naming_an_input_is_refused(camp, capsys):
    before = _hash(camp[0])
    assert main(["pitch", str(camp[0]), "--json", str(camp[0])]) == 2
    assert "input record" in capsys.readouterr().err and _hash(camp[0]) == before


def test_plot_of_a_record_named_png_keeps_the_record(tmp_path, capsys):
    rec = tmp_path / "run.png"
    rec.write_bytes(EXAMPLES[0].read_bytes())
    before = _hash(rec)
    assert main(["plot", str(rec)]) == 2
    assert "input record" in capsys.readouterr().err and _hash(rec) == before


@pytest.mark.parametrize("target", ["folder", "missing/out.json", ""])
def test_bad_output_paths_are_one_line_errors(camp, tmp_path, target, capsys):
    path = {"folder": str(tmp_path), "missing/out.json": str(tmp_path / "missing" / "o.json"),
            "": ""}[target]
    assert main(["fit", *map(str, camp), "--json", path]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--json" in err[0]


@pytest.mark.parametrize("out", ["folder", "", "missing/x.csv"])
def test_simulate_bad_out_is_one_line(tmp_path, out, capsys):
    path = {"folder": str(tmp_path), "": "", "missing/x.csv": str(tmp_path / "no" / "x.csv")}[out]
    code = main(["simulate", "--lubricant", "A", "--weight", "36", "--stiffness", "86.9",
                 "--speed", "10", "--duration", "1", "--out", path])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--out" in err[0]


def test_simulate_huge_seed_is_one_line(tmp_path, capsys):
    code = main(["simulate", "--lubricant", "A", "--weight", "36", "--stiffness", "86.9",
                 "--speed", "10", "--duration", "1", "--seed", "99999999999999999999999",
                 "--out", str(tmp_path / "x.csv")])
    assert code == 2 and "--seed" in capsys.readouterr().err
    assert not (tmp_path / "x.csv").exists()


def test_two_options_naming_one_file_are_refused(camp, tmp_path, capsys):
    same = str(tmp_path / "out.json")
    assert main(["fit", *map(str, camp), "--json", same, "--plot", same]) == 2
    assert "same file" in capsys.readouterr().err


def test_failed_write_keeps_the_previous_file(tmp_path, monkeypatch):
    target = tmp_path / "result.json"
    target.write_text('{"previous": true}')

    def boom(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError):
        _output.write_json(str(target), {"new": 1})
    assert json.loads(target.read_text()) == {"previous": True}
    assert [p.name for p in tmp_path.iterdir()] == ["result.json"]  # no temporary left


def test_json_is_strict():
    text = json.dumps(_output.strict_json({"a": float("nan"), "b": [1.0, float("inf")]}),
                      allow_nan=False)
    assert json.loads(text) == {"a": None, "b": [1.0, None]}


def test_outputs_get_the_usual_permissions(tmp_path):
    """Atomic writes go through a private temporary file; the output must still get the
    permissions a plain `open` gives (or keep those of the file it replaces)."""
    umask = os.umask(0o022)
    try:
        new = tmp_path / "new.json"
        _output.write_json(str(new), {"a": 1})
        assert new.stat().st_mode & 0o777 == 0o644
        old = tmp_path / "old.json"
        old.write_text("{}")
        old.chmod(0o640)
        _output.write_json(str(old), {"a": 2})
        assert old.stat().st_mode & 0o777 == 0o640
    finally:
        os.umask(umask)


@pytest.mark.parametrize("fix, message", [
    (["n=1", "n=2"], "given twice"),
    (["n=1e308"], "outside the physical range 0.02-5"),
    (["delta=1e-300"], "outside the physical range"),
    (["mu_s=0.2", "mu_d=0.3"], "must exceed mu_d"),
    (["mu_s=0.56", "mu_d=0.21", "gamma=0.38", "m=0.4", "delta=67", "n=1"], "nothing is left"),
    (["h_e=0.001"], "expected NAME=VALUE"),
])
def test_fixed_values_are_checked_before_fitting(fix, message, capsys):
    """Issue 21: duplicate, out-of-range, contradictory or all-fixed --fix values were
    taken silently (or crashed); now one line naming the option, exit 2, before any fit."""
    args = ["fit", *map(str, EXAMPLES)]
    for f in fix:
        args += ["--fix", f]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--fix" in err[0] and message in err[0], err


def test_fixed_mu_s_is_reported_exactly_and_a_misfit_is_said(tmp_path, capsys):
    """Issue 21: `--fix mu_s=0.3` printed 'mu_s 0.31722 fixed'; a fixed value that the
    records contradict now says so instead of a quiet 'converged'."""
    out = tmp_path / "f.json"
    assert main(["fit", *map(str, EXAMPLES), "--fix", "mu_s=0.3", "--json", str(out)]) == 0
    rep = json.loads(out.read_text())
    assert rep["parameters"]["mu_s"]["value"] == 0.3 and rep["parameters"]["mu_s"]["fixed"]
    assert any("incompatible" in w for w in rep["identifiability"]["warnings"])
    assert "incompatible" in capsys.readouterr().out


def test_a_copy_under_another_name_is_refused(tmp_path, capsys):
    """Issue 21: a byte-identical record under another name was counted twice."""
    import shutil

    for p in EXAMPLES[:3]:
        shutil.copy(p, tmp_path / p.name)
    shutil.copy(EXAMPLES[0], tmp_path / "copy.csv")
    assert main(["fit", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "same content as" in err and "copy.csv" in err


def test_printed_json_is_strict(capsys):
    """Issue 21: `steady --stiffness 1e308 --json` printed Infinity/NaN tokens."""
    assert main(["steady", "--weight", "36", "--stiffness", "1e308", "--speed", "5",
                 "--json"]) == 0
    text = capsys.readouterr().out

    def refuse(token):
        raise ValueError(token)

    doc = json.loads(text, parse_constant=refuse)
    assert doc["results"][0]["critical_speed_mm_min"] is None


def test_posterior_draws_outside_the_domain_are_refused(tmp_path, capsys):
    """Issue 21: `design --posterior` accepted draws with mu_s < 0 or mu_s < mu_d and
    reported v_c = -15.4 mm/min; `plan` proposed records from such a prior."""
    names = ["mu_s", "mu_d", "gamma", "m", "delta", "n"]
    good = [0.56, 0.21, 0.38, 0.4, 67.0, 1.0]
    draws = [good, [0.15, 0.21, 0.38, 0.4, 67.0, 1.0], [-0.3, 0.21, 0.38, 0.4, 67.0, 1.0]]
    post = tmp_path / "post.json"
    post.write_text(json.dumps({"names": names, "samples": draws}))
    assert main(["design", "--posterior", str(post), "--weight", "36", "--stiffness", "86.9",
                 "--speed", "1:100:4:log", "--json"]) == 2
    err = capsys.readouterr().err
    assert "2 of 3 draws" in err and "mu_s <= mu_d in 2" in err and "mu_s <= 0 in 1" in err
    prior = tmp_path / "prior.json"
    prior.write_text(json.dumps({"mean": dict(zip(names, [0.2, 0.3, 0.38, 0.4, 67.0, 1.0]))}))
    assert main(["plan", str(prior)]) == 2
    assert "mu_s <= mu_d" in capsys.readouterr().err


def test_noise_free_record_gets_the_noise_floor():
    """Issue 21: a noise-free record's noise estimate is floored (10 nm) and said so."""
    import numpy as np

    import stickslip_jax as ss
    from stickslip_fitting.features import NOISE_FLOOR, record_features
    from stickslip_fitting.synthetic import synthetic_campaign

    rec = synthetic_campaign(ss.lubricant("A"), speed_fractions=(0.05,), cycles=3, seed=0,
                             noise=0.0)[0]
    f = record_features(rec)
    assert f.noise == NOISE_FLOOR and f.stick_slip
    assert "below the 10 nm floor" in f.noise_note
    # plateau levels average many samples: their errors are the floor over sqrt(samples)
    assert np.all(f.trough_sd[f.complete] > 1e-3 * NOISE_FLOOR)


def test_huge_design_grid_and_plan_budget_are_refused(capsys):
    """Issue 21: a 3000^3 design grid died with ArrayMemoryError, `plan --budget 100000`
    ran for minutes with no output; both are refused at once, naming the option."""
    assert main(["design", "--weight", "10:60:3000", "--stiffness", "10:100:3000",
                 "--speed", "1:100:3000", "--json"]) == 2
    err = capsys.readouterr().err
    assert "--weight/--stiffness/--speed" in err and "GiB" in err
    truth = str(EXAMPLES[0].parent / "truth.json")
    assert main(["plan", truth, "--budget", "100000"]) == 2
    assert "--budget" in capsys.readouterr().err


def test_mcmc_seed_out_of_range_names_the_option(capsys):
    assert main(["mcmc", *map(str, EXAMPLES), "--seed", "-1"]) == 2
    assert "--seed" in capsys.readouterr().err


def test_ctrl_c_during_mcmc_keeps_the_chain(tmp_path):
    """Issue 21: Ctrl-C during `mcmc` printed a long traceback and lost the chain. Now: exit
    130, one line, and the chain so far summarised and written (subprocess with SIGINT)."""
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "m.json"
    proc = subprocess.Popen(
        [sys.executable, "-m", "stickslip_jax.cli", "mcmc", *map(str, EXAMPLES), "--walkers",
         "16", "--steps", "1000000", "--no-progress", "--json", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env=dict(os.environ, STICKSLIP_CACHE_DIR=""))
    t0 = time.time()
    line = ""
    while "sampling:" not in line and time.time() - t0 < 240:
        line = proc.stderr.readline()
        if not line and proc.poll() is not None:
            break
    assert "sampling:" in line, proc.stderr.read()
    time.sleep(15)  # compile the log-posterior and take some steps (slower on a loaded machine)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr[-2000:]
    assert "Traceback" not in stderr and "interrupted" in stderr
    rep = json.loads(out.read_text())
    assert rep["interrupted"] and len(rep["samples"]) > 0
    assert "interrupted after" in stdout


def test_ctrl_c_during_a_trace_fit_is_one_line(tmp_path):
    """Issue 21: Ctrl-C during `fit --objective trace` printed a long traceback."""
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "f.json"
    proc = subprocess.Popen(
        [sys.executable, "-m", "stickslip_jax.cli", "fit", *map(str, EXAMPLES), "--objective",
         "trace", "--json", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, env=dict(os.environ, STICKSLIP_CACHE_DIR=""))
    t0 = time.time()
    line = ""
    while "fitting" not in line and time.time() - t0 < 120:
        line = proc.stderr.readline()
        if not line and proc.poll() is not None:
            break
    assert "fitting" in line, proc.stderr.read()
    time.sleep(1.5)  # inside the fit (it takes several seconds with compilation)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr[-2000:]
    assert "Traceback" not in stderr and stderr.strip().splitlines()[-1].endswith("interrupted")
    assert not out.exists()  # no partial output


def test_debug_shows_the_traceback(tmp_path, capsys):
    """Issue 20: every ValueError became one line with no way to see the traceback."""
    missing = str(tmp_path / "nowhere.csv")
    assert main(["fit", missing]) == 2
    assert "Traceback" not in capsys.readouterr().err
    with pytest.raises((ValueError, FileNotFoundError)):
        main(["--debug", "fit", missing])


def test_a_fit_that_did_not_converge_exits_3(monkeypatch, capsys):
    """Issue 20: a fit that did not converge exited 0."""
    import dataclasses

    import stickslip_fitting.commands.fit as fit_command

    real = fit_command.fit_from_args

    def not_converged(args, **kwargs):
        fit, campaign, extra = real(args, **kwargs)
        return dataclasses.replace(fit, converged=False), campaign, extra

    monkeypatch.setattr(fit_command, "fit_from_args", not_converged)
    assert main(["fit", *map(str, EXAMPLES)]) == 3
    assert "did not converge" in capsys.readouterr().err


def test_every_json_carries_the_schema_version(tmp_path, capsys):
    """Issue 20: no output carried a schema version."""
    from stickslip_jax.output import SCHEMA_VERSION

    assert main(["steady", "--weight", "36", "--stiffness", "86.9", "--speed", "5",
                 "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["schema_version"] == SCHEMA_VERSION
    out = tmp_path / "f.json"
    assert main(["fit", *map(str, EXAMPLES), "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert list(doc)[0] == "schema_version" and doc["schema_version"] == SCHEMA_VERSION


def test_times_in_messages_are_plain_numbers(tmp_path, capsys):
    """Issue 21: times were shown as `np.float64(0.2) s`."""
    text = (EXAMPLES[0].read_text().splitlines())
    head = [ln for ln in text if ln.startswith("#") or not ln[:1].isdigit()]
    rows = [ln for ln in text if ln[:1].isdigit()][:50]
    rows[10], rows[11] = rows[11], rows[10]  # time goes back once
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(head + rows) + "\n")
    assert main(["plot", str(bad), "--out", str(tmp_path / "p.png")]) == 2
    err = capsys.readouterr().err
    assert "time" in err and "np.float64" not in err


def test_negative_grid_start_names_the_option(capsys):
    """Issue 21: `--speed -10:60:5` gave argparse's 'expected one argument'."""
    assert main(["design", "--weight", "36", "--stiffness", "86.9", "--speed", "-10:60:5",
                 "--json"]) == 2
    err = capsys.readouterr().err
    assert "--speed" in err and "positive" in err and "expected one argument" not in err


def test_leading_blank_lines_are_ignored(tmp_path, capsys):
    """Issue 21: a leading blank line was refused although blank lines are ignored."""
    rec = tmp_path / "blank.csv"
    rec.write_text("\n\n" + EXAMPLES[0].read_text())
    assert main(["plot", str(rec), "--out", str(tmp_path / "p.png")]) == 0
