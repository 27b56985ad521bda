"""Discovery on the per-cycle model (`stickslip_fitting.discovery.cycle_workflow`) against the
independent SciPy generator (`tests/independent_records.py`): a clean campaign gives
"none", a campaign with strong viscous damping (a damping *ratio*, not our force law's
coefficient) names `viscous_damping`; the command writes the JSON contract. The rates
over many campaigns are in `test_cycle_discovery_rates.py` (slow)."""

from __future__ import annotations

import json

import pytest

import independent_records as ir
from stickslip_fitting.discovery.cycle_workflow import discover_cycles

SMALL = dict(runs=((36.0, 86.9), (20.0, 27.3)), speeds=(5.0, 10.0), cycles=5.0)


@pytest.fixture(scope="module")
def clean_files(tmp_path_factory):
    from stickslip_jax.records import write_record

    d = tmp_path_factory.mktemp("clean")
    paths = []
    for i, r in enumerate(ir.campaign(seed=11, **SMALL)):
        p = d / f"r{i}.csv"
        write_record(r, p)
        paths.append(str(p))
    return paths


def test_clean_campaign_names_nothing(clean_files, tmp_path, capsys):
    from stickslip_jax.cli import main

    out = tmp_path / "d.json"
    assert main(["discover", *clean_files, "--json", str(out)]) == 0
    captured = capsys.readouterr()
    rep = json.loads(out.read_text())
    assert rep["effect"] == "none", rep["explanation"]
    assert rep["base"] == "cycle" and rep["gap_unit"] == "mm"
    assert abs(rep["gap_before"] / rep["noise"] - 1) < 0.1
    for key in ("candidates", "parameters_before", "parameters_after", "timings_s",
                "records", "residuals_by_phase_before"):
        assert key in rep
    assert {c["name"] for c in rep["candidates"]} >= {"viscous_damping", "sensor_lowpass"}
    assert "base_fit:" in captured.err and "ranking:" in captured.err  # progress lines


def test_strong_damping_is_named():
    recs = ir.campaign(physics=ir.Physics(damping_ratio=0.15), seed=12, **SMALL)
    res = discover_cycles(recs)
    named = {res.effect} | {r["name"] for r in res.indistinguishable_from}
    assert "viscous_damping" in named, res.explanation
    assert res.gap_after <= 1.15 * res.noise
    assert res.effect_size["c"]["value"] > 0
