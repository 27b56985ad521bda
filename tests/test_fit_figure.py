"""The fit figure's residual panel (`stickslip_fitting.plots.residual_panel`):
chi2/n by record and phase, the same numbers as `stickslip_fitting.adequacy`."""

from __future__ import annotations

from matplotlib.figure import Figure
import numpy as np
import pytest

import stickslip_jax as ss
from stickslip_fitting.adequacy import BAD, GOOD, PhaseRow, adequacy
from stickslip_fitting.features import record_features
from stickslip_fitting.fit import fit_features
from stickslip_fitting.synthetic import synthetic_campaign


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
    from stickslip_fitting.adequacy import Adequacy
    from stickslip_fitting.plots import residual_panel

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
    from stickslip_fitting.plots import fit_figure
    from stickslip_fitting.uncertainty import laplace

    recs, feats = campaign
    fit = fit_features(feats)
    fig = fit_figure(fit, laplace(fit), recs)
    try:
        assert len(fig.axes) == 5
        panel = fig.axes[-1]
        assert "residuals by record and phase" in panel.get_title()
        report = adequacy(fit)
        assert _bars(panel) == _rows(report)  # every record, exactly the adequacy numbers
        assert {p for _, p in _bars(panel)} == {"levels", "stick_times"}
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)


def test_trace_fit_panel_has_stick_and_slip_phases(campaign):
    from stickslip_fitting.plots import residual_panel

    recs, feats = campaign
    report = adequacy(fit_features(feats, objective="trace", records=recs, pad_cycles=8))
    fig = residual_panel(report)
    try:
        bars = _bars(fig.axes[0])
        assert {p for _, p in bars} == {"levels", "stick_times", "trace_stick", "trace_slip"}
        assert bars == _rows(report)
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)
