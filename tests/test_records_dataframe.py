"""`Record.from_dataframe`: pandas columns chosen by label, units from the labels or the
keywords, extra columns as channels; pandas stays optional."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from stickslip_jax.records import Record, RecordError, format_record, parse_record
from stickslip_jax.units import KGF_N

CONDITIONS = dict(stiffness="852 N/um", mass="30.7 g", drive_speed="40 in/min")


def _arrays(n=400):
    t = np.arange(n) * 1e-3
    force = 5.0 + np.sin(40 * t)          # N
    temp = 21.0 + 0.01 * t                 # degC
    pitch = 3.0 * np.cos(40 * t)           # um
    return t, force, temp, pitch


def test_round_trip_against_from_arrays():
    pd = pytest.importorskip("pandas")
    t, force, temp, pitch = _arrays()
    df = pd.DataFrame({"time [ms]": t * 1e3, "Force (N)": force, "temp [degC]": temp,
                       "pitch 1 [um]": pitch})
    rec = Record.from_dataframe(df, force="force", lubricant="A", **CONDITIONS)
    ref = Record.from_arrays(t * 1e3, time_unit="ms", force=force, force_unit="N",
                             channels={"temp": temp, "pitch_1": pitch * 1e-3},
                             channel_units={"temp": "degC", "pitch_1": "um"}, lubricant="A",
                             **CONDITIONS)
    assert rec == ref
    assert rec.channel_units == {"temp": "degC", "pitch_1": "um"}
    assert rec.deflection[0] == pytest.approx(5.0 / KGF_N / (852e3 / KGF_N))  # x = F/k in mm
    # and through the record file: written and read back, the same record
    assert parse_record(format_record(rec)) == rec


def test_column_units_from_labels_or_keywords():
    pd = pytest.importorskip("pandas")
    t, force, _, _ = _arrays()
    by_label = Record.from_dataframe(pd.DataFrame({"Time (s)": t, "deflection [um]": force}),
                                     **CONDITIONS)
    by_keyword = Record.from_dataframe(pd.DataFrame({"time": t, "x": force}),
                                       deflection="x", time_unit="s", deflection_unit="um",
                                       **CONDITIONS)
    assert by_label == by_keyword
    np.testing.assert_allclose(by_label.deflection, force * 1e-3, rtol=1e-15)
    np.testing.assert_allclose(by_label.time, t, rtol=1e-15)
    # a keyword overrides the label's unit
    mm = Record.from_dataframe(pd.DataFrame({"time [s]": t, "deflection [um]": force}),
                               deflection_unit="mm", **CONDITIONS)
    np.testing.assert_allclose(mm.deflection, force, rtol=1e-15)


def test_a_column_without_unit_is_refused_not_guessed():
    pd = pytest.importorskip("pandas")
    t, force, _, _ = _arrays()
    df = pd.DataFrame({"time": t, "force [N]": force})
    with pytest.raises(RecordError, match=r"column 'time' has no unit in its label: give "
                       r"time_unit=\.\.\., or name it 'time \[unit\]'"):
        Record.from_dataframe(df, **CONDITIONS)


def test_extra_columns_all_list_and_units():
    pd = pytest.importorskip("pandas")
    t, force, temp, pitch = _arrays()
    df = pd.DataFrame({"time [s]": t, "force [N]": force, "temp [degC]": temp,
                       "status": ["ok"] * t.size, "counter": np.arange(t.size)})
    rec = Record.from_dataframe(df, **CONDITIONS)
    assert set(rec.channels) == {"temp", "counter"} and rec.channel_units["counter"] == "-"
    assert any("'status' left out" in n for n in rec.notes)
    assert any("'counter' has no unit" in n for n in rec.notes)
    only = Record.from_dataframe(df, extra_columns=["temp"], **CONDITIONS)
    assert set(only.channels) == {"temp"}
    none = Record.from_dataframe(df, extra_columns=[], **CONDITIONS)
    assert none.channels == {}
    given = Record.from_dataframe(df.assign(p=pitch), extra_columns={"p": "um"}, **CONDITIONS)
    np.testing.assert_allclose(given.channels["p"], pitch * 1e-3, rtol=1e-15)
    with pytest.raises(RecordError, match="extra column 'status' is not numeric"):
        Record.from_dataframe(df, extra_columns=["status"], **CONDITIONS)


def test_datetime_time_and_index():
    pd = pytest.importorskip("pandas")
    stamps = pd.date_range("2024-05-01 10:00", periods=200, freq="5ms")
    df = pd.DataFrame({"time": stamps, "deflection [mm]": np.linspace(0, 1, 200)})
    rec = Record.from_dataframe(df, stiffness=86.9, weight=36.0, drive_speed=0.1)
    np.testing.assert_allclose(rec.time, np.arange(200) * 5e-3, atol=1e-12)
    assert Record.from_dataframe(df.set_index("time"), stiffness=86.9, weight=36.0,
                                 drive_speed=0.1) == rec
    assert Record.from_dataframe(df.set_index("time"), time=None, stiffness=86.9,
                                 weight=36.0, drive_speed=0.1) == rec


def test_jittered_clock_resamples_the_channels_too():
    pd = pytest.importorskip("pandas")
    n = 500
    rng = np.random.default_rng(0)
    t = np.arange(n) * 1e-3 + rng.uniform(-2e-5, 2e-5, n)   # 4 % jitter
    df = pd.DataFrame({"time [s]": t, "deflection [mm]": 2 * t, "ramp [mm]": 3 * t})
    rec = Record.from_dataframe(df, stiffness=86.9, weight=36.0, drive_speed=0.1)
    assert any("jitter" in n for n in rec.notes)
    np.testing.assert_allclose(rec.deflection, 2 * rec.time, rtol=1e-9)
    np.testing.assert_allclose(rec.channels["ramp"], 3 * rec.time, rtol=1e-9)


def test_bad_selections_name_the_columns():
    pd = pytest.importorskip("pandas")
    t, force, _, _ = _arrays()
    df = pd.DataFrame({"time [s]": t, "force [N]": force, "deflection [mm]": force})
    with pytest.raises(RecordError, match="name the deflection= or the force= column"):
        Record.from_dataframe(df, **CONDITIONS)
    with pytest.raises(RecordError, match=r"force='load': no column named so \(columns: "
                       r"'time \[s\]', 'force \[N\]'"):
        Record.from_dataframe(df, force="load", **CONDITIONS)
    with pytest.raises(RecordError, match="exactly one of deflection= and force="):
        Record.from_dataframe(df, force="force", deflection="deflection", **CONDITIONS)
    with pytest.raises(RecordError, match="needs a pandas DataFrame"):
        Record.from_dataframe({"time [s]": t}, **CONDITIONS)
    with pytest.raises(RecordError, match="extra_columns="):
        Record.from_dataframe(df, force="force", channels={}, **CONDITIONS)
    text = df.assign(**{"force [N]": df["force [N]"].astype(str)})
    with pytest.raises(RecordError, match="column 'force \\[N\\]' \\(force\\) is not numeric"):
        Record.from_dataframe(text, force="force", **CONDITIONS)


def test_missing_pandas_names_the_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas now raises ImportError
    with pytest.raises(ImportError, match="Record.from_dataframe needs pandas: pip install "
                       "pandas"):
        Record.from_dataframe(object(), **CONDITIONS)
