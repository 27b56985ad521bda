"""The paper's tables (Tables 1-4 and 6-12) shipped as CSV with the package.

The CSV files are package data (`stickslip_jax/paper_tables/`, read through
`importlib.resources`, so a normal non-editable install finds them); `data/paper/` in
the repository is a link to that folder. `$STICKSLIP_DATA/paper` overrides it.

Each CSV starts with `#` comment lines (table number and notes), then a header row
whose columns carry their unit in brackets, e.g. `stiffness [kgf/mm]`. Values are in
the internal unit system (kgf, mm, s) except where the header says otherwise (Table 1
contact pressure in kgf/cm^2, viscosities in cSt as printed). Example:
`load_table(6).row("A").delta` is 67.0.
"""

from __future__ import annotations

import csv
import dataclasses
import os
import re
from collections import namedtuple
from pathlib import Path

_HEADER = re.compile(r"^\s*([A-Za-z0-9_]+)\s*(?:\[(.*)\])?\s*$")


def paper_dir() -> Path:
    """Folder of the paper's table CSVs: `$STICKSLIP_DATA/paper` when that variable is
    set, else the package data `stickslip_jax/paper_tables` (importlib.resources)."""
    env = os.environ.get("STICKSLIP_DATA")
    if env:
        return Path(env) / "paper"
    from importlib.resources import files

    return Path(str(files("stickslip_jax") / "paper_tables"))


class MissingRowError(KeyError, ValueError):
    """A row key that a table does not have (both a `KeyError` and a `ValueError`)."""

    def __str__(self):
        return str(self.args[0]) if self.args else ""


@dataclasses.dataclass(frozen=True)
class PaperTable:
    """One table of the paper: typed rows (named tuples), the column units and its notes."""

    number: int
    title: str
    columns: tuple[str, ...]
    units: dict[str, str]
    rows: tuple
    path: Path

    def row(self, key: str):
        """The row whose first column equals `key` (e.g. a lubricant or surface name)."""
        for r in self.rows:
            if str(r[0]) == str(key):
                return r
        keys = ", ".join(str(r[0]) for r in self.rows)
        raise MissingRowError(f"Table {self.number} has no row {key!r}; available: {keys}")

    def rows_where(self, **match):
        return tuple(r for r in self.rows if all(getattr(r, k) == v for k, v in match.items()))

    def column(self, name: str) -> tuple:
        return tuple(getattr(r, name) for r in self.rows)


def _convert(cell: str):
    cell = cell.strip()
    if cell == "":
        return None
    try:
        return float(cell)
    except ValueError:
        return cell


def load_table(number: int) -> PaperTable:
    """Load Table `number` (1-4, 6-12) from `tableNN_*.csv` in `paper_dir()`."""
    folder = paper_dir()
    matches = sorted(folder.glob(f"table{number:02d}_*.csv"))
    if not matches:
        raise ValueError(f"no CSV for Table {number} in {folder}")
    path = matches[0]
    with path.open(encoding="utf-8") as fh:
        lines = fh.read().splitlines()
    notes = [ln[1:].strip() for ln in lines if ln.startswith("#")]
    body = [ln for ln in lines if ln.strip() and not ln.startswith("#")]
    reader = csv.reader(body)
    header = next(reader)
    names, units = [], {}
    for h in header:
        m = _HEADER.match(h)
        if m is None:
            raise ValueError(f"{path}: malformed column header {h!r}")
        names.append(m.group(1))
        units[m.group(1)] = m.group(2) if m.group(2) is not None else ""
    Row = namedtuple(f"Table{number}Row", names)
    rows = tuple(Row(*[_convert(c) for c in rec]) for rec in reader)
    title = notes[0] if notes else f"Table {number}"
    return PaperTable(number, title, tuple(names), units, rows, path)
