"""The `Record` type: one run of the slideway in internal units, the checks that make every
record valid when it is built, and the quantities derived from it."""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..units import G_MM_S2, UnitError, factor
from ..units import parse_quantity as _parse_quantity_text
from . import dataframe as _dataframe
from .drive import check_program, program_position, program_speed
from .errors import RecordError
from .grammar import KEY, KNOWN_KEYS, NAME, RESERVED_COLUMNS
from .quantities import channel_dimension
from .rig import RotationalRig
from .sampling import TIME_STEP_RTOL, time_step_deviation, uniform_clock

if TYPE_CHECKING:
    import pandas as pd


def _array(name, value, n=None):
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise RecordError(f"{name} must be an array of numbers ({exc})") from None
    if a.ndim != 1:
        raise RecordError(f"{name} must be one-dimensional, got shape {a.shape}")
    if n is not None and a.shape[0] != n:
        raise RecordError(f"{name} has {a.shape[0]} samples but time has {n}")
    if not np.all(np.isfinite(a)):
        i = int(np.flatnonzero(~np.isfinite(a))[0])
        raise RecordError(f"{name}[{i}] is {a[i]}; every sample must be finite")
    a.setflags(write=False)
    return a


def _positive(name, value, zero: bool = False):
    """`value` as a finite number > 0 (>= 0 with `zero`), else a RecordError naming it."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise RecordError(f"{name} must be a number, got {value!r}", field=name) from None
    if not (math.isfinite(v) and (v >= 0 if zero else v > 0)):
        rule = "finite and >= 0" if zero else "positive and finite"
        raise RecordError(f"{name} must be {rule}, got {v:.10g}", field=name)
    return v


def _text(name, value, field=None):
    """`value` (one line of text) or None, else a RecordError naming it (`field`: where
    it came from, `name` by default)."""
    if value is None:
        return None
    field = field or name
    if not isinstance(value, str):
        raise RecordError(f"{name} must be a string, got {type(value).__name__}", field=field)
    if value == "":
        raise RecordError(f"{name}: empty value; give a value or leave it out", field=field)
    if value != value.strip() or not value.isprintable():
        raise RecordError(f"{name} must be one line of printable text without surrounding spaces "
                          f"or control characters, got {value!r}", field=field)
    if value.endswith((",", ";")):
        raise RecordError(f"{name} must not end in ',' or ';' (a spreadsheet's padding of a "
                          f"header line reads the same), got {value!r}", field=field)
    return value


UNEVEN_FIX = "resample the run to a uniform step (or split it at the gap)"
"""The fix `Record` gives for an uneven clock (a file reader may give a closer one)."""


def _clock(time):
    """`time` checked: at least two samples, strictly increasing, uniform within
    `TIME_STEP_RTOL` (errors with `field` "time", or "time step" for unevenness, and the
    `index` of the sample)."""
    n = time.shape[0]
    if n < 2:
        raise RecordError(f"{n} data row(s) (samples); a record needs at least two",
                          field="time")
    steps = np.diff(time)
    if not np.all(steps > 0):
        i = int(np.flatnonzero(~(steps > 0))[0])
        raise RecordError(
            f"time does not increase strictly: {float(time[i + 1]):.10g} s after "
            f"{float(time[i]):.10g} s; sort the rows and remove duplicates",
            field="time", index=i + 1)
    dev, i, dt = time_step_deviation(time)
    if not dev <= TIME_STEP_RTOL:
        raise RecordError(
            f"time is uneven: the step to {float(time[i + 1]):.10g} s is {float(steps[i]):.6g} s "
            f"against the mean step {dt:.6g} s (relative deviation {dev:.3g}, tolerance "
            f"{TIME_STEP_RTOL:g}); {UNEVEN_FIX}", field="time step", index=i + 1)


_COMPARED = ("stiffness", "weight", "normal_load", "friction_radius", "drive_speed",
             "drive_program", "lubricant", "surface", "note", "truth", "extra_header")
"""The fields `Record.__eq__` compares with `==` (the arrays and channels apart)."""


@dataclasses.dataclass(frozen=True, eq=False)
class Record:
    r"""One run of the slideway, in internal units (kgf, mm, s).

    - `time` (s, shape (n,), strictly increasing, uniform within `TIME_STEP_RTOL`),
      `deflection` x (mm, shape (n,)); `force` is $kx$ in kgf.
    - `stiffness` k (kgf/mm), `weight` W (kgf, the moving mass W/g), `normal_load` N
      (kgf, the load the friction coefficients multiply; None: the paper's N = W, and
      `load` gives N or W).
    - `friction_radius` R (mm) of a rotational rig, whose quantities the record holds in
      the equivalent linear coordinates (`stickslip_jax.rigs`; `rig` gives it back), or
      None for a linear rig.
    - Drive: `drive_speed` v (mm/s), `drive` (measured drive displacement u in mm at
      `time`) or `drive_program` ((segment start s, speed mm/s), ...); at least one.
      `drive_position(t)` gives u(t) from the first present of drive, drive_program,
      drive_speed (`drive_source` says which).
    - `lubricant`, `surface`, `note`: one line of text or None.
    - `channels`: extra columns in internal units (lengths mm); `channel_units`: the
      unit each had in the file (its dimension picks the internal unit on writing).
    - `truth`: dict from a `# truth: {json}` header (synthetic records) or None.
    - `source`: the file it was read from; `extra_header`: other header keys, raw text.
    - `notes`: what reading did to the file's content (resampled a jittered clock, time
      counted from the first epoch stamp, delimiter and decimal comma); not compared.

    Arrays are read-only copies. Equality (`==`) compares the content in internal
    units; `source` and the file units of `channel_units` (not their dimensions) are
    presentation and are not compared.
    """

    time: np.ndarray
    deflection: np.ndarray
    stiffness: float
    weight: float
    drive_speed: float | None = None
    drive: np.ndarray | None = None
    drive_program: tuple[tuple[float, float], ...] | None = None
    lubricant: str | None = None
    surface: str | None = None
    note: str | None = None
    channels: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    channel_units: dict[str, str] = dataclasses.field(default_factory=dict)
    truth: dict | None = None
    source: str | None = None
    extra_header: dict[str, str] = dataclasses.field(default_factory=dict)
    notes: tuple[str, ...] = ()
    normal_load: float | None = None
    friction_radius: float | None = None

    def __post_init__(self):
        def put(name, value):
            object.__setattr__(self, name, value)

        time = _array("time", self.time)
        _clock(time)
        n = time.shape[0]
        put("time", time)
        put("stiffness", _positive("stiffness", self.stiffness))
        put("weight", _positive("weight", self.weight))
        for name in ("normal_load", "friction_radius"):
            if getattr(self, name) is not None:
                put(name, _positive(name, getattr(self, name)))
        if self.drive_speed is not None:
            put("drive_speed", _positive("drive_speed", self.drive_speed, zero=True))
        if self.drive is not None:
            put("drive", _array("drive", self.drive, n))
        if self.drive_program is not None:
            put("drive_program", check_program(self.drive_program))
        if self.drive_speed is None and self.drive is None and self.drive_program is None:
            raise RecordError("no drive: a record needs a drive_speed, a drive_program or a drive "
                              "(in a file: a '# drive_speed: 1 mm/min' or '# drive_program: ...' "
                              "line, a 'drive [mm]' or a 'drive_speed [mm/s]' column)",
                              field="drive")
        for name in ("lubricant", "surface", "note"):
            put(name, _text(name, getattr(self, name)))
        put("deflection", _array("deflection", self.deflection, n))
        channels, units = {}, {}
        if not isinstance(self.channels, Mapping) or not isinstance(self.channel_units, Mapping):
            raise RecordError("channels and channel_units must be dicts keyed by column name")
        if set(self.channels) != set(self.channel_units):
            raise RecordError(
                "channel_units must give the unit of every channel and no other: "
                f"channels {sorted(self.channels)}, units {sorted(self.channel_units)}")
        for name, values in self.channels.items():
            if not isinstance(name, str) or not NAME.fullmatch(name) or name in RESERVED_COLUMNS:
                raise RecordError(
                    f"channel name {name!r} must be an identifier (letters, digits, _) "
                    f"other than {', '.join(RESERVED_COLUMNS)}")
            unit = self.channel_units[name]
            if not isinstance(unit, str) or "[" in unit or "]" in unit or "," in unit:
                raise RecordError(f"channel {name!r}: unit {unit!r} is not a unit")
            channels[name] = _array(f"channel {name}", values, n)
            units[name] = unit.strip()
        put("channels", channels)
        put("channel_units", units)
        if self.truth is not None:
            if not isinstance(self.truth, Mapping):
                raise RecordError(f"truth must be a JSON object (a dict), got "
                                  f"{type(self.truth).__name__}", field="truth")
            try:
                json.dumps(dict(self.truth))
            except (TypeError, ValueError) as exc:
                raise RecordError(f"truth must be JSON-serialisable: {exc}",
                                  field="truth") from None
            put("truth", dict(self.truth))
        if self.source is not None:
            put("source", str(self.source))
        extra = {}
        for key, value in dict(self.extra_header).items():
            if not isinstance(key, str) or not KEY.fullmatch(key) or key in KNOWN_KEYS:
                raise RecordError(
                    f"extra header key {key!r} must be lowercase letters, digits, _ or - "
                    f"and not one of {', '.join(KNOWN_KEYS)}", field=str(key))
            extra[key] = _text(f"extra header {key!r}", value, key)
        put("extra_header", extra)

    @property
    def n_samples(self) -> int:
        """Number of samples n."""
        return int(self.time.shape[0])

    @property
    def sample_interval(self) -> float:
        """Mean time step in s: (t[-1] - t[0]) / (n - 1)."""
        return float((self.time[-1] - self.time[0]) / (self.n_samples - 1))

    @property
    def duration(self) -> float:
        """t[-1] - t[0] in s."""
        return float(self.time[-1] - self.time[0])

    @property
    def force(self) -> np.ndarray:
        """Spring force k x in kgf."""
        return self.stiffness * self.deflection

    @property
    def load(self) -> float:
        """The normal load N in kgf: `normal_load`, else the weight W (the paper's N = W)."""
        return self.weight if self.normal_load is None else self.normal_load

    @property
    def rig(self):
        """The `RotationalRig` of a record with a `friction_radius`,
        else None (a linear rig)."""
        return None if self.friction_radius is None else RotationalRig(self.friction_radius)

    @property
    def omega0(self) -> float:
        r"""Natural angular frequency $\omega_0 = \sqrt{g k / W}$ in rad/s (paper section 2)."""
        return math.sqrt(G_MM_S2 * self.stiffness / self.weight)

    @property
    def name(self) -> str | None:
        """The file name without its extension, or None for a record not read from a file."""
        return None if self.source is None else Path(self.source).stem

    @property
    def drive_source(self) -> str:
        """Which field defines the drive: "column", "program" or "speed"."""
        if self.drive is not None:
            return "column"
        if self.drive_program is not None:
            return "program"
        return "speed"

    @property
    def nominal_drive_speed(self) -> float:
        """Nominal drive speed v in mm/s.

        drive_speed if given, else the largest program speed, else the mean measured speed.
        """
        if self.drive_speed is not None:
            return self.drive_speed
        if self.drive_program is not None:
            return max(v for _, v in self.drive_program)
        return float((self.drive[-1] - self.drive[0]) / self.duration)

    def drive_position(self, t=None) -> np.ndarray:
        """Drive displacement u in mm at times `t` (s; default the record's times).

        From the `drive` column (linear interpolation, held constant outside the record),
        else the `drive_program` (u = integral of the speed from 0 to t), else
        u = drive_speed * t.
        """
        t = self.time if t is None else np.asarray(t, dtype=np.float64)
        if self.drive is not None:
            return np.interp(t, self.time, self.drive)
        if self.drive_program is not None:
            return program_position(self.drive_program, t)
        return self.drive_speed * t

    def drive_velocity(self, t=None) -> np.ndarray:
        """Drive speed du/dt in mm/s at times `t` (s; default the record's times)."""
        t = self.time if t is None else np.asarray(t, dtype=np.float64)
        if self.drive is not None:
            return np.interp(t, self.time, np.gradient(self.drive, self.time))
        if self.drive_program is not None:
            return program_speed(self.drive_program, t)
        return np.full_like(t, self.drive_speed, dtype=np.float64)

    @classmethod
    def from_arrays(cls, time, deflection=None, *, force=None, stiffness, weight=None,
                    mass=None, drive_speed=None, drive=None, normal_load=None,
                    time_unit: str = "s",
                    deflection_unit: str = "mm", force_unit: str = "kgf",
                    drive_unit: str = "mm", **fields) -> Record:
        """A record from arrays, for Python users: quantities are numbers in internal units
        (kgf, mm, s) or strings with a unit (`stiffness="852 N/um"`, `mass="30.7 g"`,
        `drive_speed="42 um/s"`, `normal_load="40 N"`); the array units are named by `time_unit`,
        `deflection_unit` (or `force_unit` for `force=`, read as x = F/k) and
        `drive_unit`. Time stamps of a jittered clock (`jittered_clock`) are resampled
        to a uniform step (the note in `Record.notes`). Other `fields` (`lubricant`,
        `note`, `channels`, ...) pass through. Raises `RecordError`."""

        def q(value, dimension, name):
            if value is None:
                return None
            if isinstance(value, str):
                try:
                    return _parse_quantity_text(value, dimension)
                except UnitError as exc:
                    raise RecordError(f"{name}: {exc}") from None
            return float(value)

        try:
            t = np.asarray(time, dtype=np.float64) * factor(time_unit, "time")
            k = q(stiffness, "stiffness", "stiffness")
            if (deflection is None) == (force is None):
                raise RecordError("give exactly one of deflection= and force=")
            x = (np.asarray(deflection, np.float64) * factor(deflection_unit, "length")
                 if deflection is not None else
                 np.asarray(force, np.float64) * factor(force_unit, "force") / k)
            u = None if drive is None else np.asarray(drive, np.float64) * factor(drive_unit,
                                                                                  "length")
        except UnitError as exc:
            raise RecordError(str(exc)) from None
        if (weight is None) == (mass is None):
            raise RecordError("give exactly one of weight= and mass=")
        w = (q(weight, "force", "weight") if weight is not None
             else q(mass, "mass", "mass") * G_MM_S2)
        notes = list(fields.pop("notes", ()))
        if t.ndim == 1 and x.shape == t.shape:  # epoch stamps, dropped samples, jitter
            channels = fields.get("channels")
            names = list(channels) if isinstance(channels, Mapping) else []
            t, (x, u, *values) = uniform_clock(t, [x, u, *(channels[k] for k in names)], notes)
            if names:
                fields["channels"] = dict(zip(names, values))
        return cls(time=t, deflection=x, stiffness=k, weight=w,
                   drive_speed=q(drive_speed, "speed", "drive_speed"), drive=u,
                   normal_load=q(normal_load, "force", "normal_load"),
                   notes=tuple(notes), **fields)

    @classmethod
    def from_dataframe(cls, df, *, time="time", deflection=None, force=None, drive=None,
                       stiffness=None, weight=None, mass=None, drive_speed=None,
                       time_unit: str | None = None, deflection_unit: str | None = None,
                       force_unit: str | None = None, drive_unit: str | None = None,
                       extra_columns="all", **fields) -> Record:
        """A record from a pandas DataFrame: `from_arrays` with the columns chosen by label.

        `time`, `deflection` or `force` (x = F/k), `drive`: a column's full label or its
        name, case-insensitive (`time` may name the index; `time=None`: the index). Units:
        the `*_unit` arguments, else the label's brackets or parentheses, never guessed.
        `extra_columns`: `"all"` (every other column a channel; one that cannot be is left
        out with a note), a list of labels, or `{label: unit}`. Conditions as in
        `from_arrays`. A frame made by `to_dataframe` gives its record back exactly
        (`fields` replace single fields). Needs pandas; raises `RecordError`. The rules in
        full: docs/records.md.
        """
        return _dataframe.record_from_dataframe(
            cls, df, time=time, deflection=deflection, force=force, drive=drive,
            stiffness=stiffness, weight=weight, mass=mass, drive_speed=drive_speed,
            time_unit=time_unit, deflection_unit=deflection_unit, force_unit=force_unit,
            drive_unit=drive_unit, extra_columns=extra_columns, **fields)

    def to_dataframe(self) -> pd.DataFrame:
        """The samples as a pandas DataFrame, units in the column names, metadata in
        `df.attrs`.

        Columns in internal units: `time_s`, `x_mm` (the deflection), `force_kgf`
        (k x), `drive_mm` (the drive displacement u(t) of `drive_position`: the measured
        column, the program's integral or v t) and one column per channel, named
        `<channel>_<unit>` in its internal unit (`pitch_1_mm`; `_1` for a pure number;
        a unit `stickslip_jax.units` does not know is kept as written, `temp_degC`).
        `df.attrs`: `stiffness_kgf_per_mm`, `weight_kgf`, `normal_load_kgf`,
        `friction_radius_mm`, `drive_source` (`"column"`,
        `"program"` or `"speed"`), `drive_speed_mm_per_s`, `drive_program`
        ((start s, speed mm/s), ...), `lubricant`, `surface`, `note`, `truth`, `source`,
        `extra_header`, `notes`, `channel_units` (each channel's unit in the file) and
        `channel_columns` (each channel's column), None where the record has none.
        `Record.from_dataframe(df)` gives the record back. Needs pandas.
        """
        return _dataframe.record_to_dataframe(self)

    def replace(self, **changes) -> Record:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def __eq__(self, other):
        if not isinstance(other, Record):
            return NotImplemented

        def same(a, b):
            if a is None or b is None:
                return a is None and b is None
            return np.array_equal(a, b)

        return (all(same(getattr(self, f), getattr(other, f))
                    for f in ("time", "deflection", "drive"))
                and all(getattr(self, f) == getattr(other, f) for f in _COMPARED)
                and self.channels.keys() == other.channels.keys()
                and all(same(v, other.channels[k]) for k, v in self.channels.items())
                and all(channel_dimension(u) == channel_dimension(other.channel_units[k])
                        for k, u in self.channel_units.items()))

    __hash__ = None

