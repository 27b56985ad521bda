"""Unit conversions at the edges (stickslip_jax.units): internal kgf, mm, s."""

import math

import pytest

from stickslip_jax import units
from stickslip_jax.units import UnitError, parse_quantity


def test_viscosity_of_lubricant_a_in_pa_s():
    # NOTES.md: lubricant A, 2.2e-8 kgf*s/mm^2 = 0.216 Pa*s (1 kgf = 9.80665 N, 1 mm^2 = 1e-6 m^2)
    pa_s = units.from_internal(2.2e-8, "Pa*s", "viscosity")
    assert pa_s == pytest.approx(2.2e-8 * 9.80665e6, rel=1e-12)
    assert round(pa_s, 3) == 0.216
    assert units.to_internal(0.216, "Pa*s", "viscosity") == pytest.approx(2.2e-8, rel=2e-3)
    assert units.from_internal(2.2e-8, "mPa*s", "viscosity") == pytest.approx(215.746, rel=1e-5)
    assert units.factor("cP", "viscosity") == units.factor("mPa*s", "viscosity")


def test_speed_mm_per_min():
    assert units.from_mm_per_min(92.0) == pytest.approx(92.0 / 60.0)
    assert units.mm_per_min(units.from_mm_per_min(0.0022)) == pytest.approx(0.0022, rel=1e-15)
    assert units.parse_quantity("0.0022", "speed", "mm/min") == pytest.approx(0.0022 / 60)
    assert units.parse_quantity("10 um/s", "speed", "mm/min") == pytest.approx(0.01)
    assert units.parse_quantity("1.2 m/min", "speed") == pytest.approx(20.0)


def test_stiffness_force_mass_pressure():
    assert units.to_internal(852.2, "N/mm", "stiffness") == pytest.approx(852.2 / 9.80665)
    assert units.to_internal(1e6, "N/m", "stiffness") == pytest.approx(1e3 / 9.80665)
    assert units.to_internal(9.80665, "N", "force") == pytest.approx(1.0)
    # A 36 kg slider weighs 36 kgf; its mass is W/g in kgf*s^2/mm.
    assert units.to_internal(36.0, "kg", "mass") == pytest.approx(36.0 / 9806.65)
    assert units.G_MM_S2 == pytest.approx(units.KGF_N * 1000.0)
    assert units.to_internal(0.215, "kgf/cm^2", "pressure") == pytest.approx(0.00215)
    assert units.from_internal(1.0, "MPa", "pressure") == pytest.approx(9.80665)
    assert units.parse_quantity("0.5 µm", "length") == pytest.approx(5e-4)
    assert units.parse_quantity("0.5μm", "length") == pytest.approx(5e-4)


def test_round_trip_every_unit():
    for dimension, table in units.UNITS.items():
        for unit in table:
            x = units.to_internal(3.7, unit, dimension)
            assert units.from_internal(x, unit, dimension) == pytest.approx(3.7, rel=1e-14)
            assert units.INTERNAL_UNIT[dimension] in table


@pytest.mark.parametrize(
    "text, dimension, default",
    [
        ("abc", "speed", "mm/min"),
        ("1.5 wibbles/fortnight", "speed", "mm/min"),
        ("1.5", "speed", None),  # bare number without a default unit
        ("2 kgf/mm", "speed", "mm/min"),  # wrong kind of unit
        ("", "force", "kgf"),
        ("nan", "force", "kgf"),
    ],
)
def test_bad_quantities_raise_unit_error(text, dimension, default):
    with pytest.raises(units.UnitError):
        units.parse_quantity(text, dimension, default)
    assert issubclass(units.UnitError, ValueError)


def test_unknown_dimension():
    with pytest.raises(units.UnitError, match="unknown dimension"):
        units.factor("mm", "colour")
    assert math.isclose(units.factor(" kgf ", "force"), 1.0)


@pytest.mark.parametrize("text, dimension, expected", [
    ("852 N/um", "stiffness", 852e3 / 9.80665),
    ("40 in/min", "speed", 40 * 25.4 / 60),
    ("10 lbf", "force", 4.4482216152605 * 10 / 9.80665),
    ("2 mN", "force", 2e-3 / 9.80665),
    ("5 um/min", "speed", 5e-3 / 60),
    ("0.216 Pa s", "viscosity", 0.216 / 9.80665 * 1e-6),
])
def test_lab_units_through_pint(text, dimension, expected):
    """Units the table does not list go through pint, checked against the dimension."""
    assert parse_quantity(text, dimension) == pytest.approx(expected, rel=1e-9)


def test_pint_refuses_the_wrong_dimension():
    with pytest.raises(UnitError, match="unknown speed unit"):
        parse_quantity("3 lbf", "speed")


def test_kinematic_viscosity_at_a_density_against_a_hand_computation():
    # eta = nu rho: 230 cSt = 230e-6 m^2/s, times 870 kg/m^3 = 0.2001 Pa*s
    hand = 230e-6 * 870.0
    for text in ("230 cSt at 870 kg/m^3", "230 mm^2/s at 0.87 g/cm^3", "2.3 St at 870 kg/m³",
                 "2.3e-4 m^2/s AT 870 kg/m^3"):
        eta = parse_quantity(text, "viscosity")
        assert units.from_internal(eta, "Pa*s", "viscosity") == pytest.approx(hand, rel=1e-12)
    assert hand == pytest.approx(0.2001, rel=1e-12)
    # the same through a bare number with the kinematic unit as the default unit
    assert parse_quantity("230", "viscosity", "cSt at 870 kg/m^3") == pytest.approx(
        units.to_internal(0.2001, "Pa*s", "viscosity"), rel=1e-12)


@pytest.mark.parametrize("text, message", [
    ("230 cSt", "kinematic viscosity needs a density: write '230 cSt at 870 kg/m^3'"),
    ("46 mm^2/s", "kinematic viscosity needs a density: write '46 mm^2/s at 870 kg/m^3'"),
    ("230 cSt at 870", "after 'at' is not a density"),
    ("230 cSt at 870 kg", "after 'at' is not a density"),
    ("230 Pa*s at 870 kg/m^3", "before 'at' is not a kinematic viscosity unit"),
    ("230 cSt at -870 kg/m^3", "density must be positive"),
])
def test_kinematic_viscosity_errors(text, message):
    with pytest.raises(UnitError) as err:
        parse_quantity(text, "viscosity")
    assert message in str(err.value)


def test_kinematic_viscosity_without_density_is_refused_by_factor_too():
    with pytest.raises(UnitError, match="kinematic viscosity needs a density"):
        units.factor("cSt", "viscosity")
    # 'at' only splits as a word: an 'atm' pressure is still a pressure
    assert units.factor("atm", "pressure") == pytest.approx(101325 / (units.KGF_N * 1e6))


def test_one_default_unit_per_quantity():
    assert units.DEFAULT_UNIT["viscosity"] == "Pa*s"
    for dimension, unit in units.DEFAULT_UNIT.items():
        assert unit in units.UNITS[dimension], dimension
