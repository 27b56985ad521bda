"""Records we did not make: cycle extraction and campaign fits on the independent SciPy
generator (`tests/independent_records.py`, no code shared with stickslip_jax.simulation),
with each instrument / drive imperfection alone and all together.

Measured rates are asserted against the targets: >= 90 % of the true slips found,
<= 1 false slip per record; a campaign with records without usable stick-slip exits 0,
lists them, and recovers mu_s and mu_d within 2 % with 95 % intervals containing them.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import independent_records as ir
from stickslip_fitting.data.campaign import NO_STICK_SLIP, SET_ASIDE, USED, screen_records
from stickslip_fitting.data.features import extract_cycles
from stickslip_jax.cli import main
from stickslip_jax.records import read_record

I = ir.Imperfections  # noqa: E741

IMPERFECTIONS = {
    "clean": I(),
    "spikes": I(spike_rate=0.002, spike_mm=0.05),
    "glitch_10mm": I(spike_rate=0.0005, spike_mm=10.0),
    "quantised_1um": I(quantum_mm=0.001),
    "quantised_5um": I(quantum_mm=0.005, noise_mm=0.001),
    "screw_10um_pitch_1mm": I(screw_amp_mm=0.010, screw_pitch_mm=1.0),
    "screw_10um_pitch_3mm": I(screw_amp_mm=0.010, screw_pitch_mm=3.0),
    "speed_drift_5pc": I(speed_drift=0.05),
    "sensor_1st_30Hz": I(sensor_order=1, sensor_hz=30.0),
    "sensor_2nd_30Hz": I(sensor_order=2, sensor_hz=30.0, sensor_zeta=0.3),
    "creep": I(creep_mm=0.005, creep_tau_s=0.2),
    "irregular_slips": I(mu_s_jitter=0.05),
    "all_together": I(noise_mm=0.001, spike_rate=0.001, spike_mm=0.03, quantum_mm=0.001,
                      screw_amp_mm=0.006, screw_pitch_mm=2.0, speed_drift=0.03,
                      sensor_order=1, sensor_hz=60.0, creep_mm=0.002, creep_tau_s=0.1,
                      mu_s_jitter=0.02),
}
RUNS = ((27.3, 5.0, 40.0, 500.0), (86.9, 5.0, 20.0, 1000.0))  # k kgf/mm, v mm/min, s, Hz
W = 36.0


def _rates(imp, seed=3, runs=RUNS):
    found = total = false = 0
    for k, v, duration, rate in runs:
        tr = ir.simulate(ir.LUBRICANT_A, weight=W, stiffness=k, speed_mm_min=v,
                         duration=duration, rate_hz=rate, imp=imp, seed=seed)
        f = extract_cycles(tr.time, tr.deflection, weight=W, stiffness=k, drive=v / 60.0)
        t2 = np.pi / np.sqrt(9806.65 * k / W)
        lag = 1.0 / (2 * np.pi * imp.sensor_hz) if imp.sensor_order else 0.0
        tol = 2.0 * t2 + lag + 2.0 / rate
        det = f.breakaway_time
        found += sum(bool(np.any(np.abs(det - b) < tol)) for b in tr.breakaways)
        total += len(tr.breakaways)
        false = max(false, sum(not np.any(np.abs(tr.breakaways - d) < tol) for d in det))
    return found, total, false


@pytest.mark.parametrize("name", list(IMPERFECTIONS))
def test_cycles_found_under_imperfection(name):
    """Slips used as cycles (not only detected): >= 90 % of the true ones, <= 1 false per
    record. Measured with seed 3: every case 100 %, 0 false."""
    found, total, false = _rates(IMPERFECTIONS[name])
    assert total >= 20
    assert found >= 0.9 * total, (name, found, total)
    assert false <= 1, (name, false)


def test_creep_through_the_whole_stick_of_a_stiff_spring():
    """k 128.5 kgf/mm at 4 mm/min: sticks of 0.39 s with a creep time constant of 0.2 s,
    so the slider creeps from the stick's start (measured: 72 of 73 cycles complete with
    the creeping-stick line model; a flat-stick model would keep 13). At 20 mm/min (85 ms
    sticks, about a third of them creeping faster than half the drive) fewer are kept: a
    documented weak spot."""
    found, total, false = _rates(IMPERFECTIONS["creep"], runs=((128.5, 4.0, 30.0, 1000.0),))
    assert total >= 60
    assert found >= 0.9 * total, (found, total)
    assert false <= 1


def test_second_order_sensor_at_the_slideway_frequency():
    """k 128.5 kgf/mm (natural frequency 29.8 Hz) read through a 30 Hz second-order sensor
    with damping ratio 0.3: the ringing splits a slip into two falls a few samples apart
    (measured: 261 of 306 slips used before those are merged, 286 after)."""
    imp = IMPERFECTIONS["sensor_2nd_30Hz"]
    found, total, false = _rates(imp, runs=((128.5, 20.0, 15.0, 2000.0),
                                            (128.5, 4.0, 30.0, 1000.0)))
    assert total >= 250
    assert found >= 0.9 * total, (found, total)
    assert false <= 1


def test_pure_noise_has_no_slips():
    """Steady sliding with noise, spikes and quantisation: no slip in 20 records of 20 k
    samples (the length-aware threshold, `stickslip_fitting.data.sticks.detection_z`)."""
    rng = np.random.default_rng(0)
    t = np.arange(20_000) * 1e-3
    slips = 0
    for _ in range(20):
        x = 0.087 + 5e-4 * rng.standard_normal(t.size)
        x[rng.random(t.size) < 1e-3] += 0.02
        x = np.round(x / 1e-3) * 1e-3 if rng.random() < 0.5 else x
        f = extract_cycles(t, x, weight=W, stiffness=86.9, drive=1.0)
        slips += len(f.peak)
    assert slips == 0


def test_small_slips_of_five_noise_sd_are_found():
    """A drop of 5 noise standard deviations, repeated: every one found."""
    rng = np.random.default_rng(1)
    k = 86.9
    t = np.arange(30_000) * 1e-3
    period, drop = 1.0, 2.5e-3  # a saw tooth: x rises with the drive, drops 2.5 um a period
    x = 0.1 + (drop / period) * np.mod(t, period)
    noise = drop / 5.0
    f = extract_cycles(t, x + noise * rng.standard_normal(t.size), weight=W, stiffness=k,
                       drive=drop / period)
    assert len(f.peak) >= 0.9 * 29
    assert abs(f.noise - noise) < 0.1 * noise


def _campaign(tmp_path, seed=0):
    F = ir.LUBRICANT_A
    runs = [(27.3, 5, 30, 500), (27.3, 12, 15, 500), (86.9, 2, 40, 500), (86.9, 5, 20, 1000),
            (86.9, 12, 10, 1000), (128.5, 4, 20, 1000), (128.5, 9, 10, 1000)]
    imps = [I(spike_rate=0.001, spike_mm=0.02), I(quantum_mm=0.001),
            I(screw_amp_mm=0.006, screw_pitch_mm=2.0), I(speed_drift=0.03),
            I(sensor_order=1, sensor_hz=60), I(), I(noise_mm=0.001)]
    paths = []
    for i, ((k, v, T, fs), imp) in enumerate(zip(runs, imps)):
        tr = ir.simulate(F, weight=W, stiffness=k, speed_mm_min=v, duration=T, rate_hz=fs,
                         imp=imp, seed=100 * seed + i)
        paths.append(tmp_path / f"A_k{k}_v{v}.csv")
        ir.write_record(paths[-1], tr, friction=F, weight=W, stiffness=k, speed_mm_min=v)
    tr = ir.simulate(F, weight=W, stiffness=86.9, speed_mm_min=200, duration=3, rate_hz=1000,
                     steady=True, imp=I(), seed=100 * seed + 50)
    paths.append(tmp_path / "A_k86.9_v200_steady.csv")
    ir.write_record(paths[-1], tr, friction=F, weight=W, stiffness=86.9, speed_mm_min=200)
    tr = ir.simulate(F, weight=W, stiffness=27.3, speed_mm_min=5, duration=6, rate_hz=500,
                     seed=100 * seed + 51)
    paths.append(tmp_path / "A_k27.3_v5_short.csv")
    ir.write_record(paths[-1], tr, friction=F, weight=W, stiffness=27.3, speed_mm_min=5)
    return [str(p) for p in paths]


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """`_campaign`'s files, written once for the module (the tests only read them)."""
    return _campaign(tmp_path_factory.mktemp("mixed_campaign"))


def test_screening_sets_records_aside(campaign):
    paths = campaign
    camp = screen_records([read_record(p) for p in paths])
    status = {s.name: s.status for s in camp.screening}
    assert status["A_k86.9_v200_steady"] in (NO_STICK_SLIP, SET_ASIDE)
    assert status["A_k27.3_v5_short"] in (NO_STICK_SLIP, SET_ASIDE)
    assert sum(s == USED for s in status.values()) == 7
    with pytest.raises(ValueError, match="--strict"):
        screen_records([read_record(p) for p in paths], strict=True)


def test_fit_goes_on_with_the_good_records(campaign, tmp_path, capsys):
    """`stickslip fit` on a mixed independent campaign: exit 0, the two records without
    usable stick-slip listed (printed and in the JSON), mu_s and mu_d within 2 % with 95 %
    intervals containing the truth; the input files unchanged."""
    paths = campaign
    before = {p: open(p, "rb").read() for p in paths}
    out = tmp_path / "fit.json"
    assert main(["fit", *paths, "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "A_k86.9_v200_steady" in text and "A_k27.3_v5_short" in text
    rep = json.loads(out.read_text())
    rows = {r["name"]: r for r in rep["records"]}
    assert len(rows) == 9 and rep["records_not_used"] == 2
    assert rows["A_k27.3_v5_short"]["status"] != "used" and rows["A_k27.3_v5_short"]["reason"]
    for name in ("mu_s", "mu_d"):
        p = rep["parameters"][name]
        assert abs(p["relative_error"]) < 0.02, (name, p)
        assert p["truth_in_ci95"], (name, p)
    assert all(open(p, "rb").read() == before[p] for p in paths)
    assert main(["fit", *paths, "--strict"]) == 2


def _steady_file(path, speed_mm_min, seed):
    rng = np.random.default_rng(seed)
    lines = ["# stickslip-record: 1", f"# drive_speed: {speed_mm_min} mm/min",
             "# stiffness: 86.9 kgf/mm", "# slider_weight: 36 kgf", "# lubricant: A",
             "time [s],deflection [mm]"]
    x = 0.21 * 36 / 86.9 + 5e-4 * rng.standard_normal(3000)
    path.write_text("\n".join(lines + [f"{i * 1e-3:.3f},{float(v)!r}" for i, v in enumerate(x)]) + "\n")
    return read_record(str(path))


def test_steady_records_against_the_boundary(campaign, tmp_path):
    """A record sliding steadily at 2 mm/min, far below lubricant A's eq (12) v_c of
    48.9 mm/min at W 36 kgf, k 86.9 kgf/mm, is a misfit of the model; at 200 mm/min it is
    consistent with it."""
    import stickslip_jax as ss
    from stickslip_fitting.solve.summary import boundary_check

    good = campaign[:2]
    recs = [read_record(p) for p in good]
    recs += [_steady_file(tmp_path / "slow.csv", 2.0, 1), _steady_file(tmp_path / "fast.csv",
                                                                        200.0, 2)]
    camp = screen_records(recs)
    got = {c["name"]: c for c in boundary_check(ss.lubricant("A"), camp)}
    assert got["slow"]["misfit"] and got["slow"]["predicted_amplitude_um"] > 10
    assert not got["fast"]["misfit"]
    assert got["fast"]["critical_speed_mm_per_min"] == pytest.approx(48.9, rel=0.01)


def test_discover_screens_the_campaign(campaign, tmp_path, capsys):
    """`stickslip discover` screens like `fit`: with one usable record of two it stops
    before any fitting with a line naming the other record."""
    good = campaign[0]
    _steady_file(tmp_path / "flat.csv", 60.0, 3)
    assert main(["discover", good, str(tmp_path / "flat.csv")]) == 2
    err = capsys.readouterr().err
    assert "only 1 of 2 records" in err and "flat" in err
