r"""A rotational rig read at the records edge: `RotationalRig` (the factors between its
units and the equivalent slideway's), `rig_header` (a record file's rig keys and units
as the linear ones) and `rig_quantities` (a record's conditions in its rig's units).
The equivalence itself: `stickslip_jax.rigs`, which also builds a record of a rig from
arrays (`rotational_record`)."""

from __future__ import annotations

import dataclasses
import math

from ..units import G_MM_S2, INTERNAL_UNIT, RIG_UNITS, UnitError, factor
from .errors import RecordError
from .grammar import QUANTITY
from .quantities import quantity

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
