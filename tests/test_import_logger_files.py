"""`stickslip import` of logger files as they come: preambles without '#', a units row,
clock stamps, Latin-1 and UTF-16 text, gzip, Excel's `sep=` line; each variant gives the
record of the plain file. A unit option contradicting the file is refused naming both,
and a bad row is named by its own line."""

from __future__ import annotations

import gzip
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stickslip_jax.cli import main
from stickslip_jax.records import read_record

N = 400
T = np.round(np.arange(N) * 0.005, 6)
X = np.round(120.0 + 30.0 * np.sin(T * 7.0), 4)  # um
_TMP = tempfile.TemporaryDirectory(prefix="import-logger-")
ARGS = ["--time-col", "time", "--deflection-col", "deflection", "--stiffness", "86.9 kgf/mm",
        "--weight", "36 kgf", "--speed", "5 mm/min"]


def _import(data: bytes, capsys, extra=()):
    d = Path(_TMP.name)
    raw, out = d / "raw.txt", d / "out.csv"
    raw.write_bytes(data)
    out.unlink(missing_ok=True)
    code = main(["import", str(raw), "--out", str(out), *ARGS, *extra])
    got = capsys.readouterr()
    return code, got, (read_record(out) if code == 0 else None)


def _text(sep=",", comma=False, preamble=0, units_row=False, clock=False, mu="um"):
    lines = [f"Logger XY-200 export {k}" for k in range(preamble)]
    lines.append(sep.join(["Time", f"Deflection [{mu}]"] if units_row
                          else ["Time [s]", f"Deflection [{mu}]"]))
    if units_row:
        lines.append(sep.join(["s", mu]))
    for t, x in zip(T, X):
        tc = (f"12:{int(t // 60):02d}:{t % 60:06.3f}" if clock else repr(float(t)))
        cells = [tc, repr(float(x))]
        if comma:
            cells = [c.replace(".", ",") for c in cells]
        lines.append(sep.join(cells))
    return "\n".join(lines) + "\n"


PLAIN = None


@settings(max_examples=40, deadline=None, suppress_health_check=[
    HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(sep=st.sampled_from([",", ";", "\t"]), comma=st.booleans(),
       preamble=st.integers(0, 3), units_row=st.booleans(), clock=st.booleans(),
       encoding=st.sampled_from(["utf-8", "latin-1", "utf-16", "gzip"]),
       mu=st.sampled_from(["um", "µm"]), excel=st.booleans())
def test_logger_variants_import_to_the_plain_record(capsys, sep, comma, preamble, units_row,
                                                    clock, encoding, mu, excel):
    global PLAIN
    if PLAIN is None:
        code, got, PLAIN = _import(_text().encode(), capsys)
        assert code == 0, got.err
    comma = comma and sep != ","
    text = (f"sep={sep}\n" if excel else "") + _text(sep, comma, preamble, units_row, clock, mu)
    data = gzip.compress(text.encode()) if encoding == "gzip" else text.encode(encoding)
    code, got, rec = _import(data, capsys)
    assert code == 0, got.err
    np.testing.assert_allclose(rec.time, PLAIN.time, atol=1e-9)
    np.testing.assert_array_equal(rec.deflection, PLAIN.deflection)


def test_a_unit_option_contradicting_the_header_is_refused(capsys):
    text = _text().replace("Deflection [um]", "Deflection (mm)")
    code, got, _ = _import(text.encode(), capsys, ["--value-unit", "um"])
    assert code == 2 and got.err.count("\n") == 1 and "Traceback" not in got.err
    assert "--value-unit um" in got.err and "'mm'" in got.err
    code, got, rec = _import(text.encode(), capsys, ["--value-unit", "mm"])  # agreeing: fine
    assert code == 0 and rec.deflection[0] == pytest.approx(X[0])


def test_a_bad_row_is_named_by_its_own_line(capsys):
    lines = _text(sep=";", comma=True).split("\n")
    lines[300] = "Date;2024-03-01"
    code, got, _ = _import("\n".join(lines).encode(), capsys)
    assert code == 2 and "Traceback" not in got.err and got.err.count("\n") == 1
    assert "line 301" in got.err and "'Date' in column 'time'" in got.err
    assert "could not convert" not in got.err and "float64" not in got.err


def test_undecodable_and_numberless_files_say_so(capsys):
    code, got, _ = _import(b"\xff\xfe\xff" * 10, capsys)
    assert code == 2 and "Traceback" not in got.err and "codec" not in got.err
    code, got, _ = _import(b"just some text\nand more\n", capsys)
    assert code == 2 and "no rows of numbers" in got.err
