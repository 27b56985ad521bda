"""Unknowns look unknown: a parameter the records do not determine has no value in the
`stickslip fit` table ("-" with the reason), in its JSON (`"value": null`, a "reason"),
in the `fit-batch` table, CSV and figure; a value at a bound of its support says so; text
tables pad every column to its widest cell, so no two columns fuse."""

from __future__ import annotations

import csv
import io
import re

import numpy as np
import pytest
from stickslip_fitting.solve.batch import FAILED, FITTED, BatchEntry, BatchResult
from stickslip_fitting.report.rows import ParameterEstimate, note_text, text_table, value_text

NUMBER = re.compile(r"[-+]?\d+(\.\d*)?([eE][-+]?\d+)?")


def cells(line: str) -> list[str]:
    """A table row split back into its cells (columns are two spaces or more apart)."""
    return re.split(r"\s{2,}", line.strip())


# -- the typed row ---------------------------------------------------------------------

def test_unidentifiable_row_has_null_value_and_reason():
    e = ParameterEstimate("n", "-", 2.39e116, None, None, identifiable=False,
                          reason="the fit left the physical range 0.02-5")
    j = e.with_truth({"n": 1.0}).to_json()
    assert j["value"] is None and j["identifiable"] is False and j["stderr"] is None
    assert j["reason"] == "not identifiable: the fit left the physical range 0.02-5"
    assert j["truth"] == 1.0 and j["relative_error"] is None and "truth_in_ci95" not in j
    assert e.value == 2.39e116  # the optimiser's point stays on the row, never in the JSON
    assert value_text(j) == "-"
    assert note_text(j) == "not identifiable: the fit left the physical range 0.02-5"
    # no reason given: still one
    bare = ParameterEstimate("m", "-", 0.0, None, None, identifiable=False).to_json()
    assert bare["value"] is None and bare["reason"].startswith("not identifiable")
    # every key is always there: determined rows have a null reason
    ok = ParameterEstimate.from_normal("mu_d", "-", 0.3, 0.01).to_json()
    assert list(ok) == ["value", "stderr", "ci95", "unit", "identifiable", "fixed", "reason",
                        "at_bound"]
    assert ok["reason"] is None and ok["at_bound"] is False and value_text(ok) == "0.3"
    fixed = ParameterEstimate("n", "-", 1.0, None, None, fixed=True).to_json()
    assert fixed["value"] == 1.0 and note_text(fixed) == "fixed"


def test_value_at_a_bound_of_its_support():
    bounds = {"delta": (1e-3, 1e5)}
    at = ParameterEstimate.from_normal("delta", "s^-n", 1e5, 3.0).with_bounds(bounds)
    assert at.at_bound == "upper"
    j = at.to_json()
    assert j["at_bound"] is True and j["value"] == 1e5
    assert j["reason"] == "at the upper bound 100000 of its support"
    assert note_text(j) == "at upper bound 100000"
    low = ParameterEstimate.from_normal("delta", "s^-n", 1e-3 * (1 + 1e-9)).with_bounds(bounds)
    assert low.at_bound == "lower"
    inside = ParameterEstimate.from_normal("delta", "s^-n", 67.0, 0.05).with_bounds(bounds)
    assert inside.at_bound is None and inside.to_json()["at_bound"] is False
    # no bounds known, or a name without bounds: never at a bound
    assert ParameterEstimate.from_normal("delta", "s^-n", 1e5).at_bound is None
    assert ParameterEstimate.from_normal("c", "-", 0.1).with_bounds(bounds).at_bound is None
    # a bound at zero (a coefficient's support [0, 0.1])
    c = ParameterEstimate.from_normal("c", "-", 0.1, 0.0).with_bounds({"c": (0.0, 0.1)})
    assert c.at_bound == "upper"


# -- tables ----------------------------------------------------------------------------

def test_text_table_pads_every_column_to_its_widest_cell():
    header = ["campaign", "delta [s^-n]", "n"]
    rows = [["examples", "67.043", "1.0001"], ["real", "2.0098e+12", "2.3878e+116"],
            ["x  y", "-", "-"]]
    text = text_table(header, rows, "lrr")
    lines = text.splitlines()
    assert set(lines[1]) == {"-"}
    assert [cells(line) for line in lines[2:]] == [rows[0], rows[1], ["x y", "-", "-"]]
    assert cells(lines[0]) == header
    # right-aligned columns end at the same place in every line
    ends = {line.index(r[1]) + len(r[1]) for line, r in zip(lines[2:], rows)}
    assert len(ends) == 1
    with pytest.raises(ValueError, match="3 cells"):
        text_table(header, [["a", "b"]])


def _batch_report(values: dict, reasons: dict | None = None) -> dict:
    """A fit report's parameters (JSON entries) for a batch table."""
    reasons = reasons or {}
    params = {}
    for name, v in values.items():
        e = ParameterEstimate("x", "s^-n" if name == "delta" else "-", v,
                              None if name in reasons else 0.1 * v,
                              None if name in reasons else (0.8 * v, 1.2 * v),
                              identifiable=name not in reasons, reason=reasons.get(name))
        params[name] = e.to_json()
    return {"parameters": params, "records": [{"status": "used"}] * 2, "reduced_chi2": 1.07,
            "converged": True}


def _batch() -> BatchResult:
    good = _batch_report({"mu_d": 0.21, "delta": 2.0098e12, "n": 1.0001})
    bad = _batch_report({"mu_d": 0.3195, "delta": 2.0098e12, "n": 2.3878e116},
                        {"delta": "the fit left the physical range 0.001-100000",
                         "n": "the fit left the physical range 0.02-5"})
    entries = (BatchEntry(0, "examples", "data/examples", FITTED, good, None, 12.1, 0),
               BatchEntry(1, "real", "data/real", FITTED, bad, None, 21.4, 0),
               BatchEntry(2, "nowhere", "nowhere", FAILED, None, "no such folder", 0.0, 0))
    return BatchResult(entries=entries, processes=1, seconds=33.5)


def test_batch_table_columns_never_fuse_and_unknowns_show_dashes():
    from stickslip_fitting.report.fit_table import batch_table

    text = batch_table(_batch())
    lines = text.splitlines()
    header = cells(lines[0])
    assert header == ["campaign", "status", "records", "mu_d", "delta [s^-n]", "n",
                      "chi2/dof", "s"]
    rows = [cells(line) for line in lines[2:5]]
    assert all(len(r) == len(header) for r in rows), rows
    assert rows[0][4] == "2.0098e+12" and rows[0][5] == "1.0001"  # determined: the values
    assert rows[1][4] == "-" and rows[1][5] == "-"                # not identifiable
    assert rows[2][:2] == ["nowhere", "failed"] and set(rows[2][2:-1]) == {"-"}
    assert "e+116" not in text and "2.0098e+12" not in lines[3]
    assert "real: n not identifiable (-): the fit left the physical range 0.02-5" in text
    assert "nowhere: failed: no such folder" in text
    # every number-like token of a row is one cell: nothing glued to a neighbour
    for r in rows:
        for c in r[3:]:
            assert c == "-" or NUMBER.fullmatch(c), c


def test_batch_csv_has_no_placeholder_and_gives_the_reason():
    from stickslip_fitting.report.fit_table import batch_csv

    rows = list(csv.DictReader(io.StringIO(batch_csv(_batch()))))
    n = next(r for r in rows if r["campaign"] == "real" and r["parameter"] == "n")
    assert n["value"] == "" and n["message"].startswith("not identifiable: the fit left")
    good = next(r for r in rows if r["campaign"] == "examples" and r["parameter"] == "n")
    assert float(good["value"]) == 1.0001 and good["message"] == ""


def test_batch_figure_draws_no_unknown_and_uses_log_axes_across_decades():
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from stickslip_fitting.report.plots import batch_figure

    fig = batch_figure(_batch())
    try:
        axes = {a.get_ylabel(): a for a in fig.axes if a.get_visible()}
        assert set(axes) == {"mu_d [-]", "delta [s^-n]", "n [-]"}  # [-]: dimensionless
        for label, ax in axes.items():
            drawn = [y for line in ax.get_lines() if line.get_marker() == "o"
                     for y in np.atleast_1d(line.get_ydata())]
            assert all(y < 1e100 for y in drawn), label  # no placeholder drawn
        # n: 1.0001 drawn, the unknown marked by a cross at the foot, not a value
        crosses = [ln for ln in axes["n [-]"].get_lines() if ln.get_marker() == "x"]
        assert len(crosses) == 1
        assert axes["mu_d [-]"].get_yscale() == "linear"
        # delta: one value 2e12 with a +-20 % interval: linear; values spanning decades: log
        wide = _batch_report({"mu_d": 0.2, "delta": 67.0, "n": 1.0})
        batch = _batch()
        entries = (batch.entries[0], dataclass_replace(batch.entries[1], report=wide))
        fig2 = batch_figure(BatchResult(entries=entries, processes=1, seconds=1.0))
        try:
            ax = next(a for a in fig2.axes if a.get_ylabel() == "delta [s^-n]")
            assert ax.get_yscale() == "log"
        finally:
            plt.close(fig2)
        legend = fig.legends[0]
        assert "not identifiable (no value)" in [t.get_text() for t in legend.get_texts()]
        assert all(isinstance(h, Line2D) for h in legend.legend_handles)
    finally:
        plt.close(fig)


def dataclass_replace(obj, **changes):
    import dataclasses

    return dataclasses.replace(obj, **changes)


# -- the shipped measured records, end to end -----------------------------------------

def test_real_records_print_dashes_for_what_they_do_not_determine(real_records_fit):
    text, report, _, _ = real_records_fit
    params = report["parameters"]
    unknown = [n for n, p in params.items() if not p["identifiable"] and not p["fixed"]]
    assert len(unknown) >= 3  # two records at one speed: eq (1)'s rise and eq (3)'s decay
    lines = text.splitlines()
    header = cells(lines[0])
    assert header[:5] == ["parameter", "value", "unit", "std err", "95 % interval"]
    rows = {cells(line)[0]: cells(line) for line in lines[2:2 + len(params)]}
    assert set(rows) == set(params)
    for name in unknown:
        assert rows[name][1] == "-", rows[name]
        assert rows[name][-1].startswith("not identifiable: "), rows[name]
        assert len(rows[name]) == len(header)
        p = params[name]
        assert p["value"] is None and p["reason"].startswith("not identifiable: ")
    assert params["mu_d"]["identifiable"] and params["mu_d"]["value"] is not None
    assert rows["mu_d"][1] == f"{params['mu_d']['value']:.5g}"
    # no placeholder anywhere in what the command prints (table, warnings, notes)
    for token in NUMBER.finditer(text):
        value = float(token.group())
        assert abs(value) < 1e9, (token.group(), text)


def test_real_records_figure_shows_every_record(real_records_fit):
    """One panel per record (the two fitted and the one set aside, said so), each over
    its own time; the parameter box gives "-" for what the records do not determine."""
    text, report, png, fig = real_records_fit
    assert png.stat().st_size > 20_000
    panels = [a for a in fig.axes if a.get_label().startswith("record ")]
    assert len(panels) == len(report["records"]) == 3
    names = {r["name"] for r in report["records"]}
    assert {a.get_label().removeprefix("record ") for a in panels} == names
    lengths = sorted(round(a.get_xlim()[1] - a.get_xlim()[0]) for a in panels)
    assert lengths == [10, 30, 60]  # each record's own duration (s)
    set_aside = [a for a in panels if "not fitted" in a.get_title()]
    assert len(set_aside) == 1 and "paper_k2254Nm" in set_aside[0].get_label()
    box = next(a for a in fig.axes if a.get_label() == "parameters").texts[0].get_text()
    for name, p in report["parameters"].items():
        if p["value"] is None:
            assert re.search(rf"{name} = -\n", box), box
    assert "e+116" not in box and "e+12" not in box
