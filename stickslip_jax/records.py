r"""Measured records: one run of the slideway read from (and written to) a CSV file.

A record is the spring deflection $x(t)$ (or the spring force $F = kx$) sampled at a
uniform step, with the run's conditions: stiffness $k$, slider weight $W$ and the drive
(a constant speed $v$, a piecewise-constant speed program, or a measured drive
displacement $u(t)$). Everything is held in the internal units kgf, mm, s; the file may
use any unit that `stickslip_jax.units` knows, converted on the way in.

File format (UTF-8, version 1)::

    # stickslip-record: 1
    # drive_speed: 1.0 mm/min
    # stiffness: 86.9 kgf/mm
    # slider_weight: 36.0 kgf
    # lubricant: A
    # surface: S1G1
    time [s],deflection [mm]
    0.000,0.1203
    0.001,0.1204

- The first line is `# stickslip-record: 1`. Header lines are `# key: value` with a
  lowercase key; quantities are `number unit` (`86.9 kgf/mm`, `852 N/mm`); a bare
  number is an error (no unit is guessed).
- Required: `stiffness`; `slider_weight` or `slider_mass` (in kg: W = m g, so 1 kg
  weighs 1 kgf); a `time` column; a `deflection` or a `force` column (x = F/k); and at
  least one drive: `drive_speed`, `drive_program` or a `drive` column. When several
  are given, the drive is the `drive` column, else the `drive_program`, else
  `drive_speed` (which then stays as the nominal speed).
- `drive_program: 0 s 1 mm/min; 30 s 0 mm/min; 60 s 1 mm/min` lists segments
  `start-time speed` separated by `;`: the speed holds from its start time to the next
  start (the last holds for ever). A hold is speed 0. Starts increase strictly, speeds
  are >= 0; before the first start the drive rests. The drive displacement is
  $u(t) = \int_0^t v(s)\,ds$ (zero at t = 0, like `drive_speed`'s $u = vt$).
- Optional: `lubricant`, `surface`, `note` (one line of free text), `truth: {json}`
  (parameters a synthetic record was made from), any other `key: value` (kept as
  raw text), and more columns `name [unit]` (e.g. `pitch_1 [um]`; `[-]` for a pure
  number) stored in `Record.channels` in internal units.
- Data rows: one number per column, `.` as decimal point. Time must increase strictly
  and be uniform: every step within `TIME_STEP_RTOL` (1e-3) of the mean step.
  Blank lines are ignored; `#` lines after the column row are an error.
- Files over `MAX_FILE_BYTES` (200 MB) are refused.

Reading never guesses and never crashes: every problem is one `RecordError` (a
`ValueError`) whose message names the file, the line and what to fix. Writing with the
defaults (internal units, `repr` precision) then reading gives the record back exactly.
"""

from __future__ import annotations

import dataclasses
import glob as _glob
import json
import math
import os
import re
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from .units import G_MM_S2, INTERNAL_UNIT, UNITS, UnitError, factor
from .units import parse_quantity as _parse_quantity_text

__all__ = [
    "FORMAT_VERSION",
    "MAX_FILE_BYTES",
    "TIME_STEP_RTOL",
    "Record",
    "RecordError",
    "check_campaign",
    "format_drive_program",
    "format_record",
    "parse_drive_program",
    "parse_record",
    "CampaignFiles",
    "read_campaign",
    "read_campaign_files",
    "read_record",
    "write_record",
]

JITTER_RTOL = 0.05
"""Time steps within this relative deviation of the mean step (and beyond
`TIME_STEP_RTOL`) are a logger's clock jitter: the record is resampled to a uniform step
with a note. Larger deviations (gaps, coarse rounding) are refused with the reason, unless
the clock is jittered by the looser test of `JITTER_STAMP`."""

JITTER_STAMP = 0.25
"""A clock of at least `JITTER_MIN_SAMPLES` samples whose stamps all lie within this
fraction of a step of the uniform grid through the first and last stamp, and whose steps
all lie within `JITTER_STEP` of the mean step, is a logger's jittered clock as well
(stamps scattered by +-10 % of a step move single steps by up to 20 %): resampled with a
note. A missing sample is a step of about twice the mean, a doubled one a step near 0,
and a run of uneven rate drifts away from the grid: all still refused."""

JITTER_STEP = 0.6
"""Largest relative step deviation of a jittered clock under `JITTER_STAMP`."""

MISSING_RUN = 10
"""Longest run of samples a logger may have dropped (a step of up to 11 steps of its
clock, the stamps otherwise on its grid within `JITTER_STAMP`): filled by linear
interpolation with a note (`missing_samples`). Longer gaps are refused (split the run
there)."""

MISSING_SHARE = 0.01
"""Largest share of a record's samples that may be missing and filled."""

JITTER_MIN_SAMPLES = 100
"""Fewer samples than this cannot tell a clock's jitter from an uneven run: only
`JITTER_RTOL` applies to them."""

EPOCH_SECONDS = 1e6
"""A first time stamp above this (s) is a logger's epoch time: time then counts from the
first sample (float64 keeps about 0.2 us of a 1.7e9 s stamp)."""

FORMAT_VERSION = "1"
"""The version in a record's first line, `# stickslip-record: 1`."""

MAX_FILE_BYTES = 200 * 1024 * 1024
"""Largest record file read (200 MiB, about 10 million samples of two columns)."""

TIME_STEP_RTOL = 1e-3
"""Largest relative deviation of a time step from the mean step, |dt_i - dt| / dt."""

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


class RecordError(ValueError):
    """A record that cannot be read or built; the message names the file, line and fix.

    Attributes: `path` (file or None), `line` (1-based line number or None) and
    `reason` (the message without the location).
    """

    def __init__(self, reason: str, path=None, line: int | None = None):
        self.path = None if path is None else str(path)
        self.line = line
        self.reason = reason
        where = ""
        if self.path is not None:
            where = f"{self.path}: " if line is None else f"{self.path}: line {line}: "
        elif line is not None:
            where = f"line {line}: "
        super().__init__(where + reason)


# ----------------------------------------------------------------------------- units


def unit_dimension(unit: str) -> str:
    """The dimension (`"length"`, `"time"`, ...) of a unit that `stickslip_jax.units` knows."""
    for dimension in UNITS:
        try:
            factor(unit, dimension)
        except UnitError:
            continue
        return dimension
    raise UnitError(f"unknown unit {unit!r}")


def _unit_choices(dimension: str) -> str:
    return ", ".join(u for u in UNITS[dimension] if u)


def channel_dimension(unit: str) -> str:
    """The dimension of an extra column's unit; a unit `stickslip_jax.units` does not know
    (`degC`, `%RH`, `V`, ...) is kept as written: dimension `"raw:<unit>"`, factor 1."""
    try:
        return unit_dimension(unit)
    except UnitError:
        return "raw:" + unit.strip()


def _channel_factor(unit: str) -> float:
    dim = channel_dimension(unit)
    return 1.0 if dim.startswith("raw:") else factor(unit, dim)


def _internal_channel_unit(unit: str) -> str:
    dim = channel_dimension(unit)
    return unit.strip() if dim.startswith("raw:") else INTERNAL_UNIT[dim]


# ---------------------------------------------------------------------------- record


_LABEL = re.compile(r"^\s*(.*?)\s*(?:\[(.*)\]|\((.*)\))?\s*$", re.DOTALL)


def _label(label) -> tuple[str, str | None]:
    """(name, unit or None) of a column label: `"force [N]"`, `"Force (N)"`, `"force"`."""
    m = _LABEL.match(str(label))
    return m.group(1), ((m.group(2) or m.group(3) or "").strip() or None)


def _resample(grid: np.ndarray, t: np.ndarray, values):
    """`values` at `t` linearly interpolated to `grid`; anything that is not an array of
    t's shape is passed on for `Record` to report."""
    try:
        a = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        return values
    return np.interp(grid, t, a) if a.shape == t.shape else values


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


def _positive(name, value):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise RecordError(f"{name} must be a number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise RecordError(f"{name} must be positive and finite, got {v}")
    return v


def _text(name, value):
    if value is None:
        return None
    if not isinstance(value, str):
        raise RecordError(f"{name} must be a string, got {type(value).__name__}")
    if value == "" or value != value.strip() or not value.isprintable():
        raise RecordError(
            f"{name} must be one line of printable text without surrounding spaces, "
            f"got {value!r}"
        )
    return value


def _uniform_grid(time: np.ndarray, dev: float, dt: float) -> tuple[np.ndarray, str]:
    """The uniform grid (mean step `dt`, same ends) that a jittered clock is resampled to,
    and the note saying so (`JITTER_RTOL`)."""
    grid = time[0] + dt * np.arange(time.size)
    grid[-1] = time[-1]
    return grid, (f"time stamps jitter by up to {100 * dev:.3g} % of the {dt:.6g} s step: "
                  "resampled to a uniform step (linear interpolation)")


def jittered_clock(time: np.ndarray, dev: float) -> bool:
    """Whether time stamps with step deviation `dev` (`time_step_deviation`) beyond
    `TIME_STEP_RTOL` are a logger's clock jitter, to resample (`JITTER_RTOL`,
    `JITTER_STAMP`)."""
    if not dev > TIME_STEP_RTOL:
        return False
    if dev <= JITTER_RTOL:
        return True
    n = time.shape[0]
    if n < JITTER_MIN_SAMPLES or dev > JITTER_STEP:
        return False
    dt = (time[-1] - time[0]) / (n - 1)
    off = np.abs(time - (time[0] + dt * np.arange(n))) / dt
    return bool(np.max(off) <= JITTER_STAMP)


def _jitter_grid(time: np.ndarray) -> tuple[np.ndarray, str] | None:
    """The uniform grid and note for a jittered clock (`jittered_clock`), or None."""
    dev, _, dt = time_step_deviation(time)
    return _uniform_grid(time, dev, dt) if jittered_clock(time, dev) else None


def missing_samples(time: np.ndarray) -> tuple[np.ndarray, str] | None:
    """A clock that dropped samples: the full uniform grid and a note, or None.

    Every stamp lies within `JITTER_STAMP` of a step of a uniform grid (its step fitted
    to the stamps; a jittered clock may drop samples too), no two stamps share a grid
    point, some grid points have no stamp, at most `MISSING_RUN` in a row and at most
    `MISSING_SHARE` in all, in a record of `JITTER_MIN_SAMPLES` or more. The grid runs
    from the first to the last stamp with the missing samples put back."""
    n = time.shape[0]
    if n < JITTER_MIN_SAMPLES:
        return None
    dt = float(np.median(np.diff(time)))
    if not dt > 0:
        return None
    runs = np.rint(np.diff(time) / dt) - 1  # grid points skipped by each step
    if np.any(runs < 0) or not np.any(runs):  # a sample written twice; none missing
        return None
    k = np.r_[0.0, np.cumsum(runs + 1)]
    dt, t0 = np.polyfit(k, time, 1)  # the clock's step over the whole run
    off = np.abs(time - (t0 + k * dt)) / dt
    if not dt > 0 or np.max(off) > JITTER_STAMP:
        return None
    lost = int(runs.sum())
    if runs.max() > MISSING_RUN or lost > MISSING_SHARE * (n + lost):
        return None
    full = n + lost
    grid = time[0] + (time[-1] - time[0]) / (full - 1) * np.arange(full)
    grid[-1] = time[-1]
    gaps = np.flatnonzero(runs)
    where = ", ".join(f"{float(time[g]):.6g} s" for g in gaps[:3]) + (
        ", ..." if gaps.size > 3 else "")
    jitter = (f"; the stamps jitter by up to {100 * float(np.max(off)):.3g} % of the step"
              if np.max(off) > TIME_STEP_RTOL else "")
    return grid, (f"{lost} sample(s) missing in {gaps.size} gap(s) of up to "
                  f"{int(runs.max())} (after {where}): filled by linear interpolation"
                  + jitter)


def time_step_deviation(time: np.ndarray) -> tuple[float, int, float]:
    """(max relative deviation |dt_i - dt|/dt, index i of the worst step, mean step dt)."""
    dt = (time[-1] - time[0]) / (time.shape[0] - 1)
    dev = np.abs(np.diff(time) - dt) / dt
    i = int(np.argmax(dev))
    return float(dev[i]), i, float(dt)


@dataclasses.dataclass(frozen=True, eq=False)
class Record:
    r"""One run of the slideway, in internal units (kgf, mm, s).

    - `time` (s, shape (n,), strictly increasing, uniform within `TIME_STEP_RTOL`),
      `deflection` x (mm, shape (n,)); `force` is $kx$ in kgf.
    - `stiffness` k (kgf/mm), `weight` W (kgf).
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

    def __post_init__(self):
        def put(name, value):
            object.__setattr__(self, name, value)

        time = _array("time", self.time)
        n = time.shape[0]
        if n < 2:
            raise RecordError(f"a record needs at least two samples, got {n}")
        steps = np.diff(time)
        if not np.all(steps > 0):
            i = int(np.flatnonzero(~(steps > 0))[0])
            raise RecordError(
                f"time must increase strictly: time[{i + 1}] = {float(time[i + 1]):.10g} s "
                f"follows time[{i}] = {float(time[i]):.10g} s"
            )
        dev, i, dt = time_step_deviation(time)
        if not dev <= TIME_STEP_RTOL:
            raise RecordError(
                f"time is uneven: step {i} is {float(steps[i]):.10g} s against the mean step "
                f"{float(dt):.10g} s "
                f"(relative deviation {dev:.3g} > {TIME_STEP_RTOL:g}); resample uniformly"
            )
        put("time", time)
        put("deflection", _array("deflection", self.deflection, n))
        put("stiffness", _positive("stiffness", self.stiffness))
        put("weight", _positive("weight", self.weight))
        if self.drive_speed is not None:
            try:
                v = float(self.drive_speed)
            except (TypeError, ValueError):
                raise RecordError(f"drive_speed must be a number, got {self.drive_speed!r}")
            if not (math.isfinite(v) and v >= 0):
                raise RecordError(f"drive_speed must be finite and >= 0, got {v}")
            put("drive_speed", v)
        if self.drive is not None:
            put("drive", _array("drive", self.drive, n))
        if self.drive_program is not None:
            put("drive_program", _check_program(self.drive_program))
        if self.drive_speed is None and self.drive is None and self.drive_program is None:
            raise RecordError("a record needs a drive: drive_speed, drive_program or drive")
        for name in ("lubricant", "surface", "note"):
            put(name, _text(name, getattr(self, name)))
        channels, units = {}, {}
        if not isinstance(self.channels, Mapping) or not isinstance(self.channel_units, Mapping):
            raise RecordError("channels and channel_units must be dicts keyed by column name")
        if set(self.channels) != set(self.channel_units):
            raise RecordError(
                "channel_units must give the unit of every channel and no other: "
                f"channels {sorted(self.channels)}, units {sorted(self.channel_units)}"
            )
        for name, values in self.channels.items():
            if not isinstance(name, str) or not _NAME.fullmatch(name) or name in RESERVED_COLUMNS:
                raise RecordError(
                    f"channel name {name!r} must be an identifier (letters, digits, _) "
                    f"other than {', '.join(RESERVED_COLUMNS)}"
                )
            unit = self.channel_units[name]
            if not isinstance(unit, str) or "[" in unit or "]" in unit or "," in unit:
                raise RecordError(f"channel {name!r}: unit {unit!r} is not a unit")
            channels[name] = _array(f"channel {name}", values, n)
            units[name] = unit.strip()
        put("channels", channels)
        put("channel_units", units)
        if self.truth is not None:
            if not isinstance(self.truth, Mapping):
                raise RecordError(f"truth must be a dict, got {type(self.truth).__name__}")
            try:
                json.dumps(dict(self.truth))
            except (TypeError, ValueError) as exc:
                raise RecordError(f"truth must be JSON-serialisable: {exc}") from None
            put("truth", dict(self.truth))
        if self.source is not None:
            put("source", str(self.source))
        extra = {}
        for key, value in dict(self.extra_header).items():
            if not isinstance(key, str) or not _KEY.fullmatch(key) or key in KNOWN_KEYS:
                raise RecordError(
                    f"extra header key {key!r} must be lowercase letters, digits, _ or - "
                    f"and not one of {', '.join(KNOWN_KEYS)}"
                )
            extra[key] = _text(f"extra header {key!r}", value)
        put("extra_header", extra)

    # -- derived quantities
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
                    mass=None, drive_speed=None, drive=None, time_unit: str = "s",
                    deflection_unit: str = "mm", force_unit: str = "kgf",
                    drive_unit: str = "mm", **fields) -> Record:
        """A record from arrays, for Python users: quantities are numbers in internal units
        (kgf, mm, s) or strings with a unit (`stiffness="852 N/um"`, `mass="30.7 g"`,
        `drive_speed="42 um/s"`); the array units are named by `time_unit`,
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
        w = q(weight, "force", "weight") if weight is not None else (
            float(mass) * G_MM_S2 if not isinstance(mass, str) else
            q(mass, "mass", "mass") * G_MM_S2)
        notes = list(fields.pop("notes", ()))
        if t.ndim == 1 and t.size and t[0] > EPOCH_SECONDS:
            notes.append(f"time counted from the first time stamp ({float(t[0])!r} s)")
            t = t - t[0]
        if t.ndim == 1 and t.size > 2 and np.all(np.diff(t) > 0) and x.shape == t.shape:
            for regrid in (missing_samples, _jitter_grid):  # dropped samples, then jitter
                got = regrid(t)
                if got is None:
                    continue
                grid, note = got
                x = np.interp(grid, t, x)
                u = None if u is None else np.interp(grid, t, u)
                if isinstance(fields.get("channels"), Mapping):
                    fields["channels"] = {k: _resample(grid, t, v)
                                          for k, v in fields["channels"].items()}
                notes.append(note)
                t = grid
        return cls(time=t, deflection=x, stiffness=k, weight=w,
                   drive_speed=q(drive_speed, "speed", "drive_speed"), drive=u,
                   notes=tuple(notes), **fields)

    @classmethod
    def from_dataframe(cls, df, *, time="time", deflection=None, force=None, drive=None,
                       stiffness, weight=None, mass=None, drive_speed=None,
                       time_unit: str | None = None, deflection_unit: str | None = None,
                       force_unit: str | None = None, drive_unit: str | None = None,
                       extra_columns="all", **fields) -> Record:
        """A record from a pandas DataFrame: `from_arrays` with the columns chosen by label.

        - `time`, `deflection` or `force` (x = F/k), `drive`: a column's full label
          (`"force [N]"`) or its name, case-insensitive (`"force"` matches `Force [N]`,
          `force (N)` and `force`); `time` may name the index. Without `deflection` and
          `force`, the one column named either is taken; a column named `drive` is the
          measured drive displacement unless `drive=` names another. `time=None`: the
          index.
        - Units: `time_unit`, `deflection_unit`, `force_unit`, `drive_unit` when given,
          else the label's brackets or parentheses (`time [ms]`, `force (N)`); a unit is
          never guessed. A datetime or timedelta time column (or index) counts seconds
          from its first stamp.
        - Conditions as in `from_arrays`: numbers in internal units or strings with a unit
          (`stiffness="852 N/um"`, `mass="30.7 g"`, `drive_speed="40 in/min"`).
        - `extra_columns`: `"all"` (default: every other column becomes a channel; one
          that cannot, non-numeric or with a reserved or repeated name, is left out with a
          note in `Record.notes`), a list of labels, or `{label: unit}`. A channel is named
          by its label's name (other characters than letters, digits and `_` become `_`),
          held in internal units, with its unit in `channel_units`: the label's, else `-`
          (a pure number, with a note).

        Needs pandas (`pip install pandas`); raises `RecordError`.

            df = pd.read_csv("run.txt", sep=";", decimal=",")   # time [s], force [N], temp [degC]
            rec = Record.from_dataframe(df, force="force", stiffness="852 N/um",
                                        mass="30.7 g", drive_speed="40 in/min")
        """
        try:
            import pandas as pd
        except ImportError:
            raise ImportError("Record.from_dataframe needs pandas: pip install pandas "
                              "(or pass the columns' arrays to Record.from_arrays)") from None
        if not isinstance(df, pd.DataFrame):
            raise RecordError(f"from_dataframe needs a pandas DataFrame, got "
                              f"{type(df).__name__}")
        if "channels" in fields or "channel_units" in fields:
            raise RecordError("from_dataframe makes the channels from the other columns; "
                              "choose them with extra_columns= (a list, or {label: unit})")
        labels = list(df.columns)
        parsed = {i: _label(c) for i, c in enumerate(labels)}
        listing = ", ".join(repr(str(c)) for c in labels)
        notes = list(fields.pop("notes", ()))

        def find(spec, what, *, index_ok=False, required=True):
            if spec is None:
                return None
            hits = [i for i, c in enumerate(labels) if c == spec]
            if not hits:
                key = _label(spec)[0].lower()
                hits = [i for i, (name, _) in parsed.items() if name.lower() == key]
            if len(hits) == 1:
                return hits[0]
            if not hits and index_ok and df.index.name is not None and (
                    df.index.name == spec
                    or _label(df.index.name)[0].lower() == _label(spec)[0].lower()):
                return "index"
            if not hits and not required:
                return None
            raise RecordError(f"{what}={spec!r}: {'no' if not hits else 'more than one'} "
                              f"column named so (columns: {listing})")

        def series(j):
            return pd.Series(df.index) if j == "index" else df.iloc[:, j]

        def label_of(j):
            return str(df.index.name) if j == "index" else str(labels[j])

        def values(j, what, given_unit):
            """(numbers, unit) of column `j` (or the index)."""
            col, label = series(j), label_of(j)
            if what == "time" and (pd.api.types.is_datetime64_any_dtype(col)
                                   or pd.api.types.is_timedelta64_dtype(col)):
                notes.append(f"time from the {label!r} stamps, counted from the first one")
                return (col - col.iloc[0]).dt.total_seconds().to_numpy(np.float64), "s"
            if not pd.api.types.is_numeric_dtype(col):
                raise RecordError(f"column {label!r} ({what}) is not numeric (dtype "
                                  f"{col.dtype}); convert it first, e.g. pd.to_numeric or "
                                  "read_csv(..., decimal=',')")
            unit = given_unit or (parsed[j][1] if j != "index" else _label(label)[1])
            if unit is None:
                raise RecordError(f"column {label!r} has no unit in its label: give "
                                  f"{what}_unit=..., or name it '{_label(label)[0]} [unit]'")
            return col.to_numpy(np.float64), unit

        j_time = "index" if time is None else find(time, "time", index_ok=True)
        if deflection is None and force is None:
            found = [(k, i) for k in ("deflection", "force")
                     if (i := find(k, k, required=False)) is not None]
            if len(found) != 1:
                raise RecordError("name the deflection= or the force= column (columns: "
                                  f"{listing})")
            (which, j_x), = found
        elif deflection is not None and force is not None:
            raise RecordError("give exactly one of deflection= and force=")
        else:
            which = "deflection" if deflection is not None else "force"
            j_x = find(deflection if deflection is not None else force, which)
        j_drive = find("drive" if drive is None else drive, "drive", required=drive is not None)
        t, t_unit = values(j_time, "time", time_unit)
        x, x_unit = values(j_x, which, deflection_unit if which == "deflection" else force_unit)
        kw = {which: x, f"{which}_unit": x_unit}
        if j_drive is not None:
            kw["drive"], kw["drive_unit"] = values(j_drive, "drive", drive_unit)
        used = {j for j in (j_time, j_x, j_drive) if j is not None}
        channels, channel_units = {}, {}
        if isinstance(extra_columns, str) and extra_columns == "all":
            chosen, units, strict = [i for i in range(len(labels)) if i not in used], {}, False
        elif isinstance(extra_columns, str):
            raise RecordError(f"extra_columns must be 'all', a list of labels or "
                              f"{{label: unit}}, got {extra_columns!r}")
        else:
            units = dict(extra_columns) if isinstance(extra_columns, Mapping) else {}
            chosen = [find(c, "extra_columns") for c in extra_columns]
            units = {j: units[c] for j, c in zip(chosen, extra_columns) if c in units}
            strict = True
        for j in chosen:
            col, label = df.iloc[:, j], str(labels[j])
            name = re.sub(r"[^A-Za-z0-9_]+", "_", parsed[j][0]).strip("_")
            name = "_" + name if name[:1].isdigit() else name
            problem = None
            if not pd.api.types.is_numeric_dtype(col):
                problem = f"is not numeric (dtype {col.dtype})"
            elif not _NAME.fullmatch(name) or name in RESERVED_COLUMNS:
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
                f = _channel_factor(unit)
            except UnitError as exc:
                raise RecordError(f"extra column {label!r}: {exc}") from None
            channels[name] = col.to_numpy(np.float64) * f
            channel_units[name] = unit
        return cls.from_arrays(t, time_unit=t_unit, stiffness=stiffness, weight=weight,
                               mass=mass, drive_speed=drive_speed, channels=channels,
                               channel_units=channel_units, notes=tuple(notes), **kw,
                               **fields)

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

        return (
            same(self.time, other.time)
            and same(self.deflection, other.deflection)
            and same(self.drive, other.drive)
            and self.stiffness == other.stiffness
            and self.weight == other.weight
            and self.drive_speed == other.drive_speed
            and self.drive_program == other.drive_program
            and (self.lubricant, self.surface, self.note)
            == (other.lubricant, other.surface, other.note)
            and self.channels.keys() == other.channels.keys()
            and all(same(v, other.channels[k]) for k, v in self.channels.items())
            and all(
                channel_dimension(u) == channel_dimension(other.channel_units[k])
                for k, u in self.channel_units.items()
            )
            and self.truth == other.truth
            and self.extra_header == other.extra_header
        )

    __hash__ = None


def _check_program(program) -> tuple[tuple[float, float], ...]:
    try:
        segs = tuple((float(s), float(v)) for s, v in program)
    except (TypeError, ValueError):
        raise RecordError(
            f"drive_program must be ((start s, speed mm/s), ...), got {program!r}"
        ) from None
    if not segs:
        raise RecordError("drive_program needs at least one segment")
    for s, v in segs:
        if not (math.isfinite(s) and math.isfinite(v)):
            raise RecordError(f"drive_program segment ({s}, {v}) is not finite")
        if v < 0:
            raise RecordError(f"drive_program speed {v} mm/s is negative; use 0 for a hold")
    for (s0, _), (s1, _) in zip(segs, segs[1:]):
        if not s1 > s0:
            raise RecordError(f"drive_program start times must increase: {s1} s follows {s0} s")
    return segs


def program_speed(program, t) -> np.ndarray:
    """Drive speed (mm/s) of a program ((start s, speed mm/s), ...) at times t (s); 0 before it."""
    t = np.asarray(t, dtype=np.float64)
    starts = np.array([s for s, _ in program])
    speeds = np.array([0.0] + [v for _, v in program])
    return speeds[np.searchsorted(starts, t, side="right")]


def program_position(program, t) -> np.ndarray:
    """Drive displacement u(t) = integral_0^t v(s) ds (mm) of a program, at times t (s)."""
    t = np.asarray(t, dtype=np.float64)
    starts = [s for s, _ in program]
    ends = starts[1:] + [np.inf]
    u = np.zeros_like(t)
    for (s, v), e in zip(program, ends):
        u = u + v * (np.clip(t, s, e) - np.clip(0.0, s, e))
    return u


# ---------------------------------------------------------------------------- reading


def _read_bytes(path: Path, max_bytes: int) -> bytes:
    try:
        if not path.exists():
            raise RecordError("no such file; check the path", path)
        if path.is_dir():
            raise RecordError("is a directory, not a record file; give one of its record "
                              "files (fit, mcmc and discover take a directory; in Python: "
                              "read_campaign)", path)
        size = path.stat().st_size
        if size > max_bytes:
            raise RecordError(
                f"file is {size / 1e6:.1f} MB, over the {max_bytes / 1e6:.0f} MB limit; "
                "split the run into several records or decimate it",
                path,
            )
        with open(path, "rb") as fh:
            data = fh.read(max_bytes + 1)
    except OSError as exc:
        raise RecordError(f"cannot read the file: {exc.strerror or exc}", path) from None
    if len(data) > max_bytes:
        raise RecordError(f"file is over the {max_bytes / 1e6:.0f} MB limit", path)
    return data


def _decode(data: bytes, path) -> str:
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    nul = data.find(b"\x00")
    if nul >= 0:
        raise RecordError(
            f"binary file (NUL byte at offset {nul}); a record is UTF-8 CSV text",
            path,
            data.count(b"\n", 0, nul) + 1,
        )
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise RecordError(
            f"not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start}); "
            "save the file as UTF-8",
            path,
            data.count(b"\n", 0, exc.start) + 1,
        ) from None
    return text


def _normalise_dialect(lines: list[str], notes: list[str]) -> list[str]:
    """The column row and data rows in the format's dialect: `,` between cells, `.` as
    decimal point, no quotes. Detected from the column row: `;` or tab separated files
    (where a `,` in the numbers is a decimal comma) and quoted cells are rewritten, with
    a note; a comma-separated file is left as it is (its errors stay precise)."""
    head = lines[0] if lines else ""
    delim = "," if "," in head else ";" if ";" in head else "\t" if "\t" in head else ","
    sample = [ln for ln in lines[1:50] if ln.strip() and not ln.lstrip().startswith("#")]
    quoted = any('"' in ln for ln in sample) or '"' in head
    if delim == "," and not quoted:
        return lines
    comma = delim != "," and any("," in ln for ln in sample)
    out = []
    for ln in lines:
        if quoted:
            ln = ln.replace('"', "")
        if comma:
            ln = ln.replace(",", ".")
        if delim != ",":
            ln = ln.replace(delim, ",")
        out.append(ln)
    name = {";": "';'", "\t": "tabs", ",": "','"}[delim]
    notes.append(f"cells separated by {name}" + (" with decimal commas" if comma else "")
                 + (", quotes removed" if quoted else ""))
    return out


def _lines(text: str, path) -> list[str]:
    if "\r" in text:  # \r\n line ends are fine; a bare \r inside a line is not
        lines = text.split("\n")
        for i, line in enumerate(lines):
            if "\r" in line.rstrip("\r"):
                raise RecordError(
                    "bare carriage return inside a line; use \\n (or \\r\\n) line ends",
                    path, i + 1)
            lines[i] = line.rstrip("\r")
        return lines
    return text.split("\n")


def _quantity(text: str, dimension: str, key: str, path, line: int) -> float:
    m = _QUANTITY.fullmatch(text)
    if m is None:
        raise RecordError(
            f"{key}: cannot read 'number unit' from {text.strip()!r}; "
            f"write e.g. '{key}: 1.5 {INTERNAL_UNIT[dimension]}'",
            path,
            line,
        )
    value, unit = float(m.group(1)), m.group(2)
    if unit == "":
        raise RecordError(
            f"{key}: {text.strip()!r} has no unit; add one of {_unit_choices(dimension)}",
            path,
            line,
        )
    try:
        f = factor(unit, dimension)
    except UnitError:
        raise RecordError(
            f"{key}: unknown {dimension} unit {unit!r}; use one of {_unit_choices(dimension)}",
            path,
            line,
        ) from None
    if not math.isfinite(value):
        raise RecordError(f"{key}: {m.group(1)!r} is out of range", path, line)
    return value * f


def _parse_program(text: str, path, line: int) -> tuple[tuple[float, float], ...]:
    segs = []
    hint = "write e.g. 'drive_program: 0 s 1 mm/min; 30 s 0 mm/min; 60 s 1 mm/min'"
    for part in text.split(";"):
        m = _SEGMENT.fullmatch(part)
        if m is None:
            raise RecordError(
                f"drive_program: cannot read segment {part.strip()!r} as "
                f"'start-time unit speed unit'; {hint}",
                path,
                line,
            )
        try:
            start = float(m.group(1)) * factor(m.group(2), "time")
        except UnitError:
            raise RecordError(
                f"drive_program: unknown time unit {m.group(2)!r}; use one of "
                f"{_unit_choices('time')}",
                path,
                line,
            ) from None
        try:
            speed = float(m.group(3)) * factor(m.group(4), "speed")
        except UnitError:
            raise RecordError(
                f"drive_program: unknown speed unit {m.group(4)!r}; use one of "
                f"{_unit_choices('speed')}",
                path,
                line,
            ) from None
        segs.append((start, speed))
    try:
        return _check_program(segs)
    except RecordError as exc:
        raise RecordError(f"{exc.reason}; {hint}", path, line) from None


def parse_drive_program(text: str) -> tuple[tuple[float, float], ...]:
    """Parse `"0 s 1 mm/min; 30 s 0 mm/min; 60 s 1 mm/min"` into ((start s, speed mm/s), ...).

    The syntax of the `drive_program` header (also for a command-line option); raises
    `RecordError` (a `ValueError`) saying what to fix.
    """
    return _parse_program(str(text), None, None)


def format_drive_program(program, speed_unit: str = "mm/s", time_unit: str = "s") -> str:
    """The `drive_program` text of ((start s, speed mm/s), ...), numbers with repr precision."""
    segs = _check_program(program)
    ft, fv = factor(time_unit, "time"), factor(speed_unit, "speed")
    return "; ".join(
        f"{_fmt(_encode(s, ft))} {time_unit} {_fmt(_encode(v, fv))} {speed_unit}" for s, v in segs
    )


def _text_value(key, value, path, line):
    if value == "":
        raise RecordError(f"{key}: empty value; give a value or delete the line", path, line)
    if not value.isprintable():
        raise RecordError(f"{key}: the value has control characters; remove them", path, line)
    return value


def _cell_problem(cell: str, column: str) -> str:
    c = cell.strip()
    if c == "":
        return f"empty cell in column {column!r}; every sample needs a value"
    if c.lower() in _NONFINITE:
        return f"{c} in column {column!r}; every value must be finite: remove or fill the sample"
    if "," in c:
        return f"{c!r} in column {column!r} is not a number"
    return f"{c[:40]!r} in column {column!r} is not a number; use '.' as the decimal point"


def _parse_data(lines, start, columns, path):
    """The data rows as an (n, ncol) float64 array and their 1-based line numbers.

    Fast path: NumPy's C parser (`numpy.loadtxt`, correctly rounded like `float`) over
    all rows at once; when it fails, or finds a count of cells, a non-finite value or a
    line it should not accept, the checked row-by-row parser below reads the file again
    and says which line is wrong and how to fix it."""
    stop = len(lines)
    while stop > start and not lines[stop - 1].strip():
        stop -= 1
    body = lines[start:stop]
    import warnings

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
    return _parse_data_checked(lines, start, columns, path)


def _parse_data_checked(lines, start, columns, path):
    """Row-by-row parser with precise errors (the format's grammar, `_NUM`)."""
    ncol = len(columns)
    cell = rf"\s*{_NUM}\s*"
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
                "header line after the column row; move every '# key: value' line above it",
                path,
                i + 1,
            )
        cells = line.split(",")
        if len(cells) != ncol:
            hint = " (a decimal comma? use '.' for decimals)" if len(cells) > ncol else ""
            raise RecordError(
                f"{len(cells)} cells but the column row has {ncol} "
                f"({', '.join(columns)}){hint}",
                path,
                i + 1,
            )
        for c, name in zip(cells, columns):
            if not _NUMBER.fullmatch(c.strip()):
                raise RecordError(_cell_problem(c, name), path, i + 1)
        raise RecordError("cannot read this row", path, i + 1)  # pragma: no cover
    if not numbers:
        return np.zeros((0, ncol)), rows
    with np.errstate(over="ignore"):
        data = np.array(numbers, dtype=np.float64)
    if not np.all(np.isfinite(data)):
        r, c = np.argwhere(~np.isfinite(data))[0]
        raise RecordError(
            f"{numbers[r][c].strip()!r} in column {columns[c]!r} is out of the float range",
            path,
            rows[r],
        )
    return data, rows


def _decimals(text: str) -> float:
    """Resolution of a written number: 10**-(decimals) scaled by its exponent."""
    t = text.strip().lower()
    mant, _, exp = t.partition("e")
    d = len(mant.partition(".")[2])
    try:
        return 10.0 ** (int(exp or 0) - d)
    except (OverflowError, ValueError):
        return math.inf


def parse_record(text: str, source=None) -> Record:
    """Parse the text of a record file; `source` names it in errors and in `Record.source`."""
    path = "<text>" if source is None else str(source)
    if text.startswith("\ufeff"):
        text = text[1:]
    if text.strip() == "":
        raise RecordError("file is empty; a record starts with '# stickslip-record: 1'", path)
    if "\x00" in text:
        raise RecordError("binary content (NUL character); a record is UTF-8 CSV text", path)
    lines = _lines(text, path)
    first = next(i for i, ln in enumerate(lines) if ln.strip())  # blank lines are ignored
    m = _HEADER.fullmatch(lines[first].strip())
    if m is None or m.group(1) != "stickslip-record":
        raise RecordError(
            f"the first line must be '# stickslip-record: {FORMAT_VERSION}', "
            f"got {lines[first][:60]!r}",
            path,
            first + 1,
        )
    # header lines
    header: dict[str, tuple[str, int]] = {}
    i = 0
    while i < len(lines):
        line = lines[i].strip()
        if line == "":
            i += 1
            continue
        if not line.startswith("#"):
            break
        m = _HEADER.fullmatch(line)
        if m is None:
            raise RecordError(
                f"header line {line[:60]!r} is not '# key: value'; "
                "put free text in '# note: ...'",
                path,
                i + 1,
            )
        key, value = m.group(1), m.group(2).strip()
        if not _KEY.fullmatch(key):
            raise RecordError(
                f"header key {key!r} must be lowercase: write '{key.lower()}'", path, i + 1
            )
        if key in header:
            raise RecordError(
                f"{key} given twice (also at line {header[key][1]}); keep one", path, i + 1
            )
        header[key] = (value, i + 1)
        i += 1
    version = header["stickslip-record"][0]
    if version != FORMAT_VERSION:
        raise RecordError(
            f"unsupported format version {version!r}; this reader knows "
            f"'stickslip-record: {FORMAT_VERSION}'",
            path,
            header["stickslip-record"][1],
        )
    if i >= len(lines):
        raise RecordError(
            "no column row after the header; add e.g. 'time [s],deflection [mm]' and the data",
            path,
            max(j + 1 for j, ln in enumerate(lines) if ln.strip()),
        )
    column_line = i + 1
    notes: list[str] = []
    lines = lines[:i] + _normalise_dialect(lines[i:], notes)
    columns, units = [], []
    for cell in lines[i].split(","):
        cm = _COLUMN.fullmatch(cell)
        if cm is None and cell.count("[") > 1:
            raise RecordError(
                f"the column row {lines[i].strip()[:60]!r} has no ',', ';' or tab between "
                "its columns; separate them (and the values) with ',' (or ';' or tabs)",
                path,
                column_line,
            )
        if cm is None:
            raise RecordError(
                f"column {cell.strip()[:40]!r} must be 'name [unit]' "
                "(e.g. 'time [s]', '[-]' for a pure number)",
                path,
                column_line,
            )
        name, unit = cm.group(1), cm.group(2).strip()
        if name in columns:
            raise RecordError(f"column {name!r} appears twice", path, column_line)
        columns.append(name)
        units.append(unit)
    col = dict(zip(columns, units))
    dims = {"time": "time", "deflection": "length", "force": "force", "drive": "length"}
    factors = []
    for name, unit in zip(columns, units):
        if name in dims:
            try:
                factors.append(factor(unit, dims[name]))
            except UnitError:
                raise RecordError(
                    f"column {name!r}: unknown {dims[name]} unit {unit!r}; use one of "
                    f"{_unit_choices(dims[name])}",
                    path,
                    column_line,
                ) from None
        else:
            try:
                factors.append(_channel_factor(unit))
            except UnitError:
                raise RecordError(
                    f"column {name!r}: unknown unit {unit!r}; use a unit of length, time, "
                    "force, speed, ... (e.g. um) or '-' for a pure number",
                    path,
                    column_line,
                ) from None
    if "time" not in col:
        raise RecordError(
            f"no 'time [s]' column (columns: {', '.join(columns)})", path, column_line
        )
    if ("deflection" in col) == ("force" in col):
        what = "both" if "deflection" in col else "neither"
        raise RecordError(
            f"{what} of 'deflection' and 'force' columns; give exactly one", path, column_line
        )
    # required header keys
    def need(key, how):
        if key not in header:
            raise RecordError(f"missing header line '# {key}: {how}'", path, column_line)
        return header[key]

    k_text, k_line = need("stiffness", "86.9 kgf/mm")
    stiffness = _quantity(k_text, "stiffness", "stiffness", path, k_line)
    if not stiffness > 0:
        raise RecordError("stiffness must be positive", path, k_line)
    if "slider_weight" in header and "slider_mass" in header:
        raise RecordError(
            "both slider_weight and slider_mass given; keep one",
            path,
            header["slider_mass"][1],
        )
    if "slider_mass" in header:
        m_text, w_line = header["slider_mass"]
        mm = _QUANTITY.fullmatch(m_text)
        if mm is not None and mm.group(2).strip() == "kg":
            weight = float(mm.group(1))  # 1 kg weighs 1 kgf (W = m g, standard gravity)
        else:
            weight = _quantity(m_text, "mass", "slider_mass", path, w_line) * G_MM_S2
    else:
        w_text, w_line = need("slider_weight", "36.0 kgf")
        weight = _quantity(w_text, "force", "slider_weight", path, w_line)
    if not (math.isfinite(weight) and weight > 0):
        raise RecordError("slider weight must be positive and finite", path, w_line)
    drive_speed = None
    if "drive_speed" in header:
        v_text, v_line = header["drive_speed"]
        drive_speed = _quantity(v_text, "speed", "drive_speed", path, v_line)
        if drive_speed < 0:
            raise RecordError("drive_speed must be >= 0", path, v_line)
    program = None
    if "drive_program" in header:
        program = _parse_program(header["drive_program"][0], path, header["drive_program"][1])
    if drive_speed is None and program is None and "drive" not in col:
        raise RecordError(
            "no drive: add '# drive_speed: 1 mm/min', a '# drive_program: ...' line "
            "or a 'drive [mm]' column",
            path,
            column_line,
        )
    texts = {}
    for key in ("lubricant", "surface", "note"):
        if key in header:
            texts[key] = _text_value(key, header[key][0], path, header[key][1])
    truth = None
    if "truth" in header:
        t_text, t_line = header["truth"]
        try:
            truth = json.loads(t_text)
        except (ValueError, RecursionError) as exc:
            raise RecordError(f"truth: not valid JSON ({str(exc)[:80]})", path, t_line) from None
        if not isinstance(truth, dict):
            raise RecordError("truth: must be a JSON object {...}", path, t_line)
    extra = {}
    for key, (value, line) in header.items():
        if key not in KNOWN_KEYS:
            extra[key] = _text_value(key, value, path, line)
    # data
    data, rows = _parse_data(lines, i + 1, columns, path)
    if data.shape[0] < 2:
        raise RecordError(
            f"{data.shape[0]} data row(s); a record needs at least two samples",
            path,
            rows[-1] if rows else column_line,
        )
    with np.errstate(over="ignore", invalid="ignore"):
        data = data * np.array(factors)
    if not np.all(np.isfinite(data)):
        r, c = np.argwhere(~np.isfinite(data))[0]
        raise RecordError(
            f"column {columns[c]!r} overflows after unit conversion", path, rows[r]
        )
    j = columns.index("time")
    time = data[:, j]
    steps = np.diff(time)
    bad = np.flatnonzero(~(steps > 0))
    if bad.size:
        r = int(bad[0])
        raise RecordError(
            f"time does not increase: {float(time[r + 1]):.10g} s after {float(time[r]):.10g} s "
            f"(line {rows[r]}); sort the rows and remove duplicates",
            path,
            rows[r + 1],
        )
    if time[0] > EPOCH_SECONDS:  # logger epoch stamps: count from the first sample
        notes.append(f"time counted from the first time stamp ({float(time[0])!r} s)")
        time = time - time[0]
        data[:, j] = time
    for regrid in (missing_samples, _jitter_grid):  # a logger's dropped samples, jitter
        got = regrid(time)
        if got is None:
            continue
        grid, note = got
        data = np.column_stack([grid if c == j else np.interp(grid, time, data[:, c])
                                for c in range(data.shape[1])])
        notes.append(note)
        time = data[:, j]  # uniform now: the line numbers below are not needed again
    dev, r, dt = time_step_deviation(time)
    if not dev <= TIME_STEP_RTOL:
        msg = (
            f"time is uneven: the step to this line is {steps[r]:.6g} s against the mean "
            f"step {dt:.6g} s (relative deviation {dev:.3g}, tolerance {TIME_STEP_RTOL:g}); "
        )
        cells = [lines[rows[r] - 1].split(",")[j], lines[rows[r + 1] - 1].split(",")[j]]
        rounding = 0.5 * sum(_decimals(c) for c in cells) * factors[j]  # of a written step
        if abs(steps[r] - dt) <= 1.01 * rounding:
            msg += (
                "this is within the rounding of the written digits: if the time stamps "
                "were rounded, write them with more digits, else resample uniformly"
            )
        else:
            msg += "resample the run to a uniform step (or split it at the gap)"
        raise RecordError(msg, path, rows[r + 1])
    k = stiffness
    if "deflection" in col:
        deflection = data[:, columns.index("deflection")]
    else:
        deflection = data[:, columns.index("force")] / k
    drive = data[:, columns.index("drive")] if "drive" in col else None
    channels = {
        name: data[:, c] for c, name in enumerate(columns) if name not in RESERVED_COLUMNS
    }
    channel_units = {name: col[name] for name in channels}
    try:
        return Record(
            time=time,
            deflection=deflection,
            stiffness=stiffness,
            weight=weight,
            drive_speed=drive_speed,
            drive=drive,
            drive_program=program,
            lubricant=texts.get("lubricant"),
            surface=texts.get("surface"),
            note=texts.get("note"),
            channels=channels,
            channel_units=channel_units,
            truth=truth,
            source=None if source is None else str(source),
            extra_header=extra,
            notes=tuple(notes),
        )
    except RecordError as exc:
        raise RecordError(exc.reason, path) from None


def read_record(path, *, max_bytes: int = MAX_FILE_BYTES) -> Record:
    """Read one record file (format in this module's docstring); raises `RecordError`."""
    path = Path(path)
    text = _decode(_read_bytes(path, max_bytes), path)
    return parse_record(text, source=path)


# ---------------------------------------------------------------------------- writing


def _encode(values: np.ndarray, f: float) -> np.ndarray:
    """Values to write in a unit of factor f, chosen so that reading (y * f) gives them back
    exactly whenever some float y does; otherwise within one unit in the last place."""
    values = np.asarray(values, dtype=np.float64)
    if f == 1.0:
        return values
    y = values / f
    for direction in (np.inf, -np.inf):
        cand = np.nextafter(y, direction)
        ok = (y * f != values) & (cand * f == values)
        y = np.where(ok, cand, y)
    return y


def _fmt(x: float) -> str:
    return repr(float(x))


def format_record(
    record: Record,
    deflection_unit: str = "mm",
    time_unit: str = "s",
    *,
    force_unit: str | None = None,
    drive_unit: str = "mm",
    channel_units: Mapping[str, str] | str | None = None,
) -> str:
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
    if channel_units is None:
        ch_units = {n: _internal_channel_unit(u) for n, u in record.channel_units.items()}
    elif channel_units == "original":
        ch_units = dict(record.channel_units)
    else:
        ch_units = {n: _internal_channel_unit(u) for n, u in record.channel_units.items()}
        for n, u in dict(channel_units).items():
            if n not in ch_units:
                raise RecordError(f"write_record: no channel {n!r}")
            if channel_dimension(u) != channel_dimension(record.channel_units[n]):
                raise RecordError(
                    f"write_record: channel {n!r} unit {u!r} is not a "
                    f"{channel_dimension(record.channel_units[n])} unit"
                )
            ch_units[n] = u
    out = [f"# stickslip-record: {FORMAT_VERSION}"]
    out.append(f"# stiffness: {_fmt(record.stiffness)} kgf/mm")
    out.append(f"# slider_weight: {_fmt(record.weight)} kgf")
    if record.drive_speed is not None:
        out.append(f"# drive_speed: {_fmt(record.drive_speed)} mm/s")
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
    names = ["time"]
    cols = [_encode(record.time, f_time)]
    heads = [f"time [{time_unit}]"]
    if f_force is None:
        cols.append(_encode(record.deflection, f_defl))
        heads.append(f"deflection [{deflection_unit}]")
    else:
        cols.append(record.force / f_force)
        heads.append(f"force [{force_unit}]")
    names.append("x")
    if record.drive is not None:
        cols.append(_encode(record.drive, f_drive))
        heads.append(f"drive [{drive_unit}]")
    for n, values in record.channels.items():
        u = ch_units[n]
        cols.append(_encode(values, _channel_factor(u)))
        heads.append(f"{n} [{u}]")
    out.append(",".join(heads))
    table = np.column_stack(cols)
    out.extend(",".join(map(repr, row)) for row in table.tolist())
    return "\n".join(out) + "\n"


def write_record(
    record: Record,
    path,
    deflection_unit: str = "mm",
    time_unit: str = "s",
    *,
    force_unit: str | None = None,
    drive_unit: str = "mm",
    channel_units: Mapping[str, str] | str | None = None,
) -> Path:
    """Write `record` to `path` (UTF-8 CSV, format in this module's docstring).

    Header quantities are written in internal units (kgf/mm, kgf, mm/s) and every
    number with `repr` precision, so reading the file gives the record back exactly
    (`read_record(p) == record`). Columns are written in `deflection_unit`, `time_unit`,
    `drive_unit` and, per channel, `channel_units` (default: the internal unit of each
    channel's dimension; `"original"`: the units in `record.channel_units`; or a dict
    of some of them); in other units than mm and s a value comes back exactly whenever
    a float exists that does so, else within one unit in the last place. With
    `force_unit` a `force` column k x replaces the deflection (read back as F/k, within
    rounding). Returns the path.
    """
    text = format_record(
        record,
        deflection_unit,
        time_unit,
        force_unit=force_unit,
        drive_unit=drive_unit,
        channel_units=channel_units,
    )
    from .output import write_text

    path = Path(path)
    write_text(str(path), text)  # atomic: a full disk leaves no half-written record
    return path


# ---------------------------------------------------------------------------- campaigns


def record_paths(spec) -> list[Path]:
    """The record files a campaign spec names (files, folders, globs; `read_campaign`)."""
    return _expand(spec)


def _expand(spec) -> list[Path]:
    if isinstance(spec, (str, os.PathLike)):
        p = Path(spec)
        if p.is_dir():
            files = sorted(q for q in p.glob("*.csv") if q.is_file())
            if not files:
                raise RecordError("directory has no *.csv record files", p)
            return files
        if p.exists():
            return [p]
        if any(ch in str(spec) for ch in "*?["):
            files = sorted(Path(q) for q in _glob.glob(str(spec)) if Path(q).is_file())
            if not files:
                raise RecordError("no file matches this pattern", spec)
            return files
        raise RecordError("no such file or directory; check the path", spec)
    if isinstance(spec, Iterable):
        out = []
        for item in spec:
            if not isinstance(item, (str, os.PathLike)):
                raise RecordError(f"campaign entries must be paths, got {item!r}")
            out.extend(_expand(item))
        return out
    raise RecordError(f"a campaign is a path, a glob or a list of them, got {spec!r}")


@dataclasses.dataclass(frozen=True)
class CampaignFiles:
    """What reading a campaign's files gave (`read_campaign_files`): the `records` read, in
    the order given, and the `unreadable` files, each as the `RecordError` that names the
    file, the line and the fix (`.path`, `.line`, `.reason`)."""

    records: list[Record]
    unreadable: list[RecordError]

    def check(self, strict: bool = False) -> None:
        """Raise the first unreadable file's error when `strict` or when no file could be
        read (a campaign of one bad file is that file's error); otherwise they are set
        aside by the caller."""
        if self.unreadable and (strict or not self.records):
            raise self.unreadable[0]


def read_campaign_files(spec, *, max_bytes: int = MAX_FILE_BYTES) -> CampaignFiles:
    """Read a campaign as `read_campaign` does, but a file whose content cannot be read (a
    summary table in the folder, a logger's long gap, a NaN cell) is listed in
    `unreadable` instead of stopping the campaign: the other records can still be fitted.
    A path that does not exist, a file named twice or a copy of another file's content
    still raises `RecordError` (the campaign as given is wrong)."""
    import hashlib

    files = _expand(spec)
    if not files:
        raise RecordError("the campaign is empty; give at least one record file")
    seen, contents = {}, {}
    for f in files:
        key = os.path.realpath(f)
        if key in seen:
            raise RecordError(f"named twice in the campaign (also as {seen[key]})", f)
        seen[key] = str(f)
    records, unreadable = [], []
    for f in files:
        digest = hashlib.sha256()
        with open(f, "rb") as fh:  # in blocks: a file over `max_bytes` is refused below
            for block in iter(lambda: fh.read(1 << 20), b""):
                digest.update(block)
        digest = digest.hexdigest()
        if digest in contents:
            raise RecordError(f"the same content as {contents[digest]}: a copy would count "
                              "its record twice; give each record once", f)
        contents[digest] = str(f)
        try:
            records.append(read_record(f, max_bytes=max_bytes))
        except RecordError as err:
            unreadable.append(err)
    return CampaignFiles(records, unreadable)


def read_campaign(spec, *, max_bytes: int = MAX_FILE_BYTES) -> list[Record]:
    """Read a campaign: a file, a directory (its *.csv, sorted), a glob, or a list of these.

    Files are returned in the order given (sorted within a directory or glob); a file
    named twice, or two files with the same content (a copy under another name would
    count its record twice), is an error. Raises `RecordError` for the first bad file
    (`read_campaign_files` lists the bad files and reads the rest).
    """
    got = read_campaign_files(spec, max_bytes=max_bytes)
    got.check(strict=True)
    return got.records


def check_campaign(
    records, *, same: Iterable[str] = ("lubricant", "surface"), strict: bool = True
) -> list[str]:
    """Problems with fitting `records` together: a field of `same` that differs between them.

    A field missing (None) in some records but given in others is a problem too. Returns
    the list of messages (empty when fine); with `strict` raises `RecordError` instead
    when there is any.
    """
    records = list(records)
    problems = []
    for field in same:
        groups: dict[object, list[str]] = {}
        for i, r in enumerate(records):
            value = getattr(r, field)
            groups.setdefault(value, []).append(r.name or f"record {i}")
        if len(groups) > 1:
            parts = "; ".join(
                f"{'not given' if v is None else repr(v)} in {', '.join(n)}"
                for v, n in groups.items()
            )
            problems.append(
                f"the campaign mixes {field}s ({parts}); fit records of one {field} together"
            )
    if strict and problems:
        raise RecordError(" | ".join(problems))
    return problems
