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
