"""Records and pandas DataFrames: a record built from a table's columns chosen by label
(`Record.from_dataframe`), and a record as a table with units in its column names
(`Record.to_dataframe`). pandas is imported only when one of them is called."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping

import numpy as np

from ..units import UnitError
from .errors import RecordError
from .grammar import FORMAT_VERSION, NAME, RESERVED_COLUMNS, column_label
from .quantities import channel_factor, internal_channel_unit

_MARK = "stickslip-record"
"""The `attrs` key that marks a frame made by `Record.to_dataframe` (the format version)."""

_OWN_COLUMNS = ("time_s", "x_mm", "force_kgf", "drive_mm")


def _unit_suffix(unit: str) -> str:
    """A unit as the tail of a column name: `mm` -> `mm`, `kgf/mm` -> `kgf_per_mm`,
    `-` (a pure number) -> `1`."""
    if unit.strip() in ("", "-"):
        return "1"
    return re.sub(r"[^A-Za-z0-9]+", "_", unit.strip().replace("/", "_per_")).strip("_")


class _Columns:
    """The columns of a DataFrame, found by full label or by name (case-insensitive)."""

    def __init__(self, pd, df, notes: list[str]):
        self.pd, self.df, self.notes = pd, df, notes
        self.labels = list(df.columns)
        self.parsed = {i: column_label(c) for i, c in enumerate(self.labels)}
        self.listing = ", ".join(repr(str(c)) for c in self.labels)

    def find(self, spec, what, *, index_ok=False, required=True):
        """The position of the column `spec` names, `"index"`, or None (not `required`)."""
        if spec is None:
            return None
        df = self.df
        hits = [i for i, c in enumerate(self.labels) if c == spec]
        if not hits:
            key = column_label(spec)[0].lower()
            hits = [i for i, (name, _) in self.parsed.items() if name.lower() == key]
        if len(hits) == 1:
            return hits[0]
        if not hits and index_ok and df.index.name is not None and (
                df.index.name == spec
                or column_label(df.index.name)[0].lower() == column_label(spec)[0].lower()):
            return "index"
        if not hits and not required:
            return None
        raise RecordError(f"{what}={spec!r}: {'no' if not hits else 'more than one'} "
                          f"column named so (columns: {self.listing})")

    def series(self, j):
        return self.pd.Series(self.df.index) if j == "index" else self.df.iloc[:, j]

    def label_of(self, j):
        return str(self.df.index.name) if j == "index" else str(self.labels[j])

    def values(self, j, what, given_unit):
        """(numbers, unit) of column `j` (or the index)."""
        pd = self.pd
        col, label = self.series(j), self.label_of(j)
        if what == "time" and (pd.api.types.is_datetime64_any_dtype(col)
                               or pd.api.types.is_timedelta64_dtype(col)):
            self.notes.append(f"time from the {label!r} stamps, counted from the first one")
            return (col - col.iloc[0]).dt.total_seconds().to_numpy(np.float64), "s"
        if not pd.api.types.is_numeric_dtype(col):
            raise RecordError(f"column {label!r} ({what}) is not numeric (dtype "
                              f"{col.dtype}); convert it first, e.g. pd.to_numeric or "
                              "read_csv(..., decimal=',')")
        unit = given_unit or (self.parsed[j][1] if j != "index" else column_label(label)[1])
        if unit is None:
            raise RecordError(f"column {label!r} has no unit in its label: give "
                              f"{what}_unit=..., or name it '{column_label(label)[0]} [unit]'")
        return col.to_numpy(np.float64), unit


def _extra_channels(cols: _Columns, used, extra_columns) -> tuple[dict, dict]:
    """(channels in internal units, their units) of the columns `extra_columns` chooses."""
    pd, df, labels, parsed, notes = cols.pd, cols.df, cols.labels, cols.parsed, cols.notes
    channels, channel_units = {}, {}
    if isinstance(extra_columns, str) and extra_columns == "all":
        chosen, units, strict = [i for i in range(len(labels)) if i not in used], {}, False
    elif isinstance(extra_columns, str):
        raise RecordError(f"extra_columns must be 'all', a list of labels or "
                          f"{{label: unit}}, got {extra_columns!r}")
    else:
        units = dict(extra_columns) if isinstance(extra_columns, Mapping) else {}
        chosen = [cols.find(c, "extra_columns") for c in extra_columns]
        units = {j: units[c] for j, c in zip(chosen, extra_columns) if c in units}
        strict = True
    for j in chosen:
        col, label = df.iloc[:, j], str(labels[j])
        name = re.sub(r"[^A-Za-z0-9_]+", "_", parsed[j][0]).strip("_")
        name = "_" + name if name[:1].isdigit() else name
        problem = None
        if not pd.api.types.is_numeric_dtype(col):
            problem = f"is not numeric (dtype {col.dtype})"
        elif not NAME.fullmatch(name) or name in RESERVED_COLUMNS:
            problem = f"gives the channel name {name!r}, which is reserved or empty"
        elif name in channels:
            problem = f"gives the channel name {name!r} a second time"
        if problem is not None:
            if strict:
                raise RecordError(f"extra column {label!r} {problem}; convert or rename "
                                  "it, or leave it out of extra_columns")
            notes.append(f"column {label!r} left out: it {problem}")
            continue
        unit = units.get(j) or parsed[j][1]
        if unit is None:
            unit = "-"
            notes.append(f"column {label!r} has no unit: kept as a pure number")
        try:
            f = channel_factor(unit)
        except UnitError as exc:
            raise RecordError(f"extra column {label!r}: {exc}") from None
        channels[name] = col.to_numpy(np.float64) * f
        channel_units[name] = unit
    return channels, channel_units


def _same(value, default) -> bool:
    return value is default or (isinstance(value, str) and value == default)


def record_from_dataframe(cls, df, *, time, deflection, force, drive, stiffness, weight,
                          mass, drive_speed, time_unit, deflection_unit, force_unit,
                          drive_unit, extra_columns, **fields):
    """`Record.from_dataframe` (its docstring says what each argument does); `cls` is the
    record class whose `from_arrays` builds the result."""
    pd = pandas_module("Record.from_dataframe", "pip install pandas (or pass the columns' "
                       "arrays to Record.from_arrays)")
    if not isinstance(df, pd.DataFrame):
        raise RecordError(f"from_dataframe needs a pandas DataFrame, got "
                          f"{type(df).__name__}")
    if stiffness is None:
        if df.attrs.get(_MARK) != FORMAT_VERSION:
            raise TypeError("Record.from_dataframe() missing 1 required keyword-only "
                            "argument: 'stiffness'")
        options = dict(time=(time, "time"), deflection=(deflection, None),
                       force=(force, None), drive=(drive, None), weight=(weight, None),
                       mass=(mass, None), drive_speed=(drive_speed, None),
                       time_unit=(time_unit, None), deflection_unit=(deflection_unit, None),
                       force_unit=(force_unit, None), drive_unit=(drive_unit, None),
                       extra_columns=(extra_columns, "all"))
        given = {k: v for k, (v, default) in options.items() if not _same(v, default)}
        return _from_own_frame(cls, df, given, fields)
    if "channels" in fields or "channel_units" in fields:
        raise RecordError("from_dataframe makes the channels from the other columns; "
                          "choose them with extra_columns= (a list, or {label: unit})")
    notes = list(fields.pop("notes", ()))
    cols = _Columns(pd, df, notes)
    j_time = "index" if time is None else cols.find(time, "time", index_ok=True)
    if deflection is None and force is None:
        found = [(k, i) for k in ("deflection", "force")
                 if (i := cols.find(k, k, required=False)) is not None]
        if len(found) != 1:
            raise RecordError("name the deflection= or the force= column (columns: "
                              f"{cols.listing})")
        (which, j_x), = found
    elif deflection is not None and force is not None:
        raise RecordError("give exactly one of deflection= and force=")
    else:
        which = "deflection" if deflection is not None else "force"
        j_x = cols.find(deflection if deflection is not None else force, which)
    j_drive = cols.find("drive" if drive is None else drive, "drive",
                        required=drive is not None)
    t, t_unit = cols.values(j_time, "time", time_unit)
    x, x_unit = cols.values(j_x, which,
                            deflection_unit if which == "deflection" else force_unit)
    kw = {which: x, f"{which}_unit": x_unit}
    if j_drive is not None:
        kw["drive"], kw["drive_unit"] = cols.values(j_drive, "drive", drive_unit)
    used = {j for j in (j_time, j_x, j_drive) if j is not None}
    channels, channel_units = _extra_channels(cols, used, extra_columns)
    return cls.from_arrays(t, time_unit=t_unit, stiffness=stiffness, weight=weight,
                           mass=mass, drive_speed=drive_speed, channels=channels,
                           channel_units=channel_units, notes=tuple(notes), **kw,
                           **fields)


def _channel_columns(record) -> dict[str, str]:
    """{channel: its `to_dataframe` column `<channel>_<internal unit>`}."""
    out = {}
    for name in record.channels:
        column = f"{name}_{_unit_suffix(internal_channel_unit(record.channel_units[name]))}"
        if column in _OWN_COLUMNS or column in out.values():
            raise RecordError(f"to_dataframe: channel {name!r} would be the column "
                              f"{column!r} a second time; rename the channel")
        out[name] = column
    return out


def pandas_module(what: str, how: str = 'pip install "stickslip-jax[pandas]" (or pip '
                                         "install pandas)"):
    """pandas, or an ImportError naming `what` needs it and `how` to install it."""
    try:
        import pandas
    except ImportError:
        raise ImportError(f"{what} needs pandas: {how}") from None
    return pandas


def record_to_dataframe(record):
    """`Record.to_dataframe` (its docstring lists the columns and `attrs`)."""
    pd = pandas_module("Record.to_dataframe")
    channel_columns = _channel_columns(record)
    columns = {"time_s": np.array(record.time), "x_mm": np.array(record.deflection),
               "force_kgf": np.array(record.force),
               "drive_mm": np.array(record.drive_position(), dtype=np.float64)}
    for name, column in channel_columns.items():
        columns[column] = np.array(record.channels[name])
    df = pd.DataFrame(columns)
    df.attrs.update({_MARK: FORMAT_VERSION, "stiffness_kgf_per_mm": record.stiffness,
                     "weight_kgf": record.weight, "normal_load_kgf": record.normal_load,
                     "friction_radius_mm": record.friction_radius,
                     "drive_source": record.drive_source,
                     "drive_speed_mm_per_s": record.drive_speed,
                     "drive_program": record.drive_program, "lubricant": record.lubricant,
                     "surface": record.surface, "note": record.note,
                     "truth": None if record.truth is None else dict(record.truth),
                     "source": record.source, "extra_header": dict(record.extra_header),
                     "notes": tuple(record.notes), "channel_units": dict(record.channel_units),
                     "channel_columns": channel_columns})
    return df


def _from_own_frame(cls, df, given: dict, fields: dict):
    """The record a `to_dataframe` frame holds, exactly (its columns and `attrs`)."""
    if given:
        raise RecordError("this frame was made by Record.to_dataframe and carries its "
                          "columns and conditions; leave out "
                          + ", ".join(f"{k}=" for k in given))
    a = df.attrs
    try:
        missing = [c for c in _OWN_COLUMNS if c not in df.columns]
        missing += [c for c in a["channel_columns"].values() if c not in df.columns]
        if missing:
            raise RecordError(f"the frame made by Record.to_dataframe lacks the column(s) "
                              f"{', '.join(map(repr, missing))}")
        record = cls(
            time=df["time_s"].to_numpy(np.float64), deflection=df["x_mm"].to_numpy(np.float64),
            stiffness=a["stiffness_kgf_per_mm"], weight=a["weight_kgf"],
            normal_load=a.get("normal_load_kgf"), friction_radius=a.get("friction_radius_mm"),
            drive_speed=a["drive_speed_mm_per_s"],
            drive=(df["drive_mm"].to_numpy(np.float64) if a["drive_source"] == "column"
                   else None),
            drive_program=a["drive_program"], lubricant=a["lubricant"], surface=a["surface"],
            note=a["note"],
            channels={n: df[c].to_numpy(np.float64) for n, c in a["channel_columns"].items()},
            channel_units=dict(a["channel_units"]), truth=a["truth"], source=a["source"],
            extra_header=dict(a["extra_header"]), notes=tuple(a["notes"]))
    except KeyError as exc:
        raise RecordError(f"the frame's attrs lack {exc.args[0]!r}, which "
                          "Record.to_dataframe writes; give stiffness= and the other "
                          "conditions to read its columns by label") from None
    return dataclasses.replace(record, **fields) if fields else record
