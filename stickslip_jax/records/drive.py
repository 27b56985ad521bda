"""Drive programs: piecewise-constant drive speeds ((segment start s, speed mm/s), ...),
their speed and displacement at given times, and the `drive_program` header's text."""

from __future__ import annotations

import math

import numpy as np

from ..units import factor
from .errors import RecordError
from .grammar import SEGMENT
from .quantities import encode, fmt, quantity


def check_program(program) -> tuple[tuple[float, float], ...]:
    try:
        segs = tuple((float(s), float(v)) for s, v in program)
    except (TypeError, ValueError):
        raise RecordError(
            f"drive_program must be ((start s, speed mm/s), ...), got {program!r}") from None
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


def parse_drive_program(text: str, path=None, line: int | None = None
                        ) -> tuple[tuple[float, float], ...]:
    """Parse `"0 s 1 mm/min; 30 s 0 mm/min; 60 s 1 mm/min"` into ((start s, speed mm/s), ...).

    The syntax of the `drive_program` header (also for a command-line option); raises
    `RecordError` (a `ValueError`) saying what to fix (and the file `path` and `line` where
    the header stands).
    """
    segs = []
    hint = "write e.g. 'drive_program: 0 s 1 mm/min; 30 s 0 mm/min; 60 s 1 mm/min'"
    for part in str(text).split(";"):
        m = SEGMENT.fullmatch(part)
        if m is None:
            raise RecordError(f"drive_program: cannot read segment {part.strip()!r} as "
                              f"'start-time unit speed unit'; {hint}", path, line)
        segs.append(tuple(quantity(f"{m.group(i)} {m.group(i + 1)}", dim, "drive_program",
                                   path, line) for i, dim in ((1, "time"), (3, "speed"))))
    try:
        return check_program(segs)
    except RecordError as exc:
        raise RecordError(f"{exc.reason}; {hint}", path, line) from None


def format_drive_program(program, speed_unit: str = "mm/s", time_unit: str = "s") -> str:
    """The `drive_program` text of ((start s, speed mm/s), ...), numbers with repr precision."""
    segs = check_program(program)
    ft, fv = factor(time_unit, "time"), factor(speed_unit, "speed")
    return "; ".join(
        f"{fmt(encode(s, ft))} {time_unit} {fmt(encode(v, fv))} {speed_unit}" for s, v in segs)


def speed_position(time, speed) -> np.ndarray:
    """The drive displacement (mm, 0 at the first sample) of a measured drive speed (mm/s)
    at `time` (s): the trapezoidal integral, so that every step downstream sees one
    measured drive whether the rig logs its position or its speed."""
    time, speed = np.asarray(time, np.float64), np.asarray(speed, np.float64)
    return np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(time))])
