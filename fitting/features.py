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
   from the second differences of $x$ (median absolute deviation).
2. Each stick plateau level $Y_j$ is the (5-sigma clipped) mean of $y$ over the stick,
   away from the slips, so $x_2$ and $x_1$ average thousands of samples instead of
   picking the noisiest sample at a peak. A plateau starts only where $y$ has settled
   (half-period blocks within 2 standard errors of its level): a slow re-slip keeps
   the slider moving after its fall of $x$ is lost in the noise.
3. A slip with constant friction is half a cosine (eq 11), symmetric about the time
   $t_c$ at which $y$ crosses the middle of its jump. $t_c$ comes from a line fit
   over the middle half of the jump; the breakaway is $t_b = t_c - T_2/2$ and the slip
   ends at $t_e = t_c + T_2/2$ (exact up to $O(v/(a\omega_0))$ corrections).
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
    stick-slip, with the reason in `message`.
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
        `fitting.objectives._levels`): one jump made of two slips, so its `end_time`
        (the end of a single half cosine about the jump's middle) is not when the
        slider came to rest."""
        a = np.maximum(self.amplitude, 1e-300)
        single = (math.pi + 2.0 * np.arctan(self.drive_speed / (self.omega0 * a))) / self.omega0
        with np.errstate(invalid="ignore"):
            return ~(np.asarray(self.slip_time) <= RESLIP_RATIO * single)

    @property
    def n_complete(self) -> int:
        return int(np.count_nonzero(self.complete))


def _robust_sigma(x: np.ndarray) -> float:
    """Noise standard deviation of x from the MAD of its second differences (white noise)."""
    if x.size < 5:
        return 0.0
    d2 = x[2:] - 2.0 * x[1:-1] + x[:-2]
    mad = np.median(np.abs(d2 - np.median(d2)))
    return float(1.4826 * mad / math.sqrt(6.0))


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
    threshold: float = 8.0,
    min_cycles: int = 2,
) -> RecordFeatures:
    r"""Find the stick-slip cycles of one record and measure their features.

    - `time` (s), `deflection` x (mm): 1-D arrays of equal length, uniform time step.
    - `weight` W (kgf), `stiffness` k (kgf/mm).
    - `drive`: the drive displacement u (mm) at `time` (array), or a constant drive
      speed v (mm/s, a number: u = v t).
    - `threshold`: a slip is a fall of x larger than `threshold` noise standard
      deviations (of a difference of two samples) within half a natural period.
    - `min_cycles`: fewer complete cycles than this is reported as no usable stick-slip.

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
    y = u - x

    h = max(1, int(round(0.5 * t2 / dt)))
    if n <= h + 2:
        return _empty(name, weight, stiffness, speed, omega0, sigma, n,
                      "record shorter than one slip; no stick-slip can be seen")
    fall = x[:-h] - x[h:]  # > 0 while x drops (a slip)
    # A floor on the threshold keeps a noise-free record from counting rounding as slips.
    floor = 1e-9 * max(1.0, float(np.max(np.abs(x))))
    thr = max(threshold * sigma * math.sqrt(2.0), floor)
    runs = _runs(fall > thr)
    # merge runs separated by less than one slip length, and widen to cover the slip
    events: list[list[int]] = []
    for a, b in runs:
        if events and a - events[-1][1] <= 2 * h:
            events[-1][1] = b + h
        else:
            events.append([a, b + h])
    if not events:
        return _empty(
            name, weight, stiffness, speed, omega0, sigma, n,
            "no stick-slip: the deflection never falls by more than "
            f"{thr * 1e3:.3g} um within half a natural period (steady sliding, or too little "
            "motion for the noise)",
        )
    margin = max(2, h // 2)
    # plateaus (sticks) between events: [0, ev0.start), [ev0.stop, ev1.start), ...
    bounds = [0] + [v for ev in events for v in ev] + [n]
    plateaus = []
    for j in range(len(events) + 1):
        a, b = bounds[2 * j], bounds[2 * j + 1]
        lo = a + (margin if j > 0 else 0)
        hi = b - (margin if j < len(events) else 0)
        if j > 0:
            lo = _settled_start(y, lo, hi, sigma, block=margin, reach=4 * h, floor=floor)
        if hi - lo >= 3:
            level, count = _clipped_mean(y[lo:hi], sigma)
            # a stick keeps y flat: a plateau that drifts by more than the noise allows
            # (the slider creeps or the trace is not stick-slip there) is not used
            spread = float(np.std(y[lo:hi] - level))
            flat = spread <= 3.0 * sigma + floor
            plateaus.append((level, count, lo, hi) if flat else None)
        else:
            plateaus.append(None)

    rows = []
    prev_end = None
    for j, (a, b) in enumerate(events):
        before, after = plateaus[j], plateaus[j + 1]
        if before is None or after is None:
            prev_end = None
            continue
        y_pre, n_pre, _, _ = before
        y_post, n_post, _, _ = after
        jump = y_post - y_pre
        if not jump > thr:
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
            prev_end = None
            continue
        # Slip from rest with the drive moving at v: omega0 T2 = pi + 2 atan(v/(omega0 a))
        # (closed form of eqs 10-11 with the drive), symmetric about t_c.
        # Refine t_c on the deflection itself: x = c - R sin(omega0 (t - t_c)) about the
        # centre of the slip, c = (x2 + x1)/2 (eq 5), R^2 = a^2 + (v/omega0)^2.
        xs = x[seg_lo:seg_hi]
        slip = t2
        for _ in range(4):
            t_b, t_e = t_c - 0.5 * slip, t_c + 0.5 * slip
            u_b, u_e = np.interp([t_b, t_e], t, u)
            x2 = float(u_b - y_pre)
            x1 = float(u_e - y_post)
            v_slip = max(float(u_e - u_b) / slip, 0.0)
            amp = 0.5 * (x2 - x1)
            if not amp > 0:
                break
            slip = (math.pi + 2.0 * math.atan(v_slip / (omega0 * amp))) / omega0
            radius = math.hypot(amp, v_slip / omega0)
            s = (0.5 * (x2 + x1) - xs) / radius
            near = (np.abs(s) < 0.75) & (np.abs(ts - t_c) < 0.3 * slip)
            if np.count_nonzero(near) >= 2:
                w = 1.0 - s[near] ** 2
                t_c = float(np.sum(w * (ts[near] - np.arcsin(s[near]) / omega0)) / np.sum(w))
                slope = radius * omega0
                n_mid = float(np.sum(w))
        tc_sd = sigma / max(abs(slope), 1e-300) / math.sqrt(n_mid)
        rows.append(dict(
            breakaway_time=t_b, end_time=t_e,
            stick_time=(t_b - prev_end) if prev_end is not None else float("nan"),
            slip_time=(t90 - t10) / _RISE_10_90 if math.isfinite(t90 - t10) else float("nan"),
            peak=x2, trough=x1,
            peak_sd=sigma / math.sqrt(n_pre), trough_sd=sigma / math.sqrt(n_post),
            stick_time_sd=math.sqrt(2.0) * tc_sd,
            complete=prev_end is not None,
        ))
        prev_end = t_e
    first = plateaus[0]
    start_level = start_sd = float("nan")
    if first is not None and first[2] == 0:
        start_level = float(u[0] - first[0])
        start_sd = sigma / math.sqrt(first[1])
    cols = {k: np.array([r[k] for r in rows], dtype=bool if k == "complete" else float)
            for k in (rows[0] if rows else {})}
    if not rows:
        return _empty(name, weight, stiffness, speed, omega0, sigma, n,
                      "no complete stick-slip cycle: every slip is cut off by the record's ends")
    feats = RecordFeatures(
        name=name, weight=weight, stiffness=stiffness, drive_speed=speed, omega0=omega0,
        noise=sigma, n_samples=n, stick_slip=True, message=None,
        start_level=start_level, start_level_sd=start_sd, **cols,
    )
    if feats.n_complete < min_cycles:
        return dataclasses.replace(
            feats, stick_slip=False,
            message=f"only {feats.n_complete} complete stick-slip cycle(s) (need {min_cycles}); "
            "record longer",
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
