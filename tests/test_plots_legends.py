"""Legends never hide data: in the fit figure's friction panels, in the record plot and in
the discovery figure (`test_figures`), no measured point lies under a legend box."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

import stickslip_jax as ss


def _hidden_points(ax, legend=None) -> int:
    """How many of the points drawn as markers on `ax` (its data, not the legend's handles)
    lie inside its legend's box (or `legend`'s, e.g. a figure's) on the laid-out figure."""
    fig = ax.get_figure(root=True)
    if fig.stale:  # laid out once (a bare Figure's canvas draws nothing: drawn here)
        fig.draw_without_rendering()
    box = (legend or ax.get_legend()).get_window_extent()
    hidden = 0
    for line in ax.get_lines():
        x, y = (np.asarray(v, float) for v in line.get_data())
        if x.size == 0:
            continue
        xy = ax.transData.transform(np.column_stack([x, y]))
        hidden += int(np.sum((xy[:, 0] > box.x0) & (xy[:, 0] < box.x1)
                             & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1)))
    return hidden


@pytest.fixture(scope="module")
def fitted():
    from stickslip_fitting.data.features import record_features
    from stickslip_fitting.data.synthetic import synthetic_campaign
    from stickslip_fitting.solve.fit import fit_features
    from stickslip_fitting.uncertainty.laplace import laplace

    recs = synthetic_campaign(ss.lubricant("A"), speed_fractions=(0.05, 0.3), cycles=4,
                              seed=11, pad_to=40_000)
    fit = fit_features([record_features(r) for r in recs])
    return fit, laplace(fit), recs


def test_fit_figure_legends_hide_no_point(fitted):
    import matplotlib.pyplot as plt
    from stickslip_fitting.report.plots import fit_figure

    fit, unc, recs = fitted
    fig = fit_figure(fit, unc, recs)
    try:
        named = {a.get_label(): a for a in fig.axes}
        for key in ("static friction", "kinetic friction"):
            ax = named[key]
            assert sum(len(ln.get_xdata()) for ln in ax.get_lines()) > 10  # points drawn
            assert _hidden_points(ax) == 0, key
            assert ax.get_legend().get_title().get_text()  # the panel's title heads it
    finally:
        plt.close(fig)


def test_record_plot_legend_hides_no_sample():
    import matplotlib.pyplot as plt
    from stickslip_jax.record_plots import plot_record
    from stickslip_jax.records import read_record

    root = pathlib.Path(__file__).resolve().parents[1]
    record = read_record(root / "data" / "examples" / "A_W36_k86.9_v5mm-min.csv")
    fig = plot_record(record)
    try:
        trace = next(a for a in fig.axes if a.get_legend() is not None
                     and "slips" in a.get_legend().get_title().get_text())
        assert _hidden_points(trace) == 0
    finally:
        plt.close(fig)


def test_a_legend_over_points_is_counted():
    """The check itself: a legend in the middle of a cloud of points hides some."""
    from matplotlib.figure import Figure

    ax = Figure().add_subplot()
    grid = np.linspace(0.0, 1.0, 30)
    ax.plot(*np.meshgrid(grid, grid), "k.", ms=2)
    ax.plot([], [], "k.", label="points")
    ax.legend(loc="center")
    assert _hidden_points(ax) > 0
