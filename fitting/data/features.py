r"""Cycle features of a measured record: breakaway peak $x_2$, slip-end trough $x_1$, $T_1$, $T_2$.

The paper reads friction off each stick-slip cycle of the spring deflection $x(t)$
(Fig 6, chapters 3-4):

- $\mu_0 = k x_2 / W$ at breakaway after a stick of $T_1$ (section 3.1, eq 1);
- $\mu_m$ from eq (5), $x_2 - x_1 = 2(\mu_0 - \mu_m) W/k$, i.e. $\mu_m = k (x_2 + x_1) / (2W)$
  with $x_1$ the deflection when the slip ends (the stick restarts there).

How the features are measured (robust to noise, partial cycles and gauge offsets):

1. The slider displacement $y = u(t) - x(t)$ ($u$ the drive displacement) is constant
   during a stick, whatever the drive does. A slip is a sudden rise of $y$: a run of
   samples where the deflection falls by more than `threshold` noise standard
   deviations over half a natural period $T_2 = \pi/\omega_0$ (eq 7); the noise
   $\sigma$ is estimated from the second differences of $x$. Two runs are one slip when
   they overlap or the slider does not rest between them (near the boundary a stick
   can be shorter than the slip).
2. Each stick plateau level $Y_j$ is the clipped mean of $y$ over the stick, so $x_2$
   and $x_1$ average thousands of samples instead of the noisiest one at a peak. A
   plateau starts only where $y$ has settled: a slow re-slip keeps the slider moving
   after its fall of $x$ is lost in the noise.
3. A slip with constant friction is half a cosine (eq 11), symmetric about the time
   $t_c$ at which $y$ crosses the middle of its jump ($t_c$ from a line over the middle
   half of the jump, refined on the deflection's half sine); $t_b = t_c - T/2$,
   $t_e = t_c + T/2$, the duration from rest to rest with the drive moving solving
   $\omega_0 T = \pi + 2\arctan(v/(\omega_0 a))$, $a = (x_2 - x_1)/2$
   (`sticks.slip_duration`). Then $x_2 = u(t_b) - Y_{j-1}$, $x_1 = u(t_e) - Y_j$,
   $T_1 = t_b - t_{e,\mathrm{prev}}$. The reported `slip_time` comes from the 10 %-90 %
   rise time of the jump, scaled for a half cosine.

The first cycle's stick began before the record (`complete` False); a slip cut off by
the end of the record is dropped. A record without usable stick-slip is reported
(`stick_slip` False and a `message`), never an exception. Units: mm, s; plain NumPy
(data preparation, run once before fitting).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from stickslip_jax.slips import SlipSearch, find_slips, paused, regions, rest, rest_length
from stickslip_jax.units import G_MM_S2

from . import sticks
from .sticks import NOISE_FLOOR, detection_z

__all__ = ["NOISE_FLOOR", "RESLIP_RATIO", "RecordFeatures", "detection_z", "extract_cycles",
           "record_features"]

_RISE_10_90 = (math.pi - 2.0 * math.acos(0.8)) / math.pi
"""Fraction of a half cosine's duration between 10 % and 90 % of its rise."""


RESLIP_RATIO = 1.3
"""A slip measured this many times longer than a single slip of its size is a re-slip
(`RecordFeatures.slipped_on`); single slips measure 0.9-1.17 (noise, synthetic
campaigns), slips with a re-slip 1.4-2.3."""


@dataclasses.dataclass(frozen=True)
class RecordFeatures:
    r"""Per-cycle features of one record (internal units: mm, s, kgf).

    Cycle arrays (length C, one per detected slip with a stick on both sides):
    `breakaway_time`, `end_time` (s), `stick_time` $T_1$ (s; NaN for the first, partial
    cycle), measured `slip_time` $T_2$ (s), `peak` $x_2$ and `trough` $x_1$ (mm) with
    standard errors `peak_sd`, `trough_sd` (mm), `stick_time_sd` (s), `complete`,
    `trough_shift` (eq (5)'s symmetric trough less the measured one under a drive whose
    speed changes during the slip, `sticks.slip_fit`; 0 otherwise, mm). `noise`: the
    deflection's noise sd (mm); `start_level`: the deflection at the first sample if the
    record starts in a stick (NaN otherwise); `stick_slip` False: no usable stick-slip,
    the reason in `message`; `spikes`: samples replaced as impulsive outliers;
    `left_out`: cycles not used, counted by reason; `drive_note`: the drive error found
    in the sticks and corrected; `deflection_used`: the deflection as the features saw it
    (spikes replaced); `drive_fix`: the correction added to the nominal drive (mm) or None.
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
    trough_shift: np.ndarray | None = dataclasses.field(default=None, repr=False)
    normal_load: float | None = None

    @property
    def load(self) -> float:
        """The normal load N in kgf that the friction coefficients multiply (W unless the
        record gives `normal_load`)."""
        return self.weight if self.normal_load is None else self.normal_load

    @property
    def mu_0(self) -> np.ndarray:
        r"""$\mu_0 = k x_2 / N$ per cycle (section 3.1, N = W; no gauge-offset correction)."""
        return self.stiffness * self.peak / self.load

    @property
    def mu_m(self) -> np.ndarray:
        r"""$\mu_m = k (x_2 + x_1)/(2N)$ per cycle (eq 5; no gauge-offset correction)."""
        return self.stiffness * 0.5 * (self.peak + self.trough) / self.load

    @property
    def amplitude(self) -> np.ndarray:
        r"""$a = (x_2 - x_1)/2$ per cycle in mm (eq 5)."""
        return 0.5 * (self.peak - self.trough)

    @property
    def slipped_on(self) -> np.ndarray:
        r"""Per cycle: True where the slip lasted over `RESLIP_RATIO` times a single slip
        of its amplitude $a$ at the drive speed $v$ (eq 11 with the drive:
        $\omega_0 T_2 = \pi + 2\arctan(v/(\omega_0 a))$), or could not be timed: a
        re-slip (`objectives.cycle_features._levels`), one jump made of two slips, whose
        `end_time` is not when the slider came to rest."""
        a = np.maximum(self.amplitude, 1e-300)
        single = (math.pi + 2.0 * np.arctan(self.drive_speed / (self.omega0 * a))) / self.omega0
        with np.errstate(invalid="ignore"):
            return ~(np.asarray(self.slip_time) <= RESLIP_RATIO * single)

    @property
    def n_complete(self) -> int:
        return int(np.count_nonzero(self.complete))


def extract_cycles(time, deflection, *, weight: float, stiffness: float, drive,
                   name: str = "record", threshold: float | None = None, min_cycles: int = 2,
                   correct_drive: bool = True, _note: str | None = None) -> RecordFeatures:
    r"""Find the stick-slip cycles of one record and measure their features.

    - `time` (s), `deflection` x (mm): 1-D arrays of equal length, uniform time step.
    - `weight` W (kgf), `stiffness` k (kgf/mm).
    - `drive`: the drive displacement u (mm) at `time` (array), or a constant drive
      speed v (mm/s, a number: u = v t).
    - `threshold`: a slip is a fall of x larger than `threshold` standard deviations;
      None (default): set by the record's length for about 0.01 false slips per record
      (`sticks.detection_z`).
    - `min_cycles`: fewer complete cycles than this is reported as no usable stick-slip.
    - `correct_drive`: estimate the drive's error from the sticks (`sticks.drive_error`:
      speed off, slow drift, lead-screw periodic error) and extract again with the
      corrected drive when the sticks show one (`RecordFeatures.drive_note`).

    Never raises for a record without stick-slip (`message` says why). The stages:
    `_prepare` (noise, y = u - x, the slips of `stickslip_jax.slips.find_slips`),
    `_stick_plateaus`, `_cycle_row` (one cycle's features), `_assemble`.
    """
    r = _prepare(time, deflection, weight, stiffness, drive, name, threshold)
    events, thr = r.found.events, r.found.threshold
    if not events or r.found.sliding:
        return r.empty(r.found.verdict)
    plateaus = _stick_plateaus(r, events)
    if correct_drive:
        # A drive error estimated from all the sticks, kept when it is significant, has
        # the shape of a drive error and leaves at least as many usable cycles.
        fix, note = sticks.drive_error(r.t, r.u, r.y, plateaus, r.sigma,
                                       min_pitch=max(4.0 * r.speed * r.t2, 0.1))
        if fix is not None:
            kw = dict(weight=r.weight, stiffness=r.stiffness, name=name, threshold=threshold,
                      min_cycles=min_cycles, correct_drive=False)
            plain = extract_cycles(r.t, r.x, drive=r.u, **kw)
            fixed = extract_cycles(r.t, r.x, drive=r.u + fix, _note=note, **kw)
            plain = dataclasses.replace(plain, spikes=r.n_spikes, deflection_used=r.x)
            fixed = dataclasses.replace(fixed, spikes=r.n_spikes, deflection_used=r.x,
                                        drive_fix=fix)
            return fixed if fixed.n_complete >= plain.n_complete else plain
    rows: list[dict] = []
    left_out: dict[str, int] = {}
    prev_end = None
    for j, ev in enumerate(events):
        row, why = _cycle_row(r, ev, plateaus[j], plateaus[j + 1], thr, prev_end, first=j == 0)
        if why is not None:
            left_out[why] = left_out.get(why, 0) + 1
        if row is None:
            prev_end = None
            continue
        if why == PAUSE:  # the slip that ended in the pause: no single slip's end either
            rows[-1]["complete"] = False
        rows.append(row)
        # the slip after a pause slides on from it: its end is timed as no rest either
        prev_end = None if why == PAUSE else row["end_time"]
    return _assemble(r, rows, plateaus[0], left_out, len(events), min_cycles, _note)


@dataclasses.dataclass(frozen=True)
class _Prepared:
    """One record ready for the cycle search: t (s), x despiked and u (mm), y = u - x
    (mm), the noise sigma (mm), omega0 (rad/s), half a natural period t2 (s) and h
    (samples), the time step dt (s)."""

    name: str
    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    y: np.ndarray
    speed: float
    weight: float
    stiffness: float
    omega0: float
    t2: float
    dt: float
    n: int
    h: int
    sigma: float
    n_spikes: int
    noise_note: str | None
    found: SlipSearch

    def empty(self, message: str) -> RecordFeatures:
        """The features of a record without stick-slip cycles, `message` saying why."""
        e = np.zeros(0)
        return RecordFeatures(self.name, self.weight, self.stiffness, self.speed, self.omega0,
                              self.sigma, self.n, False, message, e, e, e, e, e, e, e, e, e,
                              np.zeros(0, bool))

    @property
    def floor(self) -> float:
        """A floor on thresholds: a noise-free record must not count rounding as slips."""
        return 1e-9 * max(1.0, float(np.max(np.abs(self.x))))


def _prepare(time, deflection, weight, stiffness, drive, name, threshold) -> _Prepared:
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
    sigma = sticks.robust_sigma(x)
    noise_note = None
    if sigma < sticks.NOISE_FLOOR:
        noise_note = (f"noise estimate {sigma * 1e6:.2g} nm is below the "
                      f"{sticks.NOISE_FLOOR * 1e6:g} nm "
                      "floor (no instrument resolves less: the record looks noise-free, e.g. "
                      "simulated); its errors use the floor, so the intervals measure no "
                      "better than that")
        sigma = sticks.NOISE_FLOOR
    found = find_slips(t, x, u, omega0, sigma=sigma, threshold=threshold)
    return _Prepared(name, t, found.x, u, found.y, speed, weight, stiffness, omega0, t2, dt,
                     t.size, found.h, sigma, found.spikes, noise_note, found)


def _stick_plateaus(r: _Prepared, events) -> list[sticks.Plateau | None]:
    """The plateaus (sticks) between the events: [0, ev0.start), [ev0.stop, ev1.start), ...,
    None where a stick is too short to measure."""
    t, y, sigma, floor, h = r.t, r.y, r.sigma, r.floor, r.h
    margin = max(2, h // 2)
    bounds = [0] + [v for ev in events for v in ev] + [r.n]
    around = regions(r.x, events, r.n)
    plateaus: list[sticks.Plateau | None] = []
    for j in range(len(events) + 1):
        a, b = bounds[2 * j], bounds[2 * j + 1]
        lo = a + (margin if j > 0 else 0)
        hi = b - (margin if j < len(events) else 0)
        if j > 0:
            lo = sticks.settled_start(y, lo, hi, sigma, block=margin, reach=4 * h, floor=floor)
        end = hi
        p = None
        for keep in ((2.0 / 3.0, 0.5, 1.0 / 3.0) if j < len(events) else (None,)):
            if keep is not None:  # a long creep leaves only the stick's start flat
                hi = sticks.creep_end(t, y, lo, end, sigma, block=max(margin, 4), floor=floor,
                                      keep=keep)
            p = sticks.plateau(t, y, lo, hi, sigma, floor) if hi - lo >= 3 else None
            if p is None or p.flat or hi == end:
                break
        if p is not None and not p.flat and j > 0 and j < len(events):
            p = sticks.creeping_plateau(t, y, lo, end, sigma, floor, r.speed) or p
            hi = end if p.flat else hi
        if p is not None and hi < end:  # crept: the level just before the slip
            tail = slice(end - max(margin, 4), end)
            excess = float(np.mean(y[tail])) - p.level
            p = dataclasses.replace(p, creep=max(excess, 0.0),
                                    creep_sd=sigma / math.sqrt(end - tail.start))
        if (p is None or not p.flat) and (r.found.short or end - lo < 2 * h):  # y at rest
            q = rest(t, y, r.u, *around[j], sigma, floor, h)
            p = q if q is not None and q.flat else p
        plateaus.append(p)
    return plateaus


PAUSE = "a pause within a slip, no stick (a re-slip)"
"""Why a cycle whose stick is shorter than a rest is incomplete (`_cycle_row`)."""


def _cycle_row(r: _Prepared, ev, before, after, thr, prev_end, first: bool):
    """One slip's cycle features (a dict of `RecordFeatures`' cycle columns) and the reason
    it was left out (or None); the row is None when the slip gives no cycle."""
    a, b = ev
    if before is None or after is None or not (before.flat and after.flat):
        if first and before is None:  # the record's first, partial stick is no cycle
            return None, None
        why = "stick too short" if before is None or after is None else (
            "stick not flat (drive error, creep or no stick)")
        return None, why
    t, u, x, y, omega0 = r.t, r.u, r.x, r.y, r.omega0
    y_pre, y_post = before.level, after.level  # refined at t_b, t_e below
    jump = y_post - y_pre
    if not jump > thr:
        return None, "jump below the detection threshold"
    seg_lo, seg_hi = max(0, a - r.h), min(r.n, b + r.h)
    ts, ys = t[seg_lo:seg_hi], y[seg_lo:seg_hi]
    frac = (ys - y_pre) / jump
    mid = (frac > 0.25) & (frac < 0.75)
    if np.count_nonzero(mid) >= 2:
        slope, icpt = np.polyfit(ts[mid] - ts[mid].mean(), ys[mid], 1)
        t_c = float(ts[mid].mean() + (0.5 * (y_pre + y_post) - icpt) / slope)
        n_mid = int(np.count_nonzero(mid))
    else:
        t_c = sticks.crossing(ts, ys, 0.5 * (y_pre + y_post))
        slope = jump * omega0 / 2.0
        n_mid = 1
    t10 = sticks.crossing(ts, ys, y_pre + 0.1 * jump)
    t90 = sticks.crossing(ts, ys, y_pre + 0.9 * jump)
    if not (math.isfinite(t_c) and t[0] <= t_c <= t[-1]):
        return None, "slip not timed"
    # Slip from rest with the drive moving at v: omega0 T2 = pi + 2 atan(v/(omega0 a))
    # (closed form of eqs 10-11 with the drive), symmetric about t_c.
    # Refine t_c on the deflection itself: x = c - R sin(omega0 (t - t_c)) about the
    # centre of the slip, c = (x2 + x1)/2 (eq 5), R^2 = a^2 + (v/omega0)^2.
    xs_seg = x[seg_lo:seg_hi]
    y_pre, y_post = before.end_level, after.level
    for _ in range(4):
        slip, t_b, t_e, x2, x1, v_slip = sticks.slip_ends(t_c, t, u, y_pre, y_post, omega0)
        amp = 0.5 * (x2 - x1)
        if not amp > 0:
            break
        radius = math.hypot(amp, v_slip / omega0)
        s_ = (0.5 * (x2 + x1) - xs_seg) / radius
        near = (np.abs(s_) < 0.75) & (np.abs(ts - t_c) < 0.3 * slip)
        if np.count_nonzero(near) < 2:
            break
        wgt = 1.0 - s_[near] ** 2
        t_new = float(np.sum(wgt * (ts[near] - np.arcsin(s_[near]) / omega0)) / np.sum(wgt))
        slope = radius * omega0
        n_mid = float(np.sum(wgt))
        done = abs(t_new - t_c) < 1e-6 * r.t2
        t_c = t_new
        if done:
            break
    # the slip and its ends at the final centre
    slip, t_b, t_e, x2, x1, v_slip = sticks.slip_ends(t_c, t, u, y_pre, y_post, omega0)
    amp = 0.5 * (x2 - x1)
    tc_sd = r.sigma / max(abs(slope), 1e-300) / math.sqrt(n_mid)
    # the slip's duration carries the error of the jump J = y_post - y_pre (the two
    # plateau levels): dT/dJ = -q / (omega0 a), q = v / (omega0 a) (implicit
    # derivative of `sticks.slip_duration`); near the boundary (q ~ 1, a of a few um) it
    # is the larger part (measured there: end times scatter by 0.75 ms)
    slip_sd = (v_slip / (omega0 * amp) / (omega0 * amp)
               * math.hypot(before.end_sd, after.sd)) if amp > 0 else 0.0
    time_sd = math.sqrt(2.0 * tc_sd ** 2 + 0.5 * slip_sd ** 2)
    peak_sd, trough_sd, shift = before.end_sd, after.sd, 0.0
    quarters = np.diff(np.interp(np.linspace(t[before.hi - 1], t[after.lo], 5), t, u))
    if np.ptp(quarters) > 2e-3 * np.max(np.abs(quarters)):  # the drive's speed changes
        gap = max(after.lo - before.hi, 4)
        fit = sticks.slip_fit(t, u, y, y_pre, y_post, omega0, (t_b, t[before.hi - 1]),
                              r.sigma, max(before.lo, before.hi - gap // 2),
                              min(after.hi, after.lo + gap // 2))
        if fit is None:  # the constant-speed timing would be wrong by the drive's change
            return None, "slip not timed"
        t_b, t_e, sd_b, sd_e, centre = fit
        u_b, u_e = np.interp([t_b, t_e], t, u)
        x2, x1 = float(u_b - y_pre), float(u_e - y_post)
        shift = (2.0 * centre - x2) - x1  # eq (5)'s trough (a steady drive) less the real one
        v_b, v_e = np.interp([t_b, t_e], t, np.gradient(u, t))
        peak_sd, trough_sd = math.hypot(peak_sd, v_b * sd_b), math.hypot(trough_sd, v_e * sd_e)
        time_sd = math.hypot(sd_b, sd_e)
    # a stick shorter than the detector's shortest rest is a pause within one slip (a
    # re-slip): its breakaway is no eq (1) level, so the cycle counts as incomplete, and
    # so does the slip before it (measured: 0-0.2 ms "sticks" in torsional records
    # whose slider all but stopped put k x2/W 0.03-0.06 above mu_0(0), the slip before
    # timed 1 ms late, and the fit's chi2/n at 2e5); so is a longer stick whose y has
    # a pause's shape (`slips.paused`: 6-14 ms within the noise band)
    short = prev_end is not None and (t_b - prev_end < rest_length(r.h) * r.dt or (
        before.hi - before.lo < 8 * rest_length(r.h)
        and paused(t, y, before.lo, before.hi, r.sigma)))
    return dict(breakaway_time=t_b, end_time=t_e,
                stick_time=max(t_b - prev_end, 0.0) if prev_end is not None else float("nan"),
                slip_time=(t90 - t10) / _RISE_10_90 if math.isfinite(t90 - t10) else float("nan"),
                peak=x2, trough=x1, trough_shift=shift, peak_sd=peak_sd, trough_sd=trough_sd,
                stick_time_sd=time_sd,
                complete=prev_end is not None and not short), (PAUSE if short else None)


def _assemble(r: _Prepared, rows, first, left_out, n_events, min_cycles, drive_note):
    """`RecordFeatures` from the cycle rows, or the reason there is no usable stick-slip."""
    start_level = start_sd = float("nan")
    if first is not None and first.lo == 0 and first.flat:
        start_level = float(r.u[0] - first.level)
        start_sd = first.sd
    why = "; ".join(f"{c} {k}" for k, c in left_out.items())
    notes = dict(spikes=r.n_spikes, left_out=left_out, drive_note=drive_note,
                 noise_note=r.noise_note)
    if not rows:
        return dataclasses.replace(
            r.empty("no complete stick-slip cycle: " + (
                f"{n_events} slips found, cycles left out: {why}" if why else
                "every slip is cut off by the record's ends")), **notes)
    cols = {k: np.array([row[k] for row in rows], dtype=bool if k == "complete" else float)
            for k in rows[0]}
    feats = RecordFeatures(
        name=r.name, weight=r.weight, stiffness=r.stiffness, drive_speed=r.speed,
        omega0=r.omega0, noise=r.sigma, n_samples=r.n, stick_slip=True, message=None,
        start_level=start_level, start_level_sd=start_sd, deflection_used=r.x,
        **notes, **cols)
    if feats.n_complete < min_cycles:
        return dataclasses.replace(
            feats, stick_slip=False,
            message=f"only {feats.n_complete} complete stick-slip cycle(s) (need {min_cycles}); "
            + (f"cycles left out: {why}" if why else "record longer"))
    return feats


def record_features(record, **kwargs) -> RecordFeatures:
    """`extract_cycles` on a `stickslip_jax.records.Record` (its drive, W, k, N and name)."""
    return dataclasses.replace(extract_cycles(
        record.time, record.deflection, weight=record.weight, stiffness=record.stiffness,
        drive=record.drive_position(), name=record.name or "record", **kwargs,
    ), normal_load=record.normal_load)
