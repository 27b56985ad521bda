"""`stickslip design` and `stickslip plan` (stickslip_fitting.commands.design, .plan), in-process,
and `stickslip_fitting.design_map`, the Python call the command makes."""

import json

import numpy as np
import pytest

import stickslip_jax as ss
from stickslip_fitting.api.design import parse_grid
from stickslip_fitting.design import design_map, friction_from_params, friction_params, outer, save_samples
from stickslip_jax.cli import main

GRID = ["--weight", "10:60:4", "--stiffness", "20:150:3", "--speed", "40"]


def test_parse_grid_units_and_spacing():
    np.testing.assert_allclose(parse_grid("10:60:6", "force", "kgf", "--weight"),
                               np.linspace(10, 60, 6))
    np.testing.assert_allclose(parse_grid("1:100:3:log", "speed", "mm/min", "--speed"),
                               np.array([1, 10, 100]) / 60)
    np.testing.assert_allclose(parse_grid("100 um/s", "speed", "mm/min", "--speed"), [0.1])
    for bad in ("1:2", "a:2:3", "1:2:0", "0:10:3:log", "-5", "1:2:3:cubic"):
        with pytest.raises(ValueError, match="--speed"):
            parse_grid(bad, "speed", "mm/min", "--speed")


def test_design_json_matches_design_map(capsys, tmp_path):
    png = tmp_path / "map.png"
    assert main(["design", "--lubricant", "A", *GRID, "--json", "--out", str(png)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["shape"] == [4, 3, 1] and doc["index_order"] == ["weight", "stiffness", "speed"]
    assert doc["axes"]["speed_mm_min"] == pytest.approx([40.0])
    w, k, v = outer(np.linspace(10, 60, 4), np.linspace(20, 150, 3), [40.0 / 60])
    m = design_map(ss.lubricant("A"), w, k, v)
    np.testing.assert_allclose(doc["amplitude_mm"], m.amplitude, rtol=1e-12)
    np.testing.assert_allclose(doc["critical_speed_mm_min"], m.critical_speed * 60, rtol=1e-12)
    assert doc["stick_slip"] == m.stick_slip.tolist()
    assert 0 < np.mean(doc["stick_slip"]) < 1
    assert png.stat().st_size > 10_000


def test_design_posterior_and_line_plot(capsys, tmp_path):
    rng = np.random.default_rng(0)
    p = friction_params(ss.lubricant("A"))
    sample = friction_from_params({n: x * np.exp(0.05 * rng.standard_normal(8)) for n, x in p.items()})
    save_samples(sample, tmp_path / "post.csv")
    png = tmp_path / "line.png"
    argv = ["design", "--posterior", str(tmp_path / "post.csv"), "--weight", "36",
            "--stiffness", "86.9", "--speed", "1:100:12:log", "--json", "--out", str(png)]
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    prob = np.asarray(doc["probability_stick_slip"]).ravel()
    assert prob[0] == 1.0 and prob[-1] == 0.0 and np.all(np.diff(prob) <= 0)
    band = np.asarray(doc["critical_speed_band_mm_min"])[0, 0, 0]
    assert band[0] < band[1] < band[2] and 30 < band[1] < 70
    assert png.exists()


def test_design_posterior_warns_when_points_times_draws_are_many(capsys, tmp_path,
                                                                  monkeypatch):
    """The runtime of `design --posterior` grows as points x draws: the stage line states
    the count and, above `POSTERIOR_WARN`, a warning gives the expected minutes and the
    fix before the map starts."""
    from stickslip_fitting.api import design as design_api

    rng = np.random.default_rng(1)
    p = friction_params(ss.lubricant("A"))
    sample = friction_from_params({n: x * np.exp(0.05 * rng.standard_normal(8)) for n, x in p.items()})
    save_samples(sample, tmp_path / "post.csv")
    argv = ["design", "--posterior", str(tmp_path / "post.csv"), "--weight", "36",
            "--stiffness", "86.9", "--speed", "1:100:12:log"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "12 points (steady analysis over 8 posterior draws: 96 analyses)" in err
    assert "warning" not in err
    monkeypatch.setattr(design_api, "POSTERIOR_WARN", 50)
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "warning: --posterior: 12 points x 8 draws = 96 steady analyses" in err
    assert "thin the --posterior file" in err


@pytest.mark.parametrize("argv, needle", [
    (["--lubricant", "Z", *GRID], "--lubricant"),
    (["--weight", "10:60", "--stiffness", "86.9", "--speed", "1"], "--weight"),
    (["--weight", "10:60:3", "--stiffness", "20:90:3", "--speed", "1:9:3", "--out", "x.png"],
     "--out"),
    (["--posterior", "missing.csv", *GRID], "--posterior"),
    (["--max-amplitude", "1um", "--meet", "1.5", *GRID], "--meet"),  # was after the map
    (["--weight", "10:60:3", "--stiffness", "20:90:3", "--speed", "1:9:3", "--max-amplitude",
      "1um", "--plot", "x.png"], "--plot"),
])
def test_design_errors_are_one_line(capsys, argv, needle):
    assert main(["design", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0]


def test_plan_from_lubricant_prior_sample_and_records(capsys, tmp_path):
    assert main(["plan", "A", "--budget", "2", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert len(doc["records"]) == 2
    assert all(doc["relative_sd_after"][p] < doc["relative_sd_before"][p]
               for p in doc["relative_sd_before"])
    first = doc["records"][0]
    # a prior JSON with the same mean and sd gives the same plan
    p = {k: float(v) for k, v in friction_params(ss.lubricant("A")).items()}
    (tmp_path / "prior.json").write_text(json.dumps({"mean": p, "sd": 0.5}))
    assert main(["plan", str(tmp_path / "prior.json"), "--budget", "2", "--json"]) == 0
    doc2 = json.loads(capsys.readouterr().out)
    assert doc2["records"] == doc["records"]
    # an existing record at the first proposal's conditions changes the next proposal
    from stickslip_jax.records import Record, write_record

    t = np.linspace(0.0, 1.0, 11)
    rec = Record(time=t, deflection=np.zeros_like(t), stiffness=first["stiffness_kgf_mm"],
                 weight=first["weight_kgf"], drive_speed=first["speed_mm_min"] / 60)
    write_record(rec, tmp_path / "r1.csv")
    assert main(["plan", "A", str(tmp_path / "r1.csv"), "--budget", "1", "--json"]) == 0
    doc3 = json.loads(capsys.readouterr().out)
    assert "1 existing record" in doc3["source"]
    assert doc3["relative_sd_before"]["mu_s"] < doc["relative_sd_before"]["mu_s"]
    # a posterior sample as the source, and the table output
    rng = np.random.default_rng(1)
    sample = friction_from_params({k: v * np.exp(0.1 * rng.standard_normal(30)) for k, v in p.items()})
    save_samples(sample, tmp_path / "s.csv")
    assert main(["plan", str(tmp_path / "s.csv"), "--budget", "2"]) == 0
    out = capsys.readouterr().out
    assert "posterior sample s.csv (30 draws)" in out and "v [mm/min]" in out
    # the summary JSON of `stickslip mcmc --json` is a prior for plan, not a sample
    summary = {"model": "empirical", "parameters": {
        k: {"median": v, "mean": v, "sd": 0.5 * v, "ci95": [0.5 * v, 1.5 * v]} for k, v in p.items()}}
    (tmp_path / "mcmc.json").write_text(json.dumps(summary))
    assert main(["plan", str(tmp_path / "mcmc.json"), "--budget", "2", "--json"]) == 0
    doc4 = json.loads(capsys.readouterr().out)
    assert doc4["records"] == doc["records"]  # same estimate and relative sd 0.5
    assert main(["design", "--posterior", str(tmp_path / "mcmc.json"), *GRID]) == 2
    assert "without draws" in capsys.readouterr().err
    assert main(["plan", "nothing-here", "--budget", "2"]) == 2
    assert main(["plan", str(tmp_path / "r1.csv")]) == 2  # records alone: no estimate
    assert "estimate" in capsys.readouterr().err


def test_long_csv_matches_the_json_map(capsys, tmp_path):
    """--csv: one row per grid point, the same numbers as the JSON map (pandas reads it)."""
    pd = pytest.importorskip("pandas")
    out_csv, out_json = tmp_path / "map.csv", tmp_path / "map.json"
    assert main(["design", "--weight", "11.3:36:2", "--stiffness", "27.3:128.5:3",
                 "--speed", "5:60:2", "--method", "cycle", "--max-amplitude", "10um",
                 "--csv", str(out_csv), "--json", str(out_json), "--quiet"]) == 0
    capsys.readouterr()
    df = pd.read_csv(out_csv)
    doc = json.loads(out_json.read_text())
    assert len(df) == 2 * 3 * 2
    # the JSON's names (one name per quantity; the CSV cannot carry aliases)
    assert list(df.columns[:3]) == ["weight_kgf", "stiffness_kgf_per_mm",
                                    "drive_speed_mm_per_min"]
    np.testing.assert_allclose(df["amplitude_mm"], np.ravel(doc["amplitude_mm"]), rtol=1e-9)
    np.testing.assert_allclose(df["drive_speed_mm_per_min"],
                               np.tile(doc["axes"]["drive_speed_mm_per_min"], 6), rtol=1e-9)
    np.testing.assert_allclose(df["stiffness_kgf_per_mm"],
                               np.tile(np.repeat(doc["axes"]["stiffness_kgf_per_mm"], 2), 2))
    np.testing.assert_allclose(df["critical_speed_mm_per_min"],
                               np.ravel(doc["critical_speed_mm_per_min"]), rtol=1e-9)
    # every column that is also a JSON key of the map has that key's name and values
    shared = [c for c in df.columns if c in doc and c not in ("regime", "stick_slip",
                                                              "converged")]
    assert len(shared) >= 6, shared
    for c in shared:
        np.testing.assert_allclose(df[c], np.ravel(doc[c]), rtol=1e-9, err_msg=c)
    assert not set(df.columns) & set(doc["deprecated_keys"])  # no old name in the CSV
    assert set(df["regime"]) <= {"stick-slip", "re-stick failure", "steady sliding"}
    np.testing.assert_allclose(df["probability_met"],
                               np.ravel(doc["tolerance"]["probability_met"]))
    assert set(df["probability_met"]) <= {0.0, 1.0}  # one draw: the lubricant


def test_python_design_map_is_the_command(capsys, tmp_path):
    """`stickslip_fitting.design_map` gives the command's JSON, CSV and printed summary;
    its mistakes name the keyword, not the option."""
    import stickslip_fitting as sf

    out = tmp_path / "map.json"
    assert main(["design", *GRID, "--csv", str(tmp_path / "map.csv"), "--json", str(out),
                 "--quiet"]) == 0
    printed = capsys.readouterr().out
    study = sf.design_map("10:60:4", "20:150:3", "40")
    assert study.to_dict() == json.loads(out.read_text())
    assert study.to_csv() == (tmp_path / "map.csv").read_text()
    assert str(study) in printed and study.summary().shape == (12, 12)
    fig = study.plot(tmp_path / "map.png")
    assert len(fig.axes) == 4 and (tmp_path / "map.png").exists()
    with pytest.raises(ValueError, match=r"^level: acts only with posterior"):
        sf.design_map("36", "86.9", "1:10:3", level=0.8)
    with pytest.raises(ValueError, match=r"^stiffness: cannot read"):
        sf.design_map("36", "20:200", "1")


@pytest.mark.parametrize("argv, names", [
    (["--level", "0.8"], ["--level", "--posterior FILE"]),
    (["--meet", "0.9"], ["--meet", "--max-amplitude AMP"]),
    (["--posterior", "{post}"], ["post.json", "'fixed' mu_s", "null"]),
])
def test_options_that_cannot_act_and_null_fixed_values_are_one_line(capsys, tmp_path, argv,
                                                                     names):
    post = tmp_path / "post.json"
    post.write_text(json.dumps({"names": ["mu_d", "gamma", "m", "delta", "n"],
                                "samples": [[0.21, 0.38, 0.4, 67.0, 1.0]] * 3,
                                "fixed": {"mu_s": None}}))
    argv = [a.format(post=post) for a in argv]
    assert main(["design", "--weight", "36", "--stiffness", "86.9", "--speed", "1:10:3",
                 *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0]
    assert all(n in err[0] for n in names), err[0]
