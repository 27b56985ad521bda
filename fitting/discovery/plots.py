"""Figures of a discovery result: residual RMS by phase before/after, and the traces."""

from __future__ import annotations

import numpy as np

from .residuals import PHASES

__all__ = ["plot_cycle_discovery", "plot_discovery"]


def plot_discovery(result, path=None, *, records: int = 3):
    """Residual RMS by phase (um) before/after, and `records` traces with the base and
    final fits and their residuals (um against s). Returns the `Figure` (the user's
    backend is never switched); with `path`, saves it there (atomically) and closes it."""
    import matplotlib.pyplot as plt

    from stickslip_jax.output import save_figure

    tr = result.base_problem.traces
    m = np.asarray(tr.mask)
    t = np.asarray(tr.time)
    d = np.asarray(tr.data)
    # the fitted models' traces (kept from the fits: no new simulation or compilation)
    base = result.base_problem.trajectories(result.base_fit.z)[0]
    final = result.final_problem.trajectories(result.final_fit.z)[0]
    R = tr.n_records
    pick = sorted({0, R // 2, R - 1})[:records]
    fig, axes = plt.subplots(1 + len(pick), 2, figsize=(11, 2.6 * (1 + len(pick))))
    ax = axes[0, 0]
    x = np.arange(len(PHASES))
    rb = [result.residuals_before.phases[p]["rms"] * 1e3 for p in PHASES]
    ra = [result.residuals_after.phases[p]["rms"] * 1e3 for p in PHASES]
    ax.bar(x - 0.2, rb, 0.4, label="base model")
    ax.bar(x + 0.2, ra, 0.4, label=f"with {result.effect}")
    ax.axhline(result.noise * 1e3, color="k", ls="--", lw=1, label="noise")
    ax.set_xticks(x, PHASES)
    ax.set_ylabel("residual RMS (um)")
    ax.legend(fontsize=8)
    ax.set_title(f"effect: {result.effect} ({result.confidence})")
    ax = axes[0, 1]
    names = [c["name"] for c in result.candidates]
    ax.barh(names, [max(c["score"], 1e-3) for c in result.candidates])
    ax.set_xscale("log")
    ax.set_xlabel("score statistic (chi-square)")
    for row, i in enumerate(pick, start=1):
        mi = m[i]
        a = axes[row, 0]
        a.plot(t[i][mi], d[i][mi], ".", ms=2, color="0.5", label="record")
        a.plot(t[i][mi], base[i][mi], lw=1, label="base fit")
        a.plot(t[i][mi], final[i][mi], lw=1, ls="--", label="final fit")
        a.set_ylabel("deflection (mm)")
        a.legend(fontsize=7)
        b = axes[row, 1]
        b.plot(t[i][mi], (d[i][mi] - base[i][mi]) * 1e3, lw=0.8, label="base residual")
        b.plot(t[i][mi], (d[i][mi] - final[i][mi]) * 1e3, lw=0.8, label="final residual")
        b.set_ylabel("residual (um)")
        b.legend(fontsize=7)
    axes[-1, 0].set_xlabel("time (s)")
    axes[-1, 1].set_xlabel("time (s)")
    fig.tight_layout()
    if path is not None:
        save_figure(fig, str(path), dpi=110)
        plt.close(fig)
    return fig


def plot_cycle_discovery(result, *, records: int = 3):
    """Figure of a per-cycle discovery (`cycle_workflow.CycleDiscovery`): residual RMS by
    phase before and after (um), and for up to `records` records the measured deflection
    with the base and final models (mm against s) and their residuals (um). Returns the
    `matplotlib.figure.Figure` (the backend is left as it is)."""
    from matplotlib.figure import Figure

    model = result.model
    data = model.data
    mask = np.asarray(data.mask)
    t = np.asarray(data.time)[mask]
    x = np.asarray(data.deflection)[mask]
    rec = np.broadcast_to(np.asarray(data.record)[:, None], mask.shape)[mask]
    sd = np.asarray(model.sd)[mask]
    r0 = model.residuals(result.z_before)[0] * sd
    r1 = model.residuals(result.z_after, result.shape, result.sensor)[0] * sd
    G = model.n_records
    pick = sorted({0, G // 2, G - 1})[:records]
    fig = Figure(figsize=(11, 2.6 * (1 + len(pick))), layout="constrained")
    axes = fig.subplots(1 + len(pick), 2, squeeze=False)
    ax = axes[0, 0]
    names = list(result.phases_before)
    pos = np.arange(len(names))
    ax.bar(pos - 0.2, [1e3 * (result.phases_before[n]["rms"] or 0) for n in names], 0.4,
           label="paper's model")
    after = result.effect_of or result.effect  # "unexplained": the best family's refit
    ax.bar(pos + 0.2, [1e3 * (result.phases_after[n]["rms"] or 0) for n in names], 0.4,
           label=f"with {after}")
    ax.axhline(result.noise * 1e3, color="k", lw=0.8, ls="--", label="noise")
    ax.set_xticks(pos, names)
    ax.set_ylabel("residual RMS (um)")
    ax.legend(fontsize=8)
    summary = (f"effect: {result.effect} ({result.confidence})\n"
               f"gap {result.gap_before * 1e3:.3g} -> {result.gap_after * 1e3:.3g} um "
               f"(noise {result.noise * 1e3:.3g} um)")
    learned = result.learned
    if learned is None:
        axes[0, 1].axis("off")
        axes[0, 1].text(0, 0.5, summary, fontsize=10, va="center")
    else:  # the learned phase correction over the cycle, at the median climb
        ax = axes[0, 1]
        phase, corr = learned.correction_at()
        ax.plot(phase, 1e3 * corr, color="C3")
        ax.axvline(1.0, color="k", lw=0.6, ls=":")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_xlabel("stick phase (0-1), then 1 + slip phase")
        ax.set_ylabel("learned correction (um)")
        ax.set_title(summary.replace("\n", "; ") + f"\nlearned: gap -> "
                     f"{learned.gap_after * 1e3:.3g} um ({100 * learned.closes:.0f} % of "
                     "the excess)", fontsize=8)
    for row, g in enumerate(pick, start=1):
        sel = rec == g
        order = np.argsort(t[sel])
        tt = t[sel][order]
        ax = axes[row, 0]
        ax.plot(tt, x[sel][order], ".", ms=1, color="0.5", label="record")
        ax.plot(tt, (x - r0)[sel][order], lw=0.8, label="paper's model")
        ax.plot(tt, (x - r1)[sel][order], lw=0.8, label=f"with {after}")
        ax.set_ylabel("deflection (mm)")
        ax.set_title(result.campaign.records[g].note or f"record {g}", fontsize=9)
        ax = axes[row, 1]
        ax.plot(tt, 1e3 * r0[sel][order], lw=0.5, label="before")
        ax.plot(tt, 1e3 * r1[sel][order], lw=0.5, label="after")
        ax.set_ylabel("residual (um)")
        if row == 1:
            axes[row, 0].legend(fontsize=7)
            ax.legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    return fig
