r"""Sticks and slips of one record, the pieces `features.extract_cycles` is built from.

The slips and rests themselves come from `stickslip_jax.slips` (the one detector of every
command; its noise, spike, threshold and plateau pieces are re-exported here). This module
adds the noise floor of a fit (`NOISE_FLOOR`); a stick's plateau of the slider
displacement y = u - x refined (`settled_start`, `creep_end`, `creeping_plateau`); the
drive's error seen in the sticks (`drive_error`); the timing of a slip from rest to rest
with the drive moving (`slip_duration`, `slip_ends`, eq 11).
Units: mm, s. Plain NumPy (data preparation, run once before fitting).
"""

from __future__ import annotations

import math

import numpy as np

from stickslip_jax.slips import (
    CREEP_SPEED,
    Plateau,
    clipped_mean,
    despike,
    detection_z,
    moving_mean,
    plateau,
    robust_sigma,
    runs,
)

__all__ = ["CREEP_SPEED", "NOISE_FLOOR", "Plateau", "clipped_mean", "creep_end",
           "creeping_plateau", "crossing", "despike", "detection_z", "drive_error",
           "moving_mean", "plateau", "robust_sigma", "runs", "settled_start", "slip_duration",
           "slip_ends"]

NOISE_FLOOR = 1e-5
"""Smallest noise standard deviation a record is given (mm; 10 nm): the order of the best
displacement gauges on slideways (measured records here: 0.5-1.5 um). A noise-free
(simulated) record would otherwise get intervals that measure only the simulator's
rounding (measured without the floor: delta 73.03 +- 1e-8 for a truth of 67 from
noise-free records; on noise-free smoothed-simulator records, smoothing 1e-3, the 95 %
intervals missed mu_s by 0.07 % with a standard error of 3e-5 relative)."""


def settled_start(y: np.ndarray, lo: int, hi: int, sigma: float, block: int, reach: int,
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
    level, _ = clipped_mean(y[mid:hi], sigma)
    limit = max(2.0 * sigma / math.sqrt(block), floor)
    stop = min(lo + reach, mid - block)
    while lo <= stop and abs(float(np.mean(y[lo:lo + block])) - level) > limit:
        lo += max(1, block // 2)
    return lo


def creep_end(t: np.ndarray, y: np.ndarray, lo: int, hi: int, sigma: float, block: int,
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


def creeping_plateau(t: np.ndarray, y: np.ndarray, lo: int, hi: int, sigma: float,
                      floor: float, speed: float) -> Plateau | None:
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
    return Plateau(level, count, lo, hi, max(sigma, floor), True, creep=rise,
                    creep_sd=sigma * math.sqrt(1.0 / n + (ts[-1] - tm) ** 2 / sxx))


def drive_error(t: np.ndarray, u: np.ndarray, y: np.ndarray, plateaus, sigma: float,
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
        Qp = np.linalg.qr(np.stack([within(c[idx]) for c in poly.T], axis=1))[0]
        pitches = np.geomspace(min_pitch, travel, 80)
        scan = _pitch_scan(u[idx], grp, Qp, yw - Qp @ (Qp.T @ yw), pitches)
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


def _pitch_scan(us, grp, Qp, yp, pitches, chunk: int = 8) -> np.ndarray:
    r"""The residual sum of squares of the sticks' y_p (stick means and the polynomial
    taken out) after a lead-screw error of each pitch, sin and cos of 2 pi k u/p for
    k = 1, 2, at the sampled drive positions `us` (sorted stick labels `grp`).

    The screw columns a with the stick means and the polynomial (orthonormal basis Qp)
    taken out, W, give rss = |y_p|^2 - b^T (W^T W)^+ b with b = W^T y_p = a^T y_p (y_p is
    free of both already) and W^T W = a^T a - (stick sums)^2 / counts - (a^T Qp)(a^T Qp)^T:
    4 x 4 normal matrices instead of W itself. Pitches go `chunk` at a time through
    buffers allocated once (the columns of all 80 pitches at 20,000 samples would be
    51 MB of fresh memory per record)."""
    cuts = np.flatnonzero(np.r_[True, np.diff(grp) != 0])
    counts = np.diff(np.r_[cuts, grp.size])
    wave = 2.0 * np.pi / pitches
    a, q = np.empty((chunk, 4, us.size)), np.empty((chunk, us.size))
    gram, b = np.empty((pitches.size, 4, 4)), np.empty((pitches.size, 4))
    for i in range(0, pitches.size, chunk):
        n = min(chunk, pitches.size - i)
        ai, qi = a[:n], q[:n]
        s, c, s2, c2 = ai[:, 0], ai[:, 1], ai[:, 2], ai[:, 3]
        np.multiply(wave[i:i + n, None], us, out=qi)
        np.sin(qi, out=s)
        np.cos(qi, out=c)
        np.multiply(s, 2.0, out=s2)  # sin 2x = 2 sin x cos x, cos 2x = cos^2 x - sin^2 x
        s2 *= c
        np.square(c, out=c2)
        c2 -= np.square(s, out=qi)
        sums, aq = np.add.reduceat(ai, cuts, axis=2), ai @ Qp
        gram[i:i + n] = (ai @ ai.transpose(0, 2, 1) - (sums / counts) @ sums.transpose(0, 2, 1)
                         - aq @ aq.transpose(0, 2, 1))
        b[i:i + n] = ai @ yp
    proj2 = np.einsum("pi,pij,pj->p", b, np.linalg.pinv(gram, rcond=1e-13, hermitian=True), b)
    return float(yp @ yp) - proj2


def slip_duration(t_c: float, t: np.ndarray, u: np.ndarray, y_pre: float, y_post: float,
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
    f_lo, f_hi = excess(lo), excess(hi)
    if f_lo >= 0.0:
        return lo
    if f_hi <= 0.0:
        return hi
    # the Illinois variant of regula falsi on the bracket (NumPy only: SciPy's root
    # finders would cost every command the import of scipy.optimize, about 0.5 s)
    tol, side = 1e-9 * lo, 0
    for _ in range(100):
        T = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        f = excess(T)
        if f < 0.0:
            lo, f_lo, f_hi = T, f, 0.5 * f_hi if side < 0 else f_hi
            side = -1
        else:
            hi, f_hi, f_lo = T, f, 0.5 * f_lo if side > 0 else f_lo
            side = 1
        if f == 0.0 or hi - lo < tol:
            break
    return T


def slip_ends(t_c: float, t: np.ndarray, u: np.ndarray, y_pre: float, y_post: float,
               omega0: float) -> tuple[float, float, float, float, float, float]:
    """(duration T (s), breakaway t_b, end t_e (s), peak x2, trough x1 (mm), the drive's
    mean speed over the slip v (mm/s)) of the slip centred at `t_c` (`slip_duration`)."""
    slip = slip_duration(t_c, t, u, y_pre, y_post, omega0)
    t_b, t_e = t_c - 0.5 * slip, t_c + 0.5 * slip
    u_b, u_e = np.interp([t_b, t_e], t, u)
    return (slip, t_b, t_e, float(u_b - y_pre), float(u_e - y_post),
            max(float(u_e - u_b) / slip, 0.0))


def crossing(t: np.ndarray, y: np.ndarray, level: float) -> float:
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


SLOW = 0.1
"""A speed minimum of a slip under this fraction of the drive's speed is where the slider
may stop (`slip_fit`: the data decide)."""


def slip_fit(t: np.ndarray, u: np.ndarray, y: np.ndarray, y_pre: float, y_post: float,
             omega0: float, starts, sigma: float, first: int, last: int):
    r"""A slip under a drive whose speed changes during it, fitted sample by sample:
    (breakaway t_b, stop t_e, their standard errors (s), the centre c of the swing of the
    deflection (mm)), or None when it does not fit.

    From rest at y_pre at $t_b$ the slider obeys $\ddot y = \omega_0^2 (u - c - y)$
    ($c = \mu_m W/k$, constant over the slip as in eq 3) until it stops. With u linear
    between samples the motion is exact: $y = u - c + e$, $e + i\dot e/\omega_0$ turning
    by $\omega_0 \Delta t$ each step and jumping by $-i\,\Delta\dot u/\omega_0$ where the
    drive's slope changes. $t_b$ and $c$ are the least-squares fit to y from sample
    `first` (in the stick before), from each breakaway time of `starts` (s), the best
    kept: first over half a natural period past the earliest start, then up to the
    model's next speed minimum under `SLOW` times the drive's speed. There the data
    decide whether the slider stopped or slid through: over the next quarter natural
    period, a slider at rest there (the same fit from rest) must fit y better than the
    motion sliding through by a chi-square of 25. Where $\dot y$ reaches 0 it stops. A
    slider that stops and slips on from rest (y rising from the stop by more than 5 sigma
    over that quarter period) is fitted up to its stop only, and the rest of the slide
    from that stop by the same fit (one slip fitted over such a slide put the breakaway
    up to 16 ms off on `tests/torsional_rig.py`'s records). The last stop must land on
    y_post within 10 % of its jump (`last`: the end of the samples, in the stick after).
    Exact for any drive."""
    from scipy.optimize import least_squares  # here: only records with a varying drive

    dt = float(t[1] - t[0])
    lo, hi = first, last
    if hi - lo < 8:
        return None
    ts, ym = t[lo:hi], y[lo:hi]
    us = np.convolve(u, np.ones(5) / 5.0, mode="same")[lo:hi]  # the drive's noise off
    us[:2], us[-2:] = u[lo:lo + 2], u[hi - 2:hi]
    slope = np.diff(us) / dt
    turns = np.exp(-1j * omega0 * dt) ** np.arange(slope.size)  # once: the model's costliest

    def model(p, y0=y_pre):  # y over the window, the stop (s), the slow minima before it
        # (their samples and times)
        tb, c = p
        k = int(np.clip(np.searchsorted(ts, tb), 1, ts.size - 2))
        s0 = slope[k - 1]
        ub = us[k - 1] + s0 * (tb - ts[k - 1])
        w = (y0 - (ub - c)) - 1j * s0 / omega0  # e + i e'/omega0 at tb (y' = 0)
        w = w * np.exp(-1j * omega0 * (ts[k] - tb))
        ds = np.diff(slope[k - 1:])  # slope changes at ts[k], ts[k+1], ...
        turn = turns[:ds.size]
        ws = turn * (w - 1j / omega0 * np.cumsum(ds / turn))
        yk = us[k:k + ws.size] - c + ws.real
        speed = slope[k:k + ws.size] + omega0 * ws.imag  # y' (continuous at the samples)
        halt = np.flatnonzero(speed[1:] <= 0.0)
        j = int(halt[0]) + 1 if halt.size else yk.size
        minimum = np.zeros(j, bool)
        mid = speed[1:max(j - 1, 1)]
        minimum[1:1 + mid.size] = (mid <= speed[:mid.size]) & (mid <= speed[2:2 + mid.size])
        i = np.flatnonzero(minimum & (speed[:j] <= SLOW * np.abs(slope[k:k + j])))
        a, b, c = speed[i - 1], speed[i], speed[i + 1]  # the minimum between the samples
        when = ts[k + i] + 0.5 * dt * (a - c) / np.maximum(a - 2.0 * b + c, 1e-300)
        slow = (k + i, when)
        out = np.full(ts.size, y0)
        if not halt.size:
            out[k:k + yk.size] = yk
            return out, float(ts[-1]), slow
        f = speed[j - 1] / (speed[j - 1] - speed[j])
        out[k:k + j] = yk[:j]
        out[k + j:] = yk[j - 1] + f * (yk[j] - yk[j - 1])
        return out, float(ts[k + j - 1] + f * dt), slow

    jump = y_post - y_pre
    inner = (ym > y_pre + 0.02 * jump) & (ym < y_post - 0.02 * jump)
    c0 = float(np.mean((u[lo:hi] - ym)[inner])) if inner.any() else 0.0  # x swings about c

    def fit(window, guesses, y0=y_pre):  # least squares over the window, the best start
        best = None
        for p0 in guesses:
            try:
                sol = least_squares(
                    lambda p: (model(p, y0)[0][window] - ym[window]) / sigma, p0,
                    x_scale=[0.1 / omega0, 0.1 * jump], diff_step=[1e-4, 1e-4], method="lm")
            except ValueError:
                continue
            if best is None or sol.cost < best.cost:
                best = sol
        return best

    quarter = max(4, int(round(0.5 * math.pi / omega0 / dt)))
    n = int(np.clip(np.searchsorted(ts, min(starts) + math.pi / omega0), 8, ts.size))
    sol, passed = fit(slice(0, n), [(t_b, c0) for t_b in starts]), -1
    for _ in range(64):
        if sol is None:
            return None
        fitted, stop, (slow, when) = model(sol.x)
        at = min(int(np.searchsorted(ts, stop)), ts.size - 1)
        ahead = np.flatnonzero(slow > passed)
        end = int(slow[ahead[0]]) if ahead.size else at
        if max(end + 1, 8) != n:  # the window up to where the slip may end
            n = max(end + 1, 8)
            sol = fit(slice(0, n), [tuple(sol.x)])
            continue
        if end == at:  # y' reaches 0
            break
        after = slice(end, min(end + quarter, ts.size))
        held = fit(after, [(float(ts[end]), float(sol.x[1]))], y0=float(fitted[end]))
        if held is None or (np.sum(((ym[after] - fitted[after]) / sigma) ** 2)
                            <= 2.0 * held.cost + 25.0):
            passed = end  # the slider slid through the slow minimum
            continue
        stop, at = float(when[ahead[0]]), end  # it stopped there
        break
    try:
        cov = np.linalg.inv(sol.jac.T @ sol.jac)
    except np.linalg.LinAlgError:
        return None
    sd_b = float(math.sqrt(max(cov[0, 0], 0.0)))
    level, after = float(np.interp(stop, ts, fitted)), slice(at, min(at + quarter, ts.size))
    if at > 1 and after.stop - at >= 8 and y_post - level > 5.0 * sigma and np.polyfit(
            ts[after], ym[after], 1)[0] * (ts[after.stop - 1] - ts[at]) > 5.0 * sigma:
        # y rises on from the stop: the slider slips on
        rest_of = slip_fit(t, u, y, level, y_post, omega0, (stop,), sigma, lo + at - 1, last)
        if rest_of is None:
            return None
        return float(sol.x[0]), rest_of[1], sd_b, rest_of[3], float(sol.x[1])
    if not abs(level - y_post) < 0.1 * abs(jump):
        return None
    return float(sol.x[0]), float(stop), sd_b, sd_b, float(sol.x[1])
