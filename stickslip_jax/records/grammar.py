"""The record file format's vocabulary: its version, size limit, reserved column names and
header keys, and the regular expressions of its grammar."""

from __future__ import annotations

import re

FORMAT_VERSION = "1"
"""The version in a record's first line, `# stickslip-record: 1`."""

MAX_FILE_BYTES = 200 * 1024 * 1024
"""Largest record file read (200 MiB, about 10 million samples of two columns)."""

RESERVED_COLUMNS = ("time", "deflection", "force", "drive")
KNOWN_KEYS = (
    "stickslip-record",
    "stiffness",
    "slider_weight",
    "slider_mass",
    "drive_speed",
    "drive_program",
    "lubricant",
    "surface",
    "note",
    "truth",
)

_NUM = r"[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?"
_NUMBER = re.compile(_NUM)
_QUANTITY = re.compile(rf"\s*({_NUM})\s*(.*?)\s*")
_SEGMENT = re.compile(rf"\s*({_NUM})\s*([^\s\d.+-]\S*)\s+({_NUM})\s*(\S+)\s*")
_HEADER = re.compile(r"#\s*([A-Za-z][A-Za-z0-9_-]*)\s*:(.*)")
_COLUMN = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*\[([^\[\]]*)\]\s*")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_KEY = re.compile(r"[a-z][a-z0-9_-]*")
_NONFINITE = {"nan", "+nan", "-nan", "inf", "+inf", "-inf", "infinity", "+infinity", "-infinity"}
