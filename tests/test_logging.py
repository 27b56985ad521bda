"""Progress through `logging`: the long commands (fit, mcmc, discover,
design, plan) write stage lines with the time since the command started to stderr through
the `stickslip` logger; `--quiet` sets it to WARNING (no lines), `stickslip --debug` to
DEBUG; used as a library the package prints nothing. (discover's lines, from the same
logger, are checked in `tests/test_cycle_discovery.py`.)"""

from __future__ import annotations

import logging
import pathlib
import re
import subprocess
import sys

import pytest

from stickslip_jax.cli import main
from stickslip_jax.logs import LOGGER_NAME, configure, logger

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLES = sorted(str(p) for p in (ROOT / "data" / "examples").glob("*.csv"))
LINE = re.compile(r"^stickslip (?P<command>[a-z]+) \[\s*(?P<t>\d+\.\d) s\] (?P<msg>.*)$")


def _stages(err: str, command: str) -> list[tuple[float, str]]:
    """(elapsed s, message) of the stage lines in `err`; every stage line is well formed."""
    out = []
    for line in err.splitlines():
        if line.startswith(f"stickslip {command} ["):
            m = LINE.match(line)
            assert m and m["command"] == command, line
            out.append((float(m["t"]), m["msg"]))
    return out


def _assert_in_order(stages, *needles):
    msgs = [m for _, m in stages]
    at = [next(i for i, m in enumerate(msgs) if n in m) for n in needles]
    assert at == sorted(at), (needles, msgs)
    times = [t for t, _ in stages]
    assert times == sorted(times) and times[0] >= 0.0


def test_plan_stage_lines_through_the_stickslip_logger(capsys, caplog):
    with caplog.at_level(logging.INFO, logger=LOGGER_NAME):
        assert main(["plan", "A", "--budget", "1"]) == 0
    stages = _stages(capsys.readouterr().err, "plan")
    _assert_in_order(stages, "choosing 1 of", "plan done")
    records = [r for r in caplog.records if r.name == LOGGER_NAME]
    assert {r.levelno for r in records} == {logging.INFO}
    assert any("choosing 1 of" in r.getMessage() for r in records)


def test_quiet_sets_warning_and_debug_sets_debug(capsys):
    assert main(["plan", "A", "--budget", "1", "--quiet"]) == 0
    assert logger.level == logging.WARNING
    assert capsys.readouterr().err == ""
    assert main(["--debug", "plan", "A", "--budget", "1"]) == 0
    assert logger.level == logging.DEBUG
    err = capsys.readouterr().err
    assert re.search(r"^stickslip plan \[\s*\d+\.\d s\] debug: arguments: --debug plan A "
                     r"--budget 1$", err, re.M), err
    assert "choosing 1 of" in err
    # --quiet wins over nothing else: a plain run is back at INFO
    assert main(["plan", "A", "--budget", "1"]) == 0
    assert logger.level == logging.INFO and "debug:" not in capsys.readouterr().err


def test_design_stage_lines(capsys):
    assert main(["design", "--weight", "36", "--stiffness", "86.9", "--speed", "1:10:3"]) == 0
    stages = _stages(capsys.readouterr().err, "design")
    _assert_in_order(stages, "map of 1 x 1 x 3 = 3 points (method steady)", "map done")
    assert main(["design", "--weight", "36", "--stiffness", "86.9", "--speed", "1:10:3",
                 "-q"]) == 0
    assert _stages(capsys.readouterr().err, "design") == []


def test_input_errors_stay_one_line(capsys):
    """Stage lines start after the inputs are checked: a bad input is still one line."""
    assert main(["design", "--lubricant", "Z", "--weight", "36", "--stiffness", "86.9",
                 "--speed", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--lubricant" in err[0]


def test_fit_and_mcmc_stage_lines(capsys):
    assert main(["fit", *EXAMPLES]) == 0
    captured = capsys.readouterr()
    stages = _stages(captured.err, "fit")
    _assert_in_order(stages, "fitting 12 records (objective features, model empirical)",
                     "fit converged", "report done")
    assert "mu_s" in captured.out and "fitting 12" not in captured.out  # the table: stdout
    # the fit's records and test_json_keys's walkers: their compiled programs
    assert main(["mcmc", *EXAMPLES, "--steps", "12", "--walkers", "12"]) == 0
    stages = _stages(capsys.readouterr().err, "mcmc")
    _assert_in_order(stages, "fitting 12 records", "sampling: 12 walkers x 12 steps",
                     "sampling done: acceptance")
    assert main(["mcmc", *EXAMPLES, "--steps", "12", "--walkers", "12", "--quiet"]) == 0
    assert _stages(capsys.readouterr().err, "mcmc") == []


def test_formatter_counts_from_the_start_and_names_levels(capsys):
    configure("fit", start=0.0)  # the epoch: elapsed is now
    logger.warning("careful")
    err = capsys.readouterr().err
    m = LINE.match(err.strip())
    assert m and m["msg"] == "warning: careful" and float(m["t"]) > 1e9
    configure("fit")
    logger.info("one")
    assert _stages(capsys.readouterr().err, "fit")[0][0] < 1.0
    assert len(logger.handlers) == 1  # configure twice: one handler


def test_the_library_prints_nothing():
    """Imported as a library (no command line), the stage lines stay silent."""
    code = ("import stickslip_jax.logs as L, logging; "
            "L.logger.info('stage'); logging.getLogger('stickslip').debug('detail')")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60)
    assert run.returncode == 0 and run.stderr == "" and run.stdout == ""


@pytest.fixture(autouse=True)
def _restore_logger():
    level = logger.level
    yield
    logger.setLevel(level)
