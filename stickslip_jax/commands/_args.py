"""Argument types shared by subcommands: quantities with units, positive numbers."""

from __future__ import annotations

import argparse

from ..units import UnitError, parse_quantity


def quantity(dimension: str, default_unit: str, positive: bool = True):
    """argparse type: `"1.5"` (in `default_unit`) or `"1.5 mm/min"` -> internal unit."""

    def parse(text: str) -> float:
        try:
            value = parse_quantity(text, dimension, default_unit)
        except UnitError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        if positive and not value > 0:
            raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
        if value != value or value in (float("inf"), float("-inf")):
            raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
        return value

    parse.__name__ = f"{dimension} ({default_unit})"
    return parse


BARE_VISCOSITY_FLOOR = 1e-5
"""Pa*s. A bare viscosity below it (thinner than air, 1.8e-5 Pa*s) is a value written in
the old default unit of `fit --eta`, kgf*s/mm^2 (lubricant A: 2.2e-8), and is refused."""


def viscosity():
    """argparse type of a viscosity: a bare number in Pa*s (`units.DEFAULT_UNIT`, every
    command), or any unit: `0.216 Pa*s`, `216 cP`, `2.2e-8 kgf*s/mm^2`,
    `230 cSt at 870 kg/m^3`. A bare number below `BARE_VISCOSITY_FLOOR` is refused with
    how to write it in kgf*s/mm^2 (the old unit of `--eta`)."""
    parse_default = quantity("viscosity", "Pa*s")

    def parse(text: str) -> float:
        try:
            bare = float(text)
        except ValueError:
            bare = None
        if bare is not None and 0 < bare < BARE_VISCOSITY_FLOOR:
            from ..units import from_internal

            old = f"{text.strip()} kgf*s/mm^2"
            pa_s = from_internal(parse_default(old), "Pa*s", "viscosity")
            raise argparse.ArgumentTypeError(
                f"a bare viscosity is in Pa*s now (the default unit of every command; --eta "
                f"took kgf*s/mm^2 before), and {text.strip()} Pa*s is thinner than air: write "
                f"the unit, e.g. '{old}' (= {pa_s:.4g} Pa*s)")
        return parse_default(text)

    parse.__name__ = parse_default.__name__
    return parse
