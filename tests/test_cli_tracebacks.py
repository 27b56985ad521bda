"""No tracebacks and no hangs: bad output paths, huge seeds, grids and plans too large
for memory, a sampler that cannot start and Ctrl-C are one line on stderr with the right
exit code (2 bad input, 130 interrupted), never a Python traceback, a hang or a partial
file.

Each case asserts the exit code, that no input changed and that no output but the
expected one exists (`cli_safety.run_checked`; the Ctrl-C cases run a subprocess and
send it SIGINT)."""

from __future__ import annotations

import json

import pytest
from cli_safety import EXAMPLES, TRUTH, copy_records, interrupt, one_line, run_checked, snapshot

SIMULATE = ["simulate", "--lubricant", "A", "--weight", "36", "--stiffness", "86.9",
            "--speed", "10", "--duration", "1"]


@pytest.mark.parametrize("target", ["folder", "empty", "missing folder", "inside a file"])
def test_simulate_bad_out_is_one_line(tmp_path, target, capsys):
    """`simulate --out DIR`, `--out ''`, `--out file/x.csv`: one line, no Python
    traceback."""
    rec = copy_records(tmp_path, EXAMPLES[:1])[0]
    path = {"folder": tmp_path, "empty": "", "missing folder": tmp_path / "no" / "x.csv",
            "inside a file": rec / "x.csv"}[target]
    _, err = run_checked([*SIMULATE, "--out", path], capsys, tmp_path, 2)
    one_line(err, "--out")


@pytest.mark.parametrize("seed", ["99999999999999999999999", "-1"])
def test_simulate_seed_out_of_range_is_one_line(tmp_path, seed, capsys):
    _, err = run_checked([*SIMULATE, "--seed", seed, "--out", tmp_path / "x.csv"], capsys,
                         tmp_path, 2)
    one_line(err, "--seed")


@pytest.mark.parametrize("command", ["fit", "mcmc", "pitch", "discover"])
@pytest.mark.parametrize("target", ["folder", "missing/out.json", ""])
def test_json_to_a_bad_path_is_one_line(tmp_path, command, target, capsys):
    """`--json DIR`, a missing folder or an empty name (fit, mcmc, pitch, discover): one
    line naming --json, exit 2, no Python traceback."""
    records = copy_records(tmp_path / "records", EXAMPLES[:3 if command != "pitch" else 1])
    path = {"folder": tmp_path, "missing/out.json": tmp_path / "missing" / "o.json",
            "": ""}[target]
    _, err = run_checked([command, *records, "--json", path], capsys, tmp_path, 2)
    one_line(err, "--json")


def test_huge_design_grid_is_refused_with_its_size(tmp_path, capsys):
    """A 3000^3 design grid is refused with its size, not left to die with
    ArrayMemoryError."""
    _, err = run_checked(["design", "--weight", "10:60:3000", "--stiffness", "10:100:3000",
                          "--speed", "1:100:3000", "--json"], capsys, tmp_path, 2)
    one_line(err, "--weight/--stiffness/--speed", "3000 x 3000 x 3000", "GiB")


def _machine_memory(monkeypatch, gib: float) -> None:
    """This machine's memory as `check_memory` sees it (the cases below do not depend on
    the machine they run on)."""
    import os

    pages = {"SC_PAGE_SIZE": 4096, "SC_PHYS_PAGES": int(gib * 2**30) // 4096}
    real = os.sysconf
    monkeypatch.setattr(os, "sysconf", lambda name: pages.get(name) or real(name))


def test_design_memory_counts_points_times_draws(tmp_path, capsys, monkeypatch):
    """`design --posterior --max-amplitude` holds every draw's limit cycle at every grid
    point: points x draws (10^3 x 20,000 draws, about 1.2 GiB), not the grid alone
    (8 MB), is what the check must weigh; without --max-amplitude the draws are not
    weighed."""
    _machine_memory(monkeypatch, 1.0)
    post = tmp_path / "post.csv"
    post.write_text("mu_s,mu_d,gamma,m,delta,n\n"
                    + "0.58,0.21,0.38,0.39,67,1\n" * 20_000)
    grid = ["--weight", "10:60:10", "--stiffness", "20:150:10", "--speed", "1:60:10"]
    _, err = run_checked(["design", "--posterior", post, *grid, "--max-amplitude", "1um",
                          "--json", tmp_path / "map.json"], capsys, tmp_path, 2)
    line = one_line(err, "--weight/--stiffness/--speed", "10 x 10 x 10", "20000 draws",
                    "--max-amplitude", "GiB", "fewer draws")
    assert "needs about 1.19 GiB" in line  # 1000 x 20000 x 64 bytes, plus the grid's share
    # without --max-amplitude the draws stream in chunks: the same grid with a tenth of
    # the draws on a fifth of the memory is refused with --max-amplitude (0.12 GiB against
    # 0.1) and not refused without it
    _machine_memory(monkeypatch, 0.2)
    post.write_text("mu_s,mu_d,gamma,m,delta,n\n" + "0.58,0.21,0.38,0.39,67,1\n" * 2_000)
    _, err = run_checked(["design", "--posterior", post, *grid, "--max-amplitude", "1um",
                          "--quiet"], capsys, tmp_path, 2)
    assert "2000 draws" in one_line(err, "--weight/--stiffness/--speed", "GiB")
    assert run_checked(["design", "--posterior", post, *grid, "--quiet"], capsys, tmp_path,
                       0)


def test_design_memory_counts_the_outputs(tmp_path, capsys, monkeypatch):
    """300^3 points with 2 draws and --json would reach 6.8 GB: the JSON lists hold
    about 1.6 kB a point, which the check counts (and it says how to do without them)."""
    _machine_memory(monkeypatch, 4.0)
    post = tmp_path / "post.csv"
    post.write_text("mu_s,mu_d,gamma,m,delta,n\n0.58,0.21,0.38,0.39,67,1\n"
                    "0.6,0.2,0.4,0.4,66,1\n")
    _, err = run_checked(["design", "--posterior", post, "--weight", "10:60:300",
                          "--stiffness", "20:150:300", "--speed", "1:60:300", "--json",
                          tmp_path / "map.json"], capsys, tmp_path, 2)
    line = one_line(err, "--weight/--stiffness/--speed", "300 x 300 x 300", "with --json",
                    "--netcdf instead of --json", "GiB")
    assert "draws" not in line.split("needs")[0]  # without --max-amplitude draws stream


def test_huge_plan_candidate_set_is_refused_with_its_size(tmp_path, capsys):
    """`plan` with 3000^3 candidates is refused with its size before building them (they
    would die with ArrayMemoryError)."""
    _, err = run_checked(["plan", "A", "--weights", "10:60:3000", "--stiffnesses",
                          "10:100:3000", "--speeds", "1:100:3000"], capsys, tmp_path, 2)
    one_line(err, "--weights/--stiffnesses/--speeds", "candidate records", "GiB")


def test_plan_budget_is_bounded(tmp_path, capsys):
    """`plan --budget 100000` is refused in one line with the allowed range (1-1000),
    not left running for minutes without output."""
    _, err = run_checked(["plan", TRUTH, "--budget", "100000"], capsys, tmp_path, 2)
    one_line(err, "--budget", "1-1000")


def test_mcmc_that_cannot_start_its_walkers_is_one_line(tmp_path, capsys):
    """`mcmc --fix mu_d=0.9` (a fixed value the records contradict) cannot start its
    walkers (emcee: 'Initial state has a large condition number'): one line that says
    what to do."""
    records = copy_records(tmp_path, EXAMPLES)
    _, err = run_checked(["mcmc", *records, "--fix", "mu_d=0.9", "--walkers", "16", "--steps",
                          "20", "-q", "--json", tmp_path / "m.json"], capsys, tmp_path, 2)
    one_line(err, "walkers cannot start", "stickslip fit", "--fix")


@pytest.mark.slow  # 25 s; the default suite took 9.5-10.6 min on 2 cores (target 10); CI runs slow tests
def test_ctrl_c_during_mcmc_keeps_the_chain(tmp_path):
    """Ctrl-C during `mcmc`: exit 130, one line, no traceback, and the chain so far
    summarised and written (subprocess with SIGINT)."""
    records = copy_records(tmp_path, EXAMPLES)
    before = snapshot(tmp_path)
    out = tmp_path / "m.json"
    # 15 s: compile the log-posterior and take some steps (slower on a loaded machine)
    code, stdout, stderr = interrupt(
        ["mcmc", *records, "--walkers", "16", "--steps", "1000000", "--no-progress", "--json",
         out], "sampling:", 15.0, tmp_path)
    assert code == 130, stderr[-2000:]
    assert "Traceback" not in stderr and "interrupted" in stderr.strip().splitlines()[-1]
    rep = json.loads(out.read_text())
    assert rep["interrupted"] and len(rep["samples"]) > 0
    assert "interrupted after" in stdout
    after = snapshot(tmp_path)
    assert {p: after[p] for p in before} == before  # inputs unchanged
    assert set(after) - set(before) == {"m.json"}  # the chain so far, nothing partial


def test_ctrl_c_during_a_trace_fit_is_one_line(tmp_path):
    """Ctrl-C during `fit --objective trace`: one line, no traceback."""
    records = copy_records(tmp_path, EXAMPLES)
    before = snapshot(tmp_path)
    code, _, stderr = interrupt(["fit", *records, "--objective", "trace", "--json",
                                 tmp_path / "f.json"], "fitting", 1.5, tmp_path)
    assert code == 130, stderr[-2000:]
    assert "Traceback" not in stderr and stderr.strip().splitlines()[-1].endswith("interrupted")
    assert snapshot(tmp_path) == before  # inputs unchanged, no partial output


SIMULATING = ("import sys, time; import stickslip_jax.simulation.synthetic as s; "
              "s.synthetic_record = lambda *a, **k: (print('simulating', file=sys.stderr, "
              "flush=True), time.sleep(120)); ")
"""`simulate`'s simulation replaced by two minutes of waiting that say when they start."""


def test_ctrl_c_during_simulate_is_one_line(tmp_path):
    """Ctrl-C while `simulate` simulates: one line, no traceback, no record (the command
    alone, its simulation a wait: 4 s instead of 20; the compiled simulation:
    `test_ctrl_c_while_simulate_compiles_is_one_line`, slow)."""
    code, _, stderr = interrupt([*SIMULATE[:-2], "--duration", "2000", "--out",
                                 tmp_path / "long.csv"], "simulating", 0.5, tmp_path,
                                prelude=SIMULATING)
    assert code == 130, stderr[-2000:]
    assert "Traceback" not in stderr and stderr.strip().splitlines()[-1].endswith("interrupted")
    assert snapshot(tmp_path) == {}


@pytest.mark.slow  # 20 s: the simulator's compilation, which Ctrl-C waits for
def test_ctrl_c_while_simulate_compiles_is_one_line(tmp_path):
    """Ctrl-C during `simulate`: one line, no traceback, and no partial record left."""
    code, _, stderr = interrupt(
        ["simulate", "--lubricant", "A", "--weight", "36", "--stiffness", "86.9", "--speed",
         "1", "--duration", "2000", "--sample-rate", "2000", "--out", tmp_path / "long.csv"],
        None, 8.0, tmp_path)  # the run takes about 25 s: imports, simulation, writing
    assert code == 130, stderr[-2000:]
    assert "Traceback" not in stderr and stderr.strip().splitlines()[-1].endswith("interrupted")
    assert snapshot(tmp_path) == {}
