"""`stickslip import RAW --time-col ... --force-col|--deflection-col ... --stiffness ...`:
a raw logger file to a record file in the stickslip format. What it reads (separators,
decimal commas, encodings, preambles, units rows, clock stamps) and how columns and their
units are chosen (never guessed): docs/records.md, "Raw logger files".
"""

from __future__ import annotations

import math
import os
import re

NAME = "import"
HELP = "convert a raw logger file (CSV/TSV/';', decimal commas) into a record file"


def add_arguments(parser):
    parser.add_argument("raw", help="the raw file (text: CSV, TSV or ';'-separated)")
    parser.add_argument("--out", required=True, help="record file to write (.csv)")
    parser.add_argument("--time-col", required=True, help="time column: name or 0-based index")
    g = parser.add_mutually_exclusive_group(required=True)
    g.add_argument("--force-col", help="spring-force column (name or index); x = F/k")
    g.add_argument("--deflection-col", help="spring-deflection column (name or index)")
    parser.add_argument("--drive-col", help="measured drive displacement column (optional)")
    parser.add_argument("--time-unit", help="unit of the time column if the header has none "
                        "(one contradicting the header is refused)")
    parser.add_argument("--value-unit", help="unit of the force/deflection column if the "
                        "header has none (one contradicting the header is refused)")
    parser.add_argument("--drive-unit", help="unit of the drive column if the header has none "
                        "(one contradicting the header is refused)")
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


_CLOCK = re.compile(r"\s*(?:(\d{4}-\d\d-\d\d)[ T])?(\d{1,2}):(\d\d):(\d\d(?:[.,]\d*)?)\s*")


def _number(cell: str, comma: bool) -> float:
    """A cell as a number: a decimal comma (`comma`) is a point, `hh:mm:ss.fff` (with or
    without a date) is seconds; ValueError otherwise."""
    c = cell.strip().strip('"').strip()
    m = _CLOCK.fullmatch(c)
    if m is not None:
        day = 0.0
        if m.group(1):
            import datetime

            day = datetime.date.fromisoformat(m.group(1)).toordinal() * 86400.0
        return day + int(m.group(2)) * 3600.0 + int(m.group(3)) * 60.0 + float(
            m.group(4).replace(",", "."))
    value = float(c.replace(",", ".") if comma else c)
    if not math.isfinite(value):
        raise ValueError(c)
    return value


def _split(line: str, delim: str | None) -> list[str]:
    from ..records.dialects import split_cells

    return split_cells(line, delim, '"' in line)


def _numeric(cells: list[str], comma: bool) -> bool:
    try:
        for c in cells:
            _number(c, comma)
    except ValueError:
        return False
    return len(cells) >= 2


def _layout(lines: list[str], delimiter: str | None):
    """(separator, index of the first data row): the separator (given, or the first of
    `;`, tab, `,`, blanks) and decimal convention under which three rows in a row have the
    same number (2 or more) of numeric cells."""
    delims = [delimiter] if delimiter is not None else [";", "\t", ",", None]
    rows = [i for i, ln in enumerate(lines) if ln.strip() and not ln.lstrip().startswith("#")]
    for delim in delims:
        for comma in ((False, True) if delim != "," else (False,)):
            for k in range(min(len(rows), 202)):
                window = [_split(lines[i], delim) for i in rows[k:k + 3]]
                if all(len(w) == len(window[0]) and _numeric(w, comma) for w in window):
                    return delim, rows[k]
    return None


def _seconds(line: str, clock: list[int]) -> str:
    """A data row with its `hh:mm:ss.fff` cells in columns `clock` written as seconds."""
    cells = line.split(",")
    for k in clock:
        if k < len(cells) and _CLOCK.fullmatch(cells[k]):
            cells[k] = repr(_number(cells[k], True))
    return ",".join(cells)


def read_raw(path: str, delimiter: str | None = None):
    """(names, units, data, notes) of a raw text table: lines above its column row
    (a logger's preamble, with or without '#') are skipped, a units row under it is read,
    `hh:mm:ss.fff` stamps are seconds; the file's bytes, Excel's `sep=` line, separators
    and decimal commas go through `stickslip_jax.records`' reader (`dialects`), its data
    rows through `records.rows.parse_data`. Raises ValueError naming the file and line."""
    from pathlib import Path

    from ..records.dialects import decode, normalise_dialect, read_bytes, spreadsheet_header
    from ..records.grammar import MAX_FILE_BYTES, column_label
    from ..records.rows import parse_data

    notes: list[str] = []
    text = decode(read_bytes(Path(path), MAX_FILE_BYTES), path, notes)
    lines, sep = spreadsheet_header(text.splitlines(), notes)
    if delimiter is not None:
        delimiter = {"tab": "\t", "\\t": "\t"}.get(delimiter, delimiter)
    found = _layout(lines, delimiter or sep)
    if found is None:
        raise ValueError(f"{path}: no rows of numbers found (three rows in a row with the "
                         "same number of numeric cells); set --delimiter, or check the file")
    delim, first = found
    width = len(_split(lines[first], delim))
    above = [i for i in range(first) if lines[i].strip() and not lines[i].lstrip()
             .startswith("#") and len(_split(lines[i], delim)) == width]
    if not above:
        raise ValueError(f"{path}: no column row (names) above the numbers at line "
                         f"{first + 1}; add one, e.g. 'time [s];force [N]'")
    head, unit_row = above[-1], None
    if len(above) > 1 and above[-1] == first - 1 and above[-2] < above[-1]:
        head, unit_row = above[-2], _split(lines[above[-1]], delim)
        notes.append(f"units row read from line {above[-1] + 1}")
    skipped = sum(1 for ln in lines[:head] if ln.strip())
    if skipped:
        notes.append(f"column row at line {head + 1}; the {skipped} line(s) above it skipped")
    names, units = [], []
    for k, cell in enumerate(_split(lines[head], delim)):
        name, unit = column_label(cell.strip().strip('"'))
        if unit is None and unit_row is not None:
            unit = unit_row[k].strip().strip('"').strip("[]()").strip() or None
        names.append(name.lower())
        units.append(unit)
    clock = [k for k, c in enumerate(_split(lines[first], delim))
             if _CLOCK.fullmatch(c.strip().strip('"'))]
    body = ["" if ln.lstrip().startswith("#") else ln for ln in lines[head:]]
    body = ([",".join(ln.split()) for ln in body] if delim is None
            else normalise_dialect(body, notes, delim))
    if clock:
        body = [_seconds(ln, clock) if ln.strip() else ln for ln in body]
    data, _ = parse_data(lines[:head] + body, first, names, path)
    for k in clock:
        units[k] = units[k] or "s"
        data[:, k] -= data[:, k].min()
        notes.append(f"column {names[k]!r}: clock stamps (hh:mm:ss) read as seconds from "
                     "the first")
    return names, units, data, notes


def _column(spec: str, names: list[str], option: str, path: str) -> int:
    if spec.strip().isdigit():
        j = int(spec)
        if j >= len(names):
            raise ValueError(f"{option}: column {j} does not exist ({len(names)} columns)")
        return j
    from ..records.grammar import column_label

    key = column_label(spec)[0].lower()
    hits = [j for j, n in enumerate(names) if n == key] or [
        j for j, n in enumerate(names) if n.startswith(key)]
    if len(hits) != 1:
        raise ValueError(f"{option}: {'no' if not hits else 'more than one'} column named "
                         f"{spec!r} in {path} (columns: {', '.join(names)})")
    return hits[0]


def run(args) -> int:
    import numpy as np

    from ..output import check_outputs
    from ..records import Record, RecordError, write_record

    check_outputs({"--out": args.out}, [args.raw])  # a writable place, not the raw file
    if os.path.exists(args.out) and not args.overwrite:
        raise ValueError(f"--out: {args.out} exists; use --force to replace it")
    if args.drive_unit is not None and args.drive_col is None:
        raise ValueError("--drive-unit: only used with --drive-col; add it, or leave out "
                         "--drive-unit")
    if args.speed is None and args.drive_col is None:
        raise ValueError("--speed: give the drive speed (or a --drive-col)")
    names, units, data, notes = read_raw(args.raw, args.delimiter)

    def col(spec, option, unit_option, given):
        j = _column(spec, names, option, args.raw)
        unit = given or units[j]
        if given and units[j] and given.strip() != units[j]:
            raise ValueError(f"{unit_option} {given}: contradicts the unit {units[j]!r} of "
                             f"column {names[j]!r} in {args.raw}; drop {unit_option} (or "
                             "fix the file's header)")
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
    write_record(rec, args.out)  # atomic (`stickslip_jax.output.write_text`)
    print(f"wrote {args.out}: {rec.time.size} samples, {rec.time[-1] - rec.time[0]:.6g} s, "
          f"k = {rec.stiffness:.6g} kgf/mm, W = {rec.weight:.6g} kgf")
    for n in rec.notes:
        print("note: " + n)
    return 0
