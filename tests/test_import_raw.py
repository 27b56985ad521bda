"""`stickslip import` and `Record.from_arrays`: raw logger files as labs write them."""

from __future__ import annotations

import numpy as np
import pytest

from stickslip_jax.cli import main
from stickslip_jax.records import Record, RecordError, read_record


def _raw(path, sep=";", decimal=","):
    rng = np.random.default_rng(0)
    t = 1.7e9 + np.arange(3000) * 1e-3 + 2e-7 * rng.standard_normal(3000)
    force = (0.1 + 0.02 * np.mod(np.arange(3000) * 1e-3, 0.5)) * 9.80665
    rows = [f"{a:.7f}{sep}{b:.6f}{sep}21.5" for a, b in zip(t, force)]
    if decimal == ",":
        rows = [r.replace(".", ",") for r in rows]
    path.write_text("# logger v2\n" + sep.join(["Time (s)", "Force [N]", "Temperature [degC]"])
                    + "\n" + "\n".join(rows) + "\n")
    return force


def test_import_semicolons_decimal_commas_jitter_epoch(tmp_path, capsys):
    raw = tmp_path / "raw.txt"
    force = _raw(raw)
    before = raw.read_bytes()
    out = tmp_path / "rec.csv"
    args = ["import", str(raw), "--out", str(out), "--time-col", "time", "--force-col", "force",
            "--stiffness", "852 N/um", "--mass", "30.7 g", "--speed", "40 in/min"]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "decimal commas" in text and "jitter" in text and "first time stamp" in text
    rec = read_record(out)
    assert rec.stiffness == pytest.approx(852e3 / 9.80665)
    assert rec.weight == pytest.approx(0.0307)
    assert rec.drive_speed == pytest.approx(40 * 25.4 / 60)
    assert rec.time[0] == 0.0 and np.ptp(np.diff(rec.time)) < 1e-9
    assert np.allclose(rec.force / 9.80665 * 9.80665, force / 9.80665, atol=2e-4)
    assert raw.read_bytes() == before  # the input is only read
    assert main(args) == 2  # an existing output is kept
    assert "--force" in capsys.readouterr().err
    assert main([*args[:3], str(raw), *args[4:]]) == 2  # --out naming the input


def test_import_errors_name_the_option(tmp_path, capsys):
    raw = tmp_path / "raw.txt"
    _raw(raw, sep=",", decimal=".")
    base = ["import", str(raw), "--out", str(tmp_path / "r.csv"), "--stiffness", "86.9 kgf/mm",
            "--weight", "36 kgf", "--speed", "5 mm/min"]
    assert main([*base, "--time-col", "clock", "--force-col", "force"]) == 2
    assert "--time-col" in capsys.readouterr().err
    assert main([*base, "--time-col", "time", "--force-col", "9"]) == 2
    assert "--force-col" in capsys.readouterr().err


def test_from_arrays_with_units():
    t = np.arange(1000) * 1e-3
    r = Record.from_arrays(t, force=0.1 + 0.01 * np.sin(t), force_unit="N",
                           stiffness="852 N/um", mass="30.7 g", drive_speed="42 um/s")
    assert r.stiffness == pytest.approx(852e3 / 9.80665)
    assert r.weight == pytest.approx(0.0307)
    assert r.drive_speed == pytest.approx(0.042)
    with pytest.raises(RecordError, match="stiffness"):
        Record.from_arrays(t, t, stiffness="3 lbf", weight=1.0, drive_speed=1.0)
    with pytest.raises(RecordError, match="exactly one of weight"):
        Record.from_arrays(t, t, stiffness=1.0, drive_speed=1.0)


def test_import_a_jittery_logger_that_dropped_samples(tmp_path, capsys):
    """A logger whose stamps scatter by +-10 % of the step and that dropped 3 samples:
    imported (both were refused before), each with a note; the record is uniform and
    holds every sample of the run."""
    rng = np.random.default_rng(3)
    n, dt = 3000, 1e-3
    t = np.arange(n) * dt
    force = (0.1 + 0.02 * np.sin(2 * np.pi * 2 * t)) * 9.80665
    keep = np.setdiff1d(np.arange(n), [1000, 1001, 2000])
    stamps = t[keep] + 0.1 * dt * rng.uniform(-1, 1, keep.size)
    stamps[0], stamps[-1] = t[0], t[-1]
    raw = tmp_path / "raw.csv"
    raw.write_text("time [s],force [N]\n" + "\n".join(
        f"{float(a)!r},{float(b)!r}" for a, b in zip(stamps, force[keep])) + "\n")
    out = tmp_path / "rec.csv"
    assert main(["import", str(raw), "--out", str(out), "--time-col", "time", "--force-col",
                 "force", "--stiffness", "852 N/um", "--mass", "30.7 g",
                 "--speed", "42 um/s"]) == 0
    text = capsys.readouterr().out
    assert "3 sample(s) missing in 2 gap(s)" in text and "jitter" in text
    rec = read_record(out)
    assert rec.time.size == n and np.ptp(np.diff(rec.time)) < 1e-9
    assert np.allclose(rec.force * 9.80665, force, atol=2e-3)  # kgf -> N
