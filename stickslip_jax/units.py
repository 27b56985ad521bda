"""One internal unit system and the conversions at the edges.

Internally every quantity is in **kgf, mm, s** (the paper's system): force kgf, length
mm, time s, speed mm/s, stiffness kgf/mm, mass kgf*s^2/mm (= W/g), viscosity kgf*s/mm^2,
pressure kgf/mm^2 (docs/units.md).

The paper quotes drive speeds in mm/min; they are converted to mm/s on the way in
and back on the way out. Only code at the edges (records, CLI, plots) calls the
functions of this module.

A kinematic viscosity (`cSt`, `mm^2/s`, `St`, `m^2/s`: what lubricant data sheets give)
becomes the dynamic viscosity eta = nu rho only with the lubricant's density, written
after `at`: `230 cSt at 870 kg/m^3` (= 0.2001 Pa*s) or `230 mm^2/s at 0.87 g/cm^3`.
Without a density it is refused with that hint.
"""

from __future__ import annotations

import functools
import math
import re

G_MM_S2 = 9806.65
"""Standard gravity in mm/s^2 (also N per kgf divided by 1000 * 1000 mm/m: 1 kgf = 9.80665 N)."""

KGF_N = 9.80665
"""Newtons per kgf."""

# Factor that converts a value in the given unit to the internal unit, by dimension.
UNITS: dict[str, dict[str, float]] = {
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "min": 60.0},
    "length": {"mm": 1.0, "um": 1e-3, "µm": 1e-3, "m": 1e3, "cm": 10.0, "nm": 1e-6},
    "force": {"kgf": 1.0, "N": 1.0 / KGF_N, "kN": 1e3 / KGF_N},
    "speed": {"mm/s": 1.0, "mm/min": 1.0 / 60.0, "um/s": 1e-3, "µm/s": 1e-3, "m/s": 1e3,
              "m/min": 1e3 / 60.0},
    "stiffness": {"kgf/mm": 1.0, "N/mm": 1.0 / KGF_N, "N/m": 1e-3 / KGF_N, "kN/m": 1.0 / KGF_N},
    "mass": {"kg": 1.0 / (G_MM_S2), "kgf*s^2/mm": 1.0},
    "viscosity": {"kgf*s/mm^2": 1.0, "Pa*s": 1.0 / (KGF_N * 1e6), "mPa*s": 1e-3 / (KGF_N * 1e6),
                  "cP": 1e-3 / (KGF_N * 1e6)},
    "pressure": {"kgf/mm^2": 1.0, "kgf/cm^2": 1e-2, "Pa": 1.0 / (KGF_N * 1e6), "MPa": 1.0 / KGF_N},
    "dimensionless": {"": 1.0, "-": 1.0, "1": 1.0}}

RIG_UNITS: dict[str, dict[str, float]] = {
    "angle": {"rad": 1.0, "deg": math.pi / 180.0},
    "angular_speed": {"rad/s": 1.0, "rpm": math.pi / 30.0, "deg/s": math.pi / 180.0},
    "torque": {"kgf*mm": 1.0, "N*m": 1e3 / KGF_N, "N*mm": 1.0 / KGF_N},
    "torsional_stiffness": {"kgf*mm/rad": 1.0, "N*m/rad": 1e3 / KGF_N},
    "inertia": {"kgf*mm*s^2": 1.0, "kg*m^2": 1e6 / G_MM_S2}}
"""Quantities of rotational rigs (`stickslip_jax.rigs`), internal units rad, rad/s, kgf*mm,
kgf*mm/rad and kgf*mm*s^2; apart from `UNITS` so that no extra column is read as one."""

INTERNAL_UNIT = {"time": "s", "length": "mm", "force": "kgf", "speed": "mm/s",
                 "stiffness": "kgf/mm", "mass": "kgf*s^2/mm", "viscosity": "kgf*s/mm^2",
                 "pressure": "kgf/mm^2", "dimensionless": ""}


DEFAULT_UNIT = {"time": "s", "length": "mm", "force": "kgf", "speed": "mm/min",
                "stiffness": "kgf/mm", "viscosity": "Pa*s"}
"""The unit of a bare number on the command line, one per quantity in every command
(`stickslip_jax.commands.options.quantity`). Viscosity is in Pa*s, the SI unit labs use
(a bare viscosity below 1e-5 Pa*s, thinner than air, is refused: it is a value in the
paper's unit, kgf*s/mm^2, written without its unit; `commands.options.viscosity`)."""


class UnitError(ValueError):
    """A unit that is unknown, or of the wrong kind for the quantity."""


def _normalise(unit: str) -> str:
    u = unit.strip().replace(" ", "").replace("·", "*").replace("²", "^2")
    return "um" if u in ("μm",) else u.replace("μ", "u")


def factor(unit: str, dimension: str) -> float:
    """Factor that converts a value in `unit` to the internal unit of `dimension`.

    The units of `UNITS` first (exact, no dependency); any other unit through pint's
    registry, checked against the dimension (`852 N/um`, `40 in/min`, `10 lbf`, `2 mN`,
    `5 um/min`, `0.216 Pa s`: what labs write). Raises `UnitError`."""
    table = UNITS.get(dimension, RIG_UNITS.get(dimension))
    if table is None:
        raise UnitError(f"unknown dimension {dimension!r}; expected one of {sorted(UNITS)}")
    u = _normalise(unit)
    if u in table:
        return table[u]
    if dimension == "viscosity":
        parts = _AT.split(unit.strip(), maxsplit=1)
        if len(parts) == 2:
            return _kinematic_factor(*parts)
        if _pint_to(unit.strip(), "mm**2/s") is not None:
            raise UnitError(_needs_density("230", unit.strip()))
    got = _pint_factor(unit.strip(), dimension)
    if got is None:
        raise UnitError(
            f"unknown {dimension} unit {unit!r}; use one of: {', '.join(k for k in table if k)} "
            "(or any unit of that dimension that pint knows, e.g. 'N/um', 'in/min', 'lbf')")
    return got


_PINT_INTERNAL = {d: u.replace("^", "**") for d, u in {
    **INTERNAL_UNIT, "dimensionless": "dimensionless",
    **{d: next(iter(table)) for d, table in RIG_UNITS.items()}}.items()}
"""Internal unit of each dimension as pint spells it (a rig's first unit is its internal one)."""


def _pint_factor(unit: str, dimension: str) -> float | None:
    """pint's conversion factor of `unit` to the internal unit of `dimension`, or None
    (pint missing, unit unknown, another dimension, or an offset unit such as degC)."""
    if dimension not in _PINT_INTERNAL:
        return None
    return _pint_to(unit, _PINT_INTERNAL[dimension])


_AT = re.compile(r"\s+at\s+", re.IGNORECASE)
"""The word that joins a kinematic viscosity to its density (`230 cSt at 870 kg/m^3`);
spaces around it, so `atm` is not split."""

_DENSITY = "kgf*s**2/mm**4"
"""The internal unit of density (mass kgf*s^2/mm per mm^3), so that nu [mm^2/s] times
rho is a viscosity in kgf*s/mm^2."""


def _needs_density(number: str, unit: str) -> str:
    return (f"kinematic viscosity needs a density: write '{number} {unit} at 870 kg/m^3' "
            "(with the lubricant's density)")


def _kinematic_factor(kinematic: str, density: str) -> float:
    """Factor of a kinematic-viscosity unit at a density (`"cSt"`, `"870 kg/m^3"`) to the
    internal dynamic viscosity kgf*s/mm^2: eta = nu rho."""
    nu = _pint_to(kinematic.strip(), "mm**2/s") if kinematic.strip() else None
    if nu is None:
        raise UnitError(f"{kinematic.strip()!r} before 'at' is not a kinematic viscosity unit; "
                        "use cSt, mm^2/s, St or m^2/s, e.g. '230 cSt at 870 kg/m^3'")
    m = _QUANTITY.match(density)
    rho = None if m is None or not m.group(2) else _pint_to(m.group(2), _DENSITY)
    if rho is None:
        raise UnitError(f"{density.strip()!r} after 'at' is not a density with its unit; "
                        "e.g. '870 kg/m^3' or '0.87 g/cm^3'")
    rho *= float(m.group(1))
    if not (math.isfinite(rho) and rho > 0):
        raise UnitError(f"the density must be positive and finite, got {density.strip()!r}")
    return nu * rho


@functools.lru_cache(maxsize=256)
def _pint_to(unit: str, target: str) -> float | None:
    """pint's factor from `unit` to the pint unit `target`, or None (see `_pint_factor`)."""
    if not unit:
        return None
    try:
        import pint  # noqa: F401
    except ImportError:  # pragma: no cover (pint is a dependency)
        return None
    try:
        ureg = _registry()
        q = ureg.Quantity(1.0, ureg.parse_units(unit.replace("^", "**")))
        value = float(q.to(target).magnitude)
    except Exception:  # noqa: BLE001  pint's parser raises many kinds on junk text
        # (PintError, TokenError, SyntaxError, ...): any of them means "not a unit pint
        # knows of this dimension", which the caller reports with the units it accepts
        return None
    return value if math.isfinite(value) and value > 0 else None


@functools.lru_cache(maxsize=1)
def _registry():
    import pint

    return pint.UnitRegistry()


def to_internal(value, unit: str, dimension: str):
    """Convert `value` in `unit` to the internal unit of `dimension` (kgf, mm, s)."""
    return value * factor(unit, dimension)


def from_internal(value, unit: str, dimension: str):
    """Convert `value` in the internal unit of `dimension` to `unit`."""
    return value / factor(unit, dimension)


_QUANTITY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


def parse_quantity(text: str, dimension: str, default_unit: str | None = None) -> float:
    """Parse `"1.5 mm/min"` or `"0.5um"` into a float in the internal unit.

    A bare number takes `default_unit`; without one, a bare number is an error. A
    viscosity may be kinematic with its density: `"230 cSt at 870 kg/m^3"`.
    """
    m = _QUANTITY.match(str(text))
    if m is None:
        raise UnitError(f"cannot read a number from {text!r}")
    value, unit = float(m.group(1)), m.group(2)
    if unit == "":
        if default_unit is None:
            raise UnitError(f"{text!r} has no unit; expected a {dimension} unit")
        unit = default_unit
    if (dimension == "viscosity" and not _AT.search(unit)
            and _pint_to(unit.strip(), "mm**2/s") is not None):
        raise UnitError(_needs_density(m.group(1), unit.strip()))
    return to_internal(value, unit, dimension)


def mm_per_min(v_mm_s):
    """Speed in mm/s (internal) to mm/min (the paper's)."""
    return v_mm_s * 60.0


def from_mm_per_min(v_mm_min):
    """Speed in mm/min (the paper's) to mm/s (internal)."""
    return v_mm_min / 60.0
