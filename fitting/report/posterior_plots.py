"""The corner plot of posterior draws (`stickslip mcmc --plot`), drawn by `corner`.

For parameters whose posterior is narrow beside its value (mu_d = 0.21 known to 5e-5)
the ticks carry every digit that tells them apart and no offset text (matplotlib's
"1e-5+2.1e-1" would print over the neighbouring axis label), and each diagonal title
gives the median with as many decimals as its 68 % interval needs. Every axis is widened
to show a known truth, unless it lies more than `TRUTH_REACH` widths of the draws away
(then the title names it).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["TRUTH_REACH", "corner_plot"]

TRUTH_REACH = 20.0
"""A truth up to this many ranges of the draws away from them widens the axis to show it;
one farther off is named in the diagonal title ("truth X: off axis")."""


def _tick_formatter():
    """Tick labels with the significant digits their spacing needs and no offset text."""
    from matplotlib.ticker import Formatter

    class PlainTicks(Formatter):
        digits = 3
        step = 0.0

        def set_locs(self, locs):
            super().set_locs(locs)
            locs = np.asarray(locs, dtype=float)
            locs = locs[np.isfinite(locs)]
            steps = np.diff(np.sort(locs))
            steps = steps[steps > 0]
            if locs.size < 2 or steps.size == 0:
                self.digits, self.step = 3, 0.0
                return
            self.step = float(steps.min())
            big = float(np.abs(locs).max())
            # enough digits to tell two neighbouring ticks apart, at least 2
            self.digits = int(min(12, max(2, math.ceil(math.log10(big / self.step)) + 1)))

        def __call__(self, x, pos=None):
            if self.step and abs(x) < 1e-6 * self.step:
                x = 0.0
            text = f"{x:.{self.digits}g}"
            return text.replace("e+0", "e").replace("e-0", "e-").replace("e+", "e")

    return PlainTicks()


def _inner_locator(n_ticks: int, margin: float = 0.08):
    """`MaxNLocator(n_ticks)` without the ticks within `margin` of the axis ends."""
    from matplotlib.ticker import MaxNLocator

    class InnerTicks(MaxNLocator):
        def tick_values(self, vmin, vmax):
            ticks = np.asarray(super().tick_values(vmin, vmax))
            lo, hi = min(vmin, vmax), max(vmin, vmax)
            pad = margin * (hi - lo)
            return ticks[(ticks >= lo + pad) & (ticks <= hi - pad)]

    return InnerTicks(n_ticks)


def _value_title(name: str, q16: float, q50: float, q84: float, unit: str,
                 truth: float | None = None, off_axis: bool = False) -> str:
    """`name = median unit` over `+up / -down`, with the decimals of the smaller
    half-width (two significant digits of it)."""
    lo, hi = q50 - q16, q84 - q50
    width = min((x for x in (lo, hi) if x > 0), default=0.0)
    u = "" if unit in ("-", "") else f" {unit}"
    if width == 0.0 or not np.isfinite(width):
        text = f"{name} = {q50:.4g}{u}"
    else:
        scale = abs(q50) if q50 else width
        if scale >= 1e5 or scale < 1e-3:  # scientific: mantissa digits from the width
            digits = max(1, int(math.floor(math.log10(scale)) - math.floor(math.log10(width))) + 1)
            text = f"{name} = {q50:.{digits}e}{u}\n+{hi:.2g} / -{lo:.2g}"
        else:
            decimals = max(0, 1 - int(math.floor(math.log10(width))))
            text = (f"{name} = {q50:.{decimals}f}{u}\n"
                    f"+{hi:.{decimals}f} / -{lo:.{decimals}f}")
    if truth is not None and off_axis:
        text += f"\ntruth {truth:.4g}: off axis"
    return text


def corner_plot(samples, names, path=None, truth: dict | None = None, bins: int = 30,
                units: dict | None = None, **kwargs):
    """Corner plot of posterior samples (N, d) (returned; saved to `path` at 100 dpi and
    closed when given): histograms with the 16, 50 and 84 % quantiles on the diagonal
    (median and interval in the titles), 2-D histograms with density contours below, the
    truth as red lines where `truth` names a parameter, axes labelled `name [unit]` from
    `units` (`[-]` without one). Other keywords go to `corner.corner` (a `range` given
    there is kept). Example: `corner_plot(res.samples, res.names, truth=truth,
    units=res.units)` for an `McmcResult`.
    """
    import corner  # draws through pyplot with the user's backend, as it is

    samples = np.asarray(samples, dtype=float)
    names = list(names)
    units = units or {}
    truth = truth or {}

    truths = None
    if any(truth.get(n) is not None for n in names):
        truths = [truth.get(n) for n in names]
    lo, hi = samples.min(axis=0), samples.max(axis=0)
    # a parameter that did not move gets a small range (corner refuses an empty one)
    pad = np.where(hi > lo, 0.0, np.maximum(1e-9, 1e-6 * np.abs(lo)))
    lo, hi = lo - pad, hi + pad
    off_axis = [False] * len(names)
    if truths is not None:
        for i, t in enumerate(truths):
            if t is None or not np.isfinite(t) or lo[i] <= t <= hi[i]:
                continue
            span = hi[i] - lo[i]
            if abs(t - (lo[i] + hi[i]) / 2) > TRUTH_REACH * span:
                off_axis[i] = True
                continue
            lo[i], hi[i] = min(lo[i], t), max(hi[i], t)
            margin = 0.04 * (hi[i] - lo[i])  # the truth line clear of the frame
            lo[i], hi[i] = (lo[i] - margin if t == lo[i] else lo[i],
                            hi[i] + margin if t == hi[i] else hi[i])
    labels = [f"{n} [{units.get(n) or '-'}]" for n in names]
    options = dict(bins=bins, labels=labels, quantiles=[0.16, 0.5, 0.84],
                   show_titles=False, truths=truths, truth_color="tab:red",
                   label_kwargs={"fontsize": 9}, range=list(zip(lo, hi)), labelpad=0.1,
                   max_n_ticks=4)
    options.update(kwargs)
    fig = corner.corner(samples, **options)
    d = len(names)
    grid = np.asarray(fig.axes).reshape(d, d)
    q16, q50, q84 = np.percentile(samples, [16, 50, 84], axis=0)
    for i, n in enumerate(names):
        grid[i, i].set_title(_value_title(n, q16[i], q50[i], q84[i], units.get(n, "-"),
                                          truth.get(n), off_axis[i]), fontsize=8)
    from matplotlib.ticker import MaxNLocator, ScalarFormatter

    n_ticks = options["max_n_ticks"]
    for ax in fig.axes:  # corner's number ticks (not its blanked or log ones)
        for axis in (ax.xaxis, ax.yaxis):
            if isinstance(axis.get_major_locator(), MaxNLocator):
                # no tick near either end: the rotated labels of neighbouring panels meet there
                axis.set_major_locator(_inner_locator(n_ticks))
            if isinstance(axis.get_major_formatter(), ScalarFormatter):
                axis.set_major_formatter(_tick_formatter())
    from .saving import finish_figure

    return finish_figure(fig, path, 100)
