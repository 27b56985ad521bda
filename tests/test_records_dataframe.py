"""Records and pandas DataFrames: `Record.from_dataframe` (columns chosen by label, units
from the labels or the keywords, extra columns as channels) and `Record.to_dataframe`
(units in the column names, metadata in `attrs`, read back exactly); pandas stays
optional."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from stickslip_jax.records import (
    Record,
    RecordError,
    format_record,
    parse_record,
    read_record,
)
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


def _rich_record(drive="program"):
    """A record with every kind of field: channels of a known, an unknown and no unit,
    truth, extra header, notes and a source."""
    t = np.arange(300) * 2e-3
    conditions = {
        "program": dict(drive_program=((0.0, 0.02), (0.3, 0.0))),
        "speed": dict(drive_speed=0.05),
        "column": dict(drive=0.05 * t + 1e-4 * np.sin(30 * t), drive_speed=0.05),
    }[drive]
    return Record(time=t, deflection=0.1 + 0.01 * np.sin(40 * t), stiffness=86.9,
                  weight=36.0, lubricant="A", surface="S1G1", note="bench run",
                  channels={"pitch_1": 1e-3 * np.cos(40 * t), "temp": 21.0 + t,
                            "ratio": np.full_like(t, 0.5)},
                  channel_units={"pitch_1": "um", "temp": "degC", "ratio": "-"},
                  truth={"mu_s": 0.3}, source="runs/r1.csv",
                  extra_header={"operator": "kb"}, notes=("resampled",), **conditions)


@pytest.mark.parametrize("drive", ["program", "speed", "column"])
def test_to_dataframe_columns_and_attrs_and_back(drive):
    pytest.importorskip("pandas")
    rec = _rich_record(drive)
    df = rec.to_dataframe()
    assert list(df.columns) == ["time_s", "x_mm", "force_kgf", "drive_mm", "pitch_1_mm",
                                "temp_degC", "ratio_1"]
    np.testing.assert_array_equal(df["time_s"], rec.time)
    np.testing.assert_array_equal(df["x_mm"], rec.deflection)
    np.testing.assert_array_equal(df["force_kgf"], rec.force)
    np.testing.assert_array_equal(df["drive_mm"], rec.drive_position())
    np.testing.assert_array_equal(df["pitch_1_mm"], rec.channels["pitch_1"])  # internal mm
    assert df.attrs["stiffness_kgf_per_mm"] == 86.9 and df.attrs["weight_kgf"] == 36.0
    assert df.attrs["drive_source"] == drive
    assert df.attrs["drive_program"] == rec.drive_program
    assert df.attrs["drive_speed_mm_per_s"] == rec.drive_speed
    assert (df.attrs["lubricant"], df.attrs["surface"], df.attrs["note"]) == (
        "A", "S1G1", "bench run")
    assert df.attrs["truth"] == {"mu_s": 0.3} and df.attrs["source"] == "runs/r1.csv"
    assert df.attrs["channel_units"] == {"pitch_1": "um", "temp": "degC", "ratio": "-"}
    back = Record.from_dataframe(df)
    assert back == rec
    assert (back.source, back.notes, back.channel_units) == (
        rec.source, rec.notes, rec.channel_units)
    assert back.drive_source == drive
    # a field given by name replaces the frame's
    assert Record.from_dataframe(df, lubricant="B") == rec.replace(lubricant="B")


def test_to_dataframe_of_a_read_file_gives_the_file_back():
    pytest.importorskip("pandas")
    rec = read_record(sorted((Path(__file__).parents[1] / "data" / "examples").glob("*.csv"))[0])
    df = rec.to_dataframe()
    assert df.shape == (rec.n_samples, 4)
    back = Record.from_dataframe(df)
    assert back == rec and back.source == rec.source
    assert format_record(back) == format_record(rec)


def test_to_dataframe_frame_refuses_mixed_arguments_and_lost_attrs():
    pd = pytest.importorskip("pandas")
    df = _rich_record().to_dataframe()
    with pytest.raises(RecordError, match="carries its columns and conditions; leave out "
                       "time=, weight="):
        Record.from_dataframe(df, weight=36.0, time="time_s")
    bare = df.drop(columns=["temp_degC"])
    with pytest.raises(RecordError, match="lacks the column\\(s\\) 'temp_degC'"):
        Record.from_dataframe(bare)
    lost = df.copy()
    del lost.attrs["weight_kgf"]
    with pytest.raises(RecordError, match="attrs lack 'weight_kgf'"):
        Record.from_dataframe(lost)
    plain = pd.DataFrame({"time [s]": df["time_s"], "deflection [mm]": df["x_mm"]})
    with pytest.raises(TypeError, match="missing 1 required keyword-only argument: "
                       "'stiffness'"):
        Record.from_dataframe(plain, weight=36.0, drive_speed=0.05)
    # with its conditions given, a to_dataframe frame is read by label like any other
    got = Record.from_dataframe(df, time="time_s", deflection="x_mm", time_unit="s",
                                deflection_unit="mm", stiffness=86.9, weight=36.0,
                                drive_speed=0.02, extra_columns=[])
    np.testing.assert_array_equal(got.deflection, df["x_mm"])


def test_to_dataframe_refuses_a_channel_that_repeats_a_column():
    pytest.importorskip("pandas")
    t = np.arange(10) * 1e-3
    rec = Record(time=t, deflection=t, stiffness=1.0, weight=1.0, drive_speed=1.0,
                 channels={"x": t}, channel_units={"x": "um"})
    with pytest.raises(RecordError, match="channel 'x' would be the column 'x_mm'"):
        rec.to_dataframe()


def test_to_dataframe_without_pandas_names_the_extra(monkeypatch):
    rec = _rich_record()
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ImportError, match='Record.to_dataframe needs pandas: pip install '
                       '"stickslip-jax\\[pandas\\]"'):
        rec.to_dataframe()
