r"""Drives: the displacement $u(t)$ (mm) of the driving point of Fig 5 against time (s).

Every drive is a piecewise-linear $u(t)$ given by `knots()`: knot times $t_i$ (s),
positions $u_i$ (mm) and the speed $s_i$ (mm/s) that holds on $[t_i, t_{i+1})$; the
last speed continues after the last knot and the first one extends backwards before
the first knot. The exact simulator uses the knots (a constant drive speed makes the
slip a closed form); the smoothed simulator calls `position(t)` and `speed(t)`.

The drives: `ConstantSpeed` (the paper's experiments), `SpeedProgram` (velocity steps,
slide-hold-slide), `MeasuredDrive` (a record's `drive` column) and `drive_from_record`.
"""

from __future__ import annotations

import abc

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .numerics import as_float, is_concrete
from .records import Record, program_speed


class AbstractDrive(eqx.Module):
    """A drive displacement u(t) in mm, piecewise linear in t (s); speeds in mm/s."""

    @abc.abstractmethod
    def knots(self) -> tuple[Float[Array, " K"], Float[Array, " K"], Float[Array, " K"]]:
        """(times s, positions mm, speeds mm/s): speed `speeds[i]` holds from `times[i]`."""

    def _segment(self, t):
        times, positions, speeds = self.knots()
        t = jnp.asarray(t, dtype=float)
        i = jnp.clip(jnp.searchsorted(times, t, side="right") - 1, 0, times.shape[0] - 1)
        return times[i], positions[i], speeds[i]

    def position(self, t: Float[ArrayLike, "..."]) -> Float[Array, "..."]:
        """Drive displacement u(t) in mm at time t in s."""
        t0, u0, s = self._segment(t)
        return u0 + s * (jnp.asarray(t, dtype=float) - t0)

    def speed(self, t: Float[ArrayLike, "..."]) -> Float[Array, "..."]:
        """Drive speed du/dt in mm/s at time t in s (right-continuous at the knots)."""
        return self._segment(t)[2]


class ConstantSpeed(AbstractDrive):
    """Constant drive speed `speed` (mm/s, stored as field `v`): u(t) = v * t."""

    v: Float[Array, ""] = eqx.field(converter=as_float)

    def __init__(self, speed):
        self.v = speed

    def __check_init__(self):
        if jnp.ndim(self.v) != 0:
            raise ValueError("ConstantSpeed: speed must be a scalar (mm/s)")

    def knots(self):
        z = jnp.zeros((1,))
        return z, z, jnp.reshape(self.v, (1,))


class SpeedProgram(AbstractDrive):
    """Piecewise-constant speed: `speeds[i]` (mm/s, >= 0) from `start_times[i]` (s) on.

    `start_times` must increase strictly; u = 0 at `start_times[0]`. Example: a 30 s
    hold between slides at 10 um/s, `SpeedProgram([0, 20, 50], [0.01, 0.0, 0.01])`.
    """

    start_times: Float[Array, " K"] = eqx.field(converter=as_float)
    speeds: Float[Array, " K"] = eqx.field(converter=as_float)

    def __check_init__(self):
        _check_knots("SpeedProgram", ("start_times", "speeds"), self.start_times, self.speeds, 1)

    def knots(self):
        dt = jnp.diff(self.start_times)
        pos = jnp.concatenate([jnp.zeros((1,)), jnp.cumsum(self.speeds[:-1] * dt)])
        return self.start_times, pos, self.speeds


class MeasuredDrive(AbstractDrive):
    """A measured drive displacement: `positions` (mm) at `times` (s), linear between.

    Held at the last position after the last time; before the first time the first
    segment's speed extends backwards.
    """

    times: Float[Array, " N"] = eqx.field(converter=as_float)
    positions: Float[Array, " N"] = eqx.field(converter=as_float)

    def __check_init__(self):
        _check_knots("MeasuredDrive", ("times", "positions"), self.times, self.positions, 2)

    def knots(self):
        s = jnp.diff(self.positions) / jnp.diff(self.times)
        return self.times, self.positions, jnp.concatenate([s, jnp.zeros((1,))])


def _check_knots(owner: str, names, times, values, least: int) -> None:
    """ValueError unless `times` and `values` are 1-D of one length, at least `least`
    samples, with `times` increasing strictly (where concrete)."""
    if times.ndim != 1 or values.shape != times.shape:
        raise ValueError(f"{owner}: {' and '.join(names)} must be 1-D arrays of the same length")
    if times.shape[0] < least:
        raise ValueError(f"{owner}: needs at least {least} sample{'s' * (least > 1)}")
    if is_concrete(times) and np.any(np.diff(np.asarray(times)) <= 0):
        raise ValueError(f"{owner}: {names[0]} must increase strictly")


def program_drive(program) -> SpeedProgram:
    """The `SpeedProgram` of a drive program ((start s, speed mm/s), ...): at rest before
    its first start, u(0) = 0."""
    starts = [s for s, _ in program]
    starts = [0.0, *starts] if starts[0] > 0 else starts
    return SpeedProgram(starts, program_speed(program, starts))


def drive_from_record(record: Record) -> AbstractDrive:
    """The drive of a `stickslip_jax.records.Record`, as `record.drive_source` says: its
    measured `drive` column (mm), its `drive_program` (`program_drive`) or its constant
    `drive_speed` (mm/s)."""
    if record.drive_source == "column":
        return MeasuredDrive(record.time, record.drive)
    if record.drive_source == "speed":
        return ConstantSpeed(record.drive_speed)
    return program_drive(record.drive_program)
