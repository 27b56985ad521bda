"""One CLI grammar: every subcommand's parser, built in-process the way
`stickslip --help` builds it, checked for the shared options and their meanings.

- every option (and positional) has help text; hidden options are only the deprecated
  aliases listed in `DEPRECATED`, each storing into its new name's destination;
- `--json OUT` where a command writes JSON, `-` meaning stdout;
- `--plot OUT.png` where a command makes a figure;
- `--quiet` where a command prints progress (old flags kept as aliases);
- one name per concept: an option name used by several commands has one destination and
  the meaning in `MEANINGS` (its help text says so); no visible option is ambiguous.
"""

from __future__ import annotations

import argparse
import json
import re

import pytest

from stickslip_jax.cli import build_parser, main

COMMANDS = {"steady", "simulate", "plot", "import", "fit", "mcmc", "design", "plan",
            "discover", "pitch", "fit-batch"}
"""Every subcommand; a new one must be added here and to the sets below that apply."""

JSON_COMMANDS = {"steady", "design", "plan", "fit", "mcmc", "discover", "pitch", "fit-batch"}
BARE_JSON = {"steady", "design", "plan"}
"""A bare `--json` (no value) printed JSON to stdout before `--json OUT` existed."""
FIGURE_COMMANDS = {"plot", "fit", "mcmc", "design", "discover", "pitch", "fit-batch"}
PROGRESS_COMMANDS = {"fit", "mcmc", "discover", "design", "plan", "fit-batch"}

DEPRECATED = {
    ("fit", "--offset"): "--gauge-offset",
    ("mcmc", "--offset"): "--gauge-offset",
    ("pitch", "--offset"): "--drive-offset",
    ("design", "--out"): "--plot",
    ("plot", "--out"): "--plot",
    ("mcmc", "--no-progress"): None,  # hid the bar only; --quiet hides the lines too
    ("design", "--progress"): None,  # an opt-in bar; on by default on a terminal
}
"""Old option names still accepted but hidden from --help: (command, old) -> new name
(same destination), None where the old flag has no new counterpart."""

MEANINGS = {
    "--json": r"as JSON to the file OUT; '-' writes it to stdout",
    "--plot": r"^save .* to OUT\.png",
    "--quiet": r"no progress",
    "-q": r"no progress",
    "--weight": r"slider weight",
    "--stiffness": r"stiffness",
    "--damping-ratio": r"viscous damping ratio .* of\s+the slider.s own mode",
    "--speed": r"drive speed",
    "--lubricant": r"lubricant",
    "--table": r"table of eq \(1\) parameters",
    "--model": r"static-friction law",
    "--gauge-offset": r"gauge offset",
    "--slip-time": r"T2 in eq \(3\)",
    "--objective": r"features",
    "--strict": r"(refuse|fail) (the|a) campaign",
    "--fix": r"hold a parameter fixed",
    "--eta": r"viscosity",
    "--surface": r"surface pair",
    "--loss": r"likelihood of the residuals",
    "--seed": r"random seed",
    "--noise": r"noise",  # simulate: the noise added; plan: the noise of a record (sd)
    "--out": r"record|CSV",
    "--force": r"replace an existing --out file",
    "--normal-load": r"normal load N pressing the slider on the slideway",
    "--csv": r"as a long-format CSV: one row per",  # the record file written (simulate, import)
}
"""Option names used by more than one command -> a pattern their help text matches in
every command: one concept per name. An option shared by commands but missing here
fails `test_one_meaning_per_option_name` (check it means the same thing, then add it)."""

AMBIGUOUS = {"--offset", "--out-png", "--corner-png", "--progress", "--no-progress"}
"""Names that must not be visible: `--offset` meant a gauge-offset mode (fit, mcmc) and a
drive offset in mm (pitch); the progress flags were opt-in in one command, opt-out in
another."""

MINIMAL = {
    "steady": ["--weight", "36", "--stiffness", "86.9", "--speed", "1"],
    "simulate": ["--weight", "36", "--stiffness", "86.9", "--speed", "1", "--duration", "1",
                 "--out", "x.csv"],
    "plot": ["run.csv"],
    "import": ["raw.txt", "--out", "x.csv", "--time-col", "0", "--force-col", "1",
               "--stiffness", "86.9 kgf/mm", "--weight", "36 kgf"],
    "fit": ["run.csv"],
    "mcmc": ["run.csv"],
    "design": ["--weight", "36", "--stiffness", "86.9", "--speed", "1"],
    "plan": ["A"],
    "discover": ["a.csv", "b.csv"],
    "pitch": ["run.csv"],
    "fit-batch": ["campaign1", "campaign2"],
}
"""Arguments each command needs to parse (nothing is read: parsing only)."""


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


SUBS = _subparsers()


def _options(name):
    """{option string: action} of the command `name`, help action left out."""
    return {s: a for a in SUBS[name]._actions if not isinstance(a, argparse._HelpAction)
            for s in a.option_strings}


def _visible(name):
    return {s: a for s, a in _options(name).items() if a.help is not argparse.SUPPRESS}


def _parse(name, *extra):
    return SUBS[name].parse_args([*MINIMAL[name], *extra])


def test_every_command_is_classified():
    assert set(SUBS) == COMMANDS
    assert set(MINIMAL) == COMMANDS
    for name in COMMANDS:
        _parse(name)  # the minimal arguments parse


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_option_has_help(name):
    missing = [a.option_strings or a.dest for a in SUBS[name]._actions
               if not (a.help and str(a.help).strip())]
    assert not missing, f"{name}: options without help text: {missing}"
    assert SUBS[name].description, f"{name}: no description"


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_hidden_options_are_listed_aliases(name):
    opts = _options(name)
    visible = _visible(name)
    for s, action in opts.items():
        if action.help is not argparse.SUPPRESS:
            continue
        assert (name, s) in DEPRECATED, f"{name} {s}: hidden but not a listed deprecated alias"
        new = DEPRECATED[(name, s)]
        if new is not None:
            assert new in visible, f"{name} {s}: its new name {new} is missing"
            assert visible[new].dest == action.dest, f"{name} {s} does not store into {new}"
    for (cmd, old), _new in DEPRECATED.items():
        if cmd == name:
            assert old in opts, f"{name} {old}: the old name is no longer accepted"


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_json_option(name):
    has = "--json" in _options(name)
    assert has == (name in JSON_COMMANDS), f"{name}: --json {'unexpected' if has else 'missing'}"
    if not has:
        return
    action = _options(name)["--json"]
    assert action.metavar == "OUT"
    assert _parse(name, "--json", "-").json == "-"
    assert _parse(name, "--json", "out.json").json == "out.json"
    assert _parse(name).json is None
    if name in BARE_JSON:  # the old bare flag still prints JSON to stdout
        assert SUBS[name].parse_args(["--json", *MINIMAL[name]]).json == "-"
        assert _parse(name, "--json").json == "-"
    else:
        assert action.nargs is None  # a bare --json would swallow a record name


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_plot_option(name):
    has = "--plot" in _visible(name)
    assert has == (name in FIGURE_COMMANDS), f"{name}: --plot {'unexpected' if has else 'missing'}"
    if has:
        assert _options(name)["--plot"].metavar == "OUT.png"
        args = _parse(name, "--plot", "fig.png")
        assert args.plot == "fig.png" and args.plot_option == "--plot"
        assert _parse(name).plot is None


def test_old_figure_names_still_work():
    args = _parse("mcmc", "--corner", "c.png")
    assert args.plot == "c.png" and args.plot_option == "--corner"
    for name in ("design", "plot"):
        args = _parse(name, "--out", "m.png")
        assert args.plot == "m.png" and args.plot_option == "--out"


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_quiet_option(name):
    has = "--quiet" in _visible(name)
    assert has == (name in PROGRESS_COMMANDS), \
        f"{name}: --quiet {'unexpected' if has else 'missing'}"
    if has:
        assert _parse(name).quiet is False and _parse(name, "--quiet").quiet is True
        assert _parse(name, "-q").quiet is True


def test_old_progress_flags_still_work():
    assert _parse("mcmc", "--no-progress").no_progress is True
    assert _parse("mcmc").no_progress is False and _parse("mcmc").quiet is False
    assert _parse("design", "--progress").progress is True


def test_offsets_have_one_name_per_concept():
    for name in ("fit", "mcmc"):
        assert _parse(name, "--gauge-offset", "start").offset == "start"
        assert _parse(name, "--offset", "start").offset == "start"  # the old name
        assert "--drive-offset" not in _options(name)
    a = _parse("pitch", "--drive-offset", "5 mm", "--height", "45")
    assert a.drive_offset == [pytest.approx(5.0)] and a.records == ["run.csv"]
    assert _parse("pitch", "--offset", "2").drive_offset == [pytest.approx(2.0)]
    assert "--gauge-offset" not in _options("pitch")


def test_one_meaning_per_option_name():
    uses: dict[str, list[tuple[str, argparse.Action]]] = {}
    for name in COMMANDS:
        for s, action in _visible(name).items():
            uses.setdefault(s, []).append((name, action))
    visible_names = set(uses)
    assert not (visible_names & AMBIGUOUS), visible_names & AMBIGUOUS
    for s, found in uses.items():
        if len(found) < 2:
            continue
        assert s in MEANINGS, (f"{s} is used by {[n for n, _ in found]}: add it to MEANINGS "
                               "once it means one thing in all of them")
        dests = {a.dest for _, a in found}
        assert len(dests) == 1, f"{s} stores into different names: {dests}"
        for name, action in found:
            assert re.search(MEANINGS[s], action.help), (name, s, action.help)


def test_json_dash_is_stdout_and_the_table_goes_to_stderr(capsys):
    base = ["steady", "--weight", "36", "--stiffness", "86.9", "--speed", "1", "10"]
    assert main([*base, "--json", "-"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["schema_version"] >= 1  # stdout is one JSON document
    assert "v [mm/min]" in err
    assert main(["steady", "--json", *base[1:]]) == 0  # the old bare flag
    assert len(json.loads(capsys.readouterr().out)["results"]) == 2


def test_json_file_everywhere(tmp_path, capsys):
    out = tmp_path / "s.json"
    base = ["steady", "--weight", "36", "--stiffness", "86.9", "--speed", "1"]
    assert main([*base, "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "v [mm/min]" in text and f"wrote {out}" in text
    assert json.loads(out.read_text())["results"][0]["stick_slip"] is True
    plan = tmp_path / "plan.json"
    assert main(["plan", "A", "--budget", "1", "--quiet", "--json", str(plan)]) == 0
    assert json.loads(plan.read_text())["records"]
    design = tmp_path / "design.json"
    assert main(["design", "--weight", "36", "--stiffness", "86.9", "--speed", "1:10:3",
                 "--json", str(design)]) == 0
    assert json.loads(design.read_text())["shape"] == [1, 1, 3]


def test_plan_old_bare_json_before_a_source(tmp_path, capsys):
    """`plan --json A` and `plan --json prior.json` meant a bare --json and a source."""
    assert main(["plan", "--json", "A", "--budget", "1", "--quiet"]) == 0
    assert json.loads(capsys.readouterr().out)["source"].startswith("lubricant A")
    prior = tmp_path / "prior.json"
    mean = dict(zip(["mu_s", "mu_d", "gamma", "m", "delta", "n"],
                    [0.2, 0.3, 0.38, 0.4, 67.0, 1.0]))
    mean["mu_s"], mean["mu_d"] = 0.3, 0.2
    prior.write_text(json.dumps({"mean": mean, "sd": 0.5}))
    before = prior.read_text()
    assert main(["plan", "--json", str(prior), "--budget", "1", "--quiet"]) == 0
    assert json.loads(capsys.readouterr().out)["source"] == "prior prior.json"
    assert prior.read_text() == before  # the prior was read, not overwritten


def test_quiet_silences_progress(capsys):
    assert main(["plan", "A", "--budget", "1"]) == 0
    assert "choosing 1 of" in capsys.readouterr().err
    assert main(["plan", "A", "--budget", "1", "--quiet"]) == 0
    assert capsys.readouterr().err == ""


def test_discover_effect_choices_match_the_discovery_code():
    """`discover --only` lists its choices without importing the discovery code."""
    from stickslip_fitting.commands.discover import EFFECTS
    from stickslip_fitting.discovery.cycle_effects import FAMILIES
    from stickslip_fitting.discovery.effects import CANDIDATES

    assert EFFECTS == tuple(dict.fromkeys((*CANDIDATES, *(f.name for f in FAMILIES))))


_HELP_EVERYWHERE = """
import json, sys, time
from stickslip_jax.cli import main
times = {}
for name in sys.argv[1:]:
    t0 = time.perf_counter()
    try:
        main([name, "--help"])
    except SystemExit:
        pass
    times[name] = time.perf_counter() - t0
heavy = sorted(m for m in ("jax", "jaxlib", "equinox", "pint", "matplotlib", "scipy")
               if m in sys.modules)
print(json.dumps({"times": times, "heavy": heavy}))
"""


def test_help_is_built_without_jax():
    """`stickslip SUB --help` imports neither JAX nor the model code (importing JAX
    to build the parser would take 2-3 s; the time itself is a benchmark's job, not a
    test's)."""
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-c", _HELP_EVERYWHERE, *sorted(COMMANDS)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout.strip().splitlines()[-1])
    assert doc["heavy"] == [], doc["heavy"]
    assert set(doc["times"]) == set(COMMANDS)


_ONE_COMMAND = """
import sys
from stickslip_jax.cli import build_parser, registered
build_parser("steady").parse_args(["steady", "--weight", "36", "--stiffness", "86.9",
                                  "--speed", "1"])
print(" ".join(m for m in registered() if m in sys.modules))
"""


def test_a_command_line_imports_only_its_own_command():
    """`main` builds the parser for the command it runs: the other subcommands are listed
    with their one-line help (read from their source) but not imported, and the help of
    `stickslip --help` is that of the parser of every command."""
    import subprocess
    import sys

    assert build_parser("").format_help() == build_parser().format_help()
    lazy = dict(next(a for a in build_parser("fit")._actions
                     if isinstance(a, argparse._SubParsersAction)).choices)
    assert {n: p.description for n, p in lazy.items()} == {
        n: p.description for n, p in SUBS.items()}
    run = subprocess.run([sys.executable, "-c", _ONE_COMMAND], capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["stickslip_jax.commands.steady"]


@pytest.mark.parametrize("jax_first", [False, True])
def test_importing_the_package_still_enables_x64(jax_first):
    """The package imports its names on first use; x64 is on whether JAX comes before
    the package or after it."""
    import subprocess
    import sys

    code = ("import jax; " if jax_first else "") + (
        "import stickslip_jax as ss, jax.numpy as jnp; "
        "print(jnp.zeros(1).dtype, type(ss.lubricant('A')).__name__, ss.simulation.__name__)")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["float64", "Friction", "stickslip_jax.simulation"]
