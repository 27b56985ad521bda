"""One internal unit system and the conversions at the edges.

Internally every quantity is in **kgf, mm, s** (the paper's system):

| quantity        | internal unit      |
|-----------------|--------------------|
| force, weight   | kgf                |
| length          | mm                 |
| time            | s                  |
| speed           | mm/s               |
| stiffness       | kgf/mm             |
| mass            | kgf*s^2/mm (= W/g) |
| viscosity       | kgf*s/mm^2         |
| pressure        | kgf/mm^2           |

The paper quotes drive speeds in mm/min; they are converted to mm/s on the way in
and back on the way out. Only code at the edges (records, CLI, plots) calls the
functions of this module.
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
    "speed": {
        "mm/s": 1.0,
        "mm/min": 1.0 / 60.0,
        "um/s": 1e-3,
        "µm/s": 1e-3,
        "m/s": 1e3,
        "m/min": 1e3 / 60.0,
    },
    "stiffness": {"kgf/mm": 1.0, "N/mm": 1.0 / KGF_N, "N/m": 1e-3 / KGF_N, "kN/m": 1.0 / KGF_N},
    "mass": {"kg": 1.0 / (G_MM_S2), "kgf*s^2/mm": 1.0},
    "viscosity": {
        "kgf*s/mm^2": 1.0,
        "Pa*s": 1.0 / (KGF_N * 1e6),
        "mPa*s": 1e-3 / (KGF_N * 1e6),
        "cP": 1e-3 / (KGF_N * 1e6),
    },
    "pressure": {
        "kgf/mm^2": 1.0,
        "kgf/cm^2": 1e-2,
        "Pa": 1.0 / (KGF_N * 1e6),
        "MPa": 1.0 / KGF_N,
    },
    "dimensionless": {"": 1.0, "-": 1.0, "1": 1.0},
}

INTERNAL_UNIT = {
    "time": "s",
    "length": "mm",
    "force": "kgf",
    "speed": "mm/s",
    "stiffness": "kgf/mm",
    "mass": "kgf*s^2/mm",
    "viscosity": "kgf*s/mm^2",
    "pressure": "kgf/mm^2",
    "dimensionless": "",
}


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
    if dimension not in UNITS:
        raise UnitError(f"unknown dimension {dimension!r}; expected one of {sorted(UNITS)}")
    table = UNITS[dimension]
    u = _normalise(unit)
    if u in table:
        return table[u]
    got = _pint_factor(unit.strip(), dimension)
    if got is None:
        raise UnitError(
            f"unknown {dimension} unit {unit!r}; use one of: {', '.join(k for k in table if k)} "
            "(or any unit of that dimension that pint knows, e.g. 'N/um', 'in/min', 'lbf')"
        )
    return got


_PINT_INTERNAL = {
    "time": "s", "length": "mm", "force": "kgf", "speed": "mm/s", "stiffness": "kgf/mm",
    "mass": "kgf*s**2/mm", "viscosity": "kgf*s/mm**2", "pressure": "kgf/mm**2",
    "dimensionless": "dimensionless",
}


@functools.lru_cache(maxsize=256)
def _pint_factor(unit: str, dimension: str) -> float | None:
    """pint's conversion factor of `unit` to the internal unit of `dimension`, or None
    (pint missing, unit unknown, another dimension, or an offset unit such as degC)."""
    if not unit or dimension not in _PINT_INTERNAL:
        return None
    try:
        import pint
    except ImportError:  # pragma: no cover (pint is a dependency)
        return None
    try:
        ureg = _registry()
        q = ureg.Quantity(1.0, ureg.parse_units(unit.replace("^", "**")))
        value = float(q.to(_PINT_INTERNAL[dimension]).magnitude)
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

    A bare number takes `default_unit`; without one, a bare number is an error.
    """
    m = _QUANTITY.match(str(text))
    if m is None:
        raise UnitError(f"cannot read a number from {text!r}")
    value, unit = float(m.group(1)), m.group(2)
    if unit == "":
        if default_unit is None:
            raise UnitError(f"{text!r} has no unit; expected a {dimension} unit")
        unit = default_unit
    return to_internal(value, unit, dimension)


def mm_per_min(v_mm_s):
    """Speed in mm/s (internal) to mm/min (the paper's)."""
    return v_mm_s * 60.0


def from_mm_per_min(v_mm_min):
    """Speed in mm/min (the paper's) to mm/s (internal)."""
    return v_mm_min / 60.0
