r"""Figures of a fit: traces with the fitted model, $\mu_0(T_1)$ and $\mu_m(T_2)$ with bands, corner plot.

With matplotlib; the corner plot with the `corner` package. Units on the axes: s, um,
mu dimensionless; the corner plot's from the law's `UNITS`. Every function returns its
`Figure` and never switches the user's backend; given a `path` it also saves the figure
(atomically) and closes it, without one it leaves it open for Jupyter to show.
"""

from __future__ import annotations

import numpy as np

from .posterior_plots import corner_plot  # noqa: F401 (this module's name for it)
from .saving import finish_figure, interruptible, pyplot  # noqa: F401 (also its names)

__all__ = ["batch_figure", "campaign_fit_figure", "corner_plot", "finish_figure", "fit_figure",
           "fitted_traces", "friction_curves", "interruptible", "residual_panel"]


def _static_curves(logs, template, grid):
    """mu_0 of eq (1) on `grid` (s) for every row of `logs` (log parameter values)."""
    import jax

    return jax.vmap(lambda d: template.from_log_values(d).friction().static(grid))(logs)


def friction_curves(fit, unc, n_draws: int = 200, seed: int = 0, extend: float = 3.0):
    r"""(T1 grid (s), fitted mu_0, 2.5 % and 97.5 % points) of eq (1): a 95 % band from
    `n_draws` draws of the Laplace covariance (in log parameters), evaluated in one
    compiled call. The grid spans the measured stick times widened by the factor
    `extend` either way."""
    import jax

    from ..solve.fit import compiled

    t1 = np.concatenate([f.stick_time[f.complete] for f in fit.features])
    extend = max(float(extend), 1.0)
    grid = np.geomspace(max(t1.min() / extend, 1e-3), t1.max() * extend, 100)
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
    deflection mm without the gauge offset) of the exact simulator restarted at the end
    of every slip, as `objectives.trace` compares it, NaN between the cycle windows. None
    where that is not possible (no complete cycle); the figure then shows levels only."""
    import jax

    from ..solve.fit import compiled
    from ..params import CampaignParams
    from ..objectives.trace import trace_data, trace_simulation

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
"""The phases of `stickslip_fitting.uncertainty.adequacy` in the order the residual panel shows them."""


def residual_panel(report, ax=None):
    """chi2/n of the residuals by record and phase of `report`, an
    `uncertainty.adequacy.Adequacy` (one panel; returns its `Figure`, drawn on `ax` when
    given). chi2/n is in the records' own errors, so 1 is "to the noise"; dashed lines at
    `GOOD` and `BAD`, log scale. Each phase is one `BarContainer` labelled with the phase,
    its bars in record order, NaN where a record has no residual in the phase.
    Example: `residual_panel(adequacy(fit))`.
    """
    from ..uncertainty.adequacy import BAD, GOOD

    if ax is None:
        fig, ax = pyplot().subplots(figsize=(8, 3.5))
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
    finite = [v for v in value.values() if np.isfinite(v) and v > 0]
    if not finite or max(finite + [BAD]) / min(finite + [GOOD]) < 1e3:  # else too crowded
        ax.yaxis.set_minor_formatter(FormatStrFormatter("%g"))
    ax.set_xticks(x, records, rotation=30, ha="right", fontsize=7)
    ax.set(ylabel="chi2/n (records' errors)",
           title=f"residuals by record and phase (1 = to the noise; dashed: {GOOD:g}, "
                 f"{BAD:g}); verdict: {report.verdict}")
    ax.legend(fontsize=7, ncols=len(phases) or 1)
    return fig


def _group_key(weight: float, stiffness: float) -> tuple[float, float]:
    return (round(float(weight), 9), round(float(stiffness), 9))


def _group_label(weight: float, stiffness: float, omega0: float | None = None) -> str:
    """"k 27.3 kgf/mm, W 36 kgf (T2 0.0173 s)": a spring and weight (one slip time)."""
    text = f"k {stiffness:.4g} kgf/mm, W {weight:.4g} kgf"
    return text if omega0 is None else text + f" (T2 {np.pi / omega0:.3g} s)"


def _record_grid(items):
    """(rows, columns, [(row, column) per item]) of the record panels: one row per spring
    and weight with its records by drive speed when some pair has several records and
    there are at most 6 pairs, else a grid 4 wide in the order given. `items`: (weight,
    stiffness, drive speed) per record."""
    groups: dict = {}
    for i, (w, k, v) in enumerate(items):
        groups.setdefault(_group_key(w, k), []).append(i)
    if 1 < max((len(g) for g in groups.values()), default=0) <= 6 and len(groups) <= 6:
        place = [None] * len(items)
        keys = sorted(groups, key=lambda g: g[1])
        for r, key in enumerate(keys):
            members = sorted(groups[key], key=lambda i: (items[i][2] or 0.0, i))
            for c, i in enumerate(members):
                place[i] = (r, c)
        return len(keys), max(len(g) for g in groups.values()), place
    cols = min(4, max(len(items), 1))
    return -(-len(items) // cols), cols, [divmod(i, cols) for i in range(len(items))]


def campaign_fit_figure(fit, unc, campaign, path=None):
    """`fit_figure` of a fit to a screened `data.campaign.Campaign`: its used records, then
    the records not used with the reason of their screening."""
    reasons = {s.name: s.reason for s in campaign.screening}
    not_used = [(r, reasons.get(f.name) or "not used") for r, f in campaign.not_used]
    return fit_figure(fit, unc, campaign.records, path, not_used=not_used)


def fit_figure(fit, unc, records, path=None, max_traces: int | None = None, *,
               not_used=()):
    """The diagnostic figure of a campaign fit (returned; saved to `path` when given).

    - Top, one small panel per record (each over its own time): the deflection the fit
      used (um, less the fitted gauge offset), the fitted simulation restarted at every
      slip (`fitted_traces`, dashed) and the fitted breakaway levels of eq (1) (triangles).
      Rows are springs and weights, columns drive speeds, when the campaign is such a
      grid. The records the fit did not use (`not_used`: (record, reason) pairs) get a
      grey panel that says why. `max_traces` limits the panels to the first records.
    - Middle: mu_0 against T1 with the fitted eq (1) and its 95 % band (`friction_curves`;
      over the measured stick times only when a parameter of eq (1) is not identifiable),
      under it mu_0 less the fitted curve; mu_m against T2 with the fitted eq (3); points
      coloured by spring and weight; the parameters (`_parameter_box`).
    - Bottom: chi2/n of the residuals by record and phase (`residual_panel`, every record).

    Record panels are the axes labelled "record NAME" (`Axes.get_label`), in the order of
    `records`, then the records not used."""
    from ..uncertainty.adequacy import adequacy

    plt = pyplot()
    n = len(records) if max_traces is None else min(int(max_traces), len(records))
    extra = list(not_used) if max_traces is None else []
    items = [(f.weight, f.stiffness, f.drive_speed) for f in fit.features[:n]]
    items += [(r.weight, r.stiffness, r.drive_speed) for r, _ in extra]
    rows, cols, place = _record_grid(items)
    keys = sorted(dict.fromkeys(_group_key(f.weight, f.stiffness) for f in fit.features),
                  key=lambda g: g[1])
    cmap = plt.get_cmap("tab10")
    colour = {k: cmap(i % 10) for i, k in enumerate(keys)}

    fig = plt.figure(figsize=(max(12.0, 3.1 * cols), 2.0 * rows + 8.4), layout="constrained")
    outer = fig.add_gridspec(3, 1, height_ratios=(2.0 * rows + 0.4, 4.4, 3.0))
    grid = outer[0].subgridspec(rows, cols)
    _record_panels(fig, [grid[rc] for rc in place], fit, records[:n], extra, colour)
    mid = outer[1].subgridspec(1, 3, width_ratios=(1.0, 1.0, 0.95))
    _static_panels(fig, mid[0], fit, unc, colour)
    _kinetic_panel(fig.add_subplot(mid[1], label="kinetic friction"), fit, colour)
    _parameter_box(fig.add_subplot(mid[2], label="parameters"), fit, unc)
    residual_panel(adequacy(fit), ax=fig.add_subplot(outer[2], label="residuals"))
    return finish_figure(fig, path, 110)


def _record_panels(fig, specs, fit, records, extra, colour) -> None:
    """One panel per record at `specs` (the fitted `records`, then the `extra` (record,
    reason) pairs not fitted), and the legend of them all above the figure."""
    import textwrap

    import jax.numpy as jnp
    from matplotlib.lines import Line2D

    n = len(records)
    offset = np.asarray(fit.params.offset)
    fr = fit.params.friction.friction()
    simulated = fitted_traces(fit, records) if n else None
    spiky = False
    for i in range(n):
        r, f = records[i], fit.features[i]
        ax = fig.add_subplot(specs[i], label=f"record {f.name}")
        x = r.deflection if f.deflection_used is None else f.deflection_used
        spiky |= bool(f.spikes)
        ax.plot(r.time, (np.asarray(x) - offset[i]) * 1e3, lw=0.5,
                color=colour[_group_key(f.weight, f.stiffness)])
        if simulated is not None:
            ax.plot(simulated[i][0], simulated[i][1] * 1e3, "k--", lw=0.7)
        mu0 = np.asarray(fr.static(jnp.asarray(np.where(f.complete, f.stick_time, 1.0))))
        x2 = np.where(f.complete, mu0 * f.weight / f.stiffness, np.nan)
        ax.plot(f.breakaway_time, x2 * 1e3, "k^", ms=3)
        speed = "" if f.drive_speed is None else f", v {60 * f.drive_speed:.3g} mm/min"
        ax.set_title(f"{f.name[:36]}\nk {f.stiffness:.4g} kgf/mm{speed}", fontsize=7)
    for j, (r, reason) in enumerate(extra):
        name = r.name or f"record {n + j + 1}"
        ax = fig.add_subplot(specs[n + j], label=f"record {name}")
        ax.plot(r.time, r.deflection * 1e3, lw=0.5, color="0.6")
        ax.set_title(f"{name[:36]}\nnot fitted", fontsize=7, color="0.35")
        low, high = ax.get_ylim()  # the reason in the top 40 %, above the trace
        ax.set_ylim(low, high + 0.7 * (high - low))
        ax.text(0.02, 0.97, "\n".join(textwrap.wrap(str(reason), 48)[:4]), transform=ax.transAxes,
                va="top", fontsize=5.5, color="0.25", bbox=dict(fc="white", ec="0.7", alpha=0.85))
    panels = [a for a in fig.axes if a.get_label().startswith("record ")]
    for a, r in zip(panels, list(records) + [r for r, _ in extra]):
        a.set_xlim(float(r.time[0]), float(r.time[-1]))  # each record over its own time
        a.tick_params(labelsize=6)
        a.set_xlabel("time t [s]", fontsize=6, labelpad=1)
        if a.get_subplotspec().is_first_col():
            a.set_ylabel("x - offset [um]", fontsize=7)
    omega = {_group_key(f.weight, f.stiffness): f.omega0 for f in fit.features}
    handles = [Line2D([], [], color=colour[k], lw=1.5, label=_group_label(*k, omega[k]))
               for k in colour]
    handles += [Line2D([], [], color="k", ls="--", lw=0.8,
                       label="fitted simulation, restarted every cycle"),
                Line2D([], [], color="k", marker="^", ls="none", ms=4,
                       label="fitted breakaway level (eq 1)")]
    if extra:
        handles.append(Line2D([], [], color="0.6", lw=1.5, label="not fitted"))
    if panels:
        fig.legend(handles=handles, loc="outside upper center", ncols=min(len(handles), 4),
                   fontsize=7, title_fontsize=8,
                   title=("deflection x of every record, less its fitted gauge offset"
                          + (" (impulsive spikes replaced as in the fit)" if spiky else "")))


def _static_panels(fig, spec, fit, unc, colour) -> None:
    """mu_0 against T1 with the fitted eq (1) and its 95 % band at `spec`, and under it
    mu_0 less the fitted curve with the band (a narrow band stays visible there)."""
    import jax.numpy as jnp

    left = spec.subgridspec(2, 1, height_ratios=(2.4, 1.0), hspace=0.0)
    ax = fig.add_subplot(left[0], label="static friction")
    ax_res = fig.add_subplot(left[1], sharex=ax, label="static friction residual")
    named = {e.name: e for e in unc.estimates()}
    eq1 = [nm for nm in dict.fromkeys(("mu_s", "mu_d", *fit.params.friction.SHAPE_NAMES))
           if nm in named]
    unknown = [nm for nm in eq1 if not named[nm].determined]
    grid_t, best, lo, hi = friction_curves(fit, unc, extend=1.0 if unknown else 3.0)
    half = float(np.nanmax((hi - lo) / 2 / np.abs(best))) if best.size else float("nan")
    band = (f"95 % band (half-width up to {100 * half:.2g} %)" if not unknown else
            f"95 % band over the measured T1\n({', '.join(unknown)} not identifiable)")
    ax.plot(grid_t, best, "k-", lw=1.0, label="fitted eq (1)", zorder=3)
    ax.fill_between(grid_t, lo, hi, color="tab:red", alpha=0.35, lw=0, zorder=4, label=band)
    ax_res.axhline(0.0, color="k", lw=0.8, zorder=3)
    ax_res.fill_between(grid_t, lo - best, hi - best, color="tab:red", alpha=0.35, lw=0,
                        zorder=4)
    for edge in (lo, hi):  # on top: a narrow band still shows as a red line
        ax.plot(grid_t, edge, color="tab:red", lw=0.6, zorder=4)
        ax_res.plot(grid_t, edge - best, color="tab:red", lw=0.8, zorder=5)
    offset = np.asarray(fit.params.offset)
    fr = fit.params.friction.friction()
    for i, f in enumerate(fit.features):
        c = f.complete
        key = _group_key(f.weight, f.stiffness)
        measured = f.stiffness * (f.peak[c] - offset[i]) / f.weight
        ax.plot(f.stick_time[c], measured, ".", ms=4, color=colour[key], zorder=2)
        fitted = np.asarray(fr.static(jnp.asarray(f.stick_time[c])))
        ax_res.plot(f.stick_time[c], measured - fitted, ".", ms=3, color=colour[key], zorder=2)
    for k in colour:
        ax.plot([], [], ".", color=colour[k], label=_group_label(*k))
    ax.set(xscale="log", ylabel="static friction mu_0 [-]")
    ax.tick_params(labelbottom=False)
    ax_res.set(xlabel="stick time T1 [s]", ylabel="mu_0 - fit [-]")
    above_axes(ax, "static friction at breakaway (eq 1)")


def _kinetic_panel(ax, fit, colour) -> None:
    """mu_m per cycle (eq 5) against T2 with the fitted eq (3), coloured by spring."""
    import jax.numpy as jnp

    offset = np.asarray(fit.params.offset)
    fr = fit.params.friction.friction()
    mu0_all, t2_all = [], []
    for i, f in enumerate(fit.features):
        c = f.complete
        mum = f.stiffness * (0.5 * (f.peak[c] + f.trough[c]) - offset[i]) / f.weight
        t2 = np.full(mum.shape, np.pi / f.omega0)
        ax.plot(t2, mum, ".", ms=4, color=colour[_group_key(f.weight, f.stiffness)])
        mu0 = np.asarray(fr.static(jnp.asarray(f.stick_time[c])))
        pred = np.asarray(fr.kinetic(jnp.asarray(mu0), fr.mu_d, jnp.asarray(t2)))
        ax.plot(t2, pred, "ko", ms=7, mfc="none", mew=0.7)
        mu0_all.append(mu0)
        t2_all.append(t2)
    mu0_all, t2_all = np.concatenate(mu0_all), np.concatenate(t2_all)
    if mu0_all.size:
        t2_grid = np.geomspace(0.7 * t2_all.min(), 1.4 * t2_all.max(), 100)
        levels = [(mu0_all.max(), "k-")]
        if not np.isclose(mu0_all.min(), mu0_all.max(), rtol=1e-3):
            levels.append((mu0_all.min(), "k:"))
        for mu0, style in levels:
            curve = fr.kinetic(jnp.full_like(t2_grid, mu0), fr.mu_d, jnp.asarray(t2_grid))
            ax.plot(t2_grid, np.asarray(curve), style, lw=0.8,
                    label=f"fitted eq (3) at mu_0 = {mu0:.3g}")
    for k in colour:
        ax.plot([], [], ".", color=colour[k], label=_group_label(*k))
    ax.plot([], [], "ko", mfc="none", mew=0.7, label="fitted eq (3) at each cycle's mu_0")
    ax.set(xlabel="slip time T2 = pi/omega0 [s]", ylabel="mean kinetic friction mu_m [-]")
    above_axes(ax, "mean kinetic friction during slip (eq 3; points: eq 5 per cycle)")


def above_axes(ax, title: str) -> None:
    """The legend of `ax` above its axes, under `title` (in place of the axes' title), so
    that it never hides a point."""
    ax.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), ncols=2, fontsize=6,
              title=title, title_fontsize=10, frameon=False, borderaxespad=0.2)


def _parameter_box(ax, fit, unc) -> None:
    """The fitted parameters as text: value ± standard error and unit; "-" and the reason
    for one the records do not determine; fixed or at a bound said beside the value."""
    import textwrap

    from .rows import note_text, value_text

    ax.axis("off")
    bounds = fit.params.friction.PRIOR_BOUNDS
    units = fit.params.friction.UNITS
    lines = ["fitted parameters (value ± std err, unit)"]
    for e in unc.estimates():
        j = e.with_bounds(bounds).to_json()
        unit = "" if e.unit in ("-", "") else f" {e.unit}"
        if j["value"] is None:
            lines.append(f"{e.name:>6} = -")
            lines += ["         " + t for t in textwrap.wrap(note_text(j), 40)]
            continue
        se = (f" ± {j['stderr']:.2g}" if j["stderr"] is not None and not j["at_bound"]
              else "")
        note = note_text(j)
        lines.append(f"{e.name:>6} = {value_text(j, '.4g')}{se}{unit}"
                     + (f" ({note})" if note else ""))
    plain = [n for n, u in units.items() if u in ("-", "")]
    lines += ["", "dimensionless: " + ", ".join(plain)] if plain else [""]
    lines += [f"chi2/dof = {fit.reduced_chi2:.3g}, {len(fit.features)} records used"]
    ax.text(0.0, 1.0, "\n".join(lines), va="top", family="monospace", fontsize=8,
            transform=ax.transAxes)


def batch_figure(batch, path=None, dpi: int = 120):
    """The parameters of a `solve.batch.BatchResult` side by side (`stickslip fit-batch
    --plot`): one panel per parameter, a point per campaign with its 95 % interval (hollow
    where fixed, a square at a bound of its support); campaigns not fitted are named in
    the title; a grey cross at the foot marks a parameter a campaign does not determine.
    A panel whose values span more than two decades has a log axis."""
    from matplotlib.lines import Line2D

    entries = list(batch.entries)
    names = list(dict.fromkeys(p for e in entries if e.report
                               for p in e.report["parameters"]))
    ncol = min(3, max(len(names), 1))
    nrow = max(1, -(-len(names) // ncol))
    fig, axes = pyplot().subplots(nrow, ncol, figsize=(4.2 * ncol, 1.2 + 2.6 * nrow),
                                squeeze=False, sharex=True, layout="constrained")
    x = np.arange(len(entries))
    seen = set()  # the kinds of point drawn (for the legend)
    for ax, name in zip(axes.flat, names):
        unit, shown = "", []
        for i, e in enumerate(entries):
            p = (e.report or {}).get("parameters", {}).get(name)
            if p is None:
                continue
            unit = f" [{p['unit'] or '-'}]"  # [-]: dimensionless
            if p["value"] is None:  # not identifiable: no value to draw
                seen.add("unknown")
                ax.plot(i, 0.04, "x", color="0.45", ms=6, mew=1.2,
                        transform=ax.get_xaxis_transform(), clip_on=False)
                continue
            ci = p.get("ci95")
            color = "tab:blue" if e.status == "fitted" else "tab:orange"
            marker = "s" if p.get("at_bound") else "o"
            seen |= {e.status, "fixed" if p["fixed"] else "", "bound" if p.get("at_bound")
                     else ""}
            shown.append(p["value"])
            if ci and not p["fixed"] and not p.get("at_bound"):
                ax.errorbar(i, p["value"], yerr=[[p["value"] - ci[0]], [ci[1] - p["value"]]],
                            fmt=marker, color=color, ms=4, capsize=3)
                shown += [ci[0], ci[1]]
            else:
                ax.plot(i, p["value"], marker, ms=4, color=color,
                        mfc="none" if p["fixed"] else color)
        shown = np.asarray([v for v in shown if v is not None and np.isfinite(v)])
        if shown.size and shown.min() > 0 and shown.max() / shown.min() > 100:
            ax.set_yscale("log")
        else:
            ax.ticklabel_format(axis="y", useOffset=False)  # the values as they are
        ax.set_ylabel(name + unit)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(names):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xticks(x, [e.name for e in entries], rotation=30, ha="right", fontsize=7)
        ax.set_xlim(-0.5, len(entries) - 0.5)
    kinds = {"fitted": dict(color="tab:blue", marker="o", label="value, 95 % interval"),
             "not_converged": dict(color="tab:orange", marker="o", label="did not converge"),
             "fixed": dict(color="tab:blue", marker="o", mfc="none", ls="none",
                           label="fixed"),
             "bound": dict(color="tab:blue", marker="s", ls="none",
                           label="at a bound of its support"),
             "unknown": dict(color="0.45", marker="x", ls="none", mew=1.2,
                             label="not identifiable (no value)")}
    handles = [Line2D([], [], **style) for kind, style in kinds.items() if kind in seen]
    if handles:
        fig.legend(handles=handles, loc="outside lower center", ncols=len(handles),
                   fontsize=7)
    failed = [e.name for e in entries if e.report is None]
    title = f"{len(entries)} campaigns: fitted parameters"
    if failed:
        title += "; not fitted: " + ", ".join(failed)
    fig.suptitle(title, fontsize=9)
    return finish_figure(fig, path, dpi)
