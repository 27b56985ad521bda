"""The record file format's vocabulary: its version, size limit, reserved column names and
header keys, and the regular expressions of its grammar."""

from __future__ import annotations

import re

FORMAT_VERSION = "1"
"""The version in a record's first line, `# stickslip-record: 1`."""

MAX_FILE_BYTES = 200 * 1024 * 1024
"""Largest record file read (200 MiB, about 10 million samples of two columns)."""

RESERVED_COLUMNS = ("time", "deflection", "force", "drive")
KNOWN_KEYS = ("stickslip-record", "stiffness", "slider_weight", "slider_mass", "normal_load",
              "friction_radius", "torsional_stiffness", "inertia", "drive_speed", "drive_program",
              "lubricant", "surface", "note", "truth")

NUM = r"[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?"
NUMBER = re.compile(NUM)
QUANTITY = re.compile(rf"\s*({NUM})\s*(.*?)\s*")
SEGMENT = re.compile(rf"\s*({NUM})\s*([^\s\d.+-]\S*)\s+({NUM})\s*(\S+)\s*")
HEADER = re.compile(r"#\s*([A-Za-z][A-Za-z0-9_ -]*?)\s*:(.*)")
COLUMN = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*(?:\[([^\[\]]*)\]|\(([^()]*)\))?\s*")
"""A column cell: `name [unit]`, `name (unit)`, or a bare `name` whose unit a units row
under the column row or a `# <name>_unit:` header line gives."""
UNIT_CELL = re.compile(r"-|[A-Za-z\u00b5\u03bc%][A-Za-z0-9\u00b5\u03bc/*^.\u00b0% -]*")
"""A cell of a units row: `s`, `mm`, `um/s`, `-`."""
NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
KEY = re.compile(r"[a-z][a-z0-9_-]*")
NONFINITE = {"nan", "+nan", "-nan", "inf", "+inf", "-inf", "infinity", "+infinity", "-infinity"}
LABEL = re.compile(r"^\s*(.*?)\s*(?:\[(.*)\]|\((.*)\))?\s*$", re.DOTALL)


def column_label(label) -> tuple[str, str | None]:
    """(name, unit or None) of a table's column label: `"force [N]"`, `"Force (N)"`,
    `"force"` (a DataFrame's, a raw logger file's)."""
    m = LABEL.match(str(label))
    return m.group(1), ((m.group(2) or m.group(3) or "").strip() or None)
