"""Units on the command line: one default unit per quantity in every command, and the
bare `--eta` numbers of the old default unit (kgf*s/mm^2) refused with how to write them."""

import argparse

import pytest

from stickslip_jax.cli import build_parser, main
from stickslip_jax.units import DEFAULT_UNIT, from_internal


def _quantity_options():
    """(command, option, dimension, default unit) of every option typed by
    `stickslip_jax.commands.options.quantity` or `viscosity` (type names 'dimension (unit)')."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for command, p in sub.choices.items():
        for action in p._actions:
            name = getattr(action.type, "__name__", "")
            if name.endswith(")") and " (" in name:
                dimension, unit = name[:-1].split(" (", 1)
                yield command, action.option_strings[0], dimension, unit


def test_every_command_has_one_default_unit_per_quantity():
    found = list(_quantity_options())
    assert {(c, o) for c, o, _, _ in found} >= {("fit", "--eta"), ("mcmc", "--eta"),
                                                 ("pitch", "--viscosity")}
    for command, option, dimension, unit in found:
        assert unit == DEFAULT_UNIT[dimension], (command, option, unit)


def _parse(argv):
    return build_parser().parse_args(argv)


@pytest.mark.parametrize("command, option", [("fit", "--eta"), ("mcmc", "--eta"),
                                             ("pitch", "--viscosity")])
def test_a_bare_viscosity_is_pa_s(command, option):
    extra = ["--model", "microsqueeze"] if command != "pitch" else []
    for text, pa_s in (("0.216", 0.216), ("216 cP", 0.216), ("2.2e-8 kgf*s/mm^2", 0.21575),
                       ("230 cSt at 870 kg/m^3", 0.2001)):
        args = _parse([command, "r.csv", *extra, option, text])
        got = getattr(args, option.lstrip("-"))
        assert from_internal(got, "Pa*s", "viscosity") == pytest.approx(pa_s, rel=1e-4), text


@pytest.mark.parametrize("command, option", [("fit", "--eta"), ("pitch", "--viscosity")])
def test_a_bare_value_thinner_than_air_is_refused(command, option, capsys):
    with pytest.raises(SystemExit) as exc:
        main([command, "missing.csv", option, "2.2e-8"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert f"argument {option}: a bare viscosity is in Pa*s (the default unit" in err[0]
    assert "'2.2e-8 kgf*s/mm^2' (= 0.2157 Pa*s)" in err[0]


def test_kinematic_viscosity_without_density_is_one_line(capsys):
    with pytest.raises(SystemExit):
        main(["fit", "missing.csv", "--model", "microsqueeze", "--eta", "230 cSt"])
    assert ("kinematic viscosity needs a density: write '230 cSt at 870 kg/m^3'"
            in capsys.readouterr().err)
