"""Identification of the pitching model from synthetic records with pitch_N/yaw_N channels."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import stickslip_jax as ss
from stickslip_fitting.solve.pitch import PitchRun, fit_pitching, pitch_run
from stickslip_jax import pitching as pt
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.records import Record, read_record, write_record
from stickslip_jax.simulation import simulate_exact

NOISE = 5e-5  # mm (0.05 um), the displacement noise of the synthetic micrometers
DRIVES = ((20.0, 40.0), (45.0, 0.0), (70.0, -40.0))  # (h, l) mm: like C1/V, C2, C3/F
TRUTH = {"compliance_pitch": 8e-8, "neutral_height": 30.0, "tau_pitch": 1.0,
         "compliance_yaw": 1e-7, "neutral_offset": 5.0, "tau_yaw": 10.0}


@pytest.fixture(scope="module")
def simulated():
    """One exact stick-slip run (lubricant A, W2, k2, 3 mm/min, 20 s at 50 Hz); the drive
    point does not change the stick-slip (Fig 45), so the three records share its force."""
    slideway = ss.Slideway(ss.lubricant("A"), 36.0, 86.9)
    ts = jnp.linspace(0.0, 20.0, 1001)
    trace = eqx.filter_jit(simulate_exact)(slideway, ConstantSpeed(3.0 / 60), ts)
    assert int(trace.cycles.valid.sum()) >= 5
    return ts, trace.deflection


def make_records(simulated, seed, drives=DRIVES, channels=None):
    ts, x = simulated
    truth = pt.default_model()
    rng = np.random.default_rng(seed)
    records = []
    for h, o in drives:
        disp = np.asarray(pt.tilt_history(truth, ts, 86.9 * x, pt.DrivePoint(h, o)).displacement)
        disp = disp + NOISE * rng.standard_normal(disp.shape)
        names = truth.points.names if channels is None else channels
        chans = {n: disp[:, truth.points.names.index(n)] for n in names}
        records.append(Record(
            time=np.asarray(ts), deflection=np.asarray(x), stiffness=86.9, weight=36.0,
            drive_speed=3.0 / 60, lubricant="A", channels=chans,
            channel_units={n: "um" for n in names},
            extra_header={"drive_height": f"{h} mm", "drive_offset": f"{o} mm"},
        ))
    return records


def poor_template():
    """Far from the truth: a third of the compliances, neutral points at 0, lags 0.1 s."""
    m = pt.default_model()
    return eqx.tree_at(
        lambda m: (m.pitch.compliance, m.pitch.neutral, m.pitch.lag.time_constants,
                   m.yaw.compliance, m.yaw.neutral, m.yaw.lag.time_constants),
        m, (jnp.asarray(2.7e-8), jnp.asarray(0.0), jnp.asarray([0.1]),
            jnp.asarray(3e-8), jnp.asarray(0.0), jnp.asarray([0.1])))


def test_recovers_parameters_within_95_percent_intervals_through_record_files(simulated,
                                                                             tmp_path):
    template = poor_template()
    runs = []
    for i, rec in enumerate(make_records(simulated, seed=1)):
        path = write_record(rec, tmp_path / f"run{i}.csv", channel_units="original")
        back = read_record(path)
        for name, values in rec.channels.items():  # written in um, read back in mm
            np.testing.assert_allclose(back.channels[name], values, rtol=1e-14, atol=1e-18)
        runs.append(pitch_run(back, template))  # drive point from the header
    fit = fit_pitching(runs, template=template)
    assert fit.successful
    assert fit.residual_rms_mm == pytest.approx(NOISE, rel=0.05)
    for name, true in TRUTH.items():
        p = fit.parameters[name]
        assert p["free"], name
        lo, hi = p["ci95"]
        assert lo < true < hi, (name, p)
        assert p["stderr"] < 0.01 * abs(true) + 0.05, (name, p)  # and the interval is tight


@pytest.mark.slow
def test_intervals_are_calibrated_over_seeds(simulated):
    """Over 10 noise draws, the 95 % intervals hold the truth in >= 85 % of the cases."""
    template = poor_template()
    inside = []
    for seed in range(10, 20):
        runs = [pitch_run(r, template) for r in make_records(simulated, seed)]
        fit = fit_pitching(runs, template=template)
        for name, true in TRUTH.items():
            lo, hi = fit.parameters[name]["ci95"]
            inside.append(lo < true < hi)
    assert np.mean(inside) >= 0.85


def test_single_height_fixes_the_neutral_point_and_says_so(simulated):
    records = make_records(simulated, seed=2, drives=((45.0, 0.0), (45.0, 0.0)),
                           channels=("pitch_1", "pitch_3"))
    template = pt.default_model()
    fit = fit_pitching([pitch_run(r, template) for r in records], template=template)
    assert not fit.parameters["neutral_height"]["free"]
    assert fit.parameters["neutral_height"]["ci95"] is None
    assert any("single drive height" in n for n in fit.notes)
    assert any("no yaw channels" in n for n in fit.notes)
    lo, hi = fit.parameters["tau_pitch"]["ci95"]
    assert lo < 1.0 < hi


def test_records_without_channels_or_drive_height_are_refused(simulated):
    ts, x = simulated
    rec = Record(time=np.asarray(ts), deflection=np.asarray(x), stiffness=86.9, weight=36.0,
                 drive_speed=0.05)
    with pytest.raises(ValueError, match="drive height unknown"):
        pitch_run(rec, pt.default_model())
    run = pitch_run(rec, pt.default_model(), height=45.0)
    assert isinstance(run, PitchRun)
    with pytest.raises(ValueError, match="no record carries"):
        fit_pitching([run])
