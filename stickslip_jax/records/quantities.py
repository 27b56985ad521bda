"""Units of a record's quantities and columns: the dimension of a unit, the internal unit of
an extra column, a header's `number unit` read into internal units, and numbers written
in a unit so that reading them gives the internal value back exactly."""

from __future__ import annotations

import math
import re

import numpy as np

from ..units import INTERNAL_UNIT, UNITS, UnitError, factor
from .errors import RecordError
from .grammar import QUANTITY


def unit_dimension(unit: str) -> str:
    """The dimension (`"length"`, `"time"`, ...) of a unit that `stickslip_jax.units` knows."""
    for dimension in UNITS:
        try:
            factor(unit, dimension)
        except UnitError:
            continue
        return dimension
    raise UnitError(f"unknown unit {unit!r}")


def unit_choices(dimension: str) -> str:
    return ", ".join(u for u in UNITS[dimension] if u)


def channel_dimension(unit: str) -> str:
    """The dimension of an extra column's unit; a unit `stickslip_jax.units` does not know
    (`degC`, `%RH`, `V`, ...) is kept as written: dimension `"raw:<unit>"`, factor 1."""
    try:
        return unit_dimension(unit)
    except UnitError:
        return "raw:" + unit.strip()


def channel_factor(unit: str) -> float:
    dim = channel_dimension(unit)
    return 1.0 if dim.startswith("raw:") else factor(unit, dim)


def internal_channel_unit(unit: str) -> str:
    dim = channel_dimension(unit)
    return unit.strip() if dim.startswith("raw:") else INTERNAL_UNIT[dim]


_DECIMAL_COMMA = re.compile(r"(\s*[-+]?\d+),(\d+\s*(?:[eE][-+]?\d+)?\s*(?:[^\d\s,.].*)?)")


def quantity(text: str, dimension: str, key: str, path, line: int) -> float:
    """`number unit` in internal units; a decimal comma (`86,9 kgf/mm`) is a point."""
    text = _DECIMAL_COMMA.sub(r"\1.\2", text) if _DECIMAL_COMMA.fullmatch(text) else text
    m = QUANTITY.fullmatch(text)
    if m is None:
        raise RecordError(f"{key}: cannot read 'number unit' from {text.strip()!r}; "
                          f"write e.g. '{key}: 1.5 {INTERNAL_UNIT[dimension]}'", path, line)
    value, unit = float(m.group(1)), m.group(2)
    if unit == "":
        raise RecordError(
            f"{key}: {text.strip()!r} has no unit; add one of {unit_choices(dimension)}", path,
            line)
    try:
        f = factor(unit, dimension)
    except UnitError:
        raise RecordError(
            f"{key}: unknown {dimension} unit {unit!r}; use one of {unit_choices(dimension)}", path,
            line) from None
    if not math.isfinite(value):
        raise RecordError(f"{key}: {m.group(1)!r} is out of range", path, line)
    return value * f


def encode(values: np.ndarray, f: float) -> np.ndarray:
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


def fmt(x: float) -> str:
    return repr(float(x))

