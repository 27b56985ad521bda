"""Writing records: the text of a record file, in chosen units, that reads back exactly."""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..units import UnitError, factor
from .drive import format_drive_program
from .errors import RecordError
from .grammar import FORMAT_VERSION
from .quantities import channel_dimension, channel_factor, encode, fmt, internal_channel_unit
from .record import Record


def format_record(record: Record, deflection_unit: str = "mm", time_unit: str = "s", *,
                  force_unit: str | None = None, drive_unit: str = "mm",
                  channel_units: Mapping[str, str] | str | None = None) -> str:
    """The text of a record file. See `write_record`."""
    if not isinstance(record, Record):
        raise TypeError(f"format_record needs a Record, got {type(record).__name__}")
    try:
        f_time = factor(time_unit, "time")
        f_defl = factor(deflection_unit, "length")
        f_drive = factor(drive_unit, "length")
        f_force = None if force_unit is None else factor(force_unit, "force")
    except UnitError as exc:
        raise RecordError(f"write_record: {exc}") from None
    ch_units = {n: internal_channel_unit(u) for n, u in record.channel_units.items()}
    if channel_units == "original":
        ch_units = dict(record.channel_units)
    elif channel_units is not None:
        for n, u in dict(channel_units).items():
            if n not in ch_units:
                raise RecordError(f"write_record: no channel {n!r}")
            if channel_dimension(u) != channel_dimension(record.channel_units[n]):
                raise RecordError(f"write_record: channel {n!r} unit {u!r} is not a "
                                  f"{channel_dimension(record.channel_units[n])} unit")
            ch_units[n] = u
    out = [f"# stickslip-record: {FORMAT_VERSION}"]
    out.append(f"# stiffness: {fmt(record.stiffness)} kgf/mm")
    out.append(f"# slider_weight: {fmt(record.weight)} kgf")
    for key, unit in (("normal_load", "kgf"), ("friction_radius", "mm"), ("drive_speed", "mm/s")):
        if getattr(record, key) is not None:
            out.append(f"# {key}: {fmt(getattr(record, key))} {unit}")
    if record.drive_program is not None:
        out.append(f"# drive_program: {format_drive_program(record.drive_program)}")
    for key in ("lubricant", "surface", "note"):
        value = getattr(record, key)
        if value is not None:
            out.append(f"# {key}: {value}")
    if record.truth is not None:
        out.append(f"# truth: {json.dumps(record.truth)}")
    for key, value in record.extra_header.items():
        out.append(f"# {key}: {value}")
    cols = [encode(record.time, f_time)]
    heads = [f"time [{time_unit}]"]
    if f_force is None:
        cols.append(encode(record.deflection, f_defl))
        heads.append(f"deflection [{deflection_unit}]")
    else:
        cols.append(record.force / f_force)
        heads.append(f"force [{force_unit}]")
    if record.drive is not None:
        cols.append(encode(record.drive, f_drive))
        heads.append(f"drive [{drive_unit}]")
    for n, values in record.channels.items():
        u = ch_units[n]
        cols.append(encode(values, channel_factor(u)))
        heads.append(f"{n} [{u}]")
    out.append(",".join(heads))
    table = np.column_stack(cols)
    out.extend(",".join(map(repr, row)) for row in table.tolist())
    return "\n".join(out) + "\n"


def write_record(record: Record, path, *args, **options) -> Path:
    """Write `record` to `path` (UTF-8 CSV, format in the `stickslip_jax.records` docstring,
    text by `format_record(record, *args, **options)`; atomic: a full disk leaves no
    half-written record) and return the path.

    Header quantities are written in internal units (kgf/mm, kgf, mm/s) and every
    number with `repr` precision, so reading the file gives the record back exactly
    (`read_record(p) == record`). Columns are written in `deflection_unit`, `time_unit`,
    `drive_unit` and, per channel, `channel_units` (default: the internal unit of each
    channel's dimension; `"original"`: the units in `record.channel_units`; or a dict
    of some of them); in other units than mm and s a value comes back exactly whenever
    a float exists that does so, else within one unit in the last place. With
    `force_unit` a `force` column k x replaces the deflection (read back as F/k, within
    rounding).
    """
    from ..output import write_text

    path = Path(path)
    write_text(str(path), format_record(record, *args, **options))
    return path
