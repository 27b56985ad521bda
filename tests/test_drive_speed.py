"""A measured drive speed (`drive_speed [mm/s]` column: a tachometer, a motor encoder's
rate) is integrated to the drive displacement when the record is read, so cycle
extraction, the plot and the fit see one measured drive."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torsional_rig as tr
from stickslip_fitting.data.features import record_features

from stickslip_jax.record_plots import classify_phases
from stickslip_jax.records import RecordError, parse_record, read_record

HEAD = ("# stickslip-record: 1\n# stiffness: 1.0 kgf/mm\n# slider_weight: 10 kgf\n")


def test_speed_column_is_the_drive():
    t = np.arange(201) * 0.01
    v = 1.0 + 0.5 * np.sin(2.0 * np.pi * t)  # mm/s
    rows = "\n".join(f"{a:.17g},0.1,{b * 60.0:.17g}" for a, b in zip(t, v))
    rec = parse_record(HEAD + "time [s],deflection [mm],drive_speed [mm/min]\n" + rows)
    exact = t - 0.5 / (2.0 * np.pi) * (np.cos(2.0 * np.pi * t) - 1.0)
    np.testing.assert_allclose(rec.drive, exact, atol=2e-4)  # trapezoids at 100 Hz: 1e-4
    assert rec.drive_source == "column"
    assert any("drive_speed column" in n for n in rec.notes)


def test_speed_column_needs_a_speed_unit():
    with pytest.raises(RecordError, match="drive_speed"):
        parse_record(HEAD + "time [s],deflection [mm],drive_speed [mm]\n0,0,1\n0.1,0,1\n")


@pytest.mark.parametrize("seed", [7, 21])
def test_torsional_record_with_a_tachometer(tmp_path, seed):
    """The same run written with its measured position and with its measured speed:
    the same slips, breakaway friction within 0.5 % of the truth either way."""
    rig = tr.random_rig(seed)
    run = tr.simulate(rig)
    tol = 0.1 * 2.0 * math.pi / rig.omega0
    got = {}
    for channel in ("drive", "speed"):
        rec = read_record(tr.write(tmp_path / f"{channel}.csv", rig, run, channel=channel))
        f = record_features(rec)
        assert f.stick_slip, f.message
        hits = [int(np.argmin(np.abs(run["breaks"] - b))) for b in f.breakaway_time]
        assert all(abs(run["breaks"][j] - b) < tol for j, b in zip(hits, f.breakaway_time))
        err = np.abs(f.mu_0 / run["mu_0"][hits] - 1.0)
        assert np.median(err) < 5e-3, (channel, err)
        got[channel] = (len(f.peak), classify_phases(rec).n_slips)
    n_d, n_s = got["drive"], got["speed"]
    assert abs(n_d[0] - n_s[0]) <= 1 and abs(n_d[1] - n_s[1]) <= 1, got


@pytest.mark.slow  # 20 fits of 4 records: 13-27 minutes on 2 loaded cores
@pytest.mark.targets  # met: measured below
def test_measured_drive_campaigns_cover_the_truth(tmp_path):
    """Campaigns of the torsional rig (4 records: 2 springs x 2 motor speeds, motor speed
    +-10 to +-50 %), half written with the measured drive position and half with the
    measured speed: mu_s and mu_d within 3 % and their 95 % intervals holding the truth
    in >= 90 % of 20 campaigns. Measured: mu_s's intervals hold the truth in 19 of 20
    (the miss 0.03 % off), mu_d's in 20 of 20 and both within 3 % in 20 of 20 (525 s at
    load 13-15)."""
    import json

    from stickslip_jax.cli import main

    law = tr.CAMPAIGN_LAW
    close, covered = 0, {"mu_s": 0, "mu_d": 0}
    for seed in range(20):
        folder = tmp_path / f"c{seed}"
        folder.mkdir()
        paths = tr.campaign(folder, seed, channel="drive" if seed % 2 else "speed")
        out = folder / "fit.json"
        assert main(["fit", *paths, "--json", str(out), "--quiet"]) == 0
        p = json.loads(out.read_text())["parameters"]
        ok = True
        for name in covered:
            truth, value, ci = getattr(law, name), p[name]["value"], p[name]["ci95"]
            ok &= value is not None and abs(value / truth - 1.0) < 0.03
            covered[name] += ci is not None and ci[0] <= truth <= ci[1]
            print(f"campaign {seed}: {name} {value} {ci} {p[name].get('reason')}")
        close += ok
    print(f"\nwithin 3 %: {close} of 20; 95 % intervals hold the truth: {covered}")
    assert close >= 18
    assert min(covered.values()) >= 18
