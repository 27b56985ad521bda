"""`stickslip import RAW --time-col ... --force-col|--deflection-col ... --stiffness ...`:
a raw logger file (plain CSV, TSV or `;`-separated with decimal commas, a header row of
column names, extra columns) to a record file in the stickslip format.

Columns are chosen by name (case-insensitive; `force [N]`, `Force (N)` and `force` all
match `force`) or by 0-based index; their units come from the header's brackets or
parentheses, or from `--time-unit`/`--value-unit`/`--drive-unit` (a unit is never
guessed). Time stamps of a jittered clock (`stickslip_jax.records.jittered_clock`) are
resampled to a uniform step with a note; the run's conditions take any unit pint knows (`--stiffness "852 N/um"`,
`--mass "30.7 g"`, `--speed "40 in/min"`). The input is only read; the output is written
to a temporary file and renamed, and an existing output is kept unless `--force`.
"""

from __future__ import annotations

import os
import re

NAME = "import"
HELP = "convert a raw logger file (CSV/TSV/';', decimal commas) into a record file"

_UNIT = re.compile(r"^\s*(.*?)\s*(?:\[(.*)\]|\((.*)\))?\s*$")


def add_arguments(parser):
    parser.add_argument("raw", help="the raw file (text: CSV, TSV or ';'-separated)")
    parser.add_argument("--out", required=True, help="record file to write (.csv)")
    parser.add_argument("--time-col", required=True, help="time column: name or 0-based index")
    g = parser.add_mutually_exclusive_group(required=True)
    g.add_argument("--force-col", help="spring-force column (name or index); x = F/k")
    g.add_argument("--deflection-col", help="spring-deflection column (name or index)")
    parser.add_argument("--drive-col", help="measured drive displacement column (optional)")
    parser.add_argument("--time-unit", help="unit of the time column if the header has none")
    parser.add_argument("--value-unit",
                        help="unit of the force/deflection column if the header has none")
    parser.add_argument("--drive-unit", help="unit of the drive column if the header has none")
    parser.add_argument("--stiffness", required=True, help="spring stiffness with unit, "
                        "e.g. '86.9 kgf/mm' or '852 N/um'")
    w = parser.add_mutually_exclusive_group(required=True)
    w.add_argument("--weight", help="slider weight with unit, e.g. '36 kgf' or '353 N'")
    w.add_argument("--mass", help="slider mass with unit, e.g. '36 kg' or '30.7 g'")
    parser.add_argument("--speed", help="drive speed with unit, e.g. '5 mm/min' "
                        "(required unless --drive-col)")
    parser.add_argument("--lubricant", help="lubricant name written to the record")
    parser.add_argument("--delimiter", help="cell separator (default: detected: , ; tab)")
    parser.add_argument("--force", dest="overwrite", action="store_true",
                        help="replace an existing --out file")


def _cells(line: str, delim: str | None) -> list[str]:
    return line.split() if delim is None else line.split(delim)


def read_raw(path: str, delimiter: str | None = None):
    """(names, units, data, notes) of a raw text table with a header row; comment lines
    starting with '#' before it are skipped. Raises ValueError naming the file and line."""
    import numpy as np

    with open(path, encoding="utf-8-sig") as fh:
        lines = fh.read().splitlines()
    i = 0
    while i < len(lines) and (not lines[i].strip() or lines[i].lstrip().startswith("#")):
        i += 1
    if i >= len(lines):
        raise ValueError(f"{path}: no header row (column names) found")
    head = lines[i]
    if delimiter is None:
        delim = next((d for d in (";", "\t", ",") if d in head), None)
    else:
        delim = {"tab": "\t", "\\t": "\t"}.get(delimiter, delimiter)
    names, units = [], []
    for cell in _cells(head, delim):
        m = _UNIT.match(cell.strip().strip('"'))
        names.append(m.group(1).lower())
        units.append((m.group(2) or m.group(3) or "").strip() or None)
    body = [ln.replace('"', "") for ln in lines[i + 1:] if ln.strip()]
    notes = []
    if delim in (";", "\t") and any("," in ln for ln in body[:50]):
        body = [ln.replace(",", ".") for ln in body]
        notes.append("decimal commas read as points")
    try:
        data = np.loadtxt([ln if delim is None else ln.replace(delim, " ") for ln in body],
                          ndmin=2)
    except ValueError as exc:
        raise ValueError(f"{path}: cannot read the numbers after line {i + 1} ({exc}); set "
                         "--delimiter, or remove text rows") from None
    if data.shape[1] != len(names):
        raise ValueError(f"{path}: {data.shape[1]} numbers per row but {len(names)} column "
                         f"names in line {i + 1}; set --delimiter")
    return names, units, data, notes


def _column(spec: str, names: list[str], option: str, path: str) -> int:
    if spec.strip().isdigit():
        j = int(spec)
        if j >= len(names):
            raise ValueError(f"{option}: column {j} does not exist ({len(names)} columns)")
        return j
    key = _UNIT.match(spec).group(1).lower()
    hits = [j for j, n in enumerate(names) if n == key] or [
        j for j, n in enumerate(names) if n.startswith(key)]
    if len(hits) != 1:
        raise ValueError(f"{option}: {'no' if not hits else 'more than one'} column named "
                         f"{spec!r} in {path} (columns: {', '.join(names)})")
    return hits[0]


def run(args) -> int:
    import numpy as np

    from ..records import Record, RecordError, write_record
    from ..output import write_atomic

    raw, out = os.path.abspath(args.raw), os.path.abspath(args.out)
    if raw == out:
        raise ValueError("--out: names the raw input file; choose another name")
    if os.path.isdir(out):
        raise ValueError(f"--out: {args.out} is a directory; give a file name")
    if os.path.exists(out) and not args.overwrite:
        raise ValueError(f"--out: {args.out} exists; use --force to replace it")
    if not os.path.isdir(os.path.dirname(out)):
        raise ValueError(f"--out: the folder {os.path.dirname(out)} does not exist")
    if args.speed is None and args.drive_col is None:
        raise ValueError("--speed: give the drive speed (or a --drive-col)")
    names, units, data, notes = read_raw(args.raw, args.delimiter)

    def col(spec, option, unit_option, given):
        j = _column(spec, names, option, args.raw)
        unit = given or units[j]
        if unit is None:
            raise ValueError(f"{unit_option}: column {names[j]!r} has no unit in the header; "
                             f"give it, e.g. {unit_option} s")
        return data[:, j], unit

    t, t_unit = col(args.time_col, "--time-col", "--time-unit", args.time_unit)
    kw = {}
    if args.force_col:
        kw["force"], kw["force_unit"] = col(args.force_col, "--force-col", "--value-unit",
                                            args.value_unit)
    else:
        kw["deflection"], kw["deflection_unit"] = col(
            args.deflection_col, "--deflection-col", "--value-unit", args.value_unit)
    if args.drive_col:
        kw["drive"], kw["drive_unit"] = col(args.drive_col, "--drive-col", "--drive-unit",
                                            args.drive_unit)
    order = np.argsort(t, kind="stable")
    if np.any(order != np.arange(t.size)):
        notes.append("rows sorted by time")
        t = t[order]
        for key in ("force", "deflection", "drive"):
            if key in kw:
                kw[key] = kw[key][order]
    try:
        rec = Record.from_arrays(
            t, time_unit=t_unit, stiffness=args.stiffness, weight=args.weight, mass=args.mass,
            drive_speed=args.speed, lubricant=args.lubricant,
            note=f"imported from {os.path.basename(args.raw)}", notes=tuple(notes), **kw)
    except RecordError as exc:
        raise ValueError(f"{args.raw}: {exc}") from None
    write_atomic(out, lambda tmp: write_record(rec, tmp), ".csv")
    print(f"wrote {args.out}: {rec.time.size} samples, {rec.time[-1] - rec.time[0]:.6g} s, "
          f"k = {rec.stiffness:.6g} kgf/mm, W = {rec.weight:.6g} kgf")
    for n in rec.notes:
        print("note: " + n)
    return 0
