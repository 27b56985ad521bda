"""`stickslip design --netcdf` (`stickslip_fitting.design.netcdf`): the map as an xarray
Dataset written to NetCDF reopens with xarray and equals the JSON map; a missing xarray
is a one-line error naming the extra; the file is never written over an input. Also
`--damping-ratio` (the damped limit cycle's sharp boundary) on the command line."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

import stickslip_jax as ss
from stickslip_fitting.design import friction_from_params, friction_params, save_samples
from stickslip_jax.cli import main

xr = pytest.importorskip("xarray")

GRID = ["--weight", "11.3:36:2", "--stiffness", "27.3:128.5:3", "--speed", "5:60:2"]


def _key(doc, *names):
    """The first of `names` in `doc` (a renamed JSON key keeps its deprecated alias)."""
    return next(doc[n] for n in names if n in doc)


def test_netcdf_map_equals_the_json_map(capsys, tmp_path):
    nc, js = tmp_path / "map.nc", tmp_path / "map.json"
    assert main(["design", *GRID, "--method", "cycle", "--max-amplitude", "10um",
                 "--netcdf", str(nc), "--json", str(js), "--quiet"]) == 0
    assert f"wrote {nc}" in capsys.readouterr().out
    doc = json.loads(js.read_text())
    with xr.open_dataset(nc) as ds:
        ds = ds.load()
    assert ds.amplitude.dims == ("W", "k", "v")
    assert ds.W.attrs["units"] == "kgf" and ds.k.attrs["units"] == "kgf/mm"
    assert ds.v.attrs["units"] == "mm/min" and ds.amplitude.attrs["units"] == "mm"
    np.testing.assert_array_equal(ds.W, doc["axes"]["weight_kgf"])
    np.testing.assert_array_equal(ds.k, _key(doc["axes"], "stiffness_kgf_per_mm",
                                             "stiffness_kgf_mm"))
    np.testing.assert_allclose(ds.v, _key(doc["axes"], "drive_speed_mm_per_min",
                                          "speed_mm_min"), rtol=1e-15)
    np.testing.assert_array_equal(ds.amplitude, doc["amplitude_mm"])
    np.testing.assert_array_equal(ds.stick_time, doc["stick_time_s"])
    np.testing.assert_array_equal(ds.frequency, doc["frequency_hz"])
    np.testing.assert_array_equal(ds.v_c, _key(doc, "critical_speed_mm_per_min",
                                               "critical_speed_mm_min"))
    np.testing.assert_array_equal(ds.regime, doc["regime"])
    assert ds.regime.attrs["flag_meanings"].split() == [r.replace(" ", "_")
                                                        for r in doc["regimes"]]
    np.testing.assert_array_equal(ds.stick_slip.astype(bool), doc["stick_slip"])
    assert ds.attrs["method"] == "cycle"
    # the tolerance: probability over the grid, required stiffness per (W, v)
    tol = doc["tolerance"]
    np.testing.assert_array_equal(ds.probability_met, tol["probability_met"])
    assert ds.required_stiffness.dims == ("W", "v")
    need = [r.get("stiffness_kgf_per_mm", r.get("stiffness_kgf_mm"))
            for r in tol["required_stiffness"]]
    need = np.asarray([np.nan if x is None else x for x in need]).reshape(2, 2)
    np.testing.assert_array_equal(ds.required_stiffness, need)
    assert np.isfinite(need).any()


def test_netcdf_posterior_bands_and_safety(capsys, tmp_path):
    f = ss.lubricant("A")
    rng = np.random.default_rng(0)
    p = {n: x * np.exp(0.05 * rng.standard_normal(20)) for n, x in friction_params(f).items()}
    save_samples(friction_from_params(p), tmp_path / "post.csv")
    nc, js = tmp_path / "post.nc", tmp_path / "post.json"
    argv = ["design", "--posterior", str(tmp_path / "post.csv"), *GRID, "--quiet"]
    assert main([*argv, "--netcdf", str(nc), "--json", str(js)]) == 0
    doc = json.loads(js.read_text())
    with xr.open_dataset(nc) as ds:
        np.testing.assert_array_equal(ds.probability_stick_slip, doc["probability_stick_slip"])
        np.testing.assert_array_equal(ds.amplitude_band, doc["amplitude_band_mm"])
        assert ds.amplitude_band.dims == ("W", "k", "v", "band")
        assert list(ds.band.values) == ["lower", "median", "upper"]
    # never over an input, checked before the work
    before = (tmp_path / "post.csv").read_text()
    capsys.readouterr()
    assert main([*argv, "--netcdf", str(tmp_path / "post.csv")]) == 2
    assert "--netcdf" in capsys.readouterr().err
    assert (tmp_path / "post.csv").read_text() == before


def test_missing_xarray_is_one_line(capsys, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "xarray", None)  # import xarray -> ImportError
    assert main(["design", *GRID, "--netcdf", str(tmp_path / "m.nc")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "--netcdf" in err and "stickslip-jax[netcdf]" in err
    assert not (tmp_path / "m.nc").exists()


def test_damping_ratio_on_the_command_line(capsys, tmp_path):
    js = tmp_path / "d.json"
    # lubricant A, W 36 kgf, k 86.9 kgf/mm: zeta 0.1 ends stick-slip at 39.0 mm/min
    argv = ["design", "--weight", "36", "--stiffness", "86.9", "--speed", "30:48:2",
            "--method", "cycle", "--quiet"]
    assert main([*argv, "--damping-ratio", "0.1", "--json", str(js)]) == 0
    doc = json.loads(js.read_text())
    assert doc["damping_ratio"] == 0.1
    assert np.ravel(doc["stick_slip"]).tolist() == [True, False]
    assert main([*argv, "--json", str(js)]) == 0  # undamped: stick-slip at both speeds
    doc = json.loads(js.read_text())
    assert "damping_ratio" not in doc and np.ravel(doc["stick_slip"]).tolist() == [True, True]
    capsys.readouterr()
    assert main([*argv[:-3], "--damping-ratio", "0.1"]) == 2  # steady method: refused
    assert "--damping-ratio" in capsys.readouterr().err
    assert main([*argv, "--damping-ratio", "1.5"]) == 2
