"""Figures of a discovery result: residual RMS by phase before/after, and the traces.

Every record's traces are drawn over the samples the fit used, the lines broken between
fitted windows; each panel is titled by the file stem, spring and drive speed (never the
free-text note, which may be a licence paragraph); one legend above the grid, so that no
legend hides a sample.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from .residuals import PHASES

__all__ = ["TITLE_CHARS", "broken_at_gaps", "plot_cycle_discovery", "plot_discovery",
           "record_title"]

TITLE_CHARS = 60
"""The longest panel title (characters); a longer one is cut with an ellipsis."""


def record_title(record, index: int | None = None) -> str:
    """A short title of a record: `name: k = 86.9 kgf/mm, v = 5 mm/min, W = 36 kgf` (W
    where it fits), at most `TITLE_CHARS` characters."""
    name = getattr(record, "name", None) or (f"record {index}" if index is not None
                                             else "record")
    parts = []
    k, v, w = (getattr(record, a, None) for a in ("stiffness", "drive_speed", "weight"))
    if k is not None:
        parts.append(f"k = {float(k):.3g} kgf/mm")
    if v is not None:
        parts.append(f"v = {float(v) * 60.0:.3g} mm/min")
    text = name + (": " + ", ".join(parts) if parts else "")
    if w is not None and len(text) + 16 <= TITLE_CHARS:
        text += f", W = {float(w):.3g} kgf"
    return text if len(text) <= TITLE_CHARS else text[:TITLE_CHARS - 3] + "..."


def broken_at_gaps(t, *ys, segment=None, factor: float = 1.5):
    """`t` and `ys` in time order with a NaN between two segments (`segment`: a label per
    sample, e.g. its window) or, without labels, where the time step exceeds `factor` x
    the median step, so that a line drawn through them breaks there."""
    t = np.asarray(t, dtype=float)
    labels = np.zeros(t.size) if segment is None else np.asarray(segment)
    order = np.lexsort((t, labels))
    t, labels = t[order], labels[order]
    ys = [np.asarray(y, dtype=float)[order] for y in ys]
    if segment is not None:
        cut = np.flatnonzero(np.diff(labels) != 0) + 1
    elif t.size < 3:
        return (t, *ys)
    else:
        dt = np.diff(t)
        step = np.median(dt[dt > 0]) if np.any(dt > 0) else 0.0
        cut = np.flatnonzero(dt > factor * step) + 1 if step > 0 else np.array([], int)
    return (np.insert(t, cut, np.nan), *(np.insert(y, cut, np.nan) for y in ys))


def _after_label(effects: str) -> str:
    """The final model's legend label: "with EFFECTS", or that no effect was named."""
    return "final model (no effect named)" if effects == "none" else f"with {effects}"


def _layout(n_records: int, top: float, bottom: bool):
    """A figure of a top pair of axes (`top` inches), the records' grid (two columns,
    three beyond four records) and, with `bottom`, a last pair. Returns (figure, top axes,
    the grid's subfigure, columns, bottom axes or None)."""
    from matplotlib.figure import Figure

    cols = min(n_records, 3 if n_records > 4 else 2)
    grid = 3.4 * -(-n_records // cols)
    heights = [top, grid] + [2.6] * bottom
    fig = Figure(figsize=(5.2 * max(cols, 2) + 0.6, sum(heights)), layout="constrained")
    bands = fig.subfigures(len(heights), 1, height_ratios=heights)
    return (fig, bands[0].subplots(1, 2), bands[1], cols,
            bands[2].subplots(1, 2) if bottom else None)


def plot_discovery(result):
    """The smoothed base's figure: residual RMS by phase (um) before/after, the scores, and
    every record's traces and residuals. Returns the `Figure` (the backend is kept)."""
    tr = result.base_problem.traces
    m = np.asarray(tr.mask)
    t = np.asarray(tr.time)
    d = np.asarray(tr.deflection)
    # the fitted models' traces (kept from the fits: no new simulation or compilation)
    base = result.base_problem.trajectories(result.base_fit.z)[0]
    final = result.final_problem.trajectories(result.final_fit.z)[0]
    R = tr.time.shape[0]
    fig, top, grid, cols, _ = _layout(R, 2.8, False)
    ax = top[0]
    x = np.arange(len(PHASES))
    rb = [result.residuals_before.phases[p]["rms"] * 1e3 for p in PHASES]
    ra = [result.residuals_after.phases[p]["rms"] * 1e3 for p in PHASES]
    ax.bar(x - 0.2, rb, 0.4, label="base model")
    ax.bar(x + 0.2, ra, 0.4, label=_after_label(result.effect))
    ax.axhline(result.noise * 1e3, color="k", ls="--", lw=1, label="noise")
    ax.set_xticks(x, PHASES)
    ax.set_xlabel("phase of the cycle")
    ax.set_ylabel("residual RMS (um)")
    ax.set_ylim(0.0, 1.6 * ax.get_ylim()[1])  # room for the legend above the bars
    ax.legend(fontsize=8, loc="upper left", ncols=3)
    ax.set_title(f"effect: {result.effect} ({result.confidence}); traces of all {R} "
                 "records", fontsize=9)
    ax = top[1]
    names = [c["name"] for c in result.candidates]
    ax.barh(names, [max(c["score"], 1e-3) for c in result.candidates])
    ax.set_xscale("log")
    ax.set_xlabel("score statistic (chi-square, dimensionless)")
    recs = result.campaign.records  # the traces' rows, in order
    titles = [record_title(recs[i] if i < len(recs) else SimpleNamespace(
        name=f"record {i}", stiffness=float(tr.stiffness[i]), drive_speed=float(tr.speed[i]),
        weight=float(tr.weight[i])), i) for i in range(R)]
    _trace_panels(grid, cols, [(title, t[i][m[i]], d[i][m[i]], base[i][m[i]],
                                final[i][m[i]], None) for i, title in enumerate(titles)],
                  "base fit", "final fit", result.noise)
    return fig


def plot_cycle_discovery(result):
    """The per-cycle base's figure: residual RMS by phase (um) before and after against the
    noise, the parameters, the staircase of the effects named or the learned correction,
    every record's traces and residuals, and the misfit left. Returns the `Figure` (the
    backend is kept)."""
    from .cycle_model import per_sample

    model = result.model
    data = model.data
    mask = np.asarray(data.mask)
    t = np.asarray(data.time)[mask]
    x = np.asarray(data.deflection)[mask]
    rec, window = per_sample(data, "record", "window")
    sd = np.asarray(model.sd)[mask]
    r0 = model.residuals(result.z_before)[0] * sd
    r1 = model.residuals(result.z_after, result.shape, result.sensor)[0] * sd
    G = model.n_records
    left = getattr(result, "misfit_left", None)
    fig, axes, grid, cols, bottom = _layout(G, 3.9, left is not None)  # a taller top row
    if left is not None:
        _misfit_panels(bottom, left)
    ax = axes[0]
    names = list(result.phases_before)
    pos = np.arange(len(names))
    ax.bar(pos - 0.2, [1e3 * (result.phases_before[n]["rms"] or 0) for n in names], 0.4,
           label="paper's model")
    # "unexplained": the best family's refit; several effects: all of them
    after = (" + ".join(s["effect"] for s in getattr(result, "steps", None) or () if s["kept"])
             or result.effect_of or result.effect)
    after = _after_label(after)
    ax.bar(pos + 0.2, [1e3 * (result.phases_after[n]["rms"] or 0) for n in names], 0.4,
           label=after)
    ax.axhline(result.noise * 1e3, xmax=0.6, color="k", lw=0.8, ls="--", label="noise")
    expected = [result.phases_after[n].get("expected_rms") for n in names]
    if all(e is not None for e in expected):
        # a slip's timing error moves the fast trace: the slip phase's own scatter
        ax.hlines([1e3 * e for e in expected], pos - 0.45, pos + 0.45, colors="tab:red",
                  lw=1.5, ls=":", label="expected from their standard errors")
    ax.set_xticks(pos, names)
    ax.set_xlabel("phase of the cycle")
    ax.set_ylabel("residual RMS (um)")
    ax.set_ylim(0.0, 1.9 * ax.get_ylim()[1])  # room for the legend above the bars
    ax.set_xlim(-0.5, -0.5 + len(names) / 0.6)  # the right 40 %: the parameters
    ax.legend(fontsize=7, loc="upper left")
    _parameter_box(ax, result, after)
    given = len(getattr(result.campaign, "screening", ()) or ()) or G
    joint = " or ".join([result.effect] + [r["name"] for r in
                                           getattr(result, "indistinguishable_from", ()) or ()])
    summary = (f"effect: {joint} ({result.confidence})\n"
               f"gap {result.gap_before * 1e3:.3g} -> {result.gap_after * 1e3:.3g} um "
               f"(noise {result.noise * 1e3:.3g} um)\n"
               f"traces of all {G} records used"
               + (f" ({given} given)" if given > G else "") + ", fitted cycle windows only")
    learned, steps = result.learned, getattr(result, "steps", None) or []
    if steps and learned is not None:  # both: the top right panel split in two
        spec = axes[1].get_subplotspec()
        axes[1].remove()
        stair, axes[1] = spec.subgridspec(1, 2).subplots()
    elif steps:
        stair = axes[1]
    if steps:
        _staircase(stair, result, steps, summary if learned is None else None)
    if learned is None and not steps:
        axes[1].axis("off")
        axes[1].text(0, 0.5, summary, fontsize=9, va="center")
    elif learned is not None:  # the learned phase correction over the cycle, at the median climb
        ax = axes[1]
        phase, corr = learned.correction_at()
        ax.plot(phase, 1e3 * corr, color="C3", label="learned correction")
        ax.axvline(1.0, color="k", lw=0.6, ls=":", label="stick | slip")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_xlabel("stick phase (0-1), then 1 + slip phase (dimensionless)")
        ax.set_ylabel("learned correction (um)")
        ax.legend(fontsize=7)
        ax.set_title(summary + f"\nlearned: gap "
                     f"-> {learned.gap_after * 1e3:.3g} um ({100 * learned.closes:.0f} % of "
                     "the excess)", fontsize=8)
    panels = [(record_title(result.campaign.records[g], g), *(a[rec == g] for a in (
        t, x, x - r0, x - r1, window))) for g in range(G)]
    _trace_panels(grid, cols, panels, "paper's model", after, result.noise)
    return fig


def _parameter_box(ax, result, after: str) -> None:
    """The final model's parameters (`report.rows.estimate_text`), wrapped, in the right 40 %
    of the axes `ax`."""
    import textwrap

    from ..report.rows import estimate_text

    lines = [textwrap.fill(text, 36, subsequent_indent="  ") for text in
             [f"parameters ({after}):"] + [estimate_text(e) for e in
                                           getattr(result, "estimates", list)()]]
    ax.axvline(ax.get_xlim()[0] + 0.6 * np.ptp(ax.get_xlim()), color="0.7", lw=0.6)
    ax.text(0.61, 0.97, "\n".join(lines), va="top", fontsize=6, family="monospace",
            transform=ax.transAxes, gid="parameters")  # a gid: a label enters legends


def _misfit_panels(axes, left) -> None:
    """The misfit left (`misfit.MisfitLeft`): the phase's residual (um) against its clock
    (s) with the forms fitted, and each phase's and form's share of the excess."""
    from ..report.plots import above_axes

    p, um = left.profile, 1e3
    ax = axes[0]
    ax.plot(p["clock"], um * p["residual"], ".", ms=1.5, color="0.5", label="residual")
    ax.plot(p["clock"], um * p["fit"], ".", ms=1.5, color="C3",
            label="level + ramp + oscillation")
    ax.set_xlabel(f"{p['clock_words']} (s)")
    ax.set_ylabel(f"{left.phase} residual (um)")
    above_axes(ax, f"misfit left: {left.phase} phases")
    for handle in ax.get_legend().legend_handles:
        handle.set_markersize(6)  # the points' own 1.5 is too small to read
    ax = axes[1]
    names = list(left.shares) + [f"{left.phase}: {f['name']}" for f in left.forms]
    ax.bar(range(len(names)), [100 * v for v in left.shares.values()]
           + [100 * f["share"] for f in left.forms],
           color=["C0"] * len(left.shares) + ["C3"] * len(left.forms))
    ax.set_xticks(range(len(names)), names, rotation=15, fontsize=7, ha="right")
    ax.set_ylabel("share of the excess over the noise (%)")


def _staircase(ax, result, steps, title) -> None:
    """The staircase: the gap (um) with the paper's model and after each effect named."""
    um = 1e3
    gaps = [result.gap_before * um] + [s["gap_after"] * um for s in steps]
    labels = ["paper's model"] + [("+ " if s["kept"] else "(dropped) ") + s["effect"]
                                  for s in steps]
    ax.step(range(len(gaps)), gaps, where="mid", color="C0")
    ax.plot(range(len(gaps)), gaps, "o", color="C0", label="gap after each step")
    ax.axhline(result.noise * um, color="k", lw=0.8, ls="--", label="noise")
    ax.set_xticks(range(len(gaps)), labels, rotation=15, fontsize=7, ha="right")
    ax.set_ylabel("residual RMS (um)")
    ax.set_ylim(0.0, 1.15 * max(gaps))
    ax.legend(fontsize=7)
    if title:
        ax.set_title(title, fontsize=8)


def _trace_panels(grid, cols, panels, before: str, after: str, noise: float) -> None:
    """The records in the (sub)figure `grid`, `cols` a row (`panels`: title, time s,
    deflection mm, the models `before` and `after`, each sample's window or None): the
    deflection with both models above their residuals (um) over +-1 `noise`."""
    rows = -(-len(panels) // cols)
    spec = grid.add_gridspec(2 * rows, cols, height_ratios=[1.7, 1.0] * rows)
    for k, (title, *series, window) in enumerate(panels):
        tt, xx, m0, m1 = broken_at_gaps(*series, segment=window)
        ax = grid.add_subplot(spec[2 * (k // cols), k % cols])
        ax.plot(tt, xx, ".", ms=1, color="0.5", label="record")
        ax.plot(tt, m0, lw=0.8, color="C0", label=before)
        ax.plot(tt, m1, lw=0.8, color="C1", label=after)
        ax.set_ylabel("deflection (mm)")
        ax.set_title(title, fontsize=8)
        ax.tick_params(labelbottom=False)
        ax = grid.add_subplot(spec[2 * (k // cols) + 1, k % cols], sharex=ax)
        ax.axhspan(-1e3 * noise, 1e3 * noise, color="0.85", zorder=0, label="+-1 noise sd")
        ax.plot(tt, 1e3 * (xx - m0), lw=0.5, color="C0")
        ax.plot(tt, 1e3 * (xx - m1), lw=0.5, color="C1", alpha=0.7)
        ax.set_ylabel("residual (um)")
        ax.set_xlabel("time (s)")
    handles = [h for a in grid.axes[:2] for h in a.get_legend_handles_labels()[0]]
    grid.legend(handles=handles, loc="outside upper center", ncols=len(handles), fontsize=8,
                title="every record: deflection (mm) with both models, and residual (um) "
                      "= record - model", title_fontsize=8)
