"""The fit figure's residual panel (`stickslip_fitting.report.plots.residual_panel`):
chi2/n by record and phase, the same numbers as `stickslip_fitting.uncertainty.adequacy`."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.figure import Figure
from stickslip_fitting.uncertainty.adequacy import BAD, GOOD, PhaseRow, adequacy
from stickslip_fitting.data.features import record_features
from stickslip_fitting.modes import Objective, Padding
from stickslip_fitting.solve.fit import fit_features
from stickslip_fitting.data.synthetic import synthetic_campaign

import stickslip_jax as ss


def _bars(ax) -> dict[tuple[str, str], float]:
    """{(record, phase): bar height} read back from the drawn panel."""
    names = [t.get_text() for t in ax.get_xticklabels()]
    out = {}
    for container in ax.containers:
        for name, bar in zip(names, container.patches, strict=True):
            out[(name, container.get_label())] = bar.get_height()
    return out


def _rows(report) -> dict[tuple[str, str], float]:
    return {(r.record, r.phase): r.chi2_per_n for r in report.rows}


@pytest.fixture(scope="module")
def campaign():
    recs = synthetic_campaign(ss.lubricant("A"), speed_fractions=(0.05, 0.3), cycles=4,
                              seed=11, pad_to=40_000)
    return recs, [record_features(r) for r in recs]


def test_panel_shows_adequacy_by_record_and_phase():
    # rows with a phase missing for one record: NaN there, the others exactly the rows
    from stickslip_fitting.uncertainty.adequacy import Adequacy
    from stickslip_fitting.report.plots import residual_panel

    rows = [PhaseRow("r1", "levels", 10, 1.2), PhaseRow("r1", "stick_times", 9, 0.8),
            PhaseRow("r1", "trace_slip", 400, 7.5), PhaseRow("r2", "levels", 10, 3.0),
            PhaseRow("r2", "stick_times", 9, 1.1)]
    report = Adequacy(1.5, rows, "misses", [])
    fig = Figure()
    ax = fig.add_subplot()
    assert residual_panel(report, ax=ax) is fig  # one panel: draws on the given axes
    bars = _bars(ax)
    assert [c.get_label() for c in ax.containers] == ["levels", "stick_times", "trace_slip"]
    assert {k: v for k, v in bars.items() if not np.isnan(v)} == _rows(report)
    assert np.isnan(bars[("r2", "trace_slip")])
    assert ax.get_yscale() == "log"
    assert sorted(line.get_ydata()[0] for line in ax.get_lines()) == [GOOD, BAD]


def test_fit_figure_has_the_residual_panel(campaign):
    from stickslip_fitting.report.plots import fit_figure
    from stickslip_fitting.uncertainty.laplace import laplace

    recs, feats = campaign
    fit = fit_features(feats)
    fig = fit_figure(fit, laplace(fit), recs)
    try:
        # a panel per record, mu_0 and its residual, mu_m, the parameters, the residuals
        assert len(fig.axes) == len(recs) + 5
        panel = fig.axes[-1]
        assert "residuals by record and phase" in panel.get_title()
        report = adequacy(fit)
        assert _bars(panel) == _rows(report)  # every record, exactly the adequacy numbers
        assert {p for _, p in _bars(panel)} == {"levels", "stick_times"}
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)


def test_trace_fit_panel_has_stick_and_slip_phases(campaign):
    from stickslip_fitting.report.plots import residual_panel

    recs, feats = campaign
    report = adequacy(fit_features(feats, objective=Objective.TRACE, records=recs,
                                   padding=Padding(cycles=8)))
    fig = residual_panel(report)
    try:
        bars = _bars(fig.axes[0])
        assert {p for _, p in bars} == {"trace_stick", "trace_slip"}  # what it fitted
        assert report.verdict != "misses"  # clean records, judged on the samples fitted
        assert bars == _rows(report)
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)


def test_fit_figure_draws_every_record_with_units_and_legends(campaign):
    """Every record has its panel over its own time with its measured trace; the friction
    panels' coloured points have a legend entry per spring; every axis has a unit; the
    parameter box gives units; the 95 % band is drawn above the points."""
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection
    from stickslip_fitting.report.plots import fit_figure
    from stickslip_fitting.uncertainty.laplace import laplace

    recs, feats = campaign
    fit = fit_features(feats)
    fig = fit_figure(fit, laplace(fit), recs)
    try:
        panels = [a for a in fig.axes if a.get_label().startswith("record ")]
        assert [a.get_label() for a in panels] == [f"record {f.name}" for f in feats]
        for a, r in zip(panels, recs):
            assert a.get_xlim() == (pytest.approx(r.time[0]), pytest.approx(r.time[-1]))
            measured = a.get_lines()[0]
            assert len(measured.get_xdata()) == len(r.time)
            assert a.get_xlabel() == "time t [s]"
        # the records' legend: one entry per spring and weight, the model's lines
        labels = [t.get_text() for t in fig.legends[0].get_texts()]
        springs = {(f.weight, f.stiffness) for f in feats}
        assert sum(t.startswith("k ") for t in labels) == len(springs)
        named = {a.get_label(): a for a in fig.axes}
        for key in ("static friction", "kinetic friction"):
            legend = [t.get_text() for t in named[key].get_legend().get_texts()]
            assert sum(t.startswith("k ") for t in legend) == len(springs), legend
        for a in fig.axes:
            if a.axison and a.get_xlabel():
                assert "[" in a.get_xlabel(), a.get_xlabel()
            if a.axison and a.get_ylabel():
                assert "[" in a.get_ylabel() or "chi2/n" in a.get_ylabel(), a.get_ylabel()
        box = named["parameters"].texts[0].get_text()
        assert "s^-m" in box and "s^-n" in box and "dimensionless" in box
        band = [c for c in named["static friction"].collections
                if isinstance(c, PolyCollection)]
        points = [ln for ln in named["static friction"].get_lines() if ln.get_marker() == "."]
        assert band and points and band[0].get_zorder() > max(ln.get_zorder() for ln in points)
        assert "95 % band" in band[0].get_label()
    finally:
        plt.close(fig)


def test_fit_figure_limits_and_not_used_records(campaign):
    import matplotlib.pyplot as plt
    from stickslip_fitting.report.plots import fit_figure
    from stickslip_fitting.uncertainty.laplace import laplace

    recs, feats = campaign
    fit = fit_features(feats)
    fig = fit_figure(fit, laplace(fit), recs, max_traces=2)
    try:
        assert len([a for a in fig.axes if a.get_label().startswith("record ")]) == 2
    finally:
        plt.close(fig)
    fig = fit_figure(fit, laplace(fit), recs, not_used=[(recs[0], "set aside: a test")])
    try:
        panels = [a for a in fig.axes if a.get_label().startswith("record ")]
        assert len(panels) == len(recs) + 1
        assert "not fitted" in panels[-1].get_title()
        assert "set aside: a test" in panels[-1].texts[0].get_text()
    finally:
        plt.close(fig)
