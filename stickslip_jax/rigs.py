r"""Rotational rigs in the equivalent linear coordinates of the paper's slideway (Fig 5).

A torsional rig (a drive turns a shaft of torsional stiffness $k_t$ whose end, of moment
of inertia $J$, rubs under a normal load $N$ at the friction radius $R$) obeys
$J\ddot\theta = k_t(\varphi - \theta) - \mu N R$. Divided by $R$ this is the slideway's
$M\ddot y = k(u - y) - \mu N$ in the coordinates $y = R\theta$, $u = R\varphi$ (rad to mm),
$v = R\omega$, $F = T/R$ (torque kgf*mm to kgf), $k = k_t/R^2$ (kgf*mm/rad to kgf/mm),
$M = J/R^2$ (kgf*mm*s^2 to kgf*s^2/mm, $W = Mg$), with $N$ unchanged (`ROTATIONAL`),
so every model, fit and result of the slideway holds for the rig; friction coefficients
and times are the same in both. The conversion happens at the records edge: a record
whose header gives `friction_radius` may state its quantities in rotational units
(`torsional_stiffness: 0.5 N*m/rad`, `inertia: 2e-4 kg*m^2`, `drive_speed: 30 rpm`,
columns `angle [deg]`, `torque [N*m]`, `drive [rad]`), and `Record.rig` gives the rig
back to report results in its units (`RotationalRig.to_rig`, `rig_quantities`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .units import G_MM_S2, RIG_UNITS, UnitError, factor

ROTATIONAL = {"length": ("angle", 1), "speed": ("angular_speed", 1), "force": ("torque", -1),
              "stiffness": ("torsional_stiffness", -2), "mass": ("inertia", -2)}
"""Linear dimension -> (rotational dimension, p): linear value = rotational value * R**p
(R in mm, internal units on both sides)."""

RIG_KEYS = {"torsional_stiffness": "stiffness", "inertia": "slider_mass"}
"""Header keys of a rotational rig and the linear key each one gives."""

RIG_COLUMNS = {"angle": "deflection", "torque": "force"}
"""Column names of a rotational rig and the linear column each one gives."""


@dataclasses.dataclass(frozen=True)
class RotationalRig:
    """A rotational rig of friction radius `radius` R (mm): the factor between its
    quantities and the equivalent slideway's (module doc)."""

    radius: float

    def __post_init__(self):
        if not (isinstance(self.radius, int | float) and math.isfinite(self.radius)
                and self.radius > 0):
            raise ValueError(f"friction radius must be positive and finite (mm), got "
                             f"{self.radius!r}")

    def factor(self, unit: str, dimension: str) -> float:
        """Factor of `unit` to the internal unit of the linear `dimension`: a linear unit
        as `stickslip_jax.units.factor` reads it, or a rotational one (`rad`, `N*m`,
        `N*m/rad`, `kg*m^2`, `rpm`) through R. Raises `UnitError` naming both kinds."""
        try:
            return factor(unit, dimension)
        except UnitError:
            if dimension not in ROTATIONAL:
                raise
        rot, p = ROTATIONAL[dimension]
        try:
            return factor(unit, rot) * self.radius ** p
        except UnitError:
            raise UnitError(f"unknown {dimension} unit {unit!r}; on a rotational rig also a "
                            f"{rot.replace('_', ' ')} unit ({', '.join(RIG_UNITS[rot])}, or "
                            "any that pint knows)") from None

    def to_rig(self, value, dimension: str, unit: str | None = None):
        """A linear internal value of `dimension` (mm, mm/s, kgf, kgf/mm, kgf*s^2/mm) in
        the rig's quantity: in `unit` if given, else its internal unit (rad, rad/s,
        kgf*mm, kgf*mm/rad, kgf*mm*s^2)."""
        rot, p = ROTATIONAL[dimension]
        return value / self.radius ** p / (1.0 if unit is None else factor(unit, rot))


def rig_header(header: dict, path) -> tuple[RotationalRig | None, dict, dict]:
    """A record file's header (`{key: (text, line)}`) with its rig read: (the
    `RotationalRig` of a `friction_radius`, or None; the header with a rig's keys and
    units as the linear ones, `torsional_stiffness` as `stiffness`, `inertia` as
    `slider_mass`, angular `drive_speed` as mm/s; the `Record` fields `normal_load` (kgf)
    and `friction_radius` (mm) it gives). Raises `RecordError` naming the line."""
    from .records.errors import RecordError
    from .records.grammar import QUANTITY
    from .records.quantities import quantity
    from .units import INTERNAL_UNIT

    h, fields = dict(header), {}
    for key, dim in (("normal_load", "force"), ("friction_radius", "length")):
        if key in h:
            text, line = h.pop(key)
            fields[key] = quantity(text, dim, key, path, line)
    rig_keys = [k for k in RIG_KEYS if k in h]
    if "friction_radius" not in fields:
        if rig_keys:
            raise RecordError(f"{rig_keys[0]} is a rotational rig's: add its friction radius, "
                              "'# friction_radius: 20 mm'", path, h[rig_keys[0]][1])
        return None, h, fields
    try:
        rig = RotationalRig(fields["friction_radius"])
    except ValueError as exc:
        raise RecordError(str(exc), path, header["friction_radius"][1]) from None
    for key in rig_keys:
        linear = RIG_KEYS[key]
        if linear in h:
            raise RecordError(f"both {key} and {linear} given; keep one", path, h[key][1])
        h[linear] = h.pop(key)
    for key, dim in (("stiffness", "stiffness"), ("slider_mass", "mass"),
                     ("drive_speed", "speed")):
        m = QUANTITY.fullmatch(h[key][0]) if key in h else None
        if m is None or not m.group(2):
            continue
        try:
            factor(m.group(2), dim)
        except UnitError:  # a rotational unit: its value in the linear internal unit
            try:
                value = float(m.group(1)) * rig.factor(m.group(2), dim)
            except UnitError as exc:
                raise RecordError(f"{key}: {exc}", path, h[key][1]) from None
            h[key] = (f"{value!r} {INTERNAL_UNIT[dim]}", h[key][1])
    return rig, h, fields


def rig_quantities(record) -> dict:
    """A rotational record's conditions in its rig's units, keyed with their units (the
    JSON keys of reports): friction radius (mm), torsional stiffness (N*m/rad), inertia
    (kg*m^2), drive speed (rad/s; None for a drive column or program). Empty for a
    linear record."""
    rig = record.rig
    if rig is None:
        return {}
    v = record.drive_speed
    return {"friction_radius_mm": rig.radius,
            "torsional_stiffness_n_m_per_rad": rig.to_rig(record.stiffness, "stiffness",
                                                          "N*m/rad"),
            "inertia_kg_m2": rig.to_rig(record.weight / G_MM_S2, "mass", "kg*m^2"),
            "drive_speed_rad_per_s": None if v is None else rig.to_rig(v, "speed")}


def rotational_record(time, angle=None, *, torque=None, torsional_stiffness, inertia,
                      normal_load, friction_radius, drive_speed=None, drive=None,
                      time_unit: str = "s", angle_unit: str = "rad",
                      torque_unit: str = "N*m", drive_unit: str = "rad", **fields):
    """A `Record` of a rotational rig from arrays: the twist `angle` (or the shaft
    `torque`), the drive's angle `drive`, in the units named; conditions as numbers in
    internal units (kgf*mm/rad, kgf*mm*s^2, kgf, mm, rad/s) or strings with a unit
    (`torsional_stiffness="0.5 N*m/rad"`, `inertia="2e-4 kg*m^2"`, `normal_load="40 N"`,
    `friction_radius="20 mm"`, `drive_speed="30 rpm"`). The record holds the equivalent
    slideway (module doc) and the radius. Raises `RecordError`."""
    from .records import Record, RecordError
    from .units import parse_quantity

    def q(value, dimension):
        return parse_quantity(value, dimension) if isinstance(value, str) else float(value)

    try:
        rig = RotationalRig(q(friction_radius, "length"))
        k = q(torsional_stiffness, "torsional_stiffness") / rig.radius ** 2
        if (angle is None) == (torque is None):
            raise RecordError("give exactly one of angle= and torque=")
        x = ({"deflection": np.asarray(angle, float) * rig.factor(angle_unit, "length")}
             if torque is None else
             {"force": np.asarray(torque, float) * rig.factor(torque_unit, "force")})
        if drive is not None:
            fields["drive"] = np.asarray(drive, float) * rig.factor(drive_unit, "length")
        v = None if drive_speed is None else q(drive_speed, "angular_speed") * rig.radius
        return Record.from_arrays(
            time, time_unit=time_unit, stiffness=k, drive_speed=v,
            weight=q(inertia, "inertia") / rig.radius ** 2 * G_MM_S2,
            normal_load=q(normal_load, "force"), friction_radius=rig.radius, **x, **fields)
    except (UnitError, ValueError) as exc:
        if isinstance(exc, RecordError):
            raise
        raise RecordError(str(exc)) from None
