"""Drives: positions and speeds of the three drive kinds, record conversion, validation."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stickslip_jax.drives import ConstantSpeed, MeasuredDrive, SpeedProgram, drive_from_record
from stickslip_jax.records import Record


def test_constant_speed():
    d = ConstantSpeed(0.5)
    t = jnp.asarray([0.0, 1.0, 2.5])
    np.testing.assert_allclose(d.position(t), 0.5 * t)
    np.testing.assert_allclose(d.speed(t), 0.5)
    # differentiable in the speed
    assert float(jax.grad(lambda v: ConstantSpeed(v).position(2.0))(0.3)) == 2.0


def test_slide_hold_slide_program():
    d = SpeedProgram([0.0, 2.0, 5.0], [0.1, 0.0, 0.2])
    t = jnp.asarray([1.0, 2.0, 3.0, 5.0, 6.0])
    np.testing.assert_allclose(d.position(t), [0.1, 0.2, 0.2, 0.2, 0.4], atol=1e-15)
    np.testing.assert_allclose(d.speed(t), [0.1, 0.0, 0.0, 0.2, 0.2])


def test_measured_drive_interpolates_and_holds():
    d = MeasuredDrive([0.0, 1.0, 2.0], [0.0, 0.1, 0.3])
    np.testing.assert_allclose(d.position(jnp.asarray([0.5, 1.5, 3.0])), [0.05, 0.2, 0.3])
    np.testing.assert_allclose(d.speed(jnp.asarray([0.5, 1.5, 3.0])), [0.1, 0.2, 0.0])


def test_bad_drives_raise():
    with pytest.raises(ValueError, match="increase"):
        SpeedProgram([0.0, 0.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="same length"):
        SpeedProgram([0.0, 1.0], [1.0])
    with pytest.raises(ValueError, match="at least 2 samples"):
        MeasuredDrive([0.0], [0.0])


def test_drive_from_record():
    t = np.linspace(0.0, 1.0, 11)
    base = dict(time=t, deflection=np.zeros_like(t), stiffness=86.9, weight=36.0)
    assert isinstance(drive_from_record(Record(**base, drive_speed=0.1)), ConstantSpeed)
    prog = drive_from_record(Record(**base, drive_program=((0.5, 0.1), (0.8, 0.0))))
    np.testing.assert_allclose(prog.position(jnp.asarray([0.25, 0.7, 1.0])), [0.0, 0.02, 0.03],
                               atol=1e-15)
    meas = drive_from_record(Record(**base, drive=0.2 * t))
    np.testing.assert_allclose(meas.position(jnp.asarray(0.55)), 0.11)
