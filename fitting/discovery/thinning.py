r"""The stick phase compressed to the statistics the per-cycle model needs (`cycle_model`).

In a stick the model is a closed form, the deflection following the drive: over a short
span it is a straight line of the drive's slope, and the standard error of its samples is
one number per window (`trace_sd`: the slider at rest). The $m$ samples of such a span
(a **bin**) then enter the chi-square only through their mean,

$$\sum_i \frac{(x_i - f(t_i))^2}{s^2} = \frac{(\bar x - f(\bar t))^2}{s^2/m}
  + \frac{S}{s^2},$$

with $S$ the bins' scatter about the line of the drive's slope (`spread`, mm$^2$, data
only; exact for a model linear over the bin). So a bin is one residual, its mean at its
mean time with standard error $s/\sqrt m$: every chi-square difference and score is that
of all samples; levels (chi2/n, gaps) add the scatter back (`Samples`).

Bins grow with the distance to the window's events (window start, breakaway; `RESOLUTION`
of it), samples within `RAW` steps of an event kept; from `GUARD` slip times before the
breakaway (the slip) only samples closer than `SLIP_BIN` slip times are averaged. A stick
of $T_1$ holds about $2 \ln(T_1 / 8\Delta t)/\ln(1 + $ `RESOLUTION`$)$ bins: the model's
cost grows only logarithmically with the sampling rate.
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import numpy as np

from stickslip_jax.units import G_MM_S2

from ..objectives.trace import TraceData

__all__ = ["GUARD", "RAW", "RESOLUTION", "SLIP_BIN", "Samples", "thin_windows"]

RESOLUTION = 0.25
"""A bin's length over its distance to the nearest event of its window (window start,
breakaway one slip time early)."""
RAW = 8
"""Samples (sample steps) from an event kept as they are."""
GUARD = 1.0
"""Slip times pi/omega_0 before the measured breakaway from which the slip zone runs."""
SLIP_BIN = 1 / 64
"""Bin length in the slip zone, in slip times pi/omega_0 (the model's RK4 step is
2.5/128 of it): samples closer than this are averaged, about the line of their own
slope (slips sampled well above the model's resolution)."""


@dataclasses.dataclass(frozen=True)
class Samples:
    """What every residual stands for: `count` samples whose scatter about their bin's
    line is `spread` (mm^2), flat like the residuals or [N, L]."""

    count: np.ndarray
    spread: np.ndarray

    def __getitem__(self, sel) -> Samples:
        return Samples(self.count[sel], self.spread[sel])

    def flat(self, mask) -> Samples:
        """The residuals' entries ([N, L] arrays at the unpadded samples `mask`, flat)."""
        return Samples(self.count.ravel()[mask], self.spread.ravel()[mask])

    @property
    def n(self) -> int:
        """Samples represented."""
        return int(self.count.sum())

    def within(self, sd) -> float:
        """The chi-square of the bins' scatter (`sd`: the bins' standard errors, mm)."""
        return float(np.sum(self.spread / (np.asarray(sd) ** 2 * self.count)))

    def chi2(self, r, sd) -> float:
        """The chi-square of all samples represented, from the whitened residuals `r`."""
        return float(np.sum(np.asarray(r) ** 2)) + self.within(sd)

    def rms(self, r_mm) -> float:
        """Residual RMS (mm) over all samples represented, from the residuals in mm."""
        return float(np.sqrt((np.sum(self.count * np.asarray(r_mm) ** 2)
                              + np.sum(self.spread)) / max(self.count.sum(), 1)))


def _bins(t, window, t0, t_end, dt, T2):
    """Bin index of every sample and whether its bin is in the slip zone (from `t_end`)."""
    d1, d2 = t - t0, t_end - t
    stick = d2 > 0  # False where the stick time is not known (kept as it is)
    d = np.where(stick, np.minimum(d1, d2), 0.0)
    d0 = np.maximum(RAW * dt, 1e-12)
    binned = stick & (d >= d0)
    k = np.floor(np.log(np.maximum(d, d0) / d0) / np.log1p(RESOLUTION)).astype(np.int64)
    code = np.where(d1 <= d2, 2 * k, 2 * k + 1)
    code = np.where(binned, code, -1 - np.arange(t.size))  # kept: a bin of its own
    slip = (d2 <= 0) & np.isfinite(d2)
    code = np.where(slip, 10 ** 9 + np.floor(-np.where(slip, d2, 0.0) / (SLIP_BIN * T2))
                    .astype(np.int64), code)
    new = np.r_[True, (np.diff(window) != 0) | (np.diff(code) != 0)]
    return np.cumsum(new) - 1, slip


def _bucket(n: int) -> int:
    """The smallest of 8, 16, 24, 32, 40, 56, 72, 96, 120, 152, ... (multiples of 8, each
    about 1/4 above the one before) holding n."""
    b = 8
    while b < n:
        b = max(b + 8, -(-int(b * 1.25) // 8) * 8)
    return b


def thin_windows(data: TraceData) -> tuple[TraceData, Samples]:
    """`data` with every window's stick binned (module doc), in rows again, and the
    `Samples` [N, L] of its entries."""
    mask = np.asarray(data.mask)
    rows, cols = np.nonzero(mask)
    t = np.asarray(data.time)[mask]
    x = np.asarray(data.deflection)[mask]
    win = np.asarray(data.window)[rows]
    fields = ("record", "weight", "normal_load", "stiffness", "speed", "start_time",
              "start_level", "start_level_sd", "start_time_sd", "stick_time", "sigma",
              "window", "drive_poly") + (() if data.drive_knots is None else ("drive_knots",))
    per_row = {f: np.asarray(getattr(data, f)) for f in fields}
    r = rows
    T2 = np.pi / np.sqrt(per_row["stiffness"][r] * G_MM_S2 / per_row["weight"][r])
    t0 = per_row["start_time"][r]
    t_end = t0 + per_row["stick_time"][r] - GUARD * T2  # binned up to GUARD slip times before
    first = np.r_[True, np.diff(win) != 0]
    starts = np.flatnonzero(first)
    n_w = np.diff(np.r_[starts, t.size])
    span = np.maximum.reduceat(t, starts) - np.minimum.reduceat(t, starts)
    dt = np.repeat(span / np.maximum(n_w - 1, 1), n_w)
    b, slipping = _bins(t, win, t0, t_end, dt, T2)
    edges = np.flatnonzero(np.r_[True, np.diff(b) != 0])
    count = np.diff(np.r_[edges, t.size]).astype(float)
    tb = np.add.reduceat(t, edges) / count
    xb = np.add.reduceat(x, edges) / count

    def centred(a, b_):  # sum over every bin of (a - its mean)(b - its mean)
        return np.add.reduceat(a * b_, edges) - np.add.reduceat(a, edges) * np.add.reduceat(
            b_, edges) / count

    ts = t - np.repeat(t[edges], count.astype(int))  # from the bin's first sample
    xs = x - np.repeat(x[edges], count.astype(int))
    y = xs - per_row["speed"][r] * ts  # a stick bin: about the line of the drive's slope
    stt = centred(ts, ts)
    spread = np.where(slipping[edges],  # a slip bin: about its own line
                      centred(xs, xs) - centred(ts, xs) ** 2 / np.where(stt > 0, stt, 1.0),
                      centred(y, y))
    spread = np.maximum(np.where(count > 1, spread, 0.0), 0.0)
    src = r[edges]  # the original row of every bin (its window's attributes)
    wb = win[edges]
    # rows again: a window's bins cut into rows of L (128 to 512: the longest window's
    # bins), their number padded to a bucket (`_bucket`): campaigns of a similar
    # size share their compiled programs (the command's persistent cache)
    w_start = np.flatnonzero(np.r_[True, np.diff(wb) != 0])
    w_len = np.diff(np.r_[w_start, wb.size])
    L = next(n for n in (128, 192, 256, 384, 512) if n >= min(int(w_len.max()), 512))
    pos = np.arange(wb.size) - np.repeat(w_start, w_len)
    row_of = np.cumsum(np.r_[0, -(-w_len // L)])[:-1]
    row = np.repeat(row_of, w_len) + pos // L
    col = pos % L
    n_rows = int(row[-1]) + 1
    N = _bucket(n_rows)
    head = np.zeros(N, int)  # every row's original row (dummy rows: copies of the first)
    head[row] = src
    shape = (N, L)
    time, defl, m = np.zeros(shape), np.zeros(shape), np.zeros(shape, bool)
    cnt, spr = np.ones(shape), np.zeros(shape)
    time[row, col], defl[row, col], m[row, col] = tb, xb, True
    cnt[row, col], spr[row, col] = count, spread
    last = np.zeros(N, int)
    np.maximum.at(last, row, col)
    fill = np.arange(L)[None, :] > last[:, None]
    time = np.where(fill, time[np.arange(N), last][:, None], time)  # padding: last time
    time[n_rows:] = time[0]

    def j(a):  # device_put: jnp.asarray would compile a small program per shape
        return jax.device_put(np.asarray(a))

    out = eqx.tree_at(lambda d: [getattr(d, f) for f in per_row] + [d.time, d.deflection,
                                                                   d.mask],
                      data, [j(per_row[f][head]) for f in per_row] + [j(time), j(defl),
                                                                       j(m)])
    return out, Samples(cnt, spr)
