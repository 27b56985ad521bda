"""Drives: positions and speeds of the three drive kinds, record conversion, validation."""

import json

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stickslip_jax.drives import ConstantSpeed, MeasuredDrive, SpeedProgram, drive_from_record
from stickslip_jax.records import Record


def test_constant_speed():
    d = ConstantSpeed(0.5)
    t = jnp.asarray([0.0, 1.0, 2.5])
    np.testing.assert_allclose(d.position(t), 0.5 * t)
    np.testing.assert_allclose(d.speed(t), 0.5)
    # differentiable in the speed
    assert float(jax.grad(lambda v: ConstantSpeed(v).position(2.0))(0.3)) == 2.0


def test_slide_hold_slide_program():
    d = SpeedProgram([0.0, 2.0, 5.0], [0.1, 0.0, 0.2])
    t = jnp.asarray([1.0, 2.0, 3.0, 5.0, 6.0])
    np.testing.assert_allclose(d.position(t), [0.1, 0.2, 0.2, 0.2, 0.4], atol=1e-15)
    np.testing.assert_allclose(d.speed(t), [0.1, 0.0, 0.0, 0.2, 0.2])


def test_measured_drive_interpolates_and_holds():
    d = MeasuredDrive([0.0, 1.0, 2.0], [0.0, 0.1, 0.3])
    np.testing.assert_allclose(d.position(jnp.asarray([0.5, 1.5, 3.0])), [0.05, 0.2, 0.3])
    np.testing.assert_allclose(d.speed(jnp.asarray([0.5, 1.5, 3.0])), [0.1, 0.2, 0.0])


def test_bad_drives_raise():
    with pytest.raises(ValueError, match="increase"):
        SpeedProgram([0.0, 0.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="same length"):
        SpeedProgram([0.0, 1.0], [1.0])
    with pytest.raises(ValueError, match="at least 2 samples"):
        MeasuredDrive([0.0], [0.0])


def test_drive_from_record():
    t = np.linspace(0.0, 1.0, 11)
    base = dict(time=t, deflection=np.zeros_like(t), stiffness=86.9, weight=36.0)
    assert isinstance(drive_from_record(Record(**base, drive_speed=0.1)), ConstantSpeed)
    prog = drive_from_record(Record(**base, drive_program=((0.5, 0.1), (0.8, 0.0))))
    np.testing.assert_allclose(prog.position(jnp.asarray([0.25, 0.7, 1.0])), [0.0, 0.02, 0.03],
                               atol=1e-15)
    meas = drive_from_record(Record(**base, drive=0.2 * t))
    np.testing.assert_allclose(meas.position(jnp.asarray(0.55)), 0.11)
    # the object is the record's drive: the same u(t) over the record's span
    tq = np.linspace(0.0, 1.0, 37)
    for drive in ({"drive_speed": 0.1}, {"drive": 0.2 * t**2},
                  {"drive_program": ((0.0, 0.1), (0.35, 0.0), (0.6, 0.3))},
                  {"drive_program": ((0.5, 0.1), (0.8, 0.0))}):
        rec = Record(**base, **drive)
        np.testing.assert_allclose(drive_from_record(rec).position(jnp.asarray(tq)),
                                   rec.drive_position(tq), rtol=1e-14, atol=1e-15)


# --- a measured drive through the trace and smooth objectives ------------------------

SCREW = dict(screw_amp_mm=0.006, screw_pitch_mm=2.0)
RUNS = ((36.0, 86.9, 5.0, 12.0), (20.0, 27.3, 10.0, 12.0), (36.0, 86.9, 2.0, 20.0))
"""(W kgf, k kgf/mm, drive speed mm/min, duration s) of the screw-error campaign."""


def _screw_runs(imp):
    """Runs of the independent generator (lubricant A, 0.5 um noise, drive `imp`)."""
    import independent_records as ir

    return [(ir.simulate(ir.LUBRICANT_A, weight=W, stiffness=k, speed_mm_min=v, duration=T,
                         rate_hz=1000.0, imp=imp, seed=i), W, k, v)
            for i, (W, k, v, T) in enumerate(RUNS)]


def _records(runs, drive):
    """The runs as `Record`s: `drive` "column" (the generator's drive as a `drive`
    column), "steady" (a `drive` column holding u = v t) or "speed" (the nominal drive
    speed only)."""
    def kw(tr, v):
        return {"column": dict(drive=tr.drive), "steady": dict(drive=v / 60.0 * tr.time),
                "speed": dict(drive_speed=v / 60.0)}[drive]

    return [Record(time=tr.time, deflection=tr.deflection, stiffness=k, weight=W,
                   source=f"r{i}.csv", **kw(tr, v)) for i, (tr, W, k, v) in enumerate(runs)]


@pytest.fixture(scope="module")
def screw_runs():
    import independent_records as ir

    return _screw_runs(ir.Imperfections(**SCREW))


@pytest.fixture(scope="module")
def clean_runs():
    """`RUNS` without a drive error: all three for the trace objective (the screw runs'
    88 windows, so one compiled program serves both), the first two for the smoothed one."""
    import independent_records as ir

    return _screw_runs(ir.Imperfections())


def _truth_params(n):
    import independent_records as ir
    from stickslip_fitting.params import CampaignParams, EmpiricalFriction

    L = ir.LUBRICANT_A
    return CampaignParams(EmpiricalFriction.from_values(L.mu_s, L.mu_d, L.gamma, L.m,
                                                        L.delta, L.n), jnp.zeros(n))


def _trace_rms(records):
    from stickslip_fitting.data.features import record_features
    from stickslip_fitting.objectives.trace import trace_data, trace_residuals

    data = trace_data(records, [record_features(r) for r in records])
    r = np.asarray(eqx.filter_jit(trace_residuals)(_truth_params(len(records)), data))
    return r[np.asarray(data.mask).ravel()], data


def test_trace_objective_drives_with_the_measured_column(screw_runs, clean_runs):
    """At the generator's truth the trace objective's residuals are the noise when the 6 um
    screw error is in the records' `drive` column (each window driven through its knots),
    and 17x the noise with only the nominal speed (the features' own drive correction
    taken out: measured 17.4); a drive column holding u = v t gives the residuals of the
    nominal speed to rounding."""
    measured, data = _trace_rms(_records(screw_runs, "column"))
    assert data.drive_knots is not None
    assert 0.9 < np.sqrt(np.mean(measured**2)) < 1.1 and np.abs(measured).max() < 6.0
    nominal, data = _trace_rms(_records(screw_runs, "speed"))
    assert data.drive_knots is None and np.sqrt(np.mean(nominal**2)) > 5.0
    a, _ = _trace_rms(_records(clean_runs, "speed"))
    b, data = _trace_rms(_records(clean_runs, "steady"))
    assert data.drive_knots is not None
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-6)


def test_trace_objective_drives_with_a_measured_speed(screw_runs):
    """The same runs written with their measured drive *speed* (a `drive_speed [mm/s]`
    column, a tachometer's), integrated when read: the trace objective's residuals at the
    truth are the noise, as with the position column (measured: rms 0.9953 both ways; the
    integrated drive within 9e-10 mm of the generator's)."""
    from stickslip_jax.records import parse_record

    recs = []
    for tr, W, k, v in screw_runs:
        speed = np.gradient(tr.drive, tr.time)
        rows = "\n".join(f"{a:.17g},{b:.17g},{c:.17g}"
                          for a, b, c in zip(tr.time, tr.deflection, speed))
        recs.append(parse_record(f"# stickslip-record: 1\n# stiffness: {k!r} kgf/mm\n"
                                 f"# slider_weight: {W!r} kgf\n"
                                 "time [s],deflection [mm],drive_speed [mm/s]\n" + rows))
    assert all(r.drive_source == "column" for r in recs)
    r, data = _trace_rms(recs)
    assert data.drive_knots is not None
    assert 0.9 < np.sqrt(np.mean(r**2)) < 1.1 and np.abs(r).max() < 6.0


SMOOTH_SAMPLES = 12_001
"""Samples of every record of the smoothed objective's tests, padded (a record's samples
after its first slip end, at most its 12 s at 1 kHz): one compiled program for the records
with a drive column and one for those without."""


@eqx.filter_jit
def _smooth_residuals(objective, params):
    return objective.residuals_and_aux(params)


def _smooth_rms(records):
    from stickslip_fitting.data.features import record_features
    from stickslip_fitting.objectives.smooth import SmoothObjective, smooth_data

    data = smooth_data(records, [record_features(r) for r in records])
    pad = SMOOTH_SAMPLES - data.time.shape[1]  # padding as `pad_series` pads: masked out

    def padded(x, mode):
        return jnp.pad(x, ((0, 0), (0, pad)), mode=mode)

    data = eqx.tree_at(lambda d: (d.time, d.deflection, d.mask), data,
                       (padded(data.time, "edge"), padded(data.deflection, "edge"),
                        padded(data.mask, "constant")))
    obj = SmoothObjective(data)
    r, (ok, _) = _smooth_residuals(obj, _truth_params(len(records)))
    assert np.asarray(ok).all()
    return np.asarray(r)[np.asarray(obj.data.mask).ravel()], obj.data


def test_smooth_objective_drives_with_the_measured_column(screw_runs, clean_runs):
    """The smoothed simulator run freely over whole records at the truth: with the 6 um
    screw error in the `drive` column its residuals are those of the same runs without
    any drive error (measured: rms 1.266 and 1.260, the smoothing's own slip timing),
    with only the nominal speed 40x the noise; a `drive` column holding u = v t gives the
    nominal speed's residuals (to 0.05 standard errors)."""
    measured, data = _smooth_rms(_records(screw_runs[:2], "column"))
    assert data.drive_knots is not None
    clean_runs = clean_runs[:2]
    clean, _ = _smooth_rms(_records(clean_runs, "speed"))
    assert np.sqrt(np.mean(measured**2)) < 1.03 * np.sqrt(np.mean(clean**2)) < 1.4
    nominal, _ = _smooth_rms(_records(screw_runs[:2], "speed"))
    assert np.sqrt(np.mean(nominal**2)) > 10.0
    # the adaptive solver's steps differ with the knots: measured 0.010 standard errors
    steady, _ = _smooth_rms(_records(clean_runs, "steady"))
    np.testing.assert_allclose(steady, clean, rtol=0, atol=0.05)


def test_fit_trace_with_a_measured_drive_column(tmp_path, screw_runs):
    """`stickslip fit --objective trace` on records whose `drive` column holds a 6 um
    lead-screw error: the misfit is the noise (measured chi2/n 0.988) and every 95 %
    interval holds the truth (mu_s, set here by three records' stick times, to +-12 %)."""
    import independent_records as ir

    from stickslip_jax.cli import main

    paths = []
    for i, (tr, W, k, v) in enumerate(screw_runs):
        paths.append(str(tmp_path / f"r{i}.csv"))
        ir.write_record(paths[-1], tr, friction=ir.LUBRICANT_A, weight=W, stiffness=k,
                        speed_mm_min=v, drive_column=True)
    out = tmp_path / "fit.json"
    assert main(["fit", *paths, "--objective", "trace", "--json", str(out), "--quiet"]) == 0
    rep = json.loads(out.read_text())
    assert 0.85 < rep["reduced_chi2"] < 1.15, rep["reduced_chi2"]
    for name, p in rep["parameters"].items():
        truth = getattr(ir.LUBRICANT_A, name)
        assert p["ci95"][0] <= truth <= p["ci95"][1], (name, p)
    assert abs(rep["parameters"]["mu_d"]["value"] / ir.LUBRICANT_A.mu_d - 1.0) < 0.01


@pytest.mark.slow  # 271 s at load 13 on 2 cores: forward mode through the ODE solver
def test_fit_smooth_with_a_measured_drive_column(screw_runs):
    """`--objective smooth` on two records whose `drive` column holds the 6 um screw
    error: the misfit is the noise's (measured chi2/n 1.063, against 1.26^2 at the truth
    without the fit: the smoothing's slip timing) and mu_d within 0.1 % (measured 0.2101
    against 0.21; two records determine little else)."""
    import independent_records as ir

    from stickslip_fitting.data.features import record_features
    from stickslip_fitting.modes import Objective
    from stickslip_fitting.solve.fit import fit_features

    recs = _records(screw_runs[:2], "column")
    fit = fit_features([record_features(r) for r in recs], objective=Objective.SMOOTH,
                       records=recs)
    assert fit.converged and fit.trace_failures == 0
    assert fit.reduced_chi2 < 1.15
    assert abs(fit.values["mu_d"] / ir.LUBRICANT_A.mu_d - 1.0) < 0.005
