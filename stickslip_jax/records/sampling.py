"""The clock of a record: how even its time steps must be, and a logger's jittered clock,
dropped samples and epoch stamps, which reading repairs with a note."""

from __future__ import annotations

import numpy as np

TIME_STEP_RTOL = 1e-3
"""Largest relative deviation of a time step from the mean step, |dt_i - dt| / dt."""

JITTER_RTOL = 0.05
"""Time steps within this relative deviation of the mean step (and beyond
`TIME_STEP_RTOL`) are a logger's clock jitter: the record is resampled to a uniform step
with a note. Larger deviations (gaps, coarse rounding) are refused with the reason, unless
the clock is jittered by the looser test of `JITTER_STAMP`."""

JITTER_STAMP = 0.25
"""A clock of at least `JITTER_MIN_SAMPLES` samples whose stamps all lie within this
fraction of a step of the uniform grid of the stamps' least-squares line, and whose steps
all lie within `JITTER_STEP` of the mean step, is a logger's jittered clock as well
(stamps scattered by +-20 % of a step move single steps by up to 40 %): resampled with a
note. A missing sample is a step of about twice the mean, a doubled one a step near 0,
and a run of uneven rate drifts away from the grid: all still refused."""

JITTER_STEP = 0.6
"""Largest relative step deviation of a jittered clock under `JITTER_STAMP`."""

MISSING_RUN = 10
"""Longest run of samples a logger may have dropped (a step of up to 11 steps of its
clock, the stamps otherwise on its grid within `JITTER_STAMP`): filled by linear
interpolation with a note (`missing_samples`). Longer gaps are refused (split the run
there)."""

MISSING_SHARE = 0.01
"""Largest share of a record's samples that may be missing and filled."""

JITTER_MIN_SAMPLES = 100
"""Fewer samples than this cannot tell a clock's jitter from an uneven run: only
`JITTER_RTOL` applies to them."""

EPOCH_SECONDS = 1e6
"""A first time stamp above this (s) is a logger's epoch time: time then counts from the
first sample (float64 keeps about 0.2 us of a 1.7e9 s stamp)."""

def resample_to(grid: np.ndarray, t: np.ndarray, values):
    """`values` at `t` linearly interpolated to `grid`; anything that is not an array of
    t's shape is passed on for `Record` to report."""
    try:
        a = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        return values
    return np.interp(grid, t, a) if a.shape == t.shape else values


def _line(time: np.ndarray) -> tuple[float, float]:
    """(first stamp, step) of the least-squares line through the stamps: the clock a
    jittered logger kept, which its own jittered first and last stamps are not."""
    k = np.arange(time.shape[0], dtype=np.float64)
    dt, t0 = np.polyfit(k, time - time[0], 1)
    return float(time[0] + t0), float(dt)


def _uniform_grid(time: np.ndarray, dev: float) -> tuple[np.ndarray, str]:
    """The uniform grid (same ends, same count) that a jittered clock is resampled to,
    and the note saying so (`JITTER_RTOL`)."""
    dt = (time[-1] - time[0]) / (time.size - 1)
    grid = time[0] + dt * np.arange(time.size)
    grid[-1] = time[-1]
    return grid, (f"time stamps jitter by up to {100 * dev:.3g} % of the {dt:.6g} s step: "
                  "resampled to a uniform step (linear interpolation)")


def jittered_clock(time: np.ndarray, dev: float) -> bool:
    """Whether time stamps with step deviation `dev` (`time_step_deviation`) beyond
    `TIME_STEP_RTOL` are a logger's clock jitter, to resample (`JITTER_RTOL`,
    `JITTER_STAMP`)."""
    if not dev > TIME_STEP_RTOL:
        return False
    if dev <= JITTER_RTOL:
        return True
    n = time.shape[0]
    if n < JITTER_MIN_SAMPLES or dev > JITTER_STEP:
        return False
    t0, dt = _line(time)
    off = np.abs(time - (t0 + dt * np.arange(n))) / dt
    return bool(dt > 0 and np.max(off) <= JITTER_STAMP)


def jitter_grid(time: np.ndarray) -> tuple[np.ndarray, str] | None:
    """The uniform grid and note for a jittered clock (`jittered_clock`), or None."""
    dev, _, _ = time_step_deviation(time)
    return _uniform_grid(time, dev) if jittered_clock(time, dev) else None


def missing_samples(time: np.ndarray) -> tuple[np.ndarray, str] | None:
    """A clock that dropped samples: the full uniform grid and a note, or None.

    Every stamp lies within `JITTER_STAMP` of a step of a uniform grid (its step fitted
    to the stamps; a jittered clock may drop samples too), no two stamps share a grid
    point, some grid points have no stamp, at most `MISSING_RUN` in a row and at most
    `MISSING_SHARE` in all, in a record of `JITTER_MIN_SAMPLES` or more. The grid runs
    from the first to the last stamp with the missing samples put back."""
    n = time.shape[0]
    if n < JITTER_MIN_SAMPLES:
        return None
    dt = float(np.median(np.diff(time)))
    if not dt > 0:
        return None
    runs = np.rint(np.diff(time) / dt) - 1  # grid points skipped by each step
    if np.any(runs < 0) or not np.any(runs):  # a sample written twice; none missing
        return None
    k = np.r_[0.0, np.cumsum(runs + 1)]
    dt, t0 = np.polyfit(k, time, 1)  # the clock's step over the whole run
    off = np.abs(time - (t0 + k * dt)) / dt
    if not dt > 0 or np.max(off) > JITTER_STAMP:
        return None
    lost = int(runs.sum())
    if runs.max() > MISSING_RUN or lost > MISSING_SHARE * (n + lost):
        return None
    full = n + lost
    grid = time[0] + (time[-1] - time[0]) / (full - 1) * np.arange(full)
    grid[-1] = time[-1]
    gaps = np.flatnonzero(runs)
    where = ", ".join(f"{float(time[g]):.6g} s" for g in gaps[:3]) + (
        ", ..." if gaps.size > 3 else "")
    jitter = (f"; the stamps jitter by up to {100 * float(np.max(off)):.3g} % of the step"
              if np.max(off) > TIME_STEP_RTOL else "")
    return grid, (f"{lost} sample(s) missing in {gaps.size} gap(s) of up to "
                  f"{int(runs.max())} (after {where}): filled by linear interpolation"
                  + jitter)


def uniform_clock(time: np.ndarray, columns: list, notes: list[str]) -> tuple[np.ndarray, list]:
    """(time, columns) with a logger's clock read as it was meant, each repair said in
    `notes`: epoch stamps counted from the first (`EPOCH_SECONDS`), then, for strictly
    increasing stamps, dropped samples put back (`missing_samples`) and jitter evened out
    (`jitter_grid`), the `columns` (arrays at the stamps) linearly interpolated to the new
    grid (anything else passed on, `resample_to`)."""
    if time.size and time[0] > EPOCH_SECONDS:
        notes.append(f"time counted from the first time stamp ({float(time[0])!r} s)")
        time = time - time[0]
    if time.size > 2 and np.all(np.diff(time) > 0):
        for regrid in (missing_samples, jitter_grid):
            got = regrid(time)
            if got is not None:
                columns = [resample_to(got[0], time, c) for c in columns]
                notes.append(got[1])
                time = got[0]
    return time, columns


def time_step_deviation(time: np.ndarray) -> tuple[float, int, float]:
    """(max relative deviation |dt_i - dt|/dt, index i of the worst step, mean step dt)."""
    dt = (time[-1] - time[0]) / (time.shape[0] - 1)
    dev = np.abs(np.diff(time) - dt) / dt
    i = int(np.argmax(dev))
    return float(dev[i]), i, float(dt)

