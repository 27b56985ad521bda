"""Every subcommand, every option, a bad value: exit 2, one line on stderr naming what to
fix, no traceback, no file written. The options come from the parsers themselves, so a
new option is tried as soon as it exists; its bad value is the one `BAD` gives, else one
its type refuses ("abc" for a number, "bogus" for a choice, "=x" for a flag)."""

from __future__ import annotations

import argparse
import shutil
import signal

import pytest

from cli_safety import EXAMPLES, snapshot
from stickslip_jax.cli import build_parser, main

NO_FILE = "/nonexistent-folder/out"
BAD = {
    "--json": NO_FILE + ".json", "--plot": "fig.xyz", "--out": NO_FILE + ".csv",
    "--csv": NO_FILE + ".csv", "--chain": NO_FILE + ".nc", "--netcdf": NO_FILE + ".nc",
    "--fix": "mu_s=5", "--loss": "bogus", "--lubricant": "Z9", "--surface": "S9G9",
    "--drive-program": "0 s fast", "--speed": "-1", "--weight": "-36", "--stiffness": "0",
    "--duration": "-1", "--sample-rate": "0", "--noise": "-1", "--seed": "-1",
    "--smooth": "2", "--max-events": "-3", "--tolerance": "-1", "--damping-ratio": "1.5",
    "--time-col": "nosuchcolumn", "--force-col": "99", "--deflection-col": "99",
    "--drive-col": "nosuchcolumn", "--time-unit": "parsec", "--value-unit": "parsec",
    "--drive-unit": "parsec", "--mass": "-1 kg", "--delimiter": "xyz",
    "--budget": "0", "--weights": "abc", "--stiffnesses": "abc", "--speeds": "abc",
    "--prior-sd": "-1", "--top": "0", "--max-evals": "1", "--threshold": "-1",
    "--alpha": "2", "--steps": "0", "--walkers": "1", "--burn": "-1", "--draws": "0",
    "--eta": "-1", "--window": "-1", "--coordinator": "nohost", "--num-processes": "0",
    "--process-id": "-1", "--join-timeout": "0", "--level": "2", "--meet": "abc",
    "--max-amplitude": "-1", "--posterior": "/nonexistent-folder/post.json",
}
"""A bad value per option name (where the option's type does not refuse "abc" itself)."""

SKIP = {
    ("import", "--lubricant"): "a free label written to the record",
    ("simulate", "--lubricant"): None,
    ("fit-batch", "--coordinator"): "with --num-processes and --process-id only",
    ("fit-batch", "--num-processes"): "with --coordinator only",
    ("fit-batch", "--process-id"): "with --coordinator only",
}
"""(command, option) whose bad value needs other options (tried in their own tests)."""


@pytest.fixture(scope="module")
def place(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad-values")
    recs = d / "recs"
    recs.mkdir()
    for p in EXAMPLES[:3]:
        shutil.copy(p, recs / p.name)
    (d / "raw.txt").write_text("time [s];force [N]\n" + "".join(
        f"{0.001 * i:.3f};{0.1 + 0.001 * (i % 5):.4f}\n" for i in range(200)))
    return d


def _valid(place):
    rec = str(place / "recs" / EXAMPLES[0].name)
    recs = str(place / "recs")
    return {
        "steady": ["--weight", "36", "--stiffness", "86.9", "--speed", "1"],
        "simulate": ["--weight", "36", "--stiffness", "86.9", "--speed", "1",
                     "--duration", "0.5", "--out", str(place / "sim.csv")],
        "plot": [rec],
        "import": [str(place / "raw.txt"), "--out", str(place / "imp.csv"), "--time-col",
                   "time", "--force-col", "force", "--stiffness", "86.9 kgf/mm",
                   "--weight", "36 kgf", "--speed", "5 mm/min"],
        "fit": [recs], "mcmc": [recs], "discover": [recs], "pitch": [rec],
        "design": ["--weight", "36", "--stiffness", "86.9", "--speed", "1"],
        "plan": ["A"], "fit-batch": [recs],
    }


def _cases():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, p in sorted(sub.choices.items()):
        for a in p._actions:
            if isinstance(a, argparse._HelpAction) or not a.option_strings:
                continue
            opt = max(a.option_strings, key=len)
            if a.help is argparse.SUPPRESS or (name, opt) in SKIP:
                continue
            yield pytest.param(name, opt, a, id=f"{name} {opt}")


def _bad_argv(valid: list[str], opt: str, action) -> list[str]:
    argv = list(valid)
    if opt in argv:  # replace the valid value (or the group's alternative)
        i = argv.index(opt)
        del argv[i:i + 2]
    for other in ("--force-col", "--deflection-col", "--weight", "--mass"):
        if opt in ("--deflection-col", "--force-col") and other in ("--force-col",
                                                                     "--deflection-col"):
            if other in argv:
                i = argv.index(other)
                del argv[i:i + 2]
        if opt in ("--weight", "--mass") and other in ("--weight", "--mass") and other in argv:
            i = argv.index(other)
            del argv[i:i + 2]
    if action.nargs == 0:
        return argv + [f"{opt}=x"]
    if action.dest == "plot":  # a figure option under any name (mcmc --corner)
        value = BAD["--plot"]
    elif opt in BAD:
        value = BAD[opt]
    elif action.choices:
        value = "bogus"
    else:
        value = "abc"
    n = action.nargs if isinstance(action.nargs, int) else 1
    return argv + [opt, *[value] * n]


def _alarm(signum, frame):
    raise TimeoutError("took over 60 s: the value was not checked before the work")


@pytest.mark.parametrize("name, opt, action", list(_cases()))
def test_a_bad_value_is_one_line_and_exit_2(place, capsys, monkeypatch, name, opt, action):
    monkeypatch.chdir(place)
    argv = [name, *_bad_argv(_valid(place)[name], opt, action)]
    before = snapshot(place)
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(60)
    try:
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's usage errors
            code = exc.code
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert code == 2, (argv, code, err[-500:])
    assert "Traceback" not in err
    assert len([ln for ln in lines if "error" in ln]) == 1 and lines[-1].count("error") >= 1, (
        argv, err)
    assert len(lines) == 1, (argv, lines)
    assert snapshot(place) == before, f"{argv}: files written"
