"""Tests of stickslip_jax.records: the record CSV format, its errors and round trips."""

from __future__ import annotations

import json

import numpy as np
import pytest

from stickslip_jax.records import (
    MAX_FILE_BYTES,
    Record,
    RecordError,
    check_campaign,
    format_drive_program,
    format_record,
    parse_drive_program,
    parse_record,
    read_campaign,
    read_record,
    write_record,
)
from stickslip_jax.units import G_MM_S2, KGF_N

EXAMPLE = """\
# stickslip-record: 1
# drive_speed: 1.0 mm/min
# stiffness: 86.9 kgf/mm
# slider_weight: 36.0 kgf
# lubricant: A
# surface: S1G1
time [s],deflection [mm]
0.000,0.1203
0.001,0.1204
0.002,0.1206
0.003,0.1207
"""


def write(tmp_path, text, name="run.csv"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def make_record(n=50, **kw):
    t = 0.25 + 0.001 * np.arange(n)
    x = 0.05 * np.sin(7.0 * t) + 0.1
    base = dict(time=t, deflection=x, stiffness=86.9, weight=36.0, drive_speed=1.0 / 60)
    base.update(kw)
    return Record(**base)


# ---------------------------------------------------------------- reading good files


def test_the_documented_example_record_is_read(tmp_path):
    r = read_record(write(tmp_path, EXAMPLE))
    assert r.n_samples == 4
    np.testing.assert_array_equal(r.time, [0.0, 0.001, 0.002, 0.003])
    np.testing.assert_array_equal(r.deflection, [0.1203, 0.1204, 0.1206, 0.1207])
    assert r.stiffness == 86.9 and r.weight == 36.0
    assert r.drive_speed == pytest.approx(1.0 / 60, rel=1e-15)
    assert (r.lubricant, r.surface, r.note, r.truth) == ("A", "S1G1", None, None)
    assert r.drive_source == "speed"
    assert r.source == str(tmp_path / "run.csv") and r.name == "run"
    assert r.sample_interval == pytest.approx(0.001) and r.duration == pytest.approx(0.003)
    np.testing.assert_allclose(r.force, 86.9 * r.deflection)
    assert r.omega0 == pytest.approx(np.sqrt(G_MM_S2 * 86.9 / 36.0))
    np.testing.assert_allclose(r.drive_position(), r.time / 60)
    np.testing.assert_allclose(r.drive_velocity(), 1 / 60)


def test_units_are_converted(tmp_path):
    text = """\
# stickslip-record: 1
# drive_speed: 10 um/s
# stiffness: 852 N/mm
# slider_mass: 36.0 kg
# note: a free text, with commas: and colons
# operator: Bob
time [ms],force [N],drive [um],pitch_1 [um],yaw_4 [m],ratio [-]
0,8.52,0,1,1e-6,0.5
2,17.04,20,2,2e-6,0.5
4,25.56,40,3,3e-6,0.5
"""
    r = read_record(write(tmp_path, text))
    k = 852 / KGF_N
    assert r.stiffness == pytest.approx(k, rel=1e-15)
    assert r.weight == 36.0  # 1 kg weighs 1 kgf exactly
    assert r.drive_speed == pytest.approx(0.01, rel=1e-15)
    np.testing.assert_allclose(r.time, [0, 0.002, 0.004], rtol=1e-15)
    np.testing.assert_allclose(r.deflection, np.array([8.52, 17.04, 25.56]) / KGF_N / k)
    np.testing.assert_allclose(r.deflection, [0.01, 0.02, 0.03], rtol=1e-14)
    np.testing.assert_allclose(r.drive, [0, 0.02, 0.04], rtol=1e-15)
    assert r.drive_source == "column"
    np.testing.assert_allclose(r.drive_position([0.001]), [0.01])
    np.testing.assert_allclose(r.channels["pitch_1"], [0.001, 0.002, 0.003], rtol=1e-15)
    np.testing.assert_allclose(r.channels["yaw_4"], [0.001, 0.002, 0.003], rtol=1e-15)
    np.testing.assert_array_equal(r.channels["ratio"], [0.5] * 3)
    assert r.channel_units == {"pitch_1": "um", "yaw_4": "m", "ratio": "-"}
    assert r.note == "a free text, with commas: and colons"
    assert r.extra_header == {"operator": "Bob"}


def test_drive_program(tmp_path):
    text = EXAMPLE.replace(
        "# drive_speed: 1.0 mm/min",
        "# drive_program: 0 s 1 mm/min; 30 s 0 mm/min; 60000 ms 6 mm/min",
    )
    r = read_record(write(tmp_path, text))
    assert r.drive_program == ((0.0, 1 / 60), (30.0, 0.0), (60.0, 0.1))
    assert r.drive_speed is None and r.drive_source == "program"
    t = np.array([-1.0, 0.0, 15.0, 30.0, 45.0, 60.0, 70.0])
    # u = integral_0^t v: 0.5 mm at 30 s, held to 60 s, then 0.1 mm/s
    np.testing.assert_allclose(r.drive_position(t), [0, 0, 0.25, 0.5, 0.5, 0.5, 1.5], atol=1e-15)
    np.testing.assert_allclose(r.drive_velocity(t), [0, 1 / 60, 1 / 60, 0, 0, 0.1, 0.1])
    assert r.nominal_drive_speed == pytest.approx(0.1)


def test_program_starting_late_rests_before():
    r = make_record(drive_speed=None, drive_program=((10.0, 1.0),))
    np.testing.assert_allclose(r.drive_position([0.0, 5.0, 12.0]), [0.0, 0.0, 2.0])


def test_crlf_bom_blank_lines_and_spaces(tmp_path):
    text = "\ufeff" + EXAMPLE.replace("\n", "\r\n").replace("0.001,0.1204", " 0.001 , 0.1204 ")
    text = text.replace("time [s]", "\r\ntime [s]") + "\r\n\r\n"
    r = read_record(write(tmp_path, text))
    np.testing.assert_array_equal(r.deflection, [0.1203, 0.1204, 0.1206, 0.1207])


def test_float_formatting_round_off_is_tolerated(tmp_path):
    t = 1000.0 + np.arange(200) * 1e-3  # steps deviate by float round-off only
    rows = "\n".join(f"{float(ti)!r},0.1" for ti in t)
    r = read_record(write(tmp_path, EXAMPLE.split("time [s]")[0] + "time [s],deflection [mm]\n"
                          + rows + "\n"))
    assert r.n_samples == 200


# ---------------------------------------------------------------- round trips


def test_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(0)
    n = 300
    r = make_record(
        n=n,
        deflection=rng.normal(size=n) * 1e-3 + 0.1,
        stiffness=852 / KGF_N,
        weight=35.123456789,
        drive_speed=1 / 60,
        drive=np.cumsum(rng.uniform(0, 1e-4, size=n)),
        drive_program=((0.0, 1 / 60), (30.0, 0.0), (60.0, 1 / 60)),
        lubricant="A",
        surface="S1G1",
        note="synthetic: seed 0, noise 0.5 um",
        channels={"pitch_1": rng.normal(size=n) * 1e-3, "temp": rng.normal(size=n)},
        channel_units={"pitch_1": "um", "temp": "-"},
        truth={"mu_s": 0.3, "gamma": [1.0, 2.5e-7], "nested": {"m": 0.5}},
        extra_header={"operator": "Bob", "rig-id": "7"},
    )
    p = write_record(r, tmp_path / "rt.csv")
    back = read_record(p)
    assert back == r
    assert back.channel_units == {"pitch_1": "mm", "temp": ""}
    assert back.source == str(p)
    # twice: the file is stable
    assert format_record(back) == p.read_text(encoding="utf-8")


@pytest.mark.parametrize(
    "kw",
    [
        dict(deflection_unit="um", time_unit="ms", channel_units="original"),
        dict(deflection_unit="m", drive_unit="um", channel_units={"pitch_1": "m"}),
    ],
)
def test_round_trip_in_other_units(tmp_path, kw):
    rng = np.random.default_rng(1)
    n = 500
    r = make_record(
        n=n,
        deflection=rng.normal(size=n),
        drive=rng.normal(size=n),
        channels={"pitch_1": rng.normal(size=n)},
        channel_units={"pitch_1": "um"},
    )
    back = read_record(write_record(r, tmp_path / "u.csv", **kw))
    for a, b in [(r.time, back.time), (r.deflection, back.deflection), (r.drive, back.drive),
                 (r.channels["pitch_1"], back.channels["pitch_1"])]:
        np.testing.assert_array_max_ulp(a, b, maxulp=1)
    # the value search makes almost every sample exact
    assert np.mean(r.deflection == back.deflection) > 0.95


def test_force_column_round_trip(tmp_path):
    r = make_record()
    p = write_record(r, tmp_path / "f.csv", force_unit="N")
    assert "force [N]" in p.read_text()
    back = read_record(p)
    np.testing.assert_allclose(back.deflection, r.deflection, rtol=1e-15)


def test_mass_in_kg_round_trips_as_weight(tmp_path):
    r = read_record(write(tmp_path, EXAMPLE.replace("slider_weight: 36.0 kgf",
                                                    "slider_mass: 12.4 kg")))
    assert r.weight == 12.4
    assert read_record(write_record(r, tmp_path / "w.csv")) == r


# ---------------------------------------------------------------- errors


def replace(old, new):
    return lambda text: text.replace(old, new)


ERRORS = [
    # (transform of EXAMPLE, line, words expected in the message)
    (replace("# stiffness: 86.9 kgf/mm\n", ""), 6, ["missing", "stiffness"]),
    (replace("# slider_weight: 36.0 kgf\n", ""), 6, ["missing", "slider_weight"]),
    (replace("# drive_speed: 1.0 mm/min\n", ""), 6, ["no drive", "drive_speed"]),
    (replace("86.9 kgf/mm", "86.9"), 3, ["no unit", "kgf/mm"]),
    (replace("86.9 kgf/mm", "86.9 bogon/in"), 3, ["unknown stiffness unit", "'bogon/in'"]),
    (replace("86.9 kgf/mm", "stiff"), 3, ["cannot read", "number unit"]),
    (replace("1.0 mm/min", "1.0 wibble/fortnight"), 2, ["unknown speed unit"]),
    (replace("1.0 mm/min", "-1.0 mm/min"), 2, [">= 0"]),
    (replace("36.0 kgf", "0 kgf"), 4, ["positive"]),
    (replace("time [s]", "time [kg]"), 7, ["unknown time unit", "'kg'"]),
    (replace("deflection [mm]", "deflection [kgf]"), 7, ["unknown length unit"]),
    (replace("deflection [mm]", "deflection"), 7, ["name [unit]"]),
    (replace("time [s]", "t [s]"), 7, ["no 'time [s]' column"]),
    (replace("deflection [mm]", "deflection [mm],force [N]"), 7, ["both", "deflection"]),
    (replace("deflection [mm]", "x [mm]"), 7, ["neither"]),
    (replace("deflection [mm]", "deflection [mm],time [s]"), 7, ["twice"]),
    (replace("0.001,0.1204", "0.001,abc"), 9, ["'abc'", "not a number", "deflection"]),
    (replace("0.001,0.1204", "0.001,0,1204"), 9, ["3 cells", "decimal comma"]),
    (replace("0.001,0.1204", "0.001"), 9, ["1 cells"]),
    (replace("0.001,0.1204", "0.001,"), 9, ["empty cell", "deflection"]),
    (replace("0.001,0.1204", "0.001,NaN"), 9, ["NaN", "finite"]),
    (replace("0.001,0.1204", "0.001,-inf"), 9, ["-inf", "finite"]),
    (replace("0.001,0.1204", "0.001,1e999"), 9, ["float range"]),
    (replace("0.001,0.1204", "0.001,1_000"), 9, ["not a number"]),
    (replace("0.001,0.1204", "0.000,0.1204"), 9, ["does not increase", "sort"]),
    (replace("0.002,0.1206", "0.0005,0.1206"), 10, ["does not increase"]),
    (replace("0.003,0.1207", "0.0031,0.1207"), 11, ["uneven", "relative deviation"]),
    (replace("0.001,0.1204\n0.002,0.1206\n0.003,0.1207\n", ""), 8, ["1 data row", "two"]),
    (replace("time [s],deflection [mm]\n", "time [s],deflection [mm]\n# note: late\n"), 8,
     ["header line after the column row"]),
    (replace("# stickslip-record: 1", "# stickslip-record: 2"), 1, ["version"]),
    (replace("# stickslip-record: 1\n", ""), 1, ["first line", "stickslip-record"]),
    (replace("# lubricant: A", "# lubricant: A\n# lubricant: B"), 6, ["twice", "line 5"]),
    (replace("# lubricant: A", "# lubricant:"), 5, ["empty value"]),
    (replace("# lubricant: A", "# truth: {bad json"), 5, ["truth", "JSON"]),
    (replace("# lubricant: A", "# truth: [1, 2]"), 5, ["JSON object"]),
    (replace("# lubricant: A", "# truth: " + "[" * 100000), 5, ["JSON"]),
    (replace("# lubricant: A", "# slider_mass: 36 kg"), 5, ["both slider_weight and slider_mass"]),
    (replace("1.0 mm/min", "1.0 mm/min\n# drive_program: 0 s 1 mm/min; 0 s 2 mm/min"), 3,
     ["increase", "drive_program"]),
    (replace("1.0 mm/min", "1.0 mm/min\n# drive_program: 0 s 1 mm/min; 30 s"), 3,
     ["segment '30 s'"]),
    (replace("1.0 mm/min", "1.0 mm/min\n# drive_program: 0 kg 1 mm/min"), 3, ["time unit 'kg'"]),
    (replace("1.0 mm/min", "1.0 mm/min\n# drive_program: 0 s -1 mm/min"), 3, ["negative"]),
    (replace("1.0 mm/min", "1.0 mm/min\n# drive_program: 0 s 1 km/kg"), 3, ["speed unit"]),
    (replace("time [s],deflection [mm]\n0.000,0.1203\n0.001,0.1204\n0.002,0.1206\n0.003,0.1207\n",
             ""), 6, ["no column row"]),
    (replace("0.001,0.1204", "0.001,0.1204\r0.0015,2"), 9, ["carriage return"]),
    # values Record refuses, at the line they come from
    (replace("86.9 kgf/mm", "0 kgf/mm"), 3, ["stiffness must be positive"]),
    (replace("# lubricant: A", "# Operator: x"), 5, ["extra header key 'Operator'"]),
    (replace("# lubricant: A", "# operator: x\x01"), 5, ["control characters"]),
]


@pytest.mark.parametrize("transform, line, words", ERRORS)
def test_errors_name_file_line_and_fix(tmp_path, transform, line, words):
    text = transform(EXAMPLE)
    assert text != EXAMPLE
    p = write(tmp_path, text)
    with pytest.raises(RecordError) as info:
        read_record(p)
    msg = str(info.value)
    assert msg.startswith(f"{p}: line {line}: "), msg
    assert info.value.line == line and info.value.path == str(p)
    for w in words:
        assert w in msg, (w, msg)
    assert "\n" not in msg


def test_uneven_time_says_how_uneven(tmp_path):
    rows = "\n".join(f"{t:.6f},0.1" for t in np.r_[np.arange(10) * 1e-3, 0.0105])
    p = write(tmp_path, EXAMPLE.split("time [s]")[0] + "time [s],deflection [mm]\n" + rows)
    with pytest.raises(RecordError, match=r"line 18: .*uneven.*0\.0015 s.*mean step 0\.00105 s"
                       r".*relative deviation 0\.429.*tolerance 0\.001.*resample"):
        read_record(p)


def test_coarsely_rounded_times_get_a_digits_hint(tmp_path):
    rows = "\n".join(f"{t:.4f},0.1" for t in np.arange(20) / 3000)  # 3 kHz, 4 decimals
    p = write(tmp_path, EXAMPLE.split("time [s]")[0] + "time [s],deflection [mm]\n" + rows)
    with pytest.raises(RecordError, match="within the rounding of the written digits: if the "
                       "time stamps were rounded, "
                       "write them with more digits"):
        read_record(p)


def test_file_level_errors(tmp_path):
    cases = {
        "empty.csv": (b"", "empty"),
        "blank.csv": (b"  \n\n", "empty"),
        "binary.csv": (b"# stickslip-record: 1\n\x00\x01\x02", "binary"),
        "latin1.csv": ("# stickslip-record: 1\n# note: caf\u00e9\n".encode("latin-1"),
                       "no column row"),
    }
    for name, (data, word) in cases.items():
        p = tmp_path / name
        p.write_bytes(data)
        with pytest.raises(RecordError, match=word) as info:
            read_record(p)
        assert str(p) in str(info.value)
    assert "line 2" in str(pytest.raises(RecordError, read_record, tmp_path / "latin1.csv").value)
    with pytest.raises(RecordError, match="no such file"):
        read_record(tmp_path / "missing.csv")
    with pytest.raises(RecordError, match="directory"):
        read_record(tmp_path)
    big = write(tmp_path, EXAMPLE, "big.csv")
    with pytest.raises(RecordError, match=r"over the 0 MB limit; split"):
        read_record(big, max_bytes=100)
    assert MAX_FILE_BYTES == 200 * 1024 * 1024


def test_utf8_text_is_kept(tmp_path):
    r = read_record(write(tmp_path, EXAMPLE.replace("S1G1", "Gußeisen S1G1 — µ")))
    assert r.surface == "Gußeisen S1G1 — µ"


def test_record_constructor_validates():
    t = np.arange(5) * 1e-3
    with pytest.raises(RecordError, match="uneven"):
        make_record(time=np.array([0, 1, 2, 3.5, 4.0]), deflection=np.zeros(5))
    with pytest.raises(RecordError, match="increase strictly"):
        make_record(time=np.array([0, 1, 1, 2.0]), deflection=np.zeros(4))
    with pytest.raises(RecordError, match="deflection has 4 samples but time has 5"):
        make_record(time=t, deflection=np.zeros(4))
    with pytest.raises(RecordError, match="finite"):
        make_record(time=t, deflection=np.array([0, np.nan, 0, 0, 0]))
    with pytest.raises(RecordError, match="at least two"):
        make_record(time=t[:1], deflection=np.zeros(1))
    with pytest.raises(RecordError, match="needs a drive"):
        make_record(drive_speed=None)
    with pytest.raises(RecordError, match="stiffness must be positive"):
        make_record(stiffness=-1.0)
    with pytest.raises(RecordError, match="one line"):
        make_record(note="two\nlines")
    with pytest.raises(RecordError, match="channel_units"):
        make_record(channels={"p": np.zeros(50)})
    with pytest.raises(RecordError, match="identifier"):
        make_record(channels={"drive": np.zeros(50)}, channel_units={"drive": "mm"})
    # a unit the package does not know is kept as written (a logger's extra channel)
    assert make_record(channels={"p": np.zeros(50)},
                       channel_units={"p": "furlong"}).channel_units == {"p": "furlong"}
    with pytest.raises(RecordError, match="extra header key"):
        make_record(extra_header={"stiffness": "3"})
    with pytest.raises(RecordError, match="JSON"):
        make_record(truth={"f": object()})
    r = make_record()
    with pytest.raises(ValueError):
        r.time[0] = 1.0  # read-only arrays
    assert r.replace(lubricant="C").lubricant == "C"
    assert r != r.replace(weight=12.4) and r == r.replace()


# ---------------------------------------------------------------- campaigns


def test_campaign_from_directory_glob_and_list(tmp_path):
    d = tmp_path / "campaign"
    d.mkdir()
    for i, lub in enumerate(["A", "A", "C"]):
        # each run its own content (files with the same data count once)
        text = EXAMPLE.replace("lubricant: A", f"lubricant: {lub}").replace(
            "0.000,0.1203", f"0.000,0.120{3 + i}", 1)
        write(d, text, f"run{i}.csv")
    (d / "notes.txt").write_text("not a record")
    recs = read_campaign(d)
    assert [r.name for r in recs] == ["run0", "run1", "run2"]
    assert [r.name for r in read_campaign(str(d / "run[01].csv"))] == ["run0", "run1"]
    listed = read_campaign([d / "run2.csv", str(d / "run0.csv")])
    assert [r.name for r in listed] == ["run2", "run0"]
    with pytest.raises(RecordError, match="named twice"):
        read_campaign([d, d / "run1.csv"])
    (tmp_path / "copy.csv").write_bytes((d / "run0.csv").read_bytes())
    once = read_campaign([d / "run0.csv", tmp_path / "copy.csv"])  # a copy counts once
    assert [r.name for r in once] == ["run0"]
    assert once[0].notes[-1].endswith("copy.csv holds the same data: counted once")
    with pytest.raises(RecordError, match="no file matches"):
        read_campaign(str(d / "*.dat"))
    with pytest.raises(RecordError, match="no \\*.csv"):
        (tmp_path / "empty").mkdir()
        read_campaign(tmp_path / "empty")
    with pytest.raises(RecordError, match="no such file"):
        read_campaign(tmp_path / "nowhere")
    assert check_campaign(recs[:2]) == []
    with pytest.raises(RecordError, match=r"mixes lubricants \('C' in run2; 'A' in run0, run1\)"):
        check_campaign(recs)
    problems = check_campaign(recs + [recs[0].replace(surface=None)], strict=False)
    assert len(problems) == 2 and "not given in run0" in problems[1]


def test_campaign_reports_the_bad_file(tmp_path):
    write(tmp_path, EXAMPLE, "a.csv")
    write(tmp_path, EXAMPLE.replace("86.9 kgf/mm", "86.9"), "b.csv")
    with pytest.raises(RecordError, match=r"b\.csv: line 3: stiffness"):
        read_campaign(tmp_path)


def test_parse_record_without_file():
    r = parse_record(EXAMPLE)
    assert r.source is None
    with pytest.raises(RecordError, match=r"^<text>: line 3"):
        parse_record(EXAMPLE.replace("86.9 kgf/mm", "86.9"))


def test_truth_json_round_trip(tmp_path):
    truth = {"lubricant": "A", "mu_s": 0.3, "list": [1, 2.5e-300], "s": "é\"q"}
    r = make_record(truth=truth)
    text = format_record(r)
    line = [ln for ln in text.splitlines() if ln.startswith("# truth:")][0]
    assert json.loads(line.split(":", 1)[1]) == truth
    assert parse_record(text).truth == truth


def test_drive_program_text_helpers():
    program = parse_drive_program("0 s 1 mm/min; 30 s 0 mm/min; 1 min 2 um/s")
    assert program == ((0.0, 1 / 60), (30.0, 0.0), (60.0, 0.002))
    assert parse_drive_program(format_drive_program(program)) == program
    assert format_drive_program(((0.0, 1 / 60),), "mm/min") == "0.0 s 1.0 mm/min"
    with pytest.raises(RecordError, match="^drive_program: cannot read segment '30'"):
        parse_drive_program("0 s 1 mm/min; 30")
    with pytest.raises(ValueError, match="negative"):
        parse_drive_program("0 s -1 mm/min")


# ------------------------------------------------------------ what data loggers write


def test_unknown_channel_units_are_kept_as_written(tmp_path):
    """A `temperature [degC]` column does not refuse the record: kept raw, written back."""
    text = EXAMPLE.replace("deflection [mm]\n", "deflection [mm],temperature [degC]\n")
    for a, b in (("0.1203", "0.1203,21.5"), ("0.1204", "0.1204,21.6"),
                 ("0.1206", "0.1206,21.6"), ("0.1207", "0.1207,21.7")):
        text = text.replace(a + "\n", b + "\n")
    r = read_record(write(tmp_path, text))
    assert r.channel_units == {"temperature": "degC"}
    assert list(r.channels["temperature"]) == [21.5, 21.6, 21.6, 21.7]
    assert read_record(write_record(r, tmp_path / "back.csv")) == r


@pytest.mark.parametrize("delim", [";", "\t"])
def test_semicolons_tabs_and_decimal_commas(tmp_path, delim):
    head, body = EXAMPLE.split("time [s],deflection [mm]\n")
    rows = body.replace(",", delim).replace(".", ",")
    r = read_record(write(tmp_path, head + f"time [s]{delim}deflection [mm]\n" + rows))
    assert r == read_record(write(tmp_path, EXAMPLE, "plain.csv"))
    assert any("decimal commas" in n for n in r.notes)


def test_quoted_numbers(tmp_path):
    head, body = EXAMPLE.split("time [s],deflection [mm]\n")
    rows = "\n".join(",".join(f'"{c}"' for c in ln.split(",")) for ln in body.splitlines())
    r = read_record(write(tmp_path, head + "time [s],deflection [mm]\n" + rows + "\n"))
    assert r == read_record(write(tmp_path, EXAMPLE, "plain.csv"))


def test_jittered_clock_is_resampled(tmp_path):
    """0.1 % clock jitter (refused before) is resampled with a note; a 10 % gap is not."""
    rng = np.random.default_rng(0)
    t = np.arange(2000) * 1e-4 + 1e-7 * rng.standard_normal(2000)
    x = 0.1 + 0.01 * np.sin(2 * np.pi * 5 * t)
    rows = "\n".join(f"{float(a)!r},{float(b)!r}" for a, b in zip(t, x))
    r = read_record(write(tmp_path, EXAMPLE.split("time [s]")[0] + "time [s],deflection [mm]\n"
                          + rows + "\n"))
    assert any("resampled" in n for n in r.notes)
    assert np.ptp(np.diff(r.time)) < 1e-12 and np.allclose(np.diff(r.time), 1e-4, rtol=1e-5)
    assert np.max(np.abs(r.deflection - (0.1 + 0.01 * np.sin(2 * np.pi * 5 * r.time)))) < 1e-5


def test_a_loggers_wider_jitter_is_resampled_and_gaps_are_not(tmp_path):
    """Stamps scattered by +-10 % of the step (single steps off by up to 20 %, refused
    before) are a jittered logger: resampled with a note. A long gap, a doubled
    sample, or stamps scattered by +-40 % are still refused (`JITTER_STAMP`)."""
    rng = np.random.default_rng(1)
    n, dt = 3000, 1e-3
    t_true = np.arange(n) * dt
    x = 0.1 + 0.01 * np.sin(2 * np.pi * 3 * t_true)

    def read(stamps, values=x):
        rows = "\n".join(f"{float(a)!r},{float(b)!r}" for a, b in zip(stamps, values))
        return read_record(write(tmp_path, EXAMPLE.split("time [s]")[0]
                                 + "time [s],deflection [mm]\n" + rows + "\n"))

    jitter = 0.1 * dt * rng.uniform(-1, 1, n)
    jitter[0] = jitter[-1] = 0.0
    r = read(t_true + jitter)
    assert any("resampled" in note for note in r.notes)
    assert np.ptp(np.diff(r.time)) < 1e-12
    # linear interpolation at stamps 0.1 ms off: error within slope x 0.1 ms (0.02 um)
    assert np.max(np.abs(r.deflection - (0.1 + 0.01 * np.sin(2 * np.pi * 3 * r.time)))) < 3e-5
    assert Record.from_arrays(t_true + jitter, x, stiffness=86.9, weight=36.0,
                              drive_speed=0.1).notes
    with pytest.raises(RecordError, match="uneven"):  # 20 samples missing in a row
        read(np.delete(t_true, range(1500, 1520)), np.delete(x, range(1500, 1520)))
    with pytest.raises(RecordError, match="uneven"):  # a sample written twice, 1 us apart
        read(np.insert(t_true, 1501, t_true[1500] + 1e-6), np.insert(x, 1501, x[1500]))
    wild = 0.4 * dt * rng.uniform(-1, 1, n)
    wild[0] = wild[-1] = 0.0
    with pytest.raises(RecordError, match="uneven"):
        read(t_true + wild)


def test_a_loggers_dropped_samples_are_filled(tmp_path):
    """A uniform clock that dropped single samples and short runs (refused before, and
    the campaign with it): put back by linear interpolation, with a note naming how
    many and where; the samples that were read are kept exactly (`MISSING_RUN`)."""
    n, dt = 2000, 1e-3
    t = np.arange(n) * dt
    x = 0.1 + 0.01 * np.sin(2 * np.pi * 3 * t)
    drop = [300, 301, 302, 1200] + list(range(1500, 1510))
    keep = np.setdiff1d(np.arange(n), drop)

    def rows(tt, xx):
        return "\n".join(f"{float(a)!r},{float(b)!r}" for a, b in zip(tt, xx))

    head = EXAMPLE.split("time [s]")[0] + "time [s],deflection [mm]\n"
    r = read_record(write(tmp_path, head + rows(t[keep], x[keep]) + "\n"))
    assert r.time.shape == (n,) and np.allclose(r.time, t, atol=1e-12)
    assert np.array_equal(r.deflection[keep], x[keep])
    assert np.max(np.abs(r.deflection - x)) < 1e-5
    assert any("14 sample(s) missing in 3 gap(s) of up to 10" in note and "0.299 s" in note
               for note in r.notes), r.notes
    a = Record.from_arrays(t[keep], x[keep], stiffness=86.9, weight=36.0, drive_speed=0.1)
    assert a.time.shape == (n,) and a.notes == r.notes
    with pytest.raises(RecordError, match="uneven"):  # a run of 11 (a gap to split at)
        gone = np.setdiff1d(np.arange(n), range(700, 711))
        read_record(write(tmp_path, head + rows(t[gone], x[gone]) + "\n"))


def test_epoch_time_stamps(tmp_path):
    """10 kHz epoch stamps (1.7e9 s; float64 keeps ~0.2 us): counted from the first."""
    t = 1.7e9 + np.arange(500) * 1e-4
    rows = "\n".join(f"{float(a)!r},0.1" for a in t)
    r = read_record(write(tmp_path, EXAMPLE.split("time [s]")[0] + "time [s],deflection [mm]\n"
                          + rows + "\n"))
    assert r.time[0] == 0.0 and abs(r.time[-1] - 499e-4) < 1e-6
    assert any("first time stamp" in n for n in r.notes)


def test_a_text_field_ending_in_a_separator_is_refused():
    """A header value ending in ',' or ';' cannot be told from a spreadsheet's padding of
    the line, so it could not read back: refused when the record is made."""
    from stickslip_jax.records import Record, RecordError

    with pytest.raises(RecordError, match="must not end in"):
        Record(time=np.array([0.0, 1.0]), deflection=np.zeros(2), stiffness=1.0,
               weight=1.0, drive_speed=0.0, note="run 3,")
