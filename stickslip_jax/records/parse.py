"""Reading a record file: the header, the column row, the run's conditions, the data rows
and the clock, each read in the order a reader meets them, into one `Record`; the values
are checked once, by `Record`, and its refusals reported at the file's line (`_at_line`)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from ..units import G_MM_S2, UnitError, factor
from .dialects import decode, normalise_dialect, read_bytes, spreadsheet_header, text_lines
from .drive import parse_drive_program, speed_position
from .errors import RecordError
from .grammar import (COLUMN, FORMAT_VERSION, HEADER, KEY, KNOWN_KEYS, MAX_FILE_BYTES, NUMBER,
                      QUANTITY, RESERVED_COLUMNS, UNIT_CELL)
from .quantities import channel_factor, quantity, unit_choices
from .record import UNEVEN_FIX, Record
from .rig import RIG_COLUMNS, rig_header
from .rows import parse_data, resolution_of
from .sampling import uniform_clock

_DIMENSIONS = {"time": "time", "deflection": "length", "force": "force", "drive": "length",
               "drive_speed": "speed"}


def _split_lines(text: str, path: str, notes: list[str]) -> tuple[list[str], str | None]:
    """The lines of a record's text whose first non-blank line is the format's first line
    (a spreadsheet's header put back, `spreadsheet_header`), and the separator of an
    Excel `sep=` line (or None)."""
    if text.startswith("\ufeff"):
        text = text[1:]
    if text.strip() == "":
        raise RecordError("file is empty; a record starts with '# stickslip-record: 1'", path)
    if "\x00" in text:
        raise RecordError("binary content (NUL character); a record is UTF-8 CSV text", path)
    lines, delim = spreadsheet_header(text_lines(text, path), notes)
    first = next((i for i, ln in enumerate(lines) if ln.strip()), 0)
    m = HEADER.fullmatch(lines[first].strip())
    if m is None or _key(m.group(1)) != "stickslip-record":
        raise RecordError(f"the first line must be '# stickslip-record: {FORMAT_VERSION}', "
                          f"got {lines[first][:60]!r}", path,
                          first + 1)
    return lines, delim


def _key(key: str) -> str:
    """A header key as the format spells it: `Stiffness`, `drive speed` and `Drive-Speed`
    are `stiffness` and `drive_speed`; a key the format does not know is kept as written."""
    canon = re.sub(r"[\s_-]+", "_", key.strip().lower())
    canon = "stickslip-record" if canon == "stickslip_record" else canon
    return canon if canon in KNOWN_KEYS or canon.endswith("_unit") else key.strip()


def _header(lines: list[str], path: str, notes: list[str]):
    """({key: (value, line)}, index of the column row) of the header lines; a comment line
    that is not `# key: value` is left out with a note."""
    header: dict[str, tuple[str, int]] = {}
    comments = []
    i = 0
    while i < len(lines):
        line = lines[i].strip()
        if line == "":
            i += 1
            continue
        if not line.startswith("#"):
            break
        m = HEADER.fullmatch(line)
        key = None if m is None else _key(m.group(1))
        if key is None or not KEY.fullmatch(key.lower()):
            comments.append(str(i + 1))
            i += 1
            continue
        value = m.group(2).strip()
        if key in header:
            raise RecordError(
                f"{key} given twice (also at line {header[key][1]}); keep one", path, i + 1)
        header[key] = (value, i + 1)
        i += 1
    if comments:
        notes.append(f"comment line(s) {', '.join(comments[:5])} left out (not "
                     "'# key: value'; free text belongs in '# note: ...')")
    version = header["stickslip-record"][0]
    if version != FORMAT_VERSION:
        raise RecordError(f"unsupported format version {version!r}; this reader knows "
                          f"'stickslip-record: {FORMAT_VERSION}'", path,
                          header["stickslip-record"][1])
    if i >= len(lines):
        raise RecordError(
            "no column row after the header; add e.g. 'time [s],deflection [mm]' and the data",
            path,
            max(j + 1 for j, ln in enumerate(lines) if ln.strip()))
    return header, i


def _column_factor(name: str, unit: str, path: str, column_line: int, rig=None) -> float:
    """The factor to internal units of a column `name [unit]`."""
    if name in _DIMENSIONS:
        try:
            return (factor if rig is None else rig.factor)(unit, _DIMENSIONS[name])
        except UnitError:
            raise RecordError(
                f"column {name!r}: unknown {_DIMENSIONS[name]} unit {unit!r}; use one of "
                f"{unit_choices(_DIMENSIONS[name])}", path,
                column_line) from None
    try:
        return channel_factor(unit)
    except UnitError:
        raise RecordError(f"column {name!r}: unknown unit {unit!r}; use a unit of length, time, "
                          "force, speed, ... (e.g. um) or '-' for a pure number", path,
                          column_line) from None


def _units_row(lines: list[str], i: int) -> list[str] | None:
    """The cells of a units row under the column row (a logger's `s,mm`), or None."""
    j = next((k for k in range(i + 1, min(i + 4, len(lines))) if lines[k].strip()), None)
    if j is None:
        return None
    cells = [c.strip().strip("[]()").strip() for c in lines[j].split(",")]
    if not any(cells) or any(NUMBER.fullmatch(c) or not UNIT_CELL.fullmatch(c) for c in cells):
        return None
    lines[j] = ""  # not a data row
    return cells


def _column_row(lines: list[str], i: int, header, path: str, rig=None):
    """(names, units, factors to internal units) of the column row `lines[i]`; a unit is
    the cell's brackets or parentheses, a units row under it, or a `# <name>_unit:` line,
    and two of them that differ are refused."""
    row, column_line = lines[i], i + 1
    unit_row = _units_row(lines, i)
    columns, units = [], []
    for k, cell in enumerate(row.split(",")):
        cm = COLUMN.fullmatch(cell)
        if cm is None and cell.count("[") > 1:
            raise RecordError(
                f"the column row {row.strip()[:60]!r} has no ',', ';' or tab between "
                "its columns; separate them (and the values) with ',' (or ';' or tabs)", path,
                column_line)
        if cm is None:
            raise RecordError(f"column {cell.strip()[:40]!r} must be 'name [unit]' "
                              "(e.g. 'time [s]', '[-]' for a pure number)", path, column_line)
        name = cm.group(1).lower() if cm.group(1).lower() in RESERVED_COLUMNS else cm.group(1)
        name = name if rig is None else RIG_COLUMNS.get(name, name)  # angle, torque
        given = {"column row": cm.group(2) if cm.group(2) is not None else cm.group(3)}
        if unit_row is not None and k < len(unit_row) and unit_row[k]:
            given["units row"] = unit_row[k]
        if f"{name}_unit" in header:
            given[f"header '{name}_unit'"] = header[f"{name}_unit"][0]
        given = {w: u.strip() for w, u in given.items() if u is not None}
        if not given:
            raise RecordError(
                f"column {cell.strip()[:40]!r} must be 'name [unit]' (e.g. 'time [s]', "
                f"'[-]' for a pure number), or give its unit in '# {name}_unit: ...'", path,
                column_line)
        if len(set(given.values())) > 1:
            raise RecordError(f"column {name!r}: the units disagree ("
                              + ", ".join(f"{u!r} in the {w}" for w, u in given.items())
                              + "); keep one", path, column_line)
        if name in columns:
            raise RecordError(f"column {name!r} appears twice", path, column_line)
        columns.append(name)
        units.append(next(iter(given.values())))
    factors = [_column_factor(n, u, path, column_line, rig) for n, u in zip(columns, units)]
    if "time" not in columns:
        raise RecordError(
            f"no 'time [s]' column (columns: {', '.join(columns)})", path, column_line)
    if ("deflection" in columns) == ("force" in columns):
        what = "both" if "deflection" in columns else "neither"
        raise RecordError(
            f"{what} of 'deflection' and 'force' columns; give exactly one", path, column_line)
    return columns, units, factors


def _weight(header, path: str, column_line: int) -> float:
    """The slider weight W in kgf from `slider_weight` or `slider_mass` (W = m g)."""
    if "slider_weight" in header and "slider_mass" in header:
        raise RecordError("both slider_weight and slider_mass given; keep one", path,
                          header["slider_mass"][1])
    if "slider_mass" in header:
        m_text, w_line = header["slider_mass"]
        mm = QUANTITY.fullmatch(m_text)
        if mm is not None and mm.group(2).strip() == "kg":
            weight = float(mm.group(1))  # 1 kg weighs 1 kgf (W = m g, standard gravity)
        else:
            weight = quantity(m_text, "mass", "slider_mass", path, w_line) * G_MM_S2
    else:
        if "slider_weight" not in header:
            raise RecordError("missing header line '# slider_weight: 36.0 kgf'", path,
                              column_line)
        w_text, w_line = header["slider_weight"]
        weight = quantity(w_text, "force", "slider_weight", path, w_line)
    return weight


def _conditions(header, path: str, column_line: int) -> dict:
    """The `Record` fields the header gives: stiffness, weight, drive, texts, truth, extra
    (their values checked by `Record`)."""
    if "stiffness" not in header:
        raise RecordError("missing header line '# stiffness: 86.9 kgf/mm'", path, column_line)
    k_text, k_line = header["stiffness"]
    stiffness = quantity(k_text, "stiffness", "stiffness", path, k_line)
    weight = _weight(header, path, column_line)
    drive_speed = None
    if "drive_speed" in header:
        v_text, v_line = header["drive_speed"]
        drive_speed = quantity(v_text, "speed", "drive_speed", path, v_line)
    program = None
    if "drive_program" in header:
        program = parse_drive_program(header["drive_program"][0], path, header["drive_program"][1])
    fields = dict(stiffness=stiffness, weight=weight, drive_speed=drive_speed,
                  drive_program=program)
    for key in ("lubricant", "surface", "note"):
        fields[key] = header[key][0] if key in header else None
    truth = None
    if "truth" in header:
        t_text, t_line = header["truth"]
        try:
            truth = json.loads(t_text)
        except (ValueError, RecursionError) as exc:
            raise RecordError(f"truth: not valid JSON ({str(exc)[:80]})", path, t_line) from None
    fields["truth"] = truth
    fields["extra_header"] = {key: value for key, (value, _) in header.items()
                              if key not in KNOWN_KEYS}
    return fields


def _data(lines, start, columns, factors, path: str):
    """(data rows in internal units, their line numbers) after the column row."""
    data, rows = parse_data(lines, start, columns, path)
    with np.errstate(over="ignore", invalid="ignore"):
        data = data * np.array(factors)
    if not np.all(np.isfinite(data)):
        r, c = np.argwhere(~np.isfinite(data))[0]
        raise RecordError(f"column {columns[c]!r} overflows after unit conversion", path, rows[r])
    return data, rows


_HEADER_OF = {"weight": ("slider_weight", "slider_mass")}
"""The header keys a `Record` field comes from, where they are not its name."""


def _at_line(exc: RecordError, path: str, header, rows, column_line: int, time, written):
    """`Record`'s refusal `exc` at the file's line: the header line of its field, the
    data row of its sample (the clock is resampled only where it was increasing and
    becomes uniform, so a refused sample's row is the file's), else the column row. An
    uneven step within the rounding of its written time stamps (`written(r)`: the last
    digit of row r's, s) says so."""
    line = next((header[k][1] for k in _HEADER_OF.get(exc.field, (exc.field,)) if k in header),
                None)
    if exc.index is not None:
        line = rows[exc.index]
    elif exc.field == "time" and rows:
        line = rows[-1]
    reason = exc.reason
    if exc.field == "time step":
        i = exc.index
        mean = (time[-1] - time[0]) / (time.shape[0] - 1)
        rounding = 0.5 * (written(i - 1) + written(i))  # of a written step
        if abs(time[i] - time[i - 1] - mean) <= 1.01 * rounding:
            reason = reason.replace(UNEVEN_FIX, "this is within the rounding of the written "
                                    "digits: if the time stamps were rounded, write them with "
                                    "more digits, else resample uniformly")
    return RecordError(reason, path, line or column_line)


def parse_record(text: str, source=None, notes=()) -> Record:
    """Parse the text of a record file; `source` names it in errors and in `Record.source`;
    `notes` come first in `Record.notes` (what reading the bytes did)."""
    path = "<text>" if source is None else str(source)
    notes = list(notes)
    lines, delim = _split_lines(text, path, notes)
    header_in, i = _header(lines, path, notes)
    rig, header, rig_fields = rig_header(header_in, path)
    column_line = i + 1
    lines = lines[:i] + normalise_dialect(lines[i:], notes, delim)
    columns, units, factors = _column_row(lines, i, header, path, rig)
    fields = _conditions(header, path, column_line)
    data, rows = _data(lines, i + 1, columns, factors, path)
    j = columns.index("time")
    # epoch stamps, a logger's dropped samples and jitter, each with a note
    time, cols = uniform_clock(data[:, j], [data[:, c] for c in range(data.shape[1]) if c != j],
                               notes)
    data = np.column_stack(cols[:j] + [time] + cols[j:])
    if "deflection" in columns:
        deflection = data[:, columns.index("deflection")]
    else:
        with np.errstate(divide="ignore", invalid="ignore"):  # a stiffness Record refuses
            deflection = data[:, columns.index("force")] / fields["stiffness"]
    channels = {name: data[:, c] for c, name in enumerate(columns) if name not in RESERVED_COLUMNS}
    unit_of = dict(zip(columns, units))
    drive = data[:, columns.index("drive")] if "drive" in columns else None
    if drive is None and "drive_speed" in columns:  # a tachometer: one drive downstream
        drive = speed_position(data[:, j], data[:, columns.index("drive_speed")])
        notes.append("drive displacement integrated from the drive_speed column")
    try:
        return Record(time=data[:, j], deflection=deflection, drive=drive, channels=channels,
                      channel_units={name: unit_of[name] for name in channels},
                      source=None if source is None else str(source), notes=tuple(notes), **fields,
                      **rig_fields)
    except RecordError as exc:
        def written(r):
            return resolution_of(lines[rows[r] - 1].split(",")[j]) * factors[j]

        raise _at_line(exc, path, {**header_in, **header}, rows, column_line, data[:, j],
                       written) from None


def read_record(path, *, max_bytes: int = MAX_FILE_BYTES) -> Record:
    """Read one record file (format in the `stickslip_jax.records` docstring); raises
    `RecordError`."""
    path = Path(path)
    notes: list[str] = []
    text = decode(read_bytes(path, max_bytes), path, notes, max_bytes)
    return parse_record(text, source=path, notes=notes)
