"""Property-based tests of the record parser: malformed input only ever gives RecordError,
and every valid record survives a write/read round trip exactly."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from stickslip_jax.records import (
    KNOWN_KEYS,
    RESERVED_COLUMNS,
    Record,
    RecordError,
    format_record,
    parse_record,
    read_record,
    write_record,
)

SETTINGS = settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)

VALID = """\
# stickslip-record: 1
# drive_speed: 1.0 mm/min
# stiffness: 86.9 kgf/mm
# slider_weight: 36.0 kgf
# lubricant: A
time [s],deflection [mm],pitch_1 [um]
0.000,0.1203,1
0.001,0.1204,2
0.002,0.1206,3
"""

_TMP = tempfile.TemporaryDirectory(prefix="records-hypothesis-")


def read_bytes(data: bytes):
    """read_record on a file holding `data`: a Record or a RecordError, nothing else."""
    p = Path(_TMP.name) / "case.csv"
    p.write_bytes(data)
    try:
        return read_record(p)
    except RecordError as exc:
        msg = str(exc)
        assert msg.startswith(str(p)) and "\n" not in msg and exc.reason
        return exc


def parse(text: str):
    try:
        return parse_record(text, source="case.csv")
    except RecordError as exc:
        msg = str(exc)
        assert msg.startswith("case.csv: ") and "\n" not in msg and exc.reason
        return exc


# ---------------------------------------------------------------- malformed input


@SETTINGS
@given(st.sampled_from([b"", VALID.encode()]), st.binary(max_size=400))
def test_random_bytes_alone_or_after_a_valid_header(head, data):
    read_bytes(head + data)


@SETTINGS
@given(st.sampled_from(["", "# stickslip-record: 1\n"]), st.text(max_size=300))
def test_random_text_alone_or_after_the_first_line(head, text):
    parse(head + text)


@st.composite
def mutated(draw):
    """The valid file with characters deleted, inserted or replaced."""
    text = VALID
    for _ in range(draw(st.integers(1, 4))):
        first = len("# stickslip-record: 1\n")
        i = draw(st.integers(0, len(text)) | st.integers(first, len(text)))
        op = draw(st.sampled_from(["delete", "insert", "replace"]))
        piece = draw(st.sampled_from(
            ["", ",", "\n", "\r", "#", ":", "[", "]", "nan", "inf", "-", "e", "1e999", "0e99999",
             ".", " ", "\x00", "µ", "mm", "kgf", "0.0005", ";", "s", "{", "é"]
        ) | st.text(max_size=3))
        if op == "delete":
            text = text[:i] + text[i + draw(st.integers(1, 5)):]
        elif op == "insert":
            text = text[:i] + piece + text[i:]
        else:
            text = text[:i] + piece + text[i + len(piece):]
    return text


@SETTINGS
@given(mutated())
def test_mutated_valid_file(text):
    out = parse(text)
    if isinstance(out, Record):
        assert out.n_samples >= 2 and np.all(np.isfinite(out.deflection))
        assert np.all(np.diff(out.time) > 0)


NUMBERS = st.sampled_from(["0", "1", "-2.5", "1e-3", ".5", "5.", "+3", "1e999", "0e99999",
                           "nan", "inf", "", " ", "x", "1,5", "1_0", "٣", "0x10"])
UNITS = st.sampled_from(["s", "ms", "mm", "um", "m", "N", "kgf", "kg", "kgf/mm", "N/mm",
                         "mm/min", "mm/s", "-", "", "furlong", "h", "[", "mm/min;"])
KEYS = st.sampled_from(list(KNOWN_KEYS) + ["Stiffness", "x", "drive-speed", "", "1a"])


@st.composite
def grammar_file(draw):
    """A file put together from plausible pieces in random order and number."""
    lines = []
    if draw(st.booleans()):
        lines.append("# stickslip-record: " + draw(st.sampled_from(["1", "2", "", "1.0"])))
    for _ in range(draw(st.integers(0, 8))):
        key = draw(KEYS)
        value = draw(st.one_of(
            st.builds(lambda n, u: f"{n} {u}", NUMBERS, UNITS),
            st.builds(lambda a, b, c, d: f"{a} {b} {c} {d}; 30 s 0 mm/min", NUMBERS, UNITS,
                      NUMBERS, UNITS),
            st.sampled_from(["{}", '{"a": 1}', "[", "A", ""]),
        ))
        lines.append(f"# {key}: {value}")
    names = draw(st.lists(st.sampled_from(list(RESERVED_COLUMNS) + ["pitch_1", "t", "9x"]),
                          min_size=0, max_size=4))
    lines.append(",".join(f"{n} [{draw(UNITS)}]" for n in names))
    ncol = max(len(names), 1)
    for _ in range(draw(st.integers(0, 6))):
        width = draw(st.sampled_from([ncol, ncol, ncol, ncol + 1, max(ncol - 1, 0)]))
        lines.append(",".join(draw(NUMBERS) for _ in range(width)))
    sep = draw(st.sampled_from(["\n", "\r\n"]))
    return sep.join(lines) + draw(st.sampled_from(["", sep, sep + sep]))


@SETTINGS
@given(grammar_file())
def test_files_from_plausible_pieces(text):
    parse(text)


# ---------------------------------------------------------------- round trip

FINITE = st.floats(allow_nan=False, allow_infinity=False)
POSITIVE = st.floats(min_value=1e-300, max_value=1e300, allow_nan=False)
TEXT = st.text(
    st.characters(blacklist_categories=("Cc", "Cs", "Zl", "Zp")), min_size=1, max_size=20
).filter(lambda s: s == s.strip() and s.isprintable() and not s.endswith((",", ";")))
JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | FINITE | st.text(max_size=10),
    lambda c: st.lists(c, max_size=3) | st.dictionaries(st.text(max_size=5), c, max_size=3),
    max_leaves=8,
)
KEY = st.from_regex(r"[a-z][a-z0-9_-]{0,8}", fullmatch=True).filter(lambda k: k not in KNOWN_KEYS)
CHANNEL = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,6}", fullmatch=True).filter(
    lambda k: k not in RESERVED_COLUMNS
)


@st.composite
def records(draw):
    n = draw(st.integers(2, 30))
    t0 = draw(st.floats(-1e4, 1e4, allow_nan=False))
    dt = draw(st.floats(1e-6, 10.0))
    time = t0 + dt * np.arange(n)
    arr = st.lists(FINITE, min_size=n, max_size=n).map(np.array)
    drive_kind = draw(st.sampled_from(["speed", "program", "column", "all"]))
    starts = sorted(set(draw(st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=1,
                                      max_size=4))))
    program = tuple((s, draw(st.floats(0, 1e3, allow_nan=False))) for s in starts)
    speed = draw(st.floats(0, 1e6, allow_nan=False))
    chans = draw(st.dictionaries(CHANNEL, st.sampled_from(["um", "mm", "-", "s", "N"]),
                                 max_size=3))
    kw = dict(
        time=time,
        deflection=draw(arr),
        stiffness=draw(POSITIVE),
        weight=draw(POSITIVE),
        drive_speed=speed if drive_kind in ("speed", "all") else None,
        drive_program=program if drive_kind in ("program", "all") else None,
        drive=draw(arr) if drive_kind in ("column", "all") else None,
        lubricant=draw(st.none() | TEXT),
        surface=draw(st.none() | TEXT),
        note=draw(st.none() | TEXT),
        channels={c: draw(arr) for c in chans},
        channel_units=chans,
        truth=draw(st.none() | st.dictionaries(st.text(max_size=5), JSON, max_size=4)),
        extra_header=draw(st.dictionaries(KEY, TEXT, max_size=3)),
    )
    try:
        return Record(**kw)
    except RecordError:  # e.g. float round-off makes t0 + dt*i uneven for tiny dt
        assume(False)


@SETTINGS
@given(records())
def test_round_trip_exact(record):
    back = parse_record(format_record(record))
    assert back == record


@settings(max_examples=20, deadline=None)
@given(records())
def test_round_trip_through_a_file(record):
    p = write_record(record, Path(_TMP.name) / "rt.csv")
    assert read_record(p) == record
