"""Effect families of the per-cycle discovery model (fitting/discovery/cycle_effects.py):
the neighbouring shapes of the shape refinement and the Stribeck forms."""

from __future__ import annotations

import pytest

from stickslip_fitting.discovery.cycle_effects import (
    PITCH_STEP,
    SHAPE_STEP,
    STRIBECK_FORMS,
    DampingForm,
    Shape,
    StribeckForm,
    family,
    neighbour_shapes,
)


def test_stribeck_neighbours_step_the_scale_the_exponent_and_the_form():
    f = family("stribeck")
    start = Shape(vs=3.0, p=2.0, form=StribeckForm.EXP)
    near = neighbour_shapes(f, start)
    assert start not in near and len(near) == len(set(near))
    assert Shape(vs=3.0 * SHAPE_STEP, p=2.0) in near and Shape(vs=3.0 / SHAPE_STEP, p=2.0) in near
    assert Shape(vs=3.0, p=3.0) in near and Shape(vs=3.0, p=1.0) in near
    assert {s.form for s in near} == {StribeckForm.EXP, StribeckForm.RATIONAL, StribeckForm.LOG}
    # the exponent never falls below 0.5; the log form has none to step
    assert all(s.p >= 0.5 for s in neighbour_shapes(f, Shape(vs=3.0, p=0.5)))
    log = neighbour_shapes(f, Shape(vs=1.0, form=StribeckForm.LOG))
    assert all(s.p == 1.0 for s in log if s.form is StribeckForm.LOG)
    assert StribeckForm.RATIONAL in STRIBECK_FORMS


@pytest.mark.parametrize("name, shape, field, step", [
    ("rate_state", Shape(length=0.03), "length", SHAPE_STEP),
    ("drive_periodic_error", Shape(pitch=5.0), "pitch", PITCH_STEP),
])
def test_scale_like_shapes_step_by_the_factor(name, shape, field, step):
    near = neighbour_shapes(family(name), shape)
    values = sorted(getattr(s, field) for s in near)
    assert values == pytest.approx([getattr(shape, field) / step,
                                    getattr(shape, field) * step])


def test_sensor_neighbours_and_families_without_shapes():
    f = family("sensor_lowpass")
    near = neighbour_shapes(f, Shape(order=2, zeta=1.0))
    assert Shape(order=1, zeta=1.0) in near and Shape(order=2, zeta=0.85) in near
    assert all(0.3 <= s.zeta <= 1.0 for s in near)
    assert neighbour_shapes(f, Shape(order=1)) == [Shape(order=2, zeta=0.7)]
    for name in ("friction_drift", "gauge_drift", "load_coupling", "drive_speed_drift"):
        assert neighbour_shapes(family(name), Shape()) == []


def test_damping_forms_are_neighbours_and_name_their_parameter():
    f = family("viscous_damping")
    ratio = Shape(damping=DampingForm.RATIO)
    assert neighbour_shapes(f, Shape()) == [ratio]
    assert neighbour_shapes(f, ratio) == [Shape()]
    assert f.named(Shape()) == (("c",), ("kgf*s/mm",))
    assert f.named(ratio) == (("zeta",), ("-",))
    assert ratio.label(f) == "ratio"


def test_a_form_given_by_its_value_is_the_member():
    """The forms' values (the labels and JSON write them) build the same shape."""
    shape = Shape(form="rational", damping="ratio")
    assert shape.form is StribeckForm.RATIONAL and shape.damping is DampingForm.RATIO
    assert shape == Shape(form=StribeckForm.RATIONAL, damping=DampingForm.RATIO)
    assert hash(shape) == hash(Shape(form=StribeckForm.RATIONAL, damping=DampingForm.RATIO))
    with pytest.raises(ValueError):
        Shape(form="cubic")


def test_rational_stribeck_label():
    assert Shape(vs=10.0, p=2.0, form=StribeckForm.RATIONAL).label(family("stribeck")) == \
        "rational, vs = 10, p = 2"
    assert Shape(vs=10.0, p=2.0).label(family("stribeck")) == "vs = 10, p = 2"
