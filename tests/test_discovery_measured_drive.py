"""`stickslip discover` on records whose drive is measured: a lead-screw error held in the
records' `drive` column (written by the independent generator, tests/independent_records.py)
is part of the known drive, so discovery names no drive family for it; the same records
written with the nominal speed alone leave that error missing, and the drive family names
it."""

from __future__ import annotations

import json

import independent_records as ir
import pytest

from stickslip_jax.cli import main

DRIVE = ("drive_periodic_error", "drive_speed_drift")
"""The discovery families that change the drive (`discovery.cycle_effects.FAMILIES`)."""
RUNS = ((36.0, 86.9, 5.0, 10.0), (20.0, 27.3, 10.0, 10.0), (36.0, 86.9, 10.0, 6.0))
"""(W kgf, k kgf/mm, drive speed mm/min, duration s): a small campaign."""


def _discover(folder, column: bool) -> dict:
    """Write the campaign (6 um screw error on a 2 mm pitch, 0.5 um noise) with or without
    its `drive` column, run `stickslip discover`, return its JSON."""
    folder.mkdir()
    paths = []
    imp = ir.Imperfections(screw_amp_mm=0.006, screw_pitch_mm=2.0)
    for i, (W, k, v, T) in enumerate(RUNS):
        tr = ir.simulate(ir.LUBRICANT_A, weight=W, stiffness=k, speed_mm_min=v, duration=T,
                         rate_hz=1000.0, imp=imp, seed=70 + i)
        paths.append(str(folder / f"r{i}.csv"))
        ir.write_record(paths[-1], tr, friction=ir.LUBRICANT_A, weight=W, stiffness=k,
                        speed_mm_min=v, drive_column=column)
    out = folder / "discover.json"
    assert main(["discover", *paths, "--json", str(out), "--quiet"]) == 0
    return json.loads(out.read_text())


def _named(rep: dict) -> set[str]:
    """Every effect the answer names: the answer, its steps and its near equals."""
    names = {rep["effect"]} | {s["effect"] for s in rep.get("steps", []) if s.get("kept")}
    return names | {r["name"] for r in rep.get("indistinguishable_from", [])}


@pytest.mark.slow  # 799 s for the two campaigns at load 15 on 2 cores
def test_a_measured_screw_error_names_no_drive_family(tmp_path):
    measured = _discover(tmp_path / "column", True)
    assert measured["effect"] == "none", measured["explanation"]
    assert not _named(measured) & set(DRIVE)
    nominal = _discover(tmp_path / "speed", False)
    assert nominal["effect"] != "none", nominal["explanation"]
