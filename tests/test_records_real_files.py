"""Records as spreadsheets, loggers and archives leave them: every dialect, encoding,
header spelling and unit spelling of a valid record reads to the same data as the
original, with a note saying what was read; the clock of a jittered logger is resampled."""

from __future__ import annotations

import gzip
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stickslip_jax.records import RecordError, read_record

SETTINGS = settings(max_examples=120, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])

HEADER = [
    ("stickslip-record", "1"),
    ("drive_speed", "1.5 mm/min"),
    ("stiffness", "86.9 kgf/mm"),
    ("slider_weight", "36.0 kgf"),
    ("lubricant", "A"),
    ("surface", "S1G1"),
    ("note", "run 3, second try"),
]
ROWS = [(0.001 * i, 0.1203 + 0.0001 * (i % 7), 0.5 * i) for i in range(12)]
ORIGINAL = ("\n".join(f"# {k}: {v}" for k, v in HEADER)
            + "\ntime [s],deflection [mm],pitch_1 [um]\n"
            + "\n".join(f"{t!r},{x!r},{p!r}" for t, x, p in ROWS) + "\n")

_TMP = tempfile.TemporaryDirectory(prefix="records-real-")


def _read(data: bytes, name="case.csv"):
    p = Path(_TMP.name) / name
    p.write_bytes(data)
    return read_record(p)


REFERENCE = _read(ORIGINAL.encode())

KEY_SPELLINGS = {
    "stiffness": ["stiffness", "Stiffness", "STIFFNESS"],
    "drive_speed": ["drive_speed", "drive speed", "Drive Speed", "drive-speed"],
    "slider_weight": ["slider_weight", "Slider weight"],
}


@st.composite
def variants(draw):
    """(bytes of the record in one real-world dialect, what was changed)."""
    sep = draw(st.sampled_from([",", ";", "\t"]))
    decimal = "," if sep != "," and draw(st.booleans()) else "."
    quote = draw(st.booleans())
    pad = draw(st.integers(0, 2))
    excel_sep = draw(st.booleans())
    comment = draw(st.booleans())
    paren = draw(st.booleans())
    newline = draw(st.sampled_from(["\n", "\r\n"]))
    encoding = draw(st.sampled_from(["utf-8", "utf-8-sig", "utf-16", "utf-16-le",
                                     "latin-1", "gzip"]))

    def num(v):
        return repr(v).replace(".", decimal)

    def cell(text):
        return f'"{text}"' if quote else text

    lines = [f"sep={sep}"] if excel_sep else []
    for k, v in HEADER:
        k = draw(st.sampled_from(KEY_SPELLINGS.get(k, [k])))
        if k.lower() == "stiffness" and decimal == ",":
            v = v.replace(".", ",")
        line = f"# {k}: {v}"
        if quote and sep in line or '"' in line:
            line = '"' + line.replace('"', '""') + '"'
        lines.append(line + sep * pad)
        if comment and k == "lubricant":
            lines.append("# measured on the old rig" + sep * pad)
    names = ["time (s)", "deflection (mm)", "pitch_1 (um)"] if paren else [
        "time [s]", "deflection [mm]", "pitch_1 [um]"]
    lines.append(sep.join(cell(n) for n in names) + sep * pad)
    for row in ROWS:
        lines.append(sep.join(cell(num(v)) for v in row) + sep * pad)
    text = newline.join(lines) + newline
    if encoding == "gzip":
        return gzip.compress(text.encode()), locals()
    return text.encode(encoding), locals()


@SETTINGS
@given(variants())
def test_every_dialect_reads_to_the_same_data(case):
    data, how = case
    rec = _read(data)
    assert rec == REFERENCE, how
    assert rec.note == "run 3, second try"
    if how["sep"] != "," or how["quote"] or how["pad"]:
        assert any("separated by" in n for n in rec.notes), rec.notes
    if how["encoding"] in ("utf-16", "utf-16-le", "gzip"):
        word = "gzip" if how["encoding"] == "gzip" else "UTF-16"
        assert any(word in n for n in rec.notes), rec.notes


@SETTINGS
@given(st.sampled_from(["um", "µm", "μm"]), st.sampled_from(["utf-8", "latin-1", "utf-16"]))
def test_micrometre_spellings_and_encodings(unit, encoding):
    text = ORIGINAL.replace("deflection [mm]", f"deflection [{unit}]")
    for t, x, _ in ROWS:
        text = text.replace(f"{t!r},{x!r},", f"{t!r},{x * 1000!r},")
    try:
        data = text.encode(encoding)
    except UnicodeEncodeError:  # μ (Greek mu) has no Latin-1 byte
        return
    rec = _read(data)
    np.testing.assert_allclose(rec.deflection, REFERENCE.deflection, rtol=1e-14)


def test_units_row_and_unit_lines_give_a_bare_column_its_unit():
    head, body = ORIGINAL.split("time [s],deflection [mm],pitch_1 [um]\n")
    units_row = _read((head + "time,deflection,pitch_1\ns,mm,um\n" + body).encode())
    assert units_row == REFERENCE
    bracket_row = _read((head + "Time,Deflection,pitch_1\n[s],[mm],[um]\n" + body).encode())
    assert bracket_row == REFERENCE
    unit_lines = _read((head + "# deflection_unit: mm\n# time_unit: s\n"
                        "time,deflection,pitch_1 [um]\n" + body).encode())
    assert unit_lines.deflection.tolist() == REFERENCE.deflection.tolist()
    with pytest.raises(RecordError, match=r"units disagree \('mm' in the column row, 'um' "
                                          r"in the header 'deflection_unit'\)"):
        _read((head + "# deflection_unit: um\ntime [s],deflection [mm],pitch_1 [um]\n"
               + body).encode())
    with pytest.raises(RecordError, match=r"line 8: .*'deflection' must be 'name \[unit\]'.*"
                                          r"# deflection_unit"):
        _read((head + "time [s],deflection,pitch_1 [um]\n" + body).encode())


def test_damaged_gzip_and_a_named_pipe_are_refused(tmp_path):
    import os

    with pytest.raises(RecordError, match="gzip-compressed but cut short"):
        _read(gzip.compress(ORIGINAL.encode())[:60])
    with pytest.raises(RecordError, match="gzip-compressed but damaged"):
        _read(b"\x1f\x8b" + b"\x00" * 40)
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    with pytest.raises(RecordError, match="not a regular file"):
        read_record(fifo)  # refused at once: opening a pipe would wait for a writer


@pytest.mark.parametrize("jitter", [0.05, 0.12, 0.2])
def test_jittered_stamps_are_resampled_up_to_a_fifth_of_a_step(jitter):
    rng = np.random.default_rng(3)
    n, dt = 400, 0.002
    t = dt * np.arange(n) + rng.uniform(-jitter, jitter, n) * dt
    t[0], t[-1] = jitter * dt, (n - 1 - jitter) * dt  # both ends jittered inwards
    x = 0.1 + 0.01 * np.sin(t)
    head = ORIGINAL.split("time [s]")[0]
    rows = "\n".join(f"{float(a)!r},{float(b)!r}" for a, b in zip(t, x))
    rec = _read((head + "time [s],deflection [mm]\n" + rows + "\n").encode())
    assert any("jitter" in n for n in rec.notes)
    assert np.ptp(np.diff(rec.time)) < 1e-12
    np.testing.assert_allclose(rec.deflection, 0.1 + 0.01 * np.sin(rec.time), atol=1e-6)


@pytest.mark.parametrize("sep", [",", ";", "\t"])
def test_a_shipped_record_through_a_spreadsheet_reads_back_equal(sep):
    """A shipped record (its truth a JSON header with commas and quotes) opened in a
    spreadsheet and saved: cells written by the csv module as a spreadsheet writes them
    (quoted where needed, CRLF, padded rows; ';' and tabs with decimal commas)."""
    import csv
    import io

    from cli_safety import EXAMPLES

    src = EXAMPLES[0]
    out = io.StringIO()
    w = csv.writer(out, delimiter=sep, lineterminator="\r\n")
    for line in src.read_text().splitlines():
        header = line.startswith("#")
        cells = [line] if header and sep != "," else line.split(",")
        if sep != "," and not header:
            cells = [c.replace(".", ",") for c in cells]
        w.writerow(cells + ["", ""])
    rec = _read(out.getvalue().encode("utf-8-sig"))
    ref = read_record(src)
    assert rec == ref and rec.truth == ref.truth


@SETTINGS
@given(st.sampled_from(["86.9 kgf/mm", "86,9 kgf/mm", "86.9 kgf / mm", "86.9 kgf/millimeter",
                        "0.0869 kgf/um", "86900 kgf/m"]),
       st.sampled_from(["1.5 mm/min", "1,5 mm/min", "0.025 mm/s", "25 um/s", "25 µm/s"]),
       st.sampled_from(["36.0 kgf", "36 kilogram_force", "36,0 kgf", "353.0394 N"]))
def test_header_unit_spellings_read_to_the_same_conditions(stiffness, speed, weight):
    text = (ORIGINAL.replace("86.9 kgf/mm", stiffness).replace("1.5 mm/min", speed)
            .replace("36.0 kgf", weight))
    rec = _read(text.encode())
    assert rec.stiffness == pytest.approx(REFERENCE.stiffness, rel=1e-12)
    assert rec.drive_speed == pytest.approx(REFERENCE.drive_speed, rel=1e-12)
    assert rec.weight == pytest.approx(REFERENCE.weight, rel=1e-7)  # 353.0394 N: 7 digits
