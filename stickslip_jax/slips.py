r"""Slips and rests of a record's slider: the one cycle detector of `stickslip plot`,
`stickslip fit` and `stickslip discover`.

The slider's displacement $y = u - x$ ($u$ the drive displacement, measured or nominal,
$x$ the spring deflection) is constant while the slider sticks, whatever the drive does,
and rises while it slips. A slip is found as a fall of $x$ over half a natural period
$T_2 = \pi/\omega_0$ larger than a threshold set by the noise and the record's length
(`slip_events`, `detection_z`); a rest (a stick) as a run of samples where $y$ stays
within 3 noise standard deviations of one level, passed from below and left above, with
the slider slower than `CREEP_SPEED` times the drive (`rest`): a stick of a few per cent
of the cycle is found as well as one that fills it. `find_slips` runs both on a record
and says, in one line with the evidence, when there is no stick-slip: the slider stuck
for the whole record, or it slides continuously (it never rests).

Units: mm, s. Plain NumPy.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

CREEP_SPEED = 0.5
"""A rest whose slider moves at more than this fraction of the drive speed is no stick:
the slider slides (`rest`, and the creep of a stick in `stickslip_fitting.data.sticks`)."""


def robust_sigma(x: np.ndarray) -> float:
    """Noise standard deviation of x from its second differences (white noise).

    1.4826 x the median absolute deviation, refined by the RMS of the second differences
    within 6 of those deviations: impulsive spikes and the slips fall outside, and a
    logger that quantises finer than the noise cannot make the estimate collapse to 0
    (the MAD of mostly-zero differences is 0; the clipped RMS is not). Returns 0 only
    for a record that is exactly linear."""
    if x.size < 5:
        return 0.0
    d2 = x[2:] - 2.0 * x[1:-1] + x[:-2]
    mad = 1.4826 * float(np.median(np.abs(d2 - np.median(d2))))
    step = np.abs(np.diff(x))
    step = step[step > 1e-12 * max(1.0, float(np.max(np.abs(x))))]
    quantum = float(np.min(step)) if step.size else 0.0
    if mad > 2.0 * quantum:  # quantisation well below the noise: the MAD is exact
        return float(mad / math.sqrt(6.0))
    cut = 6.0 * max(mad, quantum)
    if cut <= 0.0:
        return 0.0
    inner = d2[np.abs(d2) <= cut]
    rms = float(np.sqrt(np.mean(inner**2))) if inner.size else mad
    return float(max(mad, rms) / math.sqrt(6.0))


_QUAD_WEIGHTS = np.linalg.lstsq(
    np.vander(np.array([-3.0, -2.0, -1.0, 1.0, 2.0, 3.0]), 3), np.eye(6), rcond=None)[0][-1]
"""Weights of the six neighbours (offsets -3..-1, 1..3) in the value at 0 of the
least-squares quadratic through them."""


def despike(x: np.ndarray, sigma: float, half: int = 3, k: float = 6.0) -> tuple[np.ndarray, int]:
    """Impulsive spikes replaced: a sample more than `k` sigma from both the median of its
    2 `half` + 1 neighbours (Hampel) and the quadratic through its six neighbours is a
    spike and gets that median. The quadratic keeps the real signal: the high curvature
    at a slip's turning points moves a median by several sigma (at 1 kHz and 30 Hz a
    trough's sample differs from its median by ~15 um) but not a quadratic (third
    derivative, < 1 um). Returns (x, number of samples replaced)."""
    if sigma <= 0 or x.size < 2 * half + 1:
        return x, 0
    pad = np.pad(x, half, mode="edge")
    win = np.lib.stride_tricks.sliding_window_view(pad, 2 * half + 1)
    med = np.median(win, axis=1)
    bad = np.abs(x - med) > k * sigma
    if not bad.any():
        return x, 0
    if half == 3:
        pred = win[:, [0, 1, 2, 4, 5, 6]] @ _QUAD_WEIGHTS
        dev = np.abs(x - pred)
        bad &= dev > k * sigma * math.sqrt(1.0 + float(_QUAD_WEIGHTS @ _QUAD_WEIGHTS))
        # a spike also lifts its neighbours' quadratics: keep the largest deviation of
        # each neighbourhood (spikes are isolated samples)
        peak = np.max(np.lib.stride_tricks.sliding_window_view(
            np.pad(np.where(bad, dev, 0.0), half), 2 * half + 1), axis=1)
        bad &= dev >= peak
    if not bad.any():
        return x, 0
    out = x.copy()
    out[bad] = med[bad]
    return out, int(np.count_nonzero(bad))


def moving_mean(x: np.ndarray, w: int) -> np.ndarray:
    """Mean of x over w consecutive samples (length len(x) - w + 1)."""
    if w <= 1:
        return x
    c = np.concatenate([[0.0], np.cumsum(x)])
    return (c[w:] - c[:-w]) / w


def detection_z(n_tests: float, false_rate: float = 0.01) -> float:
    """Threshold in standard deviations of the fall statistic for about `false_rate`
    false slips per record of `n_tests` independent fall measurements (Gaussian tail,
    union bound: P(max > z) ~ n_tests * exp(-z^2/2)), never below 4.5."""
    return max(4.5, math.sqrt(2.0 * math.log(max(n_tests, 1.0) / false_rate)))


def clipped_mean(y: np.ndarray, sigma: float) -> tuple[float, int]:
    """Mean of y after discarding samples more than 5 sigma from the median."""
    med = float(np.median(y))
    if sigma > 0:
        keep = np.abs(y - med) <= 5.0 * sigma
        if np.count_nonzero(keep) >= max(1, y.size // 2):
            y = y[keep]
    return float(np.mean(y)), int(y.size)


@dataclasses.dataclass(frozen=True)
class Plateau:
    """The slider's position y during one stick: its level (5-sigma clipped mean) and
    whether the stick is `flat`: the robust spread about the level within 3 sigma and
    the drift of y across the stick (a fitted line) within 3 sigma at both ends.
    `creep`: how far the slider had crept at the stick's end (mm; see `creep_end`)."""

    level: float
    count: int
    lo: int
    hi: int
    sigma: float
    flat: bool
    creep: float = 0.0
    creep_sd: float = 0.0

    @property
    def sd(self) -> float:
        return self.sigma / math.sqrt(self.count)

    @property
    def end_level(self) -> float:
        """y where the stick ends (at the breakaway): the level plus the creep."""
        return self.level + self.creep

    @property
    def end_sd(self) -> float:
        return math.hypot(self.sd, self.creep_sd)


def plateau(t: np.ndarray, y: np.ndarray, lo: int, hi: int, sigma: float,
             floor: float) -> Plateau:
    ts, ys = t[lo:hi], y[lo:hi]
    level, count = clipped_mean(ys, sigma)
    resid = ys - level
    spread = 1.4826 * float(np.median(np.abs(resid - np.median(resid))))
    tm = float(np.mean(ts))
    sxx = float(np.sum((ts - tm) ** 2))
    drift = 0.0
    if sxx > 0:
        slope = float(np.sum((ts - tm) * resid) / sxx)
        drift = abs(slope) * 0.5 * float(ts[-1] - ts[0])
    flat = spread <= 3.0 * sigma + floor and drift <= 3.0 * sigma + floor
    return Plateau(level, count, lo, hi, max(sigma, floor), flat)


def runs(flag: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) index pairs (stop exclusive) of the True runs of a bool array."""
    if flag.size == 0:
        return []
    d = np.diff(np.concatenate([[0], flag.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


def rest(t: np.ndarray, y: np.ndarray, u: np.ndarray, lo: int, hi: int, sigma: float,
         floor: float, h: int, creep: float = 0.0) -> Plateau | None:
    """The slider at rest within y[lo:hi] (a stick), or None.

    The level is where y dwells longest (the densest window of 6 sigma of its sorted
    values); the rest is the longest run of samples within 3 sigma of it (single outlying
    samples bridged), at least `rest_length(h)` samples long (`h`: samples in half a natural
    period). It is a stick when y passes through it forwards (below the level before it,
    above after it, where y[lo:hi] reaches that far: a turning point of a slider that
    reverses is no rest; asked of rests shorter than 8 `min_len`, about half a natural
    period: a longer one is a rest whichever way a drive error tilts it) and the slider is
    slower there than `creep` times the drive u: the slope fitted over the run's middle half
    (away from the slider's approach and departure) 3 standard errors below it, or for
    `creep` 0 (at rest) within 3 standard errors of 0. Slow sliding, and a slider that slows
    down without stopping, stay in the band for a while too."""
    min_len = rest_length(h)
    if hi - lo < min_len:
        return None
    ys = y[lo:hi]
    band = 3.0 * sigma + floor
    srt = np.sort(ys)
    top = np.searchsorted(srt, srt + 2.0 * band, side="right")
    i = int(np.argmax(top - np.arange(srt.size)))
    level = float(np.median(srt[i:top[i]]))
    inside = np.abs(ys - level) <= band
    inside[1:-1] |= inside[:-2] & inside[2:]
    s, e = max(runs(inside), key=lambda p: p[1] - p[0])
    if e - s < min_len:
        return None
    before, after = ys[:s], ys[e:]
    if e - s < 8 * min_len and ((before.size and not np.median(before) < level - band)
                                or (after.size and not np.median(after) > level + band)):
        return None
    s, e = s + lo, e + lo
    a, b = s + (e - s) // 4, e - (e - s) // 4  # the middle half: the slider's speed there
    ts = t[a:b] - float(np.mean(t[a:b]))
    sxx = float(ts @ ts)
    slope = float(ts @ (y[a:b] - level)) / sxx
    drive = max(float(u[e - 1] - u[s]) / float(t[e - 1] - t[s]), 0.0)
    se3 = 3.0 * sigma / math.sqrt(sxx)
    if slope > (creep * drive - se3 if creep > 0 else se3):
        return None
    return plateau(t, y, s, e, sigma, floor)


def paused(t: np.ndarray, y: np.ndarray, s: int, e: int, sigma: float) -> bool:
    """True when y over the run [s, e) and half its length each side is a pause, not a
    stick: a smooth cubic (a slider whose speed dips to a minimum near 0 and rises
    again: it passes through the band without stopping) fits at least as well as a
    stick (y flat from t_1 to t_2, quadratic before and after: it stops and breaks
    away; t_1, t_2 on a grid), to 10 sigma^2 of the squared residuals, where y spans
    12 sigma or more (less cannot tell the shapes apart: near the stick-slip boundary,
    slips of 7 sigma, every stick's test came within 3 sigma^2 of the cubic). Measured
    on the torsional generator's campaigns (tests/torsional_rig.py, 10 seeds, 4 records
    each): the stick shape wins by 11 sigma^2 or more on every rest of a true stick
    (10 ms or longer), by at most 9.6 on 42 of the 43 pauses (a stop of under 0.03 ms,
    6-14 ms in the band, y spanning 13 sigma or more), 17 on one."""
    n = e - s
    a, b = max(0, s - n // 2), min(y.size, e + n // 2)
    ts, ys = t[a:b] - 0.5 * (t[s] + t[e - 1]), y[a:b]
    if np.ptp(ys) < 12.0 * sigma:
        return False
    ts = ts / max(-ts[0], ts[-1], 1e-300)
    cubic = np.vander(ts, 4)
    rss_cubic = float(np.sum((ys - cubic @ np.linalg.lstsq(cubic, ys, rcond=None)[0]) ** 2))
    quarter = 0.125 * float(ts[-1] - ts[0])
    t1 = ts[(ts >= ts[s - a] - quarter) & (ts <= 0.0)]
    t2 = ts[(ts <= ts[e - 1 - a] + quarter) & (ts >= 0.0)]
    t1, t2 = (g[::max(1, g.size // 12)] for g in (t1, t2))
    t1, t2 = (g.ravel()[:, None] for g in np.meshgrid(t1, t2))
    m = np.stack([np.ones((t1.size, ts.size)), np.minimum(ts - t1, 0.0) ** 2,
                  np.maximum(ts - t2, 0.0) ** 2], axis=2)  # [grid, samples, 3]
    gram = np.einsum("gni,gnj->gij", m, m) + 1e-12 * np.eye(3)
    coef = np.linalg.solve(gram, np.einsum("gni,n->gi", m, ys)[..., None])
    rss_stick = float(np.min(np.sum((ys - (m @ coef)[..., 0]) ** 2, axis=1)))
    return rss_cubic - rss_stick <= 10.0 * sigma**2


def slip_events(t: np.ndarray, x: np.ndarray, y: np.ndarray, u: np.ndarray, sigma: float,
                h: int, floor: float, threshold: float | None = None, split: bool = False
                ) -> tuple[list[list[int]], float, list[int]]:
    """The slips as sample ranges [a, b), the detection threshold (mm) and the tally
    [falls close enough to be one slip, those with a rest between them (with `split`)].

    `h`: samples in half a natural period; `threshold`: in standard deviations of the
    fall statistic (None: `detection_z` of the record's length); `split`: two falls with
    a rest between them are two slips however close (sticks shorter than the slips)."""
    # The fall of x over half a natural period, each end averaged over w samples: its
    # noise is sigma sqrt(2/w); the threshold grows with the record's length so that a
    # record of pure noise shows about 0.01 false slips (`detection_z`).
    w = max(1, h // 2)
    xs = moving_mean(x, w)
    fall = xs[:-h] - xs[h:]  # > 0 while x drops (a slip)
    z = detection_z(x.size / h) if threshold is None else float(threshold)
    thr = max(z * sigma * math.sqrt(2.0 / w), floor)

    tally = [0, 0]  # falls close enough to be one slip; those with a rest between

    def rests_between(ev, a, b):  # a stick between an event and the next fall [a, b)
        tally[0] += 1
        if not split:
            return False
        lo = ev[0] + int(np.argmin(xs[ev[0]:min(ev[1], xs.size)]))
        hi = a + int(np.argmax(xs[a:max(a + 1, min(b, xs.size))]))
        found = hi > lo and rest(t, y, u, lo, hi, sigma, floor, h) is not None
        tally[1] += found
        return found

    # widen each run to cover its slip; runs that then overlap are one slip unless the
    # slider rests between them (a stick shorter than the slip); runs with a gap are
    # judged below by whether y rests between them: near the boundary a stick can be
    # shorter than the slip; measured: C, W 36, k 86.9, 20 mm/min, sticks of 10 ms,
    # merging runs within two half periods found 41 of its 64 slips)
    events: list[list[int]] = []
    for a, b in runs(fall > thr):
        a = a + w - 1  # the averaging window lets the fall start w - 1 samples early
        if events and a - events[-1][1] <= 0 and not rests_between(events[-1], a, b):
            events[-1][1] = b + h
        else:
            events.append([a, b + h])
    if not events:
        return events, thr, tally
    margin = max(2, h // 2)
    # A measurement chain that rings after the slip (a second-order sensor near the
    # slideway's own frequency) can split one slip into two falls with a few samples
    # between them: a gap shorter than a natural period that is not flat is no stick,
    # and the two events are one slip (measured: k 128.5 kgf/mm, 30 Hz sensor, zeta 0.3:
    # without this, 32 of 56 slips were used, each split slip costing both its cycles).
    merged: list[list[int]] = [events[0]]
    for ev in events[1:]:
        a, b = merged[-1][1] + margin, ev[0] - margin
        if b - a < 2 * h and (b - a < 3 or not plateau(t, y, a, b, sigma, floor).flat) \
                and not rests_between(merged[-1], ev[0], ev[1]):
            merged[-1][1] = ev[1]
        else:
            merged.append(ev)
    return merged, thr, tally


def rest_length(h: int) -> int:
    """Fewest samples of a rest (`rest`): an eighth of half a natural period, at least 5
    (a stick of 5 % of a cycle at 1 kHz and 40 rad/s lasts about 6 ms)."""
    return max(5, h // 8)


def regions(x: np.ndarray, events, n: int) -> list[tuple[int, int]]:
    """Where each stick can lie: from the deepest deflection of the slip before it (the
    record's start for the first) to the highest of the slip after it (its end for the
    last), one region per gap around the events."""
    out, lo = [], 0
    for a, b in events:
        mid = (a + b) // 2
        out.append((lo, a + int(np.argmax(x[a:max(a + 1, mid)]))))
        lo = a + int(np.argmin(x[a:b]))
    out.append((lo, n))
    return out


def no_slip_message(t, y, u, sigma: float, floor: float, thr: float, h: int) -> str:
    """Why a record without slips shows no stick-slip: stuck for the whole record, sliding
    continuously, or too little motion for the noise (one line with the numbers)."""
    whole = plateau(t, y, 0, y.size, sigma, floor)
    rise = float(u[-1] - u[0])
    if whole.flat and rise > 10.0 * sigma:
        return ("no slip yet: the slider stuck for the whole record (the deflection follows "
                f"the drive, rising {rise * 1e3:.3g} um); the record ends before the first "
                "breakaway: record longer")
    fall = (f"the deflection never falls by more than {thr * 1e3:.3g} um within half a "
            "natural period")
    moved = float(y[-1] - y[0])
    if rise > 0 and moved > CREEP_SPEED * rise and moved > 10.0 * sigma and rest(
            t, y, u, 0, y.size, sigma, floor, h, CREEP_SPEED) is None:
        return (f"no stick-slip: the record slides continuously (the slider follows the "
                f"drive, moving {moved * 1e3:.4g} um of its {rise * 1e3:.4g} um, and never "
                f"rests; {fall})")
    return f"no stick-slip: {fall} (steady sliding, or too little motion for the noise)"


@dataclasses.dataclass(frozen=True)
class SlipSearch:
    """The slips of one record (`find_slips`): the deflection with its spikes replaced
    `x` and the slider displacement `y` = u - x (mm), the noise `sigma` (mm), `spikes`
    replaced, `h` samples in half a natural period, the slips `events` ([a, b) sample
    ranges), the fall `threshold` (mm), `verdict`: None for stick-slip, else the one
    line saying why there is none (stuck throughout, slides continuously, too quiet), and
    `short`: sticks shorter than the slips, a rest found between two falls close enough
    to be one slip at least 3 times (or every time): such a record keeps every rest
    between two falls as a stick; in the others a lone brief rest within a slip is left
    to the re-slip model (`stickslip_fitting.data.features.RecordFeatures.slipped_on`;
    measured: 2 such rests among the 51 slips of the shipped real record at 1002 N/m,
    3-6 in every torsional record of tests/test_short_sticks.py with short sticks)."""

    x: np.ndarray
    y: np.ndarray
    sigma: float
    spikes: int
    h: int
    events: list
    threshold: float
    verdict: str | None
    short: bool

    @property
    def sliding(self) -> bool:
        return self.verdict is not None and "slides continuously" in self.verdict


def find_slips(t, x, u, omega0: float, *, sigma: float | None = None,
               threshold: float | None = None) -> SlipSearch:
    """The slips of a record of deflection x (mm) driven by u (mm) at times t (s), with
    natural frequency omega0 (rad/s); `sigma`: its noise (mm; None: `robust_sigma`),
    `threshold` as in `slip_events`. A record whose slips have no rest between them (or
    around them) slides continuously: its verdict says so with the longest rest found."""
    t, x, u = (np.asarray(a, dtype=np.float64) for a in (t, x, u))
    sigma = robust_sigma(x) if sigma is None else float(sigma)
    x, spikes = despike(x, sigma)
    dt = float((t[-1] - t[0]) / (t.size - 1))
    h = max(1, int(round(0.5 * math.pi / omega0 / dt)))
    y = u - x
    floor = 1e-9 * max(1.0, float(np.max(np.abs(x))))
    if t.size <= h + 2:
        return SlipSearch(x, y, sigma, spikes, h, [], float("nan"),
                          "record shorter than one slip; no stick-slip can be seen", False)
    events, thr, (close, rests) = slip_events(t, x, y, u, sigma, h, floor, threshold,
                                              split=True)
    short = close > 0 and rests >= min(3, close)  # (SlipSearch.short)
    if not short:
        events, thr, _ = slip_events(t, x, y, u, sigma, h, floor, threshold)
    verdict = None if events else no_slip_message(t, y, u, sigma, floor, thr, h)
    # the sticks of a cycle lie between two falls (around the one fall of a short record):
    # a rest only before the first fall or after the last makes no cycle (measured: the
    # shipped real record at 2254 N/m rests once, after the last of its 11 falls; between
    # them its slider moves at 0.6-1.07 times the drive speed)
    gaps = regions(x, events, t.size)
    if events and not any(rest(t, y, u, lo, hi, sigma, floor, h, CREEP_SPEED)
                          is not None for lo, hi in (gaps[1:-1] or gaps)):
        verdict = (f"no stick-slip: the record slides continuously ({len(events)} falls of "
                   f"the deflection, but the slider y = u - x never rests between them for "
                   f"{rest_length(h) * dt * 1e3:.3g} ms within {3 * sigma * 1e3:.2g} um)")
    return SlipSearch(x, y, sigma, spikes, h, events, thr, verdict, short)
