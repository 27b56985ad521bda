"""The binned sticks of the per-cycle discovery (`stickslip_fitting.discovery.thinning`):
every sample is represented once, the windows keep their events, and the chi-square,
the score and the gap of the binned windows are those of all samples."""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))
import independent_records as ir  # noqa: E402


@pytest.fixture(scope="module")
def windows():
    from stickslip_fitting.data.campaign import screen_records
    from stickslip_fitting.discovery.thinning import thin_windows
    from stickslip_fitting.objectives.trace import trace_data

    recs = ir.campaign(ir.LUBRICANT_A, imp=ir.Imperfections(screw_amp_mm=0.006,
                                                            screw_pitch_mm=2.0),
                       seed=3, cycles=3.0, rate_hz=2000.0, runs=ir.RUNS[:1], speeds=(2.0, 10.0))
    c = screen_records(recs)
    full = trace_data(c.records, c.features, drive_fix=False)
    thin, samples = thin_windows(full)
    return c, full, thin, samples


def test_every_sample_once_and_fewer_rows(windows):
    _, full, thin, samples = windows
    mask, tmask = np.asarray(full.mask), np.asarray(thin.mask)
    assert samples.flat(tmask.ravel()).n == mask.sum()
    assert tmask.sum() < 0.2 * mask.sum()
    # the windows, their order and their first and last samples are kept
    def ends(d):
        m, w, t = np.asarray(d.mask), np.asarray(d.window), np.asarray(d.time)
        ww = np.broadcast_to(w[:, None], m.shape)[m]
        tt = t[m]
        first = np.r_[True, np.diff(ww) != 0]
        last = np.r_[np.diff(ww) != 0, True]
        return ww[first], tt[first], tt[last]
    for a, b in zip(ends(full), ends(thin)):
        np.testing.assert_array_equal(a, b)
    # every bin lies in a stick: before the measured breakaway
    count = samples.count[tmask]
    t = np.asarray(thin.time)[tmask]
    rows = np.nonzero(tmask)[0]
    breakaway = np.asarray(thin.start_time)[rows] + np.asarray(thin.stick_time)[rows]
    assert np.all(t[count > 1] < breakaway[count > 1])


def test_chi_square_and_gap_of_all_samples(windows):
    """At the features' start and at frictions off it: the binned chi-square (plus the
    bins' scatter), its differences (what a fit and its score tests see) and the gap are
    those of all samples."""
    from stickslip_fitting.discovery.cycle_model import CycleModel, drift_origins
    from stickslip_fitting.discovery.decision import rms_gap
    from stickslip_fitting.discovery.stages.prepare import sd_at
    from stickslip_fitting.discovery.thinning import Samples
    from stickslip_fitting.solve.fit import fit_features

    c, full, thin, samples = windows
    G = len(c.records)
    start = fit_features(c.features).params
    out = {}
    for name, data, smp in (("full", full, Samples(np.ones(full.mask.shape),
                                                     np.zeros(full.mask.shape))),
                            ("thin", thin, samples)):
        ones = CycleModel(data, drift_origins(c.records), np.ones(data.mask.shape), G)
        z = ones.z0(start.friction, np.asarray(start.offset))
        _, yd, _ = ones.residuals(z)
        model = CycleModel(data, ones.tref, sd_at(z, data, yd, smp), G)
        sd = np.asarray(model.sd).ravel()[model.mask]
        flat = smp.flat(model.mask)
        res = []
        for dz in (0.0, 0.01, -0.01, 0.05):  # log mu_d: chi-square up by 1e2 to 1e5
            zz = z.copy()
            zz[0] += dz
            r = model.residuals(zz)[0]
            res.append((flat.chi2(r, sd), rms_gap(r, sd, flat)))
        out[name] = np.array(res)
    (c_f, gap_f), (c_t, gap_t) = out["full"].T, out["thin"].T
    np.testing.assert_allclose(c_t, c_f, rtol=2e-3)
    np.testing.assert_allclose(gap_t, gap_f, rtol=2e-3)
    np.testing.assert_allclose(c_t[1:] - c_t[0], c_f[1:] - c_f[0], rtol=1e-2)


def test_a_measured_drive_follows_its_windows(tmp_path):
    """Records with a `drive` column: every binned row carries its own window's drive
    knots (`TraceData.drive_knots`), as the unbinned rows do."""
    from stickslip_fitting.data.campaign import screen_records
    from stickslip_fitting.discovery.thinning import thin_windows
    from stickslip_fitting.objectives.trace import trace_data
    from stickslip_jax.records import read_record

    imp = ir.Imperfections(screw_amp_mm=0.006, screw_pitch_mm=2.0)
    recs = []
    for i, (W, k, v) in enumerate(((36.0, 86.9, 5.0), (20.0, 27.3, 10.0))):
        tr = ir.simulate(ir.LUBRICANT_A, weight=W, stiffness=k, speed_mm_min=v,
                         duration=6.0, rate_hz=1000.0, imp=imp, seed=40 + i)
        path = tmp_path / f"r{i}.csv"
        ir.write_record(path, tr, friction=ir.LUBRICANT_A, weight=W, stiffness=k,
                        speed_mm_min=v, drive_column=True)
        recs.append(read_record(path))
    c = screen_records(recs)
    full = trace_data(c.records, c.features, drive_fix=False)
    assert full.drive_knots is not None
    thin, _ = thin_windows(full)
    knots, tknots = np.asarray(full.drive_knots), np.asarray(thin.drive_knots)
    assert tknots.shape[0] == np.asarray(thin.mask).shape[0]
    first_row = {w: i for i, w in reversed(list(enumerate(np.asarray(full.window))))}
    for row, w in enumerate(np.asarray(thin.window)):
        np.testing.assert_array_equal(tknots[row], knots[first_row[w]])
