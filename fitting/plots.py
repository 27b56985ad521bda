r"""Figures of a fit: traces with the fitted model, $\mu_0(T_1)$ and $\mu_m(T_2)$ with bands, corner plot.

With matplotlib; the corner plot with the `corner` package (the community's standard
posterior figure: quantiles, contours, truths). Units on the axes: s, um, mu
dimensionless; the corner plot's from the parameter family's `UNITS`. Following
matplotlib's convention, every function returns its `Figure` and never switches the
user's backend; given a `path` it also saves the figure there
(atomically) and closes it, without one it leaves it open for Jupyter to show.
"""

from __future__ import annotations

from stickslip_jax.output import save_figure

import numpy as np

__all__ = ["batch_figure", "corner_plot", "fit_figure", "fitted_traces", "friction_curves", "residual_panel"]


def _plt():
    import matplotlib.pyplot as plt  # the user's backend, as it is

    return plt


def _finish(fig, path, dpi):
    """Save and close `fig` when a `path` is given; return the figure either way."""
    if path is not None:
        import matplotlib.pyplot as plt

        save_figure(fig, str(path), dpi=dpi)
        plt.close(fig)
    return fig


def _static_curves(logs, template, grid):
    """mu_0 of eq (1) on `grid` (s) for every row of `logs` (log parameter values)."""
    import jax

    return jax.vmap(lambda d: template.from_log_values(d).friction().static(grid))(logs)


def friction_curves(fit, unc, n_draws: int = 200, seed: int = 0):
    r"""(T1 grid (s), fitted mu_0, 2.5 % and 97.5 % points) of eq (1): a 95 % band from
    `n_draws` draws of the Laplace covariance (in log parameters), evaluated in one
    compiled call."""
    import jax

    from .fit import compiled

    t1 = np.concatenate([f.stick_time[f.complete] for f in fit.features])
    grid = np.geomspace(max(t1.min() / 3, 1e-3), t1.max() * 3, 100)
    logs0 = np.asarray(fit.params.friction.log_values())
    cov = np.nan_to_num(unc.cov_log)
    rng = np.random.default_rng(seed)
    draws = rng.multivariate_normal(logs0, cov, size=n_draws, check_valid="ignore")
    draws = np.concatenate([logs0[None], draws[draws[:, 0] > draws[:, 1]]])
    curves = np.asarray(compiled(_static_curves, jax.device_put(draws), fit.params.friction,
                                 jax.device_put(grid)))
    best, curves = curves[0], (curves[1:] if len(curves) > 1 else curves)
    lo, hi = np.percentile(curves, [2.5, 97.5], axis=0)
    return grid, best, lo, hi


def fitted_traces(fit, records):
    """The fitted model over `records` (the first ones of the fit): per record, (time s,
    deflection mm without the gauge offset) of the exact simulator restarted at the
    end of every slip, as the trace objective compares it (`stickslip_fitting.trace_objective`),
    NaN between the cycle windows. None where that is not possible (a drive program,
    no complete cycle); the figure then shows the fitted levels only."""
    import jax

    from .fit import compiled
    from .params import CampaignParams
    from .trace_objective import trace_data, trace_simulation

    n = len(records)
    try:
        data = trace_data(records, fit.features[:n])
    except ValueError:
        return None
    params = CampaignParams(fit.params.friction, jax.device_put(np.asarray(fit.params.offset)[:n]))
    sim = np.asarray(compiled(trace_simulation, params, data, fit.slip_time).deflection)
    rec, win = np.asarray(data.record), np.asarray(data.window)
    time, mask = np.asarray(data.time), np.asarray(data.mask)
    out = []
    for i in range(n):
        t, x = [], []
        for w in np.unique(win[(rec == i) & mask.any(axis=1)]):
            rows = np.flatnonzero((win == w) & mask.any(axis=1))
            t += [time[rows][mask[rows]], [np.nan]]
            x += [sim[rows][mask[rows]], [np.nan]]
        out.append((np.concatenate(t), np.concatenate(x)) if t else (np.array([]), np.array([])))
    return out


PHASE_ORDER = ("levels", "stick_times", "start_level", "trace_stick", "trace_slip")
"""The phases of `stickslip_fitting.adequacy` in the order the residual panel shows them."""


def residual_panel(report, ax=None):
    """chi2/n of the residuals by record and phase (one panel; returns its `Figure`, drawn
    on `ax` when given): for each record a group of bars, one per phase of `report`, a
    `stickslip_fitting.adequacy.Adequacy` (`adequacy(fit)`): levels, stick times, the first
    plateau (`--offset start`), the trace objective's stick and slip samples (trace and
    combined fits). chi2/n is in the records' own errors, so 1 is "to the noise"; dashed
    lines at `GOOD` and `BAD`, log scale. Each phase is one `BarContainer` labelled with
    the phase, its bars in record order, NaN where a record has no residual in the phase.
    Example: `residual_panel(adequacy(fit))`.
    """
    from .adequacy import BAD, GOOD

    if ax is None:
        fig, ax = _plt().subplots(figsize=(8, 3.5))
    else:
        fig = ax.figure
    records = list(dict.fromkeys(r.record for r in report.rows))
    phases = [p for p in PHASE_ORDER if any(r.phase == p for r in report.rows)]
    phases += sorted({r.phase for r in report.rows} - set(phases))
    value = {(r.record, r.phase): r.chi2_per_n for r in report.rows}
    x = np.arange(len(records))
    width = 0.8 / max(len(phases), 1)
    for j, phase in enumerate(phases):
        heights = [value.get((rec, phase), np.nan) for rec in records]
        ax.bar(x + (j - (len(phases) - 1) / 2) * width, heights, width, label=phase)
    ax.axhline(GOOD, color="0.3", ls="--", lw=0.8)
    ax.axhline(BAD, color="tab:red", ls="--", lw=0.8)
    ax.set_yscale("log")
    from matplotlib.ticker import FormatStrFormatter, LogLocator

    ax.yaxis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
    ax.yaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax.yaxis.set_minor_formatter(FormatStrFormatter("%g"))
    ax.set_xticks(x, records, rotation=30, ha="right", fontsize=7)
    ax.set(ylabel="chi2/n (records' errors)",
           title=f"residuals by record and phase (1 = to the noise; dashed: {GOOD:g}, "
                 f"{BAD:g}); verdict: {report.verdict}")
    ax.legend(fontsize=7, ncols=len(phases) or 1)
    return fig


def fit_figure(fit, unc, records, path=None, max_traces: int = 4):
    """The diagnostic figure (returned; saved to `path` when given): the first
    `max_traces` records with the fitted simulation (`fitted_traces`) and breakaway levels
    over them, mu_0 against T1 with the fitted eq (1) and its 95 % band, mu_m against T2
    with the fitted eq (3), the parameters, and below the residuals' chi2/n by record and
    phase of `stickslip_fitting.adequacy` (`residual_panel`, every record of the fit)."""
    import jax.numpy as jnp

    from .adequacy import adequacy

    plt = _plt()
    n = min(max_traces, len(records))
    fig = plt.figure(figsize=(11, 11.5))
    layout = fig.add_gridspec(3, 2, height_ratios=(1, 1, 0.85))
    axes = np.array([[fig.add_subplot(layout[i, j]) for j in range(2)] for i in range(2)])
    ax = axes[0, 0]
    offset = np.asarray(fit.params.offset)
    fr = fit.params.friction.friction()
    simulated = fitted_traces(fit, records[:n])
    for i in range(n):
        r, f = records[i], fit.features[i]
        ax.plot(r.time, (r.deflection - offset[i]) * 1e3, lw=0.6, label=f.name)
        if simulated is not None:
            ax.plot(simulated[i][0], simulated[i][1] * 1e3, "k--", lw=0.6)
        mu0 = np.asarray(fr.static(jnp.asarray(np.where(f.complete, f.stick_time, 1.0))))
        x2 = np.where(f.complete, mu0 * f.weight / f.stiffness, np.nan)
        ax.plot(f.breakaway_time, x2 * 1e3, "k^", ms=4)
    if simulated is not None:
        ax.plot([], [], "k--", lw=0.6, label="fitted simulation, restarted every cycle")
    ax.plot([], [], "k^", label="fitted breakaway level (eq 1)")
    ax.set(xlabel="time t [s]", ylabel="deflection x [um]", title="records and fitted model")
    ax.legend(fontsize=7)

    ax = axes[0, 1]
    grid, best, lo, hi = friction_curves(fit, unc)
    ax.fill_between(grid, lo, hi, alpha=0.3, label="95 % band")
    ax.plot(grid, best, "k-", label="fitted eq (1)")
    for i, f in enumerate(fit.features):
        c = f.complete
        ax.plot(f.stick_time[c], f.stiffness * (f.peak[c] - offset[i]) / f.weight, ".", ms=4)
    ax.set(xscale="log", xlabel="stick time T1 [s]", ylabel="mu_0", title="static friction")
    ax.legend(fontsize=7)

    ax = axes[1, 0]
    mu0_all, t2_all = [], []
    for i, f in enumerate(fit.features):
        c = f.complete
        mum = f.stiffness * (0.5 * (f.peak[c] + f.trough[c]) - offset[i]) / f.weight
        t2 = np.full(mum.shape, np.pi / f.omega0)
        ax.plot(t2, mum, ".", ms=5)
        mu0 = np.asarray(fr.static(jnp.asarray(f.stick_time[c])))
        pred = np.asarray(fr.kinetic(jnp.asarray(mu0), fr.mu_d, jnp.asarray(t2)))
        ax.plot(t2, pred, "ko", ms=7, mfc="none", mew=0.7)
        mu0_all.append(mu0)
        t2_all.append(t2)
    mu0_all, t2_all = np.concatenate(mu0_all), np.concatenate(t2_all)
    if mu0_all.size:
        t2_grid = np.geomspace(0.7 * t2_all.min(), 1.4 * t2_all.max(), 100)
        for mu0, style in ((mu0_all.max(), "k-"), (mu0_all.min(), "k:")):
            curve = fr.kinetic(jnp.full_like(t2_grid, mu0), fr.mu_d, jnp.asarray(t2_grid))
            ax.plot(t2_grid, np.asarray(curve), style, lw=0.8,
                    label=f"fitted eq (3) at mu_0 = {mu0:.3g}")
    ax.plot([], [], ".", color="0.4", label="measured per cycle (eq 5)")
    ax.plot([], [], "ko", mfc="none", mew=0.7, label="fitted eq (3) at each cycle's mu_0")
    ax.set(xlabel="slip time T2 = pi/omega0 [s]", ylabel="mu_m",
           title="mean kinetic friction (eq 5)")
    ax.legend(fontsize=7)

    ax = axes[1, 1]
    ax.axis("off")
    lines = [f"{r['name']:>6} = {r['value']:.4g} " + (
        f"± {r['stderr']:.2g}" if r["stderr"] is not None else
        ("(fixed)" if r["fixed"] else "(not identifiable)")) for r in unc.table()]
    lines.append(f"chi2/dof = {fit.reduced_chi2:.3g}")
    ax.text(0.0, 1.0, "\n".join(lines), va="top", family="monospace", fontsize=10)
    residual_panel(adequacy(fit), ax=fig.add_subplot(layout[2, :]))
    fig.tight_layout()
    return _finish(fig, path, 110)


def corner_plot(samples, names, path=None, truth: dict | None = None, bins: int = 30,
                units: dict | None = None, **kwargs):
    """Corner plot of posterior samples (N, d) drawn by the `corner` package (returned;
    saved to `path` when given): histograms with the 16, 50 and 84 % quantiles on the
    diagonal (their values in the titles), 2-D histograms with density contours below,
    the truth as lines where `truth` names a parameter, axes labelled
    `name [unit]` from `units` (the parameter family's `UNITS`; "-" for dimensionless
    shows no unit). Other keywords go to `corner.corner`. Example, for an `McmcResult`:
    `corner_plot(res.samples, res.names, truth=truth, units=res.units)`.
    """
    import corner  # draws through pyplot with the user's backend, as it is
    samples = np.asarray(samples, dtype=float)
    units = units or {}

    def label(n):
        u = units.get(n, "-")
        return n if u in ("-", "") else f"{n} [{u}]"

    truths = None
    if truth and any(n in truth for n in names):
        truths = [truth.get(n) for n in names]
    options = dict(bins=bins, labels=[label(n) for n in names], quantiles=[0.16, 0.5, 0.84],
                   show_titles=True, title_fmt=".3g", title_kwargs={"fontsize": 8},
                   truths=truths, truth_color="tab:red", label_kwargs={"fontsize": 9})
    lo, hi = samples.min(axis=0), samples.max(axis=0)
    if np.any(hi <= lo):  # a parameter that did not move (corner refuses no range)
        pad = np.where(hi > lo, 0.0, np.maximum(1e-9, 1e-6 * np.abs(lo)))
        options["range"] = list(zip(lo - pad, hi + pad))
    options.update(kwargs)
    fig = corner.corner(samples, **options)
    return _finish(fig, path, 100)


def batch_figure(batch, path=None, dpi: int = 120):
    """The parameters of a batch of campaign fits side by side (`stickslip fit-batch
    --plot`): one panel per fitted parameter, a point per campaign with its 95 % interval
    (none where the parameter was not identifiable; a hollow point where it was fixed),
    campaigns not fitted left empty and named in the title. `batch` is a
    `stickslip_fitting.batch.BatchResult`; returns the `Figure` (saved and closed when
    `path` is given)."""
    entries = list(batch.entries)
    names = list(dict.fromkeys(p for e in entries if e.report
                               for p in e.report["parameters"]))
    ncol = min(3, max(len(names), 1))
    nrow = max(1, -(-len(names) // ncol))
    fig, axes = _plt().subplots(nrow, ncol, figsize=(4.2 * ncol, 0.6 + 2.6 * nrow),
                                squeeze=False, sharex=True)
    x = np.arange(len(entries))
    for ax, name in zip(axes.flat, names):
        unit = ""
        for i, e in enumerate(entries):
            p = (e.report or {}).get("parameters", {}).get(name)
            if p is None:
                continue
            unit = "" if p["unit"] == "-" else f" [{p['unit']}]"
            ci = p.get("ci95")
            color = "tab:blue" if e.status == "fitted" else "tab:orange"
            if ci and not p["fixed"]:
                ax.errorbar(i, p["value"], yerr=[[p["value"] - ci[0]], [ci[1] - p["value"]]],
                            fmt="o", color=color, ms=4, capsize=3)
            else:
                ax.plot(i, p["value"], "o", ms=4, color=color,
                        mfc="none" if p["fixed"] else color)
        ax.set_ylabel(name + unit)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(names):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xticks(x, [e.name for e in entries], rotation=30, ha="right", fontsize=7)
    failed = [e.name for e in entries if e.report is None]
    title = (f"{len(entries)} campaigns: value and 95 % interval (orange: did not converge; "
             "no bar: not identifiable; hollow: fixed)")
    if failed:
        title += "\nnot fitted: " + ", ".join(failed)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return _finish(fig, path, dpi)
