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

import numpy as np

from .records import Record, RecordError
from .records.rig import (RIG_COLUMNS, RIG_KEYS, ROTATIONAL, RotationalRig, rig_header,
                          rig_quantities)
from .units import G_MM_S2, UnitError

__all__ = ["RIG_COLUMNS", "RIG_KEYS", "ROTATIONAL", "RotationalRig", "rig_header",
           "rig_quantities", "rotational_record"]


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
