"""Argument types and options shared by subcommands: quantities with units, and the one
grammar of output options (`--json OUT`, `--plot OUT.png`, `--quiet`). Public: the
subcommands registered from other packages (`stickslip_fitting.commands`) use them.

Nothing here imports JAX or pint at import time: `stickslip --help` builds every parser
without them (the unit parser is imported when a value is read).
"""

from __future__ import annotations

import argparse


def quantity(dimension: str, default_unit: str, positive: bool = True):
    """argparse type: `"1.5"` (in `default_unit`) or `"1.5 mm/min"` -> internal unit."""

    def parse(text: str) -> float:
        from ..units import UnitError, parse_quantity

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


def add_slideway_options(p) -> None:
    """`--weight` W and `--stiffness` k (required) and `--normal-load` N (default W), each
    a number in kgf or kgf/mm or a quantity with its unit."""
    p.add_argument("--weight", type=quantity("force", "kgf"), required=True,
                   help="slider weight W (kgf, or with unit: '353 N')")
    p.add_argument("--stiffness", type=quantity("stiffness", "kgf/mm"), required=True,
                   help="drive stiffness k (kgf/mm, or with unit: '852 N/mm')")
    add_normal_load_option(p)


def add_lubricant_options(p) -> None:
    """`--lubricant` (a paper lubricant) and `--table` (the table of eq (1)'s parameters)."""
    p.add_argument("--lubricant", default="A", help="paper lubricant (Table 6: A, C)")
    p.add_argument("--table", type=int, default=6, choices=(4, 6, 9),
                   help="table of eq (1) parameters (default 6; 4 and 9 borrow delta, n of A)")


def add_normal_load_option(p) -> None:
    """`--normal-load` N (kgf or a quantity with its unit; default None: N = W)."""
    p.add_argument("--normal-load", type=quantity("force", "kgf"), default=None,
                   help="normal load N pressing the slider on the slideway, when a dead "
                        "weight or a cylinder sets it apart from the moving weight W (kgf, or "
                        "with unit; default W)")


def add_json_option(parser, what: str, *, bare: bool = False, action=None) -> None:
    """`--json OUT`: write `what` as JSON to the file OUT, or to stdout with `-` (the
    command's table then goes to stderr: `stickslip_jax.output.json_owns_stdout`).
    `bare`: a `--json` without a value also means `--json -` (steady, design, plan). `action`: an argparse
    Action class in place of storing the value."""
    extra = dict(nargs="?", const="-") if bare else {}
    if action is not None:
        extra["action"] = action
    parser.add_argument(
        "--json", metavar="OUT", **extra,
        help=f"write {what} as JSON to the file OUT; '-' writes it to stdout (the table "
        "then goes to stderr)" + ("; a bare --json is --json -" if bare else ""))


class _StoreNamed(argparse.Action):
    """Store the value and the option name the user typed (`args.<dest>_option`), so an
    error names `--corner` when the user wrote `--corner`, not its other name `--plot`."""

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, values)
        setattr(namespace, f"{self.dest}_option", option_string)


def add_plot_option(parser, what: str, *, aliases=(), hidden=()) -> None:
    """`--plot OUT.png`: save the command's figure `what` (format from the extension);
    `args.plot_option` is the name the user gave it. `aliases`: other visible names of the
    option; `hidden`: old names still accepted but not shown in --help (deprecated)."""
    parser.add_argument("--plot", *aliases, dest="plot", metavar="OUT.png", action=_StoreNamed,
                        help=f"save {what} to OUT.png (the format follows the extension)")
    for name in hidden:
        parser.add_argument(name, dest="plot", metavar="OUT.png", action=_StoreNamed,
                            default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    parser.set_defaults(plot_option="--plot")


def add_quiet_option(parser) -> None:
    """`--quiet`: no progress lines or bars on stderr (they are on by default)."""
    parser.add_argument("--quiet", "-q", action="store_true",
                        help="print no progress (stage lines, bars) on stderr")


BARE_VISCOSITY_FLOOR = 1e-5
"""Pa*s. A bare viscosity below it (thinner than air, 1.8e-5 Pa*s) is a value written in
the paper's unit, kgf*s/mm^2 (lubricant A: 2.2e-8), and is refused."""


def viscosity():
    """argparse type of a viscosity: a bare number in Pa*s (`units.DEFAULT_UNIT`, every
    command), or any unit: `0.216 Pa*s`, `216 cP`, `2.2e-8 kgf*s/mm^2`,
    `230 cSt at 870 kg/m^3`. A bare number below `BARE_VISCOSITY_FLOOR` is refused with
    how to write it in kgf*s/mm^2 (the paper's unit)."""
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
                f"a bare viscosity is in Pa*s (the default unit of every command), and "
                f"{text.strip()} Pa*s is thinner than air: write the unit, e.g. '{old}' "
                f"(= {pa_s:.4g} Pa*s)")
        return parse_default(text)

    parse.__name__ = parse_default.__name__
    return parse
