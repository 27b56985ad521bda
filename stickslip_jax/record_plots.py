r"""Stick and slip phases detected in a measured record, and its figure (trace + phase plane).

Phase rule (`classify_phases`; in prose in docs/records.md): in a stick the slider rests,
so the deflection rises with the drive, $\dot x = \dot u$; in a slip $x$ falls fast.

1. $\dot x$, $\dot u$: least-squares slopes through `window` samples about each sample
   (default the odd count nearest $T_2/4 = \pi/(4\omega_0)$, at least 3); near the ends,
   the slope of the first (last) full window.
2. $\sigma$: the noise of such a slope of $y = u - x$, from its second differences
   (`stickslip_jax.slips.robust_sigma`), whatever the share of time in stick.
3. $r = \dot x - \dot u$, $\theta = \max(5\sigma, 0.05 \max|r|, 10^{-9}\max(|\dot x|,
   |\dot u|))$: **stick** where $|r| \le \theta$, **slip** where $\dot x < -\theta$ within a
   slip of `stickslip_jax.slips.find_slips`, **other** for the rest of a slip, **sliding**
   outside every slip (`PhaseSplit.verdict` says when the record slides continuously).
4. A stick with motion on both sides is a **pause** within a slip when neither it nor the
   rest `stickslip_jax.slips.rest` finds about it (within `window` samples each side) is a
   stick to the detector: shorter than `stickslip_jax.slips.rest_length`, or with a
   pause's shape (`stickslip_jax.slips.paused`). The slip runs on through it.

Two logger defects are handled first, so that they do not change the count of slips:
**glitches** (further from the median of the 5 samples about it than half the 1st-99th
percentile range and 10 noise sd: replaced by the line through its neighbours, counted in
`PhaseSplit.glitches`; one 10 mm spike otherwise made a 6-slip record show 1 slip) and
**quantisation** (every change a whole number of a step q and x constant while the drive
moves: $\theta \ge 3q/(w\,\Delta t)$, `PhaseSplit.quantum`; a 5 um-quantised record
otherwise counted 81 slips instead of 6).

The phase plane is that of Figs 34/35: $x$ (mm) against $\dot x/\omega_0$ (mm),
$\omega_0 = \sqrt{g k / W}$, on equal axes: a slip under constant kinetic friction is a
half circle about $\mu_m W/k$.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from .records import Record
from .slips import find_slips, paused, rest, rest_length, robust_sigma, runs

STICK, SLIP, UNCLASSIFIED, SLIDE, PAUSE = 0, 1, -1, 2, 3
"""Phase labels of `PhaseSplit.labels` (UNCLASSIFIED is shown as "other", SLIDE as
"sliding", PAUSE as "pause": a moment at rest within a slip, module doc)."""

ROUNDOFF = 1e-9
"""Smallest threshold relative to the largest rate (for noiseless, e.g. synthetic, traces)."""

MAD_SCALE = 1.4826
"""Median absolute deviation to standard deviation for Gaussian noise."""


def default_window(record: Record) -> int:
    """Odd number of samples nearest a quarter of T2 = pi/omega0 (at least 3, at most n)."""
    quarter = math.pi / record.omega0 / 4 / record.sample_interval
    w = max(3, 2 * int(round((quarter - 1) / 2)) + 1)
    n = record.n_samples
    return min(w, n if n % 2 else n - 1) if n >= 3 else 2


def _slope(y: np.ndarray, time: np.ndarray, w: int) -> np.ndarray:
    dt = (time[-1] - time[0]) / (time.shape[0] - 1)
    rate = np.gradient(y, time)
    if w < 3 or w > y.shape[0]:
        return rate
    if w % 2 == 0:
        raise ValueError(f"window must be odd, got {w}")
    j = np.arange(w) - (w - 1) / 2
    kernel = j / (np.sum(j**2) * dt)
    h = (w - 1) // 2
    rate[h:-h] = np.convolve(y, kernel[::-1], mode="valid")
    rate[:h] = rate[h]  # at the ends: the slope of the first (last) full window
    rate[-h:] = rate[-h - 1]
    return rate


@dataclasses.dataclass(frozen=True)
class PhaseSplit:
    """Stick/slip labels of every sample of a record (see the module docstring for the rule)."""

    labels: np.ndarray  # int8: STICK, SLIP, UNCLASSIFIED, SLIDE or PAUSE per sample
    rate: np.ndarray  # dx/dt, mm/s
    drive_rate: np.ndarray  # du/dt (same slope fit), mm/s
    threshold: float  # theta, mm/s
    noise: float  # sigma of dx/dt - du/dt, mm/s
    window: int  # samples in the slope fit
    glitches: int = 0  # single-sample spikes replaced before the slopes (module doc)
    quantum: float = 0.0  # the logger's resolution q in mm when quantised, else 0
    slips: tuple = ()  # the cycle detector's slips, (first, last + 1) sample indices
    verdict: str | None = None  # why there is no stick-slip (`slips.find_slips`), or None

    def runs(self, label: int) -> list[tuple[int, int]]:
        """(first, last + 1) sample indices of each run of `label`."""
        return runs(self.labels == label)

    @property
    def n_slips(self) -> int:
        """Number of slips (the cycle detector's)."""
        return len(self.slips)

    @property
    def stick_fraction(self) -> float:
        """Fraction of samples in stick."""
        return float(np.mean(self.labels == STICK))

    @property
    def pause_fraction(self) -> float:
        """Fraction of samples in pauses within slips (module doc)."""
        return float(np.mean(self.labels == PAUSE))

    @property
    def sliding_fraction(self) -> float:
        """Fraction of samples sliding outside every slip."""
        return float(np.mean(self.labels == SLIDE))


GLITCH_NOISE = 10.0
"""A glitch lies at least this many noise sd (and half the record's range) from its
neighbours' median (module doc)."""


def glitches(x: np.ndarray) -> np.ndarray:
    """Boolean mask of single-sample spikes of `x` (module doc): further from the median of
    the 5 samples about them than half the 1st-99th percentile range and `GLITCH_NOISE`
    noise sd (the noise from the scaled MAD of the first differences)."""
    x = np.asarray(x, dtype=float)
    mask = np.zeros(x.shape, dtype=bool)
    if x.shape[0] < 5:
        return mask
    window = np.lib.stride_tricks.sliding_window_view(np.pad(x, 2, mode="edge"), 5)
    deviation = np.abs(x - np.median(window, axis=1))
    d = np.diff(x)
    noise = MAD_SCALE * float(np.median(np.abs(d - np.median(d)))) / math.sqrt(2.0)
    lo, hi = np.percentile(x, [1.0, 99.0])
    limit = max(0.5 * (hi - lo), GLITCH_NOISE * noise)
    return deviation > limit if limit > 0 else mask


def quantum(x: np.ndarray, moving: np.ndarray) -> float:
    """The step q of a quantised record (module doc), else 0: every nonzero change between
    samples is a whole number of the smallest one, and x stays exactly constant over at
    least a quarter of the sample pairs where the drive moves (`moving`)."""
    d = np.diff(np.asarray(x, dtype=float))
    step = np.abs(d[d != 0])
    if step.size < 2:
        return 0.0
    q = float(np.min(step))
    ratio = step / q
    if np.max(np.abs(ratio - np.round(ratio))) > 1e-3:
        return 0.0
    still = (d == 0) & np.asarray(moving[1:], dtype=bool)
    n_moving = int(np.sum(moving[1:]))
    return q if n_moving and still.sum() >= 0.25 * n_moving else 0.0


def classify_phases(record: Record, window: int | None = None) -> PhaseSplit:
    """Label each sample of `record` stick, slip or unclassified (rule in the module docstring)."""
    w = default_window(record) if window is None else int(window)
    time = record.time
    spikes = glitches(record.deflection)
    x = record.deflection
    if spikes.any():
        good = ~spikes
        x = x.copy()
        x[spikes] = np.interp(time[spikes], time[good], x[good])
    drive = record.drive_position()
    rate = _slope(x, time, w)
    drive_rate = _slope(drive, time, w)
    q = quantum(x, np.abs(drive_rate) > 0)
    r = rate - drive_rate
    dt = (time[-1] - time[0]) / (time.shape[0] - 1)
    noise = robust_sigma(drive - x) * math.sqrt(12.0 / max(w * (w * w - 1), 6)) / dt
    roundoff = ROUNDOFF * max(float(np.max(np.abs(rate))), float(np.max(np.abs(drive_rate))))
    threshold = max(5.0 * noise, 0.05 * float(np.max(np.abs(r))), roundoff)  # module doc
    if q > 0:
        threshold = max(threshold, 3.0 * q / (max(w, 2) * dt))
    found = find_slips(time, record.deflection, drive, record.omega0)
    slips = () if found.verdict else tuple((a, min(b, r.size)) for a, b in found.events)
    stick = np.abs(r) <= threshold
    pause = np.zeros(r.shape, dtype=bool)
    floor, shortest = 1e-9 * max(1.0, float(np.max(np.abs(found.x)))), rest_length(found.h)

    def no_rest(a, b):  # shorter than the shortest rest, or with a pause's shape
        return b - a < shortest or (b - a < 8 * shortest and paused(time, found.y, a, b,
                                                                     found.sigma))

    for a, b in runs(stick) if slips else ():  # a stick between two motions: a pause?
        if a == 0 or b == r.size or not no_rest(a, b):
            continue
        at = rest(time, found.y, drive, max(a - w, 0), min(b + w, r.size), found.sigma, floor,
                  found.h)
        if at is None or no_rest(at.lo, at.hi):
            pause[a:b], stick[a:b] = True, False
    in_slip = np.zeros(r.shape, dtype=bool)
    for a, b in slips:
        in_slip[a:b] = True
    for a, b in runs(~stick):  # a slip runs from stick to stick
        if in_slip[a:b].any():
            in_slip[a:b] = True
    labels = np.where(in_slip, UNCLASSIFIED, SLIDE).astype(np.int8)
    labels[in_slip & (rate < -threshold)] = SLIP
    labels[stick] = STICK
    labels[pause] = PAUSE
    return PhaseSplit(labels, rate, drive_rate, threshold, noise, w, int(spikes.sum()), q,
                      slips, found.verdict)


MAX_SHADED = 2000
"""Most slip phases shaded individually in the trace (more are shown only by colour)."""


def plot_record(record: Record, phases: PhaseSplit | None = None):
    """A matplotlib Figure: (a) x(t) with the phases marked, (b) the phase plane x vs xdot/omega0.

    Uses the Agg canvas directly (no pyplot, no display needed).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    phases = classify_phases(record) if phases is None else phases
    t, x = record.time, record.deflection
    fig = Figure(figsize=(11, 4.6), layout="constrained")
    FigureCanvasAgg(fig)
    ax, ph = fig.subplots(1, 2, width_ratios=[1.7, 1])
    colours = {STICK: "tab:blue", SLIP: "tab:red", UNCLASSIFIED: "0.6", SLIDE: "tab:orange",
               PAUSE: "tab:purple"}
    names = {STICK: "stick", SLIP: "slip", UNCLASSIFIED: "other", SLIDE: "sliding",
             PAUSE: "pause"}
    ax.plot(t, x, color="0.75", lw=0.6, zorder=1)
    if len(phases.slips) <= MAX_SHADED:
        for a, b in phases.slips:
            ax.axvspan(t[a], t[min(b, len(t) - 1)], color="tab:red", alpha=0.12, lw=0, zorder=0)
    for label in (STICK, SLIP, UNCLASSIFIED, SLIDE, PAUSE):
        mask = phases.labels == label
        if mask.any():
            n = int(mask.sum())
            ax.plot(np.where(mask, t, np.nan), np.where(mask, x, np.nan), color=colours[label],
                    lw=1.0, label=f"{names[label]} ({100 * n / len(t):.0f} % of samples)")
            ph.plot(np.where(mask, phases.rate / record.omega0, np.nan), np.where(mask, x, np.nan),
                    color=colours[label], lw=0.8, label=names[label])
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("spring deflection x [mm]")
    v = record.nominal_drive_speed * 60
    title = (f"{record.name or 'record'}: W = {record.weight:g} kgf, k = {record.stiffness:g} "
             f"kgf/mm, v = {v:.4g} mm/min ({record.drive_source})")
    if record.lubricant:
        title += f", lubricant {record.lubricant}"
    ax.set_title(title, fontsize=9)
    sliding = phases.verdict is not None and "slides continuously" in phases.verdict
    ax.legend(loc="best", fontsize=8, title_fontsize=8,
              title="slides continuously" if sliding else f"{phases.n_slips} slips")
    ph.set_xlabel(r"$\dot x/\omega_0$ [mm],  $\omega_0$ = " + f"{record.omega0:.4g} rad/s")
    ph.set_ylabel("x [mm]")
    ph.set_title("phase plane (Figs 34/35)", fontsize=9)
    ph.set_aspect("equal", adjustable="datalim")
    ph.axvline(0.0, color="0.8", lw=0.6, zorder=0)
    ph.legend(loc="best", fontsize=8)
    return fig


def save_record_plot(record: Record, out, phases: PhaseSplit | None = None, dpi: int = 120) -> Path:
    """Save `plot_record(record)` as a PNG at `out`; returns the path."""
    out = Path(out)
    from .output import save_figure

    fig = plot_record(record, phases)
    save_figure(fig, str(out), dpi=dpi, format="png")
    return out
