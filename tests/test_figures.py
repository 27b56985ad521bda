"""The figures' readability, checked on their matplotlib objects: the corner plot shows the
truth inside its axes and prints no offset text, the discovery figure titles records
briefly and breaks its lines between fitted windows, the design map draws the stick-slip
boundary its title promises (dashed)."""

from __future__ import annotations

import re
import types

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

NAMES = ["mu_s", "mu_d", "gamma", "m", "delta", "n"]
TRUTH = dict(zip(NAMES, [0.56, 0.21, 0.38, 0.4, 67.0, 1.0]))
UNITS = {"mu_s": "-", "mu_d": "-", "gamma": "s^-m", "m": "-", "delta": "s^-n", "n": "-"}


def _draws(mean, sd, n=3000, seed=0):
    rng = np.random.default_rng(seed)
    return np.asarray(mean) + np.asarray(sd) * rng.standard_normal((n, len(mean)))


def _grid(fig, d):
    return np.asarray(fig.axes).reshape(d, d)


def test_corner_axes_contain_a_truth_the_draws_miss():
    """A posterior of delta at 77 +- 1 (truth 67) and n at 1.04 (truth 1.0): every axis
    of those parameters is widened to show the truth, with the line inside the frame."""
    import matplotlib.pyplot as plt

    from stickslip_fitting.report.plots import corner_plot  # the name kept beside the new module

    s = _draws([0.56, 0.21, 0.38, 0.4, 77.0, 1.04], [2e-3, 5e-5, 2e-3, 3e-4, 1.0, 3e-3])
    assert s[:, 4].min() > 67.0 and s[:, 5].min() > 1.0  # the truths lie outside the draws
    fig = corner_plot(s, NAMES, truth=TRUTH, units=UNITS)
    g = _grid(fig, 6)
    for j, name in enumerate(NAMES):
        t = TRUTH[name]
        for i in range(j, 6):  # column j: the x axis is parameter j
            lo, hi = g[i, j].get_xlim()
            assert lo < t < hi, (name, i, lo, hi)
        for k in range(j):  # row j below the diagonal: the y axis is parameter j
            lo, hi = g[j, k].get_ylim()
            assert lo < t < hi, (name, k, lo, hi)
    assert "67" not in g[4, 4].get_title()  # shown, so not named as off axis
    plt.close(fig)


def test_corner_names_a_truth_too_far_to_share_the_axis():
    import matplotlib.pyplot as plt

    from stickslip_fitting.report.posterior_plots import TRUTH_REACH, corner_plot

    s = _draws([1.0, 2.0], [0.01, 0.01])
    far = 1.0 + 10 * TRUTH_REACH * np.ptp(s[:, 0])
    fig = corner_plot(s, ["a", "b"], truth={"a": far, "b": 2.0})
    g = _grid(fig, 2)
    assert "off axis" in g[0, 0].get_title() and "off axis" not in g[1, 1].get_title()
    assert g[1, 0].get_xlim()[1] < far  # the axis keeps the draws readable
    plt.close(fig)


def test_corner_ticks_have_no_offset_text_and_tell_ticks_apart():
    """mu_d = 0.21 known to 5e-6: matplotlib's default would print "+2.1e-1" (and a
    scale) in a corner; the ticks carry their digits instead, each label distinct."""
    import matplotlib.pyplot as plt

    from stickslip_fitting.report.posterior_plots import corner_plot

    s = _draws([0.56, 0.21, 67.0], [1e-4, 5e-6, 0.05])
    fig = corner_plot(s, ["mu_s", "mu_d", "delta"], truth={"mu_d": 0.21},
                      units={"delta": "s^-n"})
    fig.canvas.draw()
    labelled = 0
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            assert axis.get_offset_text().get_text() == "", axis.get_offset_text().get_text()
            texts = [t.get_text() for t in axis.get_ticklabels() if t.get_text()]
            if texts:
                labelled += 1
                assert len(set(texts)) == len(texts), texts
                for text in texts:
                    float(text)  # a plain number each, no "1e-5+2.1e-1" pieces
    assert labelled >= 4
    g = _grid(fig, 3)
    # the median with the decimals of its interval (4.8e-6: 7), not "0.21" of ".3g"
    assert re.fullmatch(r"mu_d = 0\.\d{7}\n\+0\.00000\d\d / -0\.00000\d\d",
                        g[1, 1].get_title()), g[1, 1].get_title()
    plt.close(fig)


def test_plotting_modules_keep_the_backend():
    import pathlib

    root = pathlib.Path(__file__).resolve().parents[1]
    for rel in ("fitting/report/posterior_plots.py", "fitting/discovery/plots.py"):
        assert "matplotlib.use(" not in (root / rel).read_text(), rel


# --- the discovery figure -------------------------------------------------------------

LICENCE = ("measured by Colas et al. (ENS de Lyon), npusteln/stickslip data_raw/k168Nm_v42.mat "
           "from t = 93.9095 s; licence CeCILL-B; cite: J. Colas, N. Pustelnik, C. Oliver, "
           "P. Abry, J.-C. Geminard, V. Vidal, Nonlinear denoising for solid friction")


def _record(name, k, v, w=0.0307):
    return types.SimpleNamespace(name=name, stiffness=k, drive_speed=v, weight=w, note=LICENCE)


def test_record_title_is_short_and_never_the_note():
    from stickslip_fitting.discovery.plots import TITLE_CHARS, record_title

    title = record_title(_record("paper_k168Nm_v42um-s", 0.0171, 0.042))
    assert title.startswith("paper_k168Nm_v42um-s: k = 0.0171 kgf/mm, v = 2.52 mm/min")
    assert len(title) <= TITLE_CHARS and "licence" not in title
    long = record_title(_record("x" * 200, 1.0, 1.0))
    assert len(long) == TITLE_CHARS and long.endswith("...")


def test_broken_at_gaps_puts_nan_between_windows():
    from stickslip_fitting.discovery.plots import broken_at_gaps

    t = np.r_[np.arange(10) * 0.1, 5.0 + np.arange(10) * 0.1]
    tt, y = broken_at_gaps(t[::-1], t[::-1] * 2)  # sorted on the way
    assert np.isnan(tt).sum() == 1 and np.isnan(y).sum() == 1
    k = int(np.flatnonzero(np.isnan(tt))[0])
    assert tt[k - 1] == pytest.approx(0.9) and tt[k + 1] == pytest.approx(5.0)
    assert np.isnan(broken_at_gaps(np.arange(20) * 0.1)[0]).sum() == 0
    # labelled windows: a break between two windows, never inside one, whatever its
    # sampling (a cycle window's stick is binned: its samples lie far apart)
    t = np.r_[0.0, 0.5, 1.0, 1.001, 1.002, 1.003, 1.5, 2.0, 2.001, 2.002]
    window = np.r_[np.zeros(6), np.ones(4)]
    tt, y = broken_at_gaps(t[::-1], t[::-1], segment=window[::-1])
    assert np.isnan(tt).sum() == 1 and int(np.flatnonzero(np.isnan(tt))[0]) == 6
    assert np.array_equal(tt[~np.isnan(tt)], t) and np.array_equal(y[~np.isnan(y)], t)


class _CycleModel:
    """The surface of `cycle_model.CycleModel` the figure reads: `n_records` records, each
    in two windows of 50 samples (rows of 25) separated by a gap of 10 s."""

    def __init__(self, n_records=2):
        rows, self.per, self.n_records = [], 25, n_records
        for g in range(n_records):
            for start in (0.0, 0.5, 10.0, 10.5):
                rows.append((g, start + 0.02 * np.arange(self.per), int(start > 5.0)))
        self.data = types.SimpleNamespace(
            mask=np.ones((len(rows), self.per), bool),
            time=np.array([r[1] for r in rows]),
            deflection=np.array([0.1 + 0.01 * np.sin(r[1]) for r in rows]),
            record=np.array([r[0] for r in rows]), window=np.array([r[2] for r in rows]))
        self.sd = np.full((len(rows), self.per), 1e-3)

    def residuals(self, z, shape=None, sensor=None):
        rng = np.random.default_rng(int(z))
        return (rng.standard_normal(self.data.mask.sum()),)


def _cycle_result(n_records=2):
    model = _CycleModel(n_records)
    phases = {"stick": {"rms": 2e-3}, "slip": {"rms": 3e-3}}
    return types.SimpleNamespace(
        model=model, z_before=0, z_after=1, shape=None, sensor=None,
        phases_before=phases, phases_after=phases, effect="viscous_damping",
        effect_of="", confidence="low", noise=1e-3, gap_before=2e-3, gap_after=1.5e-3,
        learned=None, indistinguishable_from=[{"name": "stribeck"}],
        campaign=types.SimpleNamespace(
            records=[_record("paper_k1002Nm_v42um-s", 0.102, 0.042),
                     _record("paper_k168Nm_v42um-s", 0.0171, 0.042)]
            + [_record(f"r{g}", 86.9, 0.1) for g in range(2, n_records)],
            screening=[None, None, None]))


def test_cycle_discovery_figure_titles_records_and_breaks_lines_at_gaps():
    from stickslip_fitting.discovery.plots import TITLE_CHARS, plot_cycle_discovery

    fig = plot_cycle_discovery(_cycle_result())
    top, grid = fig.subfigs
    axes = np.asarray(grid.axes).reshape(-1, 2)  # per record: deflection, residual
    assert len(top.axes) == 2 and axes.shape[0] == 2
    for row, name in zip(axes, ("paper_k1002Nm", "paper_k168Nm")):
        title = row[0].get_title()
        assert title.startswith(name) and len(title) <= TITLE_CHARS and "licence" not in title
        for ax in row:
            assert "(um)" in ax.get_ylabel() or "(mm)" in ax.get_ylabel()
            assert ax.get_xlabel() in ("", "time (s)") and ax.get_legend() is None
            lines = [ln for ln in ax.get_lines() if ln.get_linestyle() not in ("None", "")]
            assert lines
            for ln in lines:  # one break per record: the 9.5 s gap between its windows
                x = np.asarray(ln.get_xdata(), float)
                assert np.isnan(x).sum() == 1, ln.get_label()
                k = int(np.flatnonzero(np.isnan(x))[0])
                assert x[k + 1] - x[k - 1] > 9.0
        assert row[1].get_xlabel() == "time (s)"
    (legend,) = grid.legends  # one legend above the records names every line
    assert [t.get_text() for t in legend.get_texts()] == [
        "record", "paper's model", "with viscous_damping", "+-1 noise sd"]
    summary = top.axes[1].texts[0].get_text()
    assert "viscous_damping or stribeck (low)" in summary and "3 given" in summary
    assert "traces of all 2 records used" in summary
    for ax in axes[:, 1]:  # the residuals over the noise band, +-1 um (noise 1e-3 mm)
        band = [p for p in ax.patches if p.get_label() == "+-1 noise sd"]
        assert len(band) == 1
        y = ax.transData.inverted().transform(band[0].get_verts())[:, 1]
        assert y.min() == pytest.approx(-1.0) and y.max() == pytest.approx(1.0)


def test_cycle_discovery_figure_shows_every_record_in_a_grid():
    from stickslip_fitting.discovery.plots import plot_cycle_discovery

    fig = plot_cycle_discovery(_cycle_result(12))
    grid = fig.subfigs[1]
    titles = [ax.get_title() for ax in grid.axes if ax.get_title()]
    assert len(titles) == 12
    assert titles[0].startswith("paper_k1002Nm") and titles[-1].startswith("r11")
    columns = {round(ax.get_position().x0, 3) for ax in grid.axes}
    assert len(columns) == 3  # three records a row beyond four records


def test_discovery_figure_legends_hide_no_sample():
    """Every legend of the figure (the records' legend above their grid, the phase bars',
    the staircase's, the learned correction's, the misfit's) against every panel's points."""
    from stickslip_fitting.discovery.plots import plot_cycle_discovery
    from test_plots_legends import _hidden_points

    rng = np.random.default_rng(3)
    clock = np.linspace(0.0, 1.6, 400)
    learned = types.SimpleNamespace(
        correction_at=lambda: (np.linspace(0, 2.5, 100), 1e-3 * np.sin(np.linspace(0, 6, 100))),
        gap_after=1.2e-3, closes=0.4)
    misfit = types.SimpleNamespace(
        phase="slip", shares={"stick": 0.1, "breakaway": 0.2, "slip": 0.7},
        forms=[{"name": "level", "share": 0.5}],
        profile={"clock": clock, "residual": 1e-3 * rng.standard_normal(400),
                 "fit": 1e-4 * clock, "clock_words": "the time since the breakaway"})
    steps = [{"effect": "viscous_damping", "gap_after": 1.5e-3, "kept": True},
             {"effect": "stribeck", "gap_after": 1.4e-3, "kept": False}]
    for extra in ({}, {"learned": learned, "misfit_left": misfit, "steps": steps}):
        fig = plot_cycle_discovery(types.SimpleNamespace(**{**vars(_cycle_result(5)), **extra}))
        legends = [*fig.subfigs[1].legends] + [a.get_legend() for a in fig.axes
                                               if a.get_legend() is not None]
        assert len(legends) == 2 + 3 * bool(extra)
        for ax in fig.axes:
            for legend in legends:
                assert _hidden_points(ax, legend) == 0, (ax.get_title(), ax.get_ylabel())


def test_discovery_figure_of_no_effect_names_no_effect():
    from stickslip_fitting.discovery.plots import plot_cycle_discovery

    fig = plot_cycle_discovery(types.SimpleNamespace(**{**vars(_cycle_result()),
                                                        "effect": "none"}))
    labels = {t for ax in fig.axes for t in ax.get_legend_handles_labels()[1]}
    assert "final model (no effect named)" in labels and "with none" not in labels


# --- the design map -------------------------------------------------------------------

def test_design_map_draws_the_boundary_its_title_promises_dashed(tmp_path, monkeypatch):
    import stickslip_fitting.commands.design as design
    from stickslip_jax.cli import main

    figures = []
    draw = design.plot
    monkeypatch.setattr(design, "plot", lambda *a, **k: figures.append(draw(*a, **k)))
    out = tmp_path / "map.png"
    assert main(["design", "--lubricant", "A", "--weight", "36", "--stiffness", "20:200:8",
                 "--speed", "0.5:200:8:log", "--plot", str(out), "--quiet"]) == 0
    assert out.exists() and len(figures) == 1
    fig = figures[0]
    assert "dashed: stick-slip boundary" in fig._suptitle.get_text()
    from matplotlib.collections import QuadMesh
    from matplotlib.contour import ContourSet

    maps = [ax for ax in fig.axes if ax.get_title()  # not the colour bars
            and any(isinstance(c, QuadMesh) for c in ax.collections)]
    assert len(maps) == 2  # amplitude and v_c
    for ax in maps:
        sets = [c for c in ax.collections if isinstance(c, ContourSet)]
        assert sets, ax.get_title()
        for cs in sets:
            styles = cs.get_linestyles()
            assert styles and all(dashes is not None for _, dashes in styles), styles
            assert any(len(p.vertices) > 1 for p in cs.get_paths())  # a boundary is drawn


def _smooth_result():
    """The surface of `SmoothDiscovery` that `plot_discovery` reads: three records, each
    with samples at 0-1 s and 6-7 s (a 5 s window gap) and padding."""
    from stickslip_fitting.discovery.residuals import PHASES

    R, N = 3, 120
    t = np.tile(np.r_[np.linspace(0, 1, 50), np.linspace(6, 7, 50), np.zeros(20)], (R, 1))
    mask = np.tile(np.r_[np.ones(100, bool), np.zeros(20, bool)], (R, 1))
    data = 0.1 + 0.01 * np.sin(t)
    traces = types.SimpleNamespace(time=t, deflection=data, mask=mask, n_records=R,
                                   stiffness=np.array([27.3, 86.9, 128.5]),
                                   speed=np.array([5.0, 10.0, 20.0]) / 60.0,
                                   weight=np.full(R, 36.0))

    def problem(offset):
        return types.SimpleNamespace(traces=traces,
                                     trajectories=lambda z: (data + offset,))

    phases = types.SimpleNamespace(phases={p: {"rms": 1e-3} for p in PHASES})
    return types.SimpleNamespace(
        base_problem=problem(1e-3), final_problem=problem(2e-4),
        base_fit=types.SimpleNamespace(z=None), final_fit=types.SimpleNamespace(z=None),
        residuals_before=phases, residuals_after=phases, noise=5e-4, effect="stribeck",
        confidence="high", candidates=[{"name": "stribeck", "score": 30.0},
                                       {"name": "rate_state", "score": 2.0}],
        campaign=types.SimpleNamespace(records=[types.SimpleNamespace(
            name=f"k{k:g}", stiffness=k, drive_speed=v, weight=36.0)
            for k, v in zip(traces.stiffness, traces.speed)]))


def test_smooth_discovery_figure_titles_records_and_breaks_lines_at_gaps():
    from stickslip_fitting.discovery.plots import plot_discovery

    fig = plot_discovery(_smooth_result())
    axes = np.asarray(fig.subfigs[1].axes).reshape(-1, 2)  # per record: deflection, residual
    assert axes.shape[0] == 3 and len(fig.subfigs[1].legends) == 1
    # titled by the record's name (file stem), the rows in the campaign's order
    assert axes[0, 0].get_title() == "k27.3: k = 27.3 kgf/mm, v = 5 mm/min, W = 36 kgf"
    assert axes[2, 0].get_title().startswith("k128.5: ")
    for row in axes:
        for ax in row:
            assert "(" in ax.get_ylabel()
            for ln in ax.get_lines():
                if ln.get_linestyle() in ("None", ""):
                    continue
                x = np.asarray(ln.get_xdata(), float)
                assert np.isnan(x).sum() == 1 and x[~np.isnan(x)].min() == 0.0
