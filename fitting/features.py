r"""Cycle features of a measured record: breakaway peak $x_2$, slip-end trough $x_1$, $T_1$, $T_2$.

The paper reads friction off each stick-slip cycle of the spring deflection $x(t)$
(Fig 6, chapters 3-4):

- $\mu_0 = k x_2 / W$ at breakaway after a stick of $T_1$ (section 3.1, eq 1);
- $\mu_m$ from eq (5), $x_2 - x_1 = 2(\mu_0 - \mu_m) W/k$, i.e. $\mu_m = k (x_2 + x_1) / (2W)$
  with $x_1$ the deflection when the slip ends (the stick restarts there).

How the features are measured (robust to noise, partial cycles and gauge offsets):

1. The slider displacement $y = u(t) - x(t)$ ($u$ the drive displacement) is constant
   during a stick, whatever the drive does (constant speed, programs with holds,
   measured $u$). A slip is a sudden rise of $y$, found as a run of samples where the
   deflection falls by more than `threshold` noise standard deviations over half a
   natural period $T_2 = \pi/\omega_0$ (eq 7). The noise $\sigma$ is estimated robustly
   from the second differences of $x$ (median absolute deviation). Two runs are one slip
   when they overlap, or when the slider does not rest (y not flat) between them: near
   the stick-slip boundary a stick can be shorter than the slip.
2. Each stick plateau level $Y_j$ is the (5-sigma clipped) mean of $y$ over the stick,
   away from the slips, so $x_2$ and $x_1$ average thousands of samples instead of
   picking the noisiest sample at a peak. A plateau starts only where $y$ has settled
   (half-period blocks within 2 standard errors of its level): a slow re-slip keeps
   the slider moving after its fall of $x$ is lost in the noise.
3. A slip with constant friction is half a cosine (eq 11), symmetric about the time
   $t_c$ at which $y$ crosses the middle of its jump. $t_c$ comes from a line fit
   over the middle half of the jump, refined on the deflection's half sine; the breakaway
   is $t_b = t_c - T/2$ and the slip ends at $t_e = t_c + T/2$, where the duration $T$
   from rest to rest with the drive moving solves $\omega_0 T = \pi + 2\arctan(v /
   (\omega_0 a))$, $a = (x_2 - x_1)/2$ (`_slip_duration`; $T_2 = \pi/\omega_0$ when the
   drive is slow). Its standard error (from the plateau levels' errors) is part of
   `stick_time_sd`.
   Then $x_2 = u(t_b) - Y_{j-1}$, $x_1 = u(t_e) - Y_j$, $T_1 = t_b - t_{e,\mathrm{prev}}$.
   The measured slip time (reported, `slip_time`) comes from the 10 %-90 % rise time
   of the jump, scaled for a half cosine.

The first cycle's stick began before the record (its $T_1$ is unknown: `complete`
False); a slip cut off by the end of the record is dropped. A record with no slip
event, or with fewer than two complete cycles, is reported (`stick_slip` False and a
`message`), never an exception. Units: mm, s; features are plain NumPy (this is data
preparation, run once before fitting).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.optimize

from stickslip_jax.units import G_MM_S2

__all__ = ["RESLIP_RATIO", "RecordFeatures", "extract_cycles", "record_features"]

_RISE_10_90 = (math.pi - 2.0 * math.acos(0.8)) / math.pi
"""Fraction of a half cosine's duration between 10 % and 90 % of its rise."""


RESLIP_RATIO = 1.3
"""A slip measured this many times longer than a single slip of its size is a re-slip
(`RecordFeatures.slipped_on`); single slips measure 0.9-1.17 (noise, synthetic
campaigns), slips with a re-slip 1.4-2.3."""


@dataclasses.dataclass(frozen=True)
class RecordFeatures:
    r"""Per-cycle features of one record (internal units: mm, s, kgf).

    Cycle arrays (length C, one entry per detected slip with a stick on both sides):
    `breakaway_time`, `end_time` (s), `stick_time` $T_1$ (s; NaN for the first, partial
    cycle), `slip_time` $T_2$ measured (s), `peak` $x_2$ and `trough` $x_1$ (mm) with their
    standard errors `peak_sd`, `trough_sd` (mm), `stick_time_sd` (s), `complete`.
    `noise` is the estimated noise standard deviation of the deflection (mm);
    `start_level` the deflection at the first sample if the record starts in a stick
    (from the first plateau; NaN otherwise). `stick_slip` False means no usable
    stick-slip, with the reason in `message`. `spikes`: samples replaced as impulsive
    outliers (Hampel filter); `left_out`: cycles not used, counted by reason (a stick
    too short or not flat, a jump below the threshold, a slip not timed); `drive_note`:
    the drive error found in the sticks and corrected, if any; `deflection_used`: the
    deflection (mm, at the record's times) as the features saw it (spikes replaced);
    `drive_fix`: the correction added to the nominal drive (mm, at the record's times)
    or None.
    """

    name: str
    weight: float
    stiffness: float
    drive_speed: float
    omega0: float
    noise: float
    n_samples: int
    stick_slip: bool
    message: str | None
    breakaway_time: np.ndarray
    end_time: np.ndarray
    stick_time: np.ndarray
    slip_time: np.ndarray
    peak: np.ndarray
    trough: np.ndarray
    peak_sd: np.ndarray
    trough_sd: np.ndarray
    stick_time_sd: np.ndarray
    complete: np.ndarray
    start_level: float = float("nan")
    start_level_sd: float = float("nan")
    spikes: int = 0
    left_out: dict = dataclasses.field(default_factory=dict)
    drive_note: str | None = None
    noise_note: str | None = None
    deflection_used: np.ndarray | None = dataclasses.field(default=None, repr=False)
    drive_fix: np.ndarray | None = dataclasses.field(default=None, repr=False)

    @property
    def model_slip_time(self) -> float:
        r"""Eq (7): $T_2 = \pi/\omega_0$ in s."""
        return math.pi / self.omega0

    @property
    def mu_0(self) -> np.ndarray:
        r"""$\mu_0 = k x_2 / W$ per cycle (section 3.1; no gauge-offset correction)."""
        return self.stiffness * self.peak / self.weight

    @property
    def mu_m(self) -> np.ndarray:
        r"""$\mu_m = k (x_2 + x_1)/(2W)$ per cycle (eq 5; no gauge-offset correction)."""
        return self.stiffness * 0.5 * (self.peak + self.trough) / self.weight

    @property
    def amplitude(self) -> np.ndarray:
        r"""$a = (x_2 - x_1)/2$ per cycle in mm (eq 5)."""
        return 0.5 * (self.peak - self.trough)

    @property
    def slipped_on(self) -> np.ndarray:
        r"""Per cycle: True where the slip lasted over `RESLIP_RATIO` times a single slip
        of its amplitude $a$ at the drive speed $v$ (eq 11 with the drive:
        $\omega_0 T_2 = \pi + 2\arctan(v/(\omega_0 a))$), or could not be timed. Such a
        slip ended above $\mu_d W/k$ and slipped on from rest (a re-slip, see
        `stickslip_fitting.objectives._levels`): one jump made of two slips, so its `end_time`
        (the end of a single half cosine about the jump's middle) is not when the
        slider came to rest."""
        a = np.maximum(self.amplitude, 1e-300)
        single = (math.pi + 2.0 * np.arctan(self.drive_speed / (self.omega0 * a))) / self.omega0
        with np.errstate(invalid="ignore"):
            return ~(np.asarray(self.slip_time) <= RESLIP_RATIO * single)

    @property
    def n_complete(self) -> int:
        return int(np.count_nonzero(self.complete))


NOISE_FLOOR = 1e-5
"""Smallest noise standard deviation a record is given (mm; 10 nm): the order of the best
displacement gauges on slideways (measured records here: 0.5-1.5 um). A noise-free
(simulated) record would otherwise get intervals that measure only the simulator's
rounding (measured without the floor: delta 73.03 +- 1e-8 for a truth of 67 from
noise-free records; on noise-free smoothed-simulator records, smoothing 1e-3, the 95 %
intervals missed mu_s by 0.07 % with a standard error of 3e-5 relative)."""


def _robust_sigma(x: np.ndarray) -> float:
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


def _despike(x: np.ndarray, sigma: float, half: int = 3, k: float = 6.0) -> tuple[np.ndarray, int]:
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


def _moving_mean(x: np.ndarray, w: int) -> np.ndarray:
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


def _clipped_mean(y: np.ndarray, sigma: float) -> tuple[float, int]:
    """Mean of y after discarding samples more than 5 sigma from the median."""
    med = float(np.median(y))
    if sigma > 0:
        keep = np.abs(y - med) <= 5.0 * sigma
        if np.count_nonzero(keep) >= max(1, y.size // 2):
            y = y[keep]
    return float(np.mean(y)), int(y.size)


def _settled_start(y: np.ndarray, lo: int, hi: int, sigma: float, block: int, reach: int,
                   floor: float) -> int:
    """First index of y[lo:hi] from which the slider has come to rest (y level).

    A slip that ends with a re-slip keeps the slider moving slowly for up to a natural
    period after the fall of x is lost in the noise, so a plateau that starts where the
    fall detector stops would average part of that motion in. Blocks of `block` samples,
    stepped by half a block up to `reach` samples in, are dropped while their mean is
    more than 2 standard errors from the level of the plateau's second half (a
    block of pure noise is dropped 5 % of the time, which costs samples, not accuracy)."""
    mid = (lo + hi) // 2
    if mid - lo < 2 * block:
        return lo
    level, _ = _clipped_mean(y[mid:hi], sigma)
    limit = max(2.0 * sigma / math.sqrt(block), floor)
    stop = min(lo + reach, mid - block)
    while lo <= stop and abs(float(np.mean(y[lo:lo + block])) - level) > limit:
        lo += max(1, block // 2)
    return lo


def _creep_end(t: np.ndarray, y: np.ndarray, lo: int, hi: int, sigma: float, block: int,
               floor: float, keep: float = 2.0 / 3.0) -> int:
    """Last index (exclusive) of a stick before the slider starts to creep.

    Creep before breakaway moves the slider forward (y rises) while x is still far from
    its peak. Only when the last block of `block` samples lies more than 5 standard
    errors above the line fitted to the stick's first `keep` (two thirds; about 3e-7
    false alarms per stick) are blocks dropped from the end, half a block at a time,
    while their mean lies more than 3 standard errors above that line; at most the rest
    of the stick is dropped (a creep as long as the stick: `keep` 1/2 or 1/3, tried by
    `extract_cycles` when the stick is not flat otherwise)."""
    count = hi - lo
    if count < 6 * block:
        return hi
    ref = lo + int(keep * count)
    tm = float(np.mean(t[lo:ref]))
    slope, icpt = np.polyfit(t[lo:ref] - tm, y[lo:ref], 1)
    limit = max(3.0 * sigma / math.sqrt(block), floor)
    last = slice(hi - block, hi)
    if float(np.mean(y[last] - (icpt + slope * (t[last] - tm)))) <= 5.0 / 3.0 * limit:
        return hi
    while hi - block >= ref:
        seg = slice(hi - block, hi)
        if float(np.mean(y[seg] - (icpt + slope * (t[seg] - tm)))) <= limit:
            break
        hi -= max(1, block // 2)
    return hi


@dataclasses.dataclass(frozen=True)
class _Plateau:
    """The slider's position y during one stick: its level (5-sigma clipped mean) and
    whether the stick is `flat`: the robust spread about the level within 3 sigma and
    the drift of y across the stick (a fitted line) within 3 sigma at both ends.
    `creep`: how far the slider had crept at the stick's end (mm; see `_creep_end`)."""

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


def _plateau(t: np.ndarray, y: np.ndarray, lo: int, hi: int, sigma: float,
             floor: float) -> _Plateau:
    ts, ys = t[lo:hi], y[lo:hi]
    level, count = _clipped_mean(ys, sigma)
    resid = ys - level
    spread = 1.4826 * float(np.median(np.abs(resid - np.median(resid))))
    tm = float(np.mean(ts))
    sxx = float(np.sum((ts - tm) ** 2))
    drift = 0.0
    if sxx > 0:
        slope = float(np.sum((ts - tm) * resid) / sxx)
        drift = abs(slope) * 0.5 * float(ts[-1] - ts[0])
    flat = spread <= 3.0 * sigma + floor and drift <= 3.0 * sigma + floor
    return _Plateau(level, count, lo, hi, max(sigma, floor), flat)


CREEP_SPEED = 0.5
"""A stick whose slider creeps at more than this fraction of the drive speed is not a
stick (`_creeping_plateau`)."""


def _creeping_plateau(t: np.ndarray, y: np.ndarray, lo: int, hi: int, sigma: float,
                      floor: float, speed: float) -> _Plateau | None:
    """A stick the slider creeps through from its start (a creep time constant as long
    as the stick: y rises nearly linearly), as a line: the level where the stick starts
    (the slider's rest position after the slip) and the creep up to the stick's end.
    Returned (flat) when y rises, slower than `CREEP_SPEED` times the drive, and the
    samples scatter about the line within 3 sigma; None otherwise (a drive error whose
    sign makes y fall, no stick at all)."""
    if hi - lo < 8:
        return None
    ts, ys = t[lo:hi], y[lo:hi]
    tm = float(np.mean(ts))
    slope, icpt = np.polyfit(ts - tm, ys, 1)
    resid = ys - (icpt + slope * (ts - tm))
    spread = 1.4826 * float(np.median(np.abs(resid - np.median(resid))))
    if not (0.0 < slope < CREEP_SPEED * speed and spread <= 3.0 * sigma + floor):
        return None
    n = hi - lo
    sxx = float(np.sum((ts - tm) ** 2))
    start = float(icpt + slope * (ts[0] - tm))
    start_sd = sigma * math.sqrt(1.0 / n + (ts[0] - tm) ** 2 / sxx)
    rise = float(slope * (ts[-1] - ts[0]))
    level, count = start, max(1, int(round((sigma / max(start_sd, 1e-300)) ** 2)))
    return _Plateau(level, count, lo, hi, max(sigma, floor), True, creep=rise,
                    creep_sd=sigma * math.sqrt(1.0 / n + (ts[-1] - tm) ** 2 / sxx))


def _drive_error(t: np.ndarray, u: np.ndarray, y: np.ndarray, plateaus, sigma: float,
                 min_pitch: float) -> tuple[np.ndarray | None, str | None]:
    r"""The drive's error e(t) (mm) estimated from the sticks, or (None, None).

    During a stick y = u - x is constant when u is the true drive; with a drive that is
    not u = v t (a speed a little off, a slow drift, a lead-screw periodic error) the
    nominal y = Y_j - e(t). Fitted over every stick with one level per stick:
    e(t) = c_1 t + c_2 t^2 (speed error and drift) + a lead-screw error of pitch p with
    its second harmonic, sum_k a_k sin(2 pi k u/p) + b_k cos(2 pi k u/p), p scanned on a
    log grid from `min_pitch` to the record's travel. Each part is kept only when it
    lowers chi^2 by more than 40 (a drive that is exact is left alone), explains most of
    the sticks' excess variance, and stays within physical bounds (speed within 10 % of
    nominal over the record, periodic error up to 20 um). Returns the
    correction to add to u and a one-line description."""
    sel = [p for p in plateaus if p is not None and p.hi - p.lo >= 8]
    if len(sel) < 3 or sigma <= 0:
        return None, None
    idx = np.concatenate([np.arange(p.lo, p.hi) for p in sel])
    grp = np.concatenate([np.full(p.hi - p.lo, j) for j, p in enumerate(sel)])
    if idx.size > 20000:  # every k-th sample: the fit needs shape, not all the noise
        k = -(-idx.size // 20000)
        idx, grp = idx[::k], grp[::k]
        scale = float(k)
    else:
        scale = 1.0
    counts = np.bincount(grp).astype(float)

    def within(col):  # remove each stick's mean (its level is free); 1-D or columns
        col = np.asarray(col, float)
        if col.ndim > 1:
            return np.stack([within(c) for c in col.T], axis=1)
        return col - (np.bincount(grp, col) / counts)[grp]

    span = float(t[-1] - t[0]) or 1.0
    tn = (t - t[0]) / span
    yw = within(y[idx])
    poly = np.stack([tn, tn**2], axis=1)

    def rss(cols):
        a = np.stack([within(c[idx]) for c in cols.T], axis=1)
        coef, *_ = np.linalg.lstsq(a, yw, rcond=None)
        r = yw - a @ coef
        return float(r @ r), coef

    base = float(yw @ yw)
    rss_poly, _ = rss(poly)
    travel = float(u[-1] - u[0])
    best = (rss_poly, None)
    if travel > 2.0 * min_pitch:
        # all pitches at once, at the sampled sticks only: the screw columns with the
        # stick means and the polynomial taken out, rss = |y_p|^2 - |Q^T y_p|^2 (Q: an
        # orthonormal basis of those columns; the least squares of `rss` by projection)
        Qp = np.linalg.qr(np.stack([within(c[idx]) for c in poly.T], axis=1))[0]
        yp = yw - Qp @ (Qp.T @ yw)
        pitches = np.geomspace(min_pitch, travel, 80)
        q = (2.0 * np.pi / pitches)[:, None] * u[idx]
        a = np.empty((pitches.size, 4, idx.size))
        a[:, 0], a[:, 1] = np.sin(q), np.cos(q)
        a[:, 2], a[:, 3] = 2.0 * a[:, 0] * a[:, 1], a[:, 1] ** 2 - a[:, 0] ** 2
        cuts = np.flatnonzero(np.r_[True, np.diff(grp) != 0])  # grp is sorted
        a -= np.repeat(np.add.reduceat(a, cuts, axis=2) / np.diff(np.r_[cuts, grp.size]),
                       np.diff(np.r_[cuts, grp.size]), axis=2)
        a -= (a @ Qp) @ Qp.T
        proj = np.linalg.qr(a.transpose(0, 2, 1))[0].transpose(0, 2, 1) @ yp
        scan = float(yp @ yp) - np.sum(proj**2, axis=1)
        i = int(np.argmin(scan))
        if scan[i] < best[0]:
            best = (float(scan[i]), float(pitches[i]))
    var = sigma**2 / scale
    use_poly = (base - rss_poly) / var > 40.0
    use_screw = best[1] is not None and (rss_poly - best[0]) / var > 40.0
    if not (use_poly or use_screw):
        return None, None
    # A drive error explains most of the sticks' excess variance over the noise; motion
    # of the slider itself (settling after a re-slip, creep) does not fit its shape.
    noise_rss = yw.size * var - len(sel) * var
    excess = base - noise_rss
    left = (best[0] if use_screw else rss_poly) - noise_rss
    if not left < 0.3 * excess:
        return None, None
    cols = poly
    if use_screw:
        q = 2.0 * np.pi * u / best[1]
        cols = np.column_stack([poly, np.sin(q), np.cos(q), np.sin(2 * q), np.cos(2 * q)])
    _, coef = rss(cols)
    fitted = cols @ coef  # the part of y that is the drive's error, -e(t)
    fitted = fitted - fitted[0]
    # physical bounds: a drive off its nominal speed by over 10 % (a wrong header, or a
    # slider that slides) or a periodic error over 20 um is not corrected here
    if abs(fitted[-1] - fitted[0]) > 0.1 * travel:
        return None, None
    if use_screw and float(np.hypot(coef[2], coef[3])) > 0.02:
        return None, None
    rate = (fitted[-1] - fitted[0]) / span
    what = [f"speed off by {-rate * 60:.3g} mm/min on average"]
    if use_screw:
        amp = float(np.hypot(coef[2], coef[3]))
        what.append(f"periodic error {amp * 1e3:.3g} um at pitch {best[1]:.4g} mm")
    return -fitted, "drive corrected from the sticks: " + ", ".join(what)


def _slip_duration(t_c: float, t: np.ndarray, u: np.ndarray, y_pre: float, y_post: float,
                   omega0: float) -> float:
    r"""Duration $T$ of a slip centred at `t_c` from rest to rest with the drive moving
    (closed form of eqs 10-11): $\omega_0 T = \pi + 2\arctan(v/(\omega_0 a))$ with
    $a = (x_2 - x_1)/2$, $x_2 = u(t_c - T/2) - y_\mathrm{pre}$, $x_1 = u(t_c + T/2) -
    y_\mathrm{post}$ and $v$ the drive's mean speed over the slip (s).

    $a$ falls as $T$ grows, so $T$ is a fixed point, solved here by Brent's method on
    $[\pi, 2\pi]/\omega_0$. (A few plain iterations from $\pi/\omega_0$ contract only
    by $q^2/(1+q^2)$, $q = v/(\omega_0 a)$: near the stick-slip boundary, $q \approx 1.2$,
    four of them left the slips 1.3 ms short of 28 ms and the ends 0.6 ms early.)"""

    def excess(T):
        u_b, u_e = np.interp([t_c - 0.5 * T, t_c + 0.5 * T], t, u)
        amp = 0.5 * (float(u_b - u_e) + y_post - y_pre)
        if not amp > 0:  # the limit a -> 0+
            return T - 2.0 * math.pi / omega0
        v = max(float(u_e - u_b) / T, 0.0)
        return T - (math.pi + 2.0 * math.atan(v / (omega0 * amp))) / omega0

    lo, hi = math.pi / omega0, 2.0 * math.pi / omega0
    if excess(lo) >= 0.0:
        return lo
    if excess(hi) <= 0.0:
        return hi
    return float(scipy.optimize.brentq(excess, lo, hi, xtol=1e-9 * lo))


def _slip_ends(t_c: float, t: np.ndarray, u: np.ndarray, y_pre: float, y_post: float,
               omega0: float) -> tuple[float, float, float, float, float, float]:
    """(duration T (s), breakaway t_b, end t_e (s), peak x2, trough x1 (mm), the drive's
    mean speed over the slip v (mm/s)) of the slip centred at `t_c` (`_slip_duration`)."""
    slip = _slip_duration(t_c, t, u, y_pre, y_post, omega0)
    t_b, t_e = t_c - 0.5 * slip, t_c + 0.5 * slip
    u_b, u_e = np.interp([t_b, t_e], t, u)
    return (slip, t_b, t_e, float(u_b - y_pre), float(u_e - y_post),
            max(float(u_e - u_b) / slip, 0.0))


def _runs(flag: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) index pairs (stop exclusive) of the True runs of a bool array."""
    if flag.size == 0:
        return []
    d = np.diff(np.concatenate([[0], flag.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def _crossing(t: np.ndarray, y: np.ndarray, level: float) -> float:
    """First time y (rising) reaches `level`, linear interpolation; NaN if it never does."""
    above = np.flatnonzero(y >= level)
    if above.size == 0:
        return float("nan")
    i = int(above[0])
    if i == 0:
        return float(t[0])
    y0, y1 = y[i - 1], y[i]
    frac = 0.0 if y1 == y0 else (level - y0) / (y1 - y0)
    return float(t[i - 1] + frac * (t[i] - t[i - 1]))


def _empty(name, weight, stiffness, speed, omega0, noise, n, message):
    e = np.zeros(0)
    return RecordFeatures(
        name, weight, stiffness, speed, omega0, noise, n, False, message,
        e, e, e, e, e, e, e, e, e, np.zeros(0, bool),
    )


def extract_cycles(
    time,
    deflection,
    *,
    weight: float,
    stiffness: float,
    drive,
    name: str = "record",
    threshold: float | None = None,
    min_cycles: int = 2,
    correct_drive: bool = True,
    _note: str | None = None,
) -> RecordFeatures:
    r"""Find the stick-slip cycles of one record and measure their features.

    - `time` (s), `deflection` x (mm): 1-D arrays of equal length, uniform time step.
    - `weight` W (kgf), `stiffness` k (kgf/mm).
    - `drive`: the drive displacement u (mm) at `time` (array), or a constant drive
      speed v (mm/s, a number: u = v t).
    - `threshold`: a slip is a fall of x (averaged over a quarter natural period) larger
      than `threshold` standard deviations of that fall within half a natural period;
      None (default): set by the record's length for about 0.01 false slips per record
      (`detection_z`), so slips of about 5 noise standard deviations are found.
    - `min_cycles`: fewer complete cycles than this is reported as no usable stick-slip.
    - `correct_drive`: estimate the drive's error from the sticks (`_drive_error`: speed
      off, slow drift, lead-screw periodic error) and extract again with the corrected
      drive when the sticks show one (`RecordFeatures.drive_note` says what was found).

    Returns `RecordFeatures`; never raises for a record without stick-slip.
    """
    t = np.asarray(time, dtype=np.float64)
    x = np.asarray(deflection, dtype=np.float64)
    if t.ndim != 1 or x.shape != t.shape or t.size < 2:
        raise ValueError(f"{name}: time and deflection must be 1-D arrays of equal length >= 2")
    if np.isscalar(drive) or np.ndim(drive) == 0:
        speed = float(drive)
        u = speed * t
    else:
        u = np.asarray(drive, dtype=np.float64)
        if u.shape != t.shape:
            raise ValueError(f"{name}: the drive displacement must have the shape of time")
        speed = float((u[-1] - u[0]) / (t[-1] - t[0]))
    weight, stiffness = float(weight), float(stiffness)
    omega0 = math.sqrt(G_MM_S2 * stiffness / weight)
    t2 = math.pi / omega0
    dt = float((t[-1] - t[0]) / (t.size - 1))
    n = t.size
    sigma = _robust_sigma(x)
    noise_note = None
    if sigma < NOISE_FLOOR:
        noise_note = (f"noise estimate {sigma * 1e6:.2g} nm is below the {NOISE_FLOOR * 1e6:g} nm "
                      "floor (no instrument resolves less: the record looks noise-free, e.g. "
                      "simulated); its errors use the floor, so the intervals measure no "
                      "better than that")
        sigma = NOISE_FLOOR
    x, n_spikes = _despike(x, sigma)
    drive_note = _note
    y = u - x

    h = max(1, int(round(0.5 * t2 / dt)))
    if n <= h + 2:
        return _empty(name, weight, stiffness, speed, omega0, sigma, n,
                      "record shorter than one slip; no stick-slip can be seen")
    # The fall of x over half a natural period, each end averaged over w samples: its
    # noise is sigma sqrt(2/w); the threshold grows with the record's length so that a
    # record of pure noise shows about 0.01 false slips (`detection_z`).
    w = max(1, h // 2)
    xs = _moving_mean(x, w)
    fall = xs[:-h] - xs[h:]  # > 0 while x drops (a slip)
    # A floor on the threshold keeps a noise-free record from counting rounding as slips.
    floor = 1e-9 * max(1.0, float(np.max(np.abs(x))))
    z = detection_z(n / h) if threshold is None else float(threshold)
    thr = max(z * sigma * math.sqrt(2.0 / w), floor)
    runs = _runs(fall > thr)
    # widen each run to cover its slip; runs that then overlap are one slip (runs with
    # a gap are judged below by whether y rests between them: near the boundary a
    # stick can be shorter than the slip; measured: C, W 36, k 86.9, 20 mm/min, sticks
    # of 10 ms, merging runs within two half periods found 41 of its 64 slips)
    events: list[list[int]] = []
    for a, b in runs:
        a = a + w - 1  # the averaging window lets the fall start w - 1 samples early
        if events and a - events[-1][1] <= 0:
            events[-1][1] = b + h
        else:
            events.append([a, b + h])
    if not events:
        whole = _plateau(t, y, 0, n, sigma, floor)
        rise = float(u[-1] - u[0])
        if whole.flat and rise > 10.0 * sigma:
            return _empty(
                name, weight, stiffness, speed, omega0, sigma, n,
                "no slip yet: the slider stuck for the whole record (the deflection follows "
                f"the drive, rising {rise * 1e3:.3g} um); the record ends before the first "
                "breakaway: record longer")
        return _empty(
            name, weight, stiffness, speed, omega0, sigma, n,
            "no stick-slip: the deflection never falls by more than "
            f"{thr * 1e3:.3g} um within half a natural period (steady sliding, or too little "
            "motion for the noise)",
        )
    margin = max(2, h // 2)
    # A measurement chain that rings after the slip (a second-order sensor near the
    # slideway's own frequency) can split one slip into two falls with a few samples
    # between them: a gap shorter than a natural period that is not flat is no stick,
    # and the two events are one slip (measured: k 128.5 kgf/mm, 30 Hz sensor, zeta 0.3:
    # 32 of 56 slips used before, each split slip costing both its cycles).
    merged: list[list[int]] = [events[0]]
    for ev in events[1:]:
        a, b = merged[-1][1] + margin, ev[0] - margin
        if b - a < 2 * h and (b - a < 3 or not _plateau(t, y, a, b, sigma, floor).flat):
            merged[-1][1] = ev[1]
        else:
            merged.append(ev)
    events = merged
    # plateaus (sticks) between events: [0, ev0.start), [ev0.stop, ev1.start), ...
    bounds = [0] + [v for ev in events for v in ev] + [n]
    plateaus: list[_Plateau | None] = []
    left_out: dict[str, int] = {}
    for j in range(len(events) + 1):
        a, b = bounds[2 * j], bounds[2 * j + 1]
        lo = a + (margin if j > 0 else 0)
        hi = b - (margin if j < len(events) else 0)
        if j > 0:
            lo = _settled_start(y, lo, hi, sigma, block=margin, reach=4 * h, floor=floor)
        end = hi
        p = None
        for keep in ((2.0 / 3.0, 0.5, 1.0 / 3.0) if j < len(events) else (None,)):
            if keep is not None:  # a long creep leaves only the stick's start flat
                hi = _creep_end(t, y, lo, end, sigma, block=max(margin, 4), floor=floor,
                                keep=keep)
            p = _plateau(t, y, lo, hi, sigma, floor) if hi - lo >= 3 else None
            if p is None or p.flat or hi == end:
                break
        if p is not None and not p.flat and j > 0 and j < len(events):
            p = _creeping_plateau(t, y, lo, end, sigma, floor, speed) or p
            hi = end if p.flat else hi
        if p is not None and hi < end:  # crept: the level just before the slip
            tail = slice(end - max(margin, 4), end)
            excess = float(np.mean(y[tail])) - p.level
            p = dataclasses.replace(p, creep=max(excess, 0.0),
                                    creep_sd=sigma / math.sqrt(end - tail.start))
        plateaus.append(p)
    if correct_drive:
        # A drive error estimated from all the sticks, kept when it is significant, has
        # the shape of a drive error and leaves at least as many usable cycles.
        fix, note = _drive_error(t, u, y, plateaus, sigma,
                                 min_pitch=max(4.0 * speed * t2, 0.1))
        if fix is not None:
            kw = dict(weight=weight, stiffness=stiffness, name=name, threshold=threshold,
                      min_cycles=min_cycles, correct_drive=False)
            plain = extract_cycles(t, x, drive=u, **kw)
            fixed = extract_cycles(t, x, drive=u + fix, _note=note, **kw)
            plain = dataclasses.replace(plain, spikes=n_spikes, deflection_used=x)
            fixed = dataclasses.replace(fixed, spikes=n_spikes, deflection_used=x,
                                        drive_fix=fix)
            return fixed if fixed.n_complete >= plain.n_complete else plain

    rows = []
    prev_end = None
    for j, (a, b) in enumerate(events):
        before, after = plateaus[j], plateaus[j + 1]
        if before is None or after is None or not (before.flat and after.flat):
            if j > 0 or before is not None:  # the record's first, partial stick is no cycle
                why = "stick too short" if before is None or after is None else (
                    "stick not flat (drive error, creep or no stick)")
                left_out[why] = left_out.get(why, 0) + 1
            prev_end = None
            continue
        y_pre, y_post = before.level, after.level  # refined at t_b, t_e below
        jump = y_post - y_pre
        if not jump > thr:
            left_out["jump below the detection threshold"] = left_out.get(
                "jump below the detection threshold", 0) + 1
            prev_end = None
            continue
        seg_lo = max(0, a - h)
        seg_hi = min(n, b + h)
        ts, ys = t[seg_lo:seg_hi], y[seg_lo:seg_hi]
        frac = (ys - y_pre) / jump
        mid = (frac > 0.25) & (frac < 0.75)
        if np.count_nonzero(mid) >= 2:
            slope, icpt = np.polyfit(ts[mid] - ts[mid].mean(), ys[mid], 1)
            t_c = float(ts[mid].mean() + (0.5 * (y_pre + y_post) - icpt) / slope)
            n_mid = int(np.count_nonzero(mid))
        else:
            t_c = _crossing(ts, ys, 0.5 * (y_pre + y_post))
            slope = jump * omega0 / 2.0
            n_mid = 1
        t10 = _crossing(ts, ys, y_pre + 0.1 * jump)
        t90 = _crossing(ts, ys, y_pre + 0.9 * jump)
        if not (math.isfinite(t_c) and t[0] <= t_c <= t[-1]):
            left_out["slip not timed"] = left_out.get("slip not timed", 0) + 1
            prev_end = None
            continue
        # Slip from rest with the drive moving at v: omega0 T2 = pi + 2 atan(v/(omega0 a))
        # (closed form of eqs 10-11 with the drive), symmetric about t_c.
        # Refine t_c on the deflection itself: x = c - R sin(omega0 (t - t_c)) about the
        # centre of the slip, c = (x2 + x1)/2 (eq 5), R^2 = a^2 + (v/omega0)^2.
        xs_seg = x[seg_lo:seg_hi]
        y_pre, y_post = before.end_level, after.level
        for _ in range(4):
            slip, t_b, t_e, x2, x1, v_slip = _slip_ends(t_c, t, u, y_pre, y_post, omega0)
            amp = 0.5 * (x2 - x1)
            if not amp > 0:
                break
            radius = math.hypot(amp, v_slip / omega0)
            s_ = (0.5 * (x2 + x1) - xs_seg) / radius
            near = (np.abs(s_) < 0.75) & (np.abs(ts - t_c) < 0.3 * slip)
            if np.count_nonzero(near) < 2:
                break
            wgt = 1.0 - s_[near] ** 2
            t_new = float(np.sum(wgt * (ts[near] - np.arcsin(s_[near]) / omega0))
                          / np.sum(wgt))
            slope = radius * omega0
            n_mid = float(np.sum(wgt))
            done = abs(t_new - t_c) < 1e-6 * t2
            t_c = t_new
            if done:
                break
        # the slip and its ends at the final centre
        slip, t_b, t_e, x2, x1, v_slip = _slip_ends(t_c, t, u, y_pre, y_post, omega0)
        amp = 0.5 * (x2 - x1)
        tc_sd = sigma / max(abs(slope), 1e-300) / math.sqrt(n_mid)
        # the slip's duration carries the error of the jump J = y_post - y_pre (the two
        # plateau levels): dT/dJ = -q / (omega0 a), q = v / (omega0 a) (implicit
        # derivative of `_slip_duration`); near the boundary (q ~ 1, a of a few um) it
        # is the larger part (measured there: end times scatter by 0.75 ms)
        slip_sd = (v_slip / (omega0 * amp) / (omega0 * amp)
                   * math.hypot(before.end_sd, after.sd)) if amp > 0 else 0.0
        rows.append(dict(
            breakaway_time=t_b, end_time=t_e,
            stick_time=(t_b - prev_end) if prev_end is not None else float("nan"),
            slip_time=(t90 - t10) / _RISE_10_90 if math.isfinite(t90 - t10) else float("nan"),
            peak=x2, trough=x1,
            peak_sd=before.end_sd, trough_sd=after.sd,
            stick_time_sd=math.sqrt(2.0 * tc_sd ** 2 + 0.5 * slip_sd ** 2),
            complete=prev_end is not None,
        ))
        prev_end = t_e
    first = plateaus[0]
    start_level = start_sd = float("nan")
    if first is not None and first.lo == 0 and first.flat:
        start_level = float(u[0] - first.level)
        start_sd = first.sd
    cols = {k: np.array([r[k] for r in rows], dtype=bool if k == "complete" else float)
            for k in (rows[0] if rows else {})}
    if not rows:
        why = "; ".join(f"{c} {k}" for k, c in left_out.items())
        return dataclasses.replace(
            _empty(name, weight, stiffness, speed, omega0, sigma, n,
                   "no complete stick-slip cycle: " + (
                       f"{len(events)} slips found, cycles left out: {why}" if why else
                       "every slip is cut off by the record's ends")),
            spikes=n_spikes, left_out=left_out, drive_note=drive_note, noise_note=noise_note)
    feats = RecordFeatures(
        name=name, weight=weight, stiffness=stiffness, drive_speed=speed, omega0=omega0,
        noise=sigma, n_samples=n, stick_slip=True, message=None,
        start_level=start_level, start_level_sd=start_sd, spikes=n_spikes,
        left_out=left_out, drive_note=drive_note, noise_note=noise_note, deflection_used=x,
        **cols,
    )
    if feats.n_complete < min_cycles:
        why = "; ".join(f"{c} {k}" for k, c in left_out.items())
        return dataclasses.replace(
            feats, stick_slip=False,
            message=f"only {feats.n_complete} complete stick-slip cycle(s) (need {min_cycles}); "
            + (f"cycles left out: {why}" if why else "record longer"),
        )
    return feats


def record_features(record, **kwargs) -> RecordFeatures:
    """`extract_cycles` on a `stickslip_jax.records.Record` (its drive, W, k and name)."""
    return extract_cycles(
        record.time,
        record.deflection,
        weight=record.weight,
        stiffness=record.stiffness,
        drive=record.drive_position(),
        name=record.name or "record",
        **kwargs,
    )
