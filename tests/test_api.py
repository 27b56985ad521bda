"""The one-call Python fit, `stickslip_fitting.fit(records, ...)` -> `CampaignFit`: the
same numbers and the same JSON document as `stickslip fit --json`, a summary table,
the figure, and errors that name what to fix."""

import dataclasses
import json
import math
import os
import pathlib
import sys
import warnings

import pytest

import stickslip_fitting as sf
from stickslip_fitting.api.campaign import SUMMARY_COLUMNS, CampaignFit
from stickslip_jax.cli import main

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "data" / "examples"
NAMES = ("mu_s", "mu_d", "gamma", "m", "delta", "n")
UNITS = {"mu_s": "-", "mu_d": "-", "gamma": "s^-m", "m": "-", "delta": "s^-n", "n": "-"}


@pytest.fixture(scope="module")
def result():
    """One fit of the shipped example campaign, shared by the tests of this module."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # it converges: no warning
        return sf.fit(str(EXAMPLES / "*.csv"))


@pytest.fixture(scope="module")
def cli_document(tmp_path_factory):
    """`stickslip fit data/examples --json OUT` (the command, in this process)."""
    out = tmp_path_factory.mktemp("cli") / "fit.json"
    assert main(["fit", str(EXAMPLES), "--json", str(out), "-q"]) == 0
    return json.loads(out.read_text())


def _same_document(a, b, where="document"):
    """Equal JSON documents: the same keys and values, floats to 1e-12 relative."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), (where, list(a), list(b))
        for k in a:
            _same_document(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            _same_document(x, y, f"{where}[{i}]")
    elif isinstance(a, float) and not isinstance(b, bool) and isinstance(b, (int, float)):
        assert b == pytest.approx(a, rel=1e-12, abs=1e-300), where
    else:
        assert a == b, (where, a, b)


def test_the_call_is_the_package_attribute(result):
    import inspect

    from stickslip_fitting.api.campaign import fit

    assert isinstance(result, CampaignFit) and result.converged
    assert sf.fit is fit
    assert list(inspect.signature(sf.fit).parameters)[:3] == ["records", "model", "objective"]
    assert sf.CampaignFit is CampaignFit


def test_json_is_the_commands_document(result, cli_document, tmp_path):
    path = tmp_path / "fit.json"
    text = result.to_json(path)
    assert path.read_text() == text
    doc = json.loads(text)
    assert doc["schema_version"] == cli_document["schema_version"]
    _same_document(cli_document, doc)
    assert result.to_dict() == doc
    for name in NAMES:
        assert result.values[name] == pytest.approx(cli_document["parameters"][name]["value"],
                                                    rel=1e-12)


def test_summary_values_intervals_and_units(result, cli_document):
    table = result.summary()
    assert tuple(table.columns) == SUMMARY_COLUMNS
    assert table.index.name == "parameter" and tuple(table.index) == NAMES
    assert table["unit"].to_dict() == UNITS
    for name in NAMES:
        p = cli_document["parameters"][name]
        row = table.loc[name]
        assert row["value"] == pytest.approx(p["value"], rel=1e-12)
        assert row["std_err"] == pytest.approx(p["stderr"], rel=1e-12)
        assert (row["low"], row["high"]) == pytest.approx(tuple(p["ci95"]), rel=1e-12)
        assert bool(row["identifiable"]) and row["reason"] == ""
        assert row["low"] < row["value"] < row["high"]
    # the campaign was made with these values (data/examples/truth.json)
    friction = json.loads((EXAMPLES / "truth.json").read_text())["friction"]
    truth = {**friction["static"], **friction["kinetic"]}
    for name in NAMES:
        assert table.loc[name, "value"] == pytest.approx(truth[name], rel=2e-3)


def test_str_is_the_commands_table(result, capsys):
    main(["fit", str(EXAMPLES), "-q"])
    printed = capsys.readouterr().out.strip()
    assert str(result).strip() == printed
    assert "CampaignFit(model='empirical', records=12, converged=True" in repr(result)


def test_unknown_parameters_have_no_value(result):
    """A parameter the records do not determine: NaN with identifiable False and the
    reason; a fixed one: its value, no interval, reason "fixed"."""
    report = json.loads(json.dumps(result.report))
    report["parameters"]["n"].update(value=None, stderr=None, ci95=None, identifiable=False,
                                     reason="not identifiable: delta and n trade off")
    report["parameters"]["delta"].update(identifiable=False, stderr=None, ci95=None)
    report["parameters"]["delta"].pop("reason", None)
    report["parameters"]["m"].update(fixed=True, stderr=None, ci95=None)
    report["parameters"]["m"].pop("reason", None)
    table = dataclasses.replace(result, report=report).summary()
    n, delta, m = table.loc["n"], table.loc["delta"], table.loc["m"]
    assert math.isnan(n["value"]) and math.isnan(n["std_err"]) and math.isnan(n["low"])
    assert not n["identifiable"] and n["reason"] == "not identifiable: delta and n trade off"
    # an older entry that still carries the optimiser's placeholder: no value either
    assert math.isnan(delta["value"]) and "not identifiable" in delta["reason"]
    assert m["value"] == pytest.approx(result.values["m"]) and math.isnan(m["std_err"])
    assert m["reason"].startswith("fixed")


def test_records_as_objects_give_the_same_fit(result):
    from stickslip_jax.records import read_record

    records = [read_record(p) for p in sorted(EXAMPLES.glob("*.csv"))]
    again = sf.fit(records)
    for name in NAMES:
        assert again.values[name] == pytest.approx(result.values[name], rel=1e-9)
    assert again.report["parameters"]["delta"]["ci95"] == pytest.approx(
        result.report["parameters"]["delta"]["ci95"], rel=1e-9)
    with pytest.raises(ValueError, match="at least 2 records"):  # one: test_one_record.py
        sf.fit(records[:1], model="microsqueeze")


def test_plot_writes_a_png(result, tmp_path):
    path = tmp_path / "fit.png"
    fig = result.plot(path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000
    assert fig.axes


def test_outputs_never_overwrite_a_record(result):
    record = sorted(EXAMPLES.glob("*.csv"))[0]
    before = record.read_bytes()
    with pytest.raises(ValueError, match="input records"):
        result.to_json(record)
    assert record.read_bytes() == before


def test_a_glob_that_matches_nothing_names_the_pattern(tmp_path):
    pattern = str(tmp_path / "nothing_here_*.csv")
    with pytest.raises(ValueError, match="no file matches") as err:
        sf.fit(pattern)
    assert pattern in str(err.value)


@pytest.mark.parametrize("options, message", [
    (dict(objective="samples"), "objective must be one of"),
    (dict(model="coulomb"), "model must be one of"),
    (dict(fix={"nu": 1.0}), "fix: expected NAME=VALUE with NAME in mu_s"),
    (dict(fix={"n": "one"}), "fix n: 'one' is not a number"),
    (dict(fix={"n": 1e9}), "outside the physical range"),
    (dict(loss="cauchy"), "loss: expected one of"),
    (dict(gauge_offset="middle"), "gauge_offset must be one of"),
    (dict(slip_time="exact"), "slip_time must be one of"),
    (dict(eta=0.2), "eta: only used with model='microsqueeze'"),
    (dict(model="microsqueeze", surface="S9Z9"), "surface: unknown surface pair 'S9Z9'"),
])
def test_option_errors_name_the_keyword(options, message):
    # checked before the records are read: the folder below does not exist
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        sf.fit("no/such/folder", **options)


def test_typed_options_are_accepted():
    """The option objects (modes, loss, law) are checked like their strings."""
    from stickslip_fitting.api import campaign as api
    from stickslip_fitting.objectives.losses import Huber
    from stickslip_fitting.microsqueeze_params import MicrosqueezeFriction
    from stickslip_fitting.params import EmpiricalFriction, Hold

    assert api._law(EmpiricalFriction) is EmpiricalFriction
    assert api._law("microsqueeze") is MicrosqueezeFriction
    assert api.loss_option(Huber(2.0)) == Huber(2.0)
    assert api.loss_option("huber:2").spec() == "huber:2"
    start = EmpiricalFriction.from_values(0.4, 0.3, 1.0, 0.5, 2.0, 1.3)
    assert api._fixed({"n": 1}, EmpiricalFriction) == {"n": 1.0}
    assert Hold.named(api._fixed({"n": 1}, EmpiricalFriction)).natural(start) == {"n": 1.0}
    assert api._fixed({}, EmpiricalFriction) == {}
    assert api._viscosity("216 cP") == pytest.approx(api._viscosity(0.216))


def test_summary_without_pandas_names_the_extra(result, monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ImportError, match=r"stickslip-jax\[pandas\]"):
        result.summary()


def test_real_records_show_unknowns_as_unknown():
    """The shipped real records determine mu_d only: every other parameter is NaN with
    its reason, never the optimiser's placeholder."""
    real = sf.fit(str(ROOT / "data" / "real" / "*.csv"))
    table = real.summary()
    assert table.loc["mu_d", "identifiable"] and 0.2 < table.loc["mu_d", "value"] < 0.5
    unknown = table[~table["identifiable"].astype(bool)]
    assert len(unknown) >= 3, table
    for name, row in unknown.iterrows():
        assert math.isnan(row["value"]) and math.isnan(row["std_err"]), name
        assert row["reason"].startswith("not identifiable"), (name, row["reason"])
        assert real.report["parameters"][name]["identifiable"] is False


_USER_CODE = '''
import stickslip_fitting as sf
from stickslip_fitting import CampaignFit
from stickslip_fitting.objectives.losses import Huber
from stickslip_fitting.modes import Objective
from stickslip_jax.modes import GaugeOffset

result: CampaignFit = sf.fit("data/examples/*.csv", objective=Objective.TRACE,
                             fix={"n": 1.0}, loss=Huber(2.0), gauge_offset=GaugeOffset.START)
result.plot("fit.png")
text: str = result.to_json("fit.json")
converged: bool = result.converged
values: dict[str, float] = result.values
wrong = sf.fit("data/examples", objective=3.5)
'''

_MYPY_INI = """[mypy]
follow_imports = silent
[mypy-jax.*,jaxlib.*,equinox.*,diffrax.*,optimistix.*,lineax.*,jaxtyping.*,numpy.*,matplotlib.*,scipy.*,pandas.*,emcee.*,corner.*,pint.*,arviz.*,xarray.*,tqdm.*]
follow_imports = skip
ignore_missing_imports = True
"""


@pytest.mark.slow  # a mypy process over the imported packages: about 6 s of CPU, 8-12 s wall
def test_public_api_type_checks(tmp_path):
    """mypy over the public entry points (the packages ship py.typed): a user's script
    that calls `stickslip_fitting.fit` type-checks, a wrong option type is reported, and
    the modules of the call have no type errors."""
    pytest.importorskip("mypy", reason="mypy (the [test] extra) is not installed")
    import subprocess

    src = tmp_path / "src"  # the installed names: stickslip_fitting is the folder fitting/
    src.mkdir()
    (src / "stickslip_fitting").symlink_to(ROOT / "fitting")
    (src / "stickslip_jax").symlink_to(ROOT / "stickslip_jax")
    (tmp_path / "mypy.ini").write_text(_MYPY_INI)
    (tmp_path / "user.py").write_text(_USER_CODE)
    run = subprocess.run(
        [sys.executable, "-m", "mypy", "--config-file", "mypy.ini", "--cache-dir",
         str(tmp_path / "cache"), "--no-error-summary", "user.py",
         "src/stickslip_fitting/__init__.py", "src/stickslip_fitting/api/campaign.py",
         "src/stickslip_jax/__init__.py"],
        cwd=tmp_path, env={**os.environ, "MYPYPATH": str(src)},
        capture_output=True, text=True, timeout=600)
    errors = [line for line in run.stdout.splitlines() if ": error:" in line]
    assert len(errors) == 1, run.stdout + run.stderr
    line = _USER_CODE.splitlines().index(next(t for t in _USER_CODE.splitlines()
                                                 if t.startswith("wrong ="))) + 1
    assert errors[0].startswith(f"user.py:{line}:") and 'Argument "objective"' in errors[0], errors
