"""Cycle features near the stick-slip boundary, against the independent SciPy generator.

The record: lubricant C (of `independent_records`), W 36 kgf, k 86.9 kgf/mm, 20 mm/min:
slips of 3.5 um whose sticks (10 ms) are half a slip long, the drive moving 2.2 um per
radian of the slip (q = v / (omega0 a) ~ 1.2). The generator records the true breakaways
and slip ends, so the extraction is checked slip by slip.
"""

import os
import sys

import numpy as np
import pytest

from stickslip_fitting.data.features import extract_cycles

sys.path.insert(0, os.path.dirname(__file__))
import independent_records as ir  # noqa: E402

W, K, V = 36.0, 86.9, 20.0  # kgf, kgf/mm, mm/min


def _record(noise_mm, seed):
    imp = ir.Imperfections(noise_mm=noise_mm)
    tr = ir.simulate(ir.LUBRICANT_C, weight=W, stiffness=K, speed_mm_min=V, duration=3.0,
                     rate_hz=1000.0, imp=imp, seed=seed)
    f = extract_cycles(tr.time, tr.deflection, weight=W, stiffness=K, drive=V / 60.0)
    return tr, f


def _matched(tr, f, tol=0.005):
    """(index of the true slip, index of the found slip) pairs within `tol` s."""
    out = []
    for i, b in enumerate(f.breakaway_time):
        j = int(np.argmin(np.abs(tr.breakaways - b)))
        if abs(tr.breakaways[j] - b) < tol:
            out.append((j, i))
    return out


@pytest.fixture(scope="module")
def noisy():
    return _record(5e-4, 313)


def test_short_sticks_are_not_merged(noisy):
    """Two slips 10 ms apart stay two cycles (before: runs closer than two half periods
    were merged, 41 of 64 slips found, windows holding two slips)."""
    tr, f = noisy
    assert f.stick_slip
    assert len(_matched(tr, f)) >= len(tr.breakaways) - 1
    # no complete cycle's stick hides a true slip
    for j in np.flatnonzero(f.complete):
        lo, hi = f.end_time[j - 1], f.breakaway_time[j]
        assert not np.any((tr.breakaways > lo + 0.002) & (tr.breakaways < hi - 0.002))


def test_slip_ends_are_unbiased_at_low_noise():
    """The slip's duration is the fixed point of the closed form, not four iterations from
    pi / omega0 (which leave the ends 0.7 ms early and the breakaways 0.6 ms late at any
    noise)."""
    tr, f = _record(5e-5, 7)
    pairs = _matched(tr, f)
    assert len(pairs) >= 50
    end_err = np.array([f.end_time[i] - tr.slip_ends[j] for j, i in pairs])
    brk_err = np.array([f.breakaway_time[i] - tr.breakaways[j] for j, i in pairs])
    assert abs(np.mean(end_err)) < 0.1e-3
    assert abs(np.mean(brk_err)) < 0.1e-3


def test_slip_end_errors_match_their_standard_errors(noisy):
    """The reported standard error of a slip end (`stick_time_sd` / sqrt 2, the trace
    objective's `start_time_sd`) includes the slip duration's error: near the boundary
    it is most of it."""
    tr, f = noisy
    pairs = _matched(tr, f)
    z = np.array([(f.end_time[i] - tr.slip_ends[j]) / (f.stick_time_sd[i] / np.sqrt(2.0))
                  for j, i in pairs])
    assert z.size >= 50
    assert 0.6 < np.std(z) < 1.6
    assert abs(np.mean(z)) < 0.5
