"""The data rows of a record file: a fast reader for well-formed rows and a checked
row-by-row reader that names the line and the fix of a bad one."""

from __future__ import annotations

import math
import re
import warnings

import numpy as np

from .errors import RecordError
from .grammar import NONFINITE, NUM, NUMBER


def _cell_problem(cell: str, column: str) -> str:
    c = cell.strip()
    if c == "":
        return f"empty cell in column {column!r}; every sample needs a value"
    if c.lower() in NONFINITE:
        return f"{c} in column {column!r}; every value must be finite: remove or fill the sample"
    if "," in c:
        return f"{c!r} in column {column!r} is not a number"
    return f"{c[:40]!r} in column {column!r} is not a number; use '.' as the decimal point"


def parse_data(lines, start, columns, path):
    """The data rows as an (n, ncol) float64 array and their 1-based line numbers.

    Fast path: NumPy's C parser (`numpy.loadtxt`, correctly rounded like `float`) over
    all rows at once; when it fails, or finds a count of cells, a non-finite value or a
    line it should not accept, the checked row-by-row parser below reads the file again
    and says which line is wrong and how to fix it."""
    stop = len(lines)
    while stop > start and not lines[stop - 1].strip():
        stop -= 1
    body = lines[start:stop]
    try:
        with warnings.catch_warnings():  # no rows: said below, with the line
            warnings.simplefilter("ignore", UserWarning)
            data = np.loadtxt(body, delimiter=",", comments=None, dtype=np.float64, ndmin=2)
    except ValueError:
        data = None
    if data is not None and data.shape[1:] == (len(columns),) and bool(np.isfinite(data).all()):
        if data.shape[0] == len(body):  # no blank line inside: row k is line start + 1 + k
            return data, range(start + 1, start + 1 + len(body))
        rows = [start + 1 + k for k, ln in enumerate(body) if ln.strip()]
        if data.shape[0] == len(rows):
            return data, rows
    return parse_data_checked(lines, start, columns, path)


def parse_data_checked(lines, start, columns, path):
    """Row-by-row parser with precise errors (the format's grammar, `NUM`)."""
    ncol = len(columns)
    cell = rf"\s*{NUM}\s*"
    row_re = re.compile(cell + (rf",{cell}" * (ncol - 1)))
    rows, numbers = [], []
    fullmatch = row_re.fullmatch
    for i in range(start, len(lines)):
        line = lines[i]
        if fullmatch(line):
            rows.append(i + 1)
            numbers.append(line.split(","))
            continue
        if line.strip() == "":
            continue
        if line.lstrip().startswith("#"):
            raise RecordError(
                "header line after the column row; move every '# key: value' line above it", path,
                i + 1)
        cells = line.split(",")
        if len(cells) != ncol:
            hint = " (a decimal comma? use '.' for decimals)" if len(cells) > ncol else ""
            raise RecordError(f"{len(cells)} cells but the column row has {ncol} "
                              f"({', '.join(columns)}){hint}", path,
                              i + 1)
        for c, name in zip(cells, columns):
            if not NUMBER.fullmatch(c.strip()):
                raise RecordError(_cell_problem(c, name), path, i + 1)
        raise RecordError("cannot read this row", path, i + 1)  # pragma: no cover
    if not numbers:
        return np.zeros((0, ncol)), rows
    with np.errstate(over="ignore"):
        data = np.array(numbers, dtype=np.float64)
    if not np.all(np.isfinite(data)):
        r, c = np.argwhere(~np.isfinite(data))[0]
        raise RecordError(
            f"{numbers[r][c].strip()!r} in column {columns[c]!r} is out of the float range", path,
            rows[r])
    return data, rows


def resolution_of(text: str) -> float:
    """Resolution of a written number: 10**-(decimals) scaled by its exponent."""
    t = text.strip().lower()
    mant, _, exp = t.partition("e")
    d = len(mant.partition(".")[2])
    try:
        return 10.0 ** (int(exp or 0) - d)
    except (OverflowError, ValueError):
        return math.inf

