"""`stickslip fit` end to end on record files, and its one-line errors for bad input."""

import json

import pytest

import stickslip_jax as ss
from stickslip_fitting.data.synthetic import synthetic_campaign
from stickslip_jax.cli import main
from stickslip_jax.records import write_record


@pytest.fixture(scope="module")
def campaign_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("campaign")
    recs = synthetic_campaign(ss.lubricant("A"), speed_fractions=(0.05, 0.3), cycles=4, seed=2,
                              pad_to=40_000)
    paths = []
    for r in recs:
        p = d / f"{r.name}.csv"
        write_record(r, p)
        paths.append(str(p))
    return d, paths


def test_fit_prints_table_and_writes_json(campaign_dir, tmp_path, capsys):
    _, paths = campaign_dir
    out = tmp_path / "fit.json"
    assert main(["fit", *paths, "--json", str(out)]) == 0
    text = capsys.readouterr().out
    for name in ("mu_s", "mu_d", "gamma", "delta", "95 % interval", "truth"):
        assert name in text
    rep = json.loads(out.read_text())
    assert rep["model"] == "empirical" and len(rep["records"]) == 6
    for name, p in rep["parameters"].items():
        assert {"value", "stderr", "ci95", "unit"} <= set(p)
        assert p["truth_in_ci95"], name
    assert rep["parameters"]["gamma"]["unit"] == "s^-m"
    assert rep["residual_rms_mm"] < 1e-3


def _err(capsys):
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1
    return err


def test_single_record_is_refused_by_microsqueeze(campaign_dir, capsys):
    """(The empirical law fits one record: tests/test_one_record.py.)"""
    _, paths = campaign_dir
    assert main(["fit", "--model", "microsqueeze", paths[0]]) == 2
    assert "at least 2 records" in _err(capsys)


def test_record_without_stick_slip(campaign_dir, tmp_path, capsys):
    _, paths = campaign_dir
    flat = tmp_path / "flat.csv"
    lines = ["# stickslip-record: 1", "# drive_speed: 60 mm/min", "# stiffness: 86.9 kgf/mm",
             "# slider_weight: 36 kgf", "# lubricant: A", "time [s],deflection [mm]"]
    lines += [f"{i * 1e-3:.3f},0.087" for i in range(3000)]
    flat.write_text("\n".join(lines) + "\n")
    assert main(["fit", paths[0], str(flat)]) == 2
    err = _err(capsys)
    assert "flat" in err and "no stick-slip" in err


@pytest.mark.parametrize("old, new, said", [
    ("# lubricant: A", "# lubricant: C", "mixes lubricants"),  # mixed lubricants
    ("deflection [mm]", "deflection [kgf]", "bad.csv"),  # a unit of the wrong dimension
])
def test_a_record_that_does_not_fit_the_campaign(campaign_dir, tmp_path, capsys, old, new,
                                                 said):
    _, paths = campaign_dir
    bad = tmp_path / "bad.csv"
    bad.write_text(open(paths[1]).read().replace(old, new))
    assert main(["fit", paths[0], str(bad)]) == 2
    assert said in _err(capsys)


def test_bad_fix_and_model(campaign_dir, capsys):
    _, paths = campaign_dir
    assert main(["fit", *paths[:2], "--fix", "nu=1"]) == 2
    assert "--fix" in _err(capsys)


# every bad campaign gets one clear line (exit 2, no traceback) from both commands and
# both models: the campaign is checked before any fitting, so these runs are fast
COMMANDS = {
    "fit": ["fit"],
    "fit-microsqueeze": ["fit", "--model", "microsqueeze"],
    "mcmc": ["mcmc", "--no-progress", "--steps", "20"],
    "mcmc-microsqueeze": ["mcmc", "--model", "microsqueeze", "--no-progress", "--steps", "20"],
}


def _bad_campaigns(paths, tmp_path):
    flat = tmp_path / "flat.csv"
    lines = ["# stickslip-record: 1", "# drive_speed: 60 mm/min", "# stiffness: 86.9 kgf/mm",
             "# slider_weight: 36 kgf", "# lubricant: A", "time [s],deflection [mm]"]
    flat.write_text("\n".join(lines + [f"{i * 1e-3:.3f},0.087" for i in range(3000)]) + "\n")
    flat2 = tmp_path / "flat2.csv"
    flat2.write_text(flat.read_text().replace("60 mm/min", "30 mm/min"))
    text = open(paths[1]).read()
    other = tmp_path / "lubC.csv"
    other.write_text(text.replace("# lubricant: A", "# lubricant: C"))
    units = tmp_path / "units.csv"
    units.write_text(text.replace("kgf/mm", "kgf/s"))
    return {
        "single record": ([paths[0]], "at least 2 records"),
        "no stick-slip": ([paths[0], str(flat)], "only 1 of 2 records have usable stick-slip"),
        "all without stick-slip": ([str(flat), str(flat2)], "flat2"),
        "a file named twice": ([paths[0], paths[0]], "named twice"),
        "mixed lubricants": ([paths[0], str(other)], "mixes lubricants"),
        "conflicting units": ([paths[0], str(units)], "units.csv"),
        "missing file": ([paths[0], str(tmp_path / "nope.csv")], "no such file"),
    }


@pytest.mark.parametrize("command", list(COMMANDS))
def test_bad_campaigns_give_one_line(command, campaign_dir, tmp_path, capsys):
    _, paths = campaign_dir
    for case, (files, expected) in _bad_campaigns(paths, tmp_path).items():
        if command in ("fit", "mcmc") and case == "single record":  # test_one_record.py
            continue
        assert main([*COMMANDS[command], *files]) == 2, case
        err = _err(capsys)
        assert expected in err, (case, err)


def test_mcmc_option_errors(campaign_dir, capsys):
    _, paths = campaign_dir
    for args, expected in ((["--steps", "5"], "--steps"), (["--draws", "0"], "--draws"),
                           (["--burn", "50", "--steps", "40"], "--burn"),
                           (["--eta", "0.2 Pa*s"], "--eta"),
                           (["--model", "microsqueeze", "--surface", "XX"], "--surface"),
                           (["--model", "microsqueeze", "--fix", "gamma=1"], "--fix")):
        assert main(["mcmc", *paths, "--no-progress", *args]) == 2, args
        assert expected in _err(capsys), args


def test_truth_in_stickslip_simulate_layout():
    from stickslip_fitting.data.campaign import find_truth
    from stickslip_jax.records import Record

    truth = {"friction": {"static": {"law": "KatoStatic", "mu_s": 0.56, "mu_d": 0.21,
                                     "gamma": 0.38, "m": 0.4},
                          "kinetic": {"law": "KatoKinetic", "delta": 67.0, "n": 1.0},
                          "weight_kgf": 36.0}}
    import numpy as np

    rec = Record(time=np.arange(3.0), deflection=np.zeros(3), stiffness=1.0, weight=1.0,
                 drive_speed=1.0, truth=truth)
    assert find_truth([rec, rec]) == {"mu_s": 0.56, "mu_d": 0.21, "gamma": 0.38, "m": 0.4,
                                      "delta": 67.0, "n": 1.0}
