"""The learned phase correction of the per-cycle discovery base (fitting/discovery/
cycle_learned.py): phase coordinates, recovery of a phase-locked pattern, nothing learned
from a residual that is not locked to the cycle."""

from __future__ import annotations

import types

import numpy as np
import pytest

from stickslip_fitting.discovery.cycle_learned import (
    correction_columns,
    fit_cycle_correction,
    phase_coordinates,
)


def _windows(n_windows=12, samples=400, seed=0):
    """A TraceData-like set of windows (one row each): stick T1 then a slip of pi/omega0,
    sampled from the window's start (the previous slip end) to 1.6 slips after breakaway.
    Records differ in W, k and v, so climbs differ."""
    rng = np.random.default_rng(seed)
    w = rng.choice([20.0, 36.0], n_windows)
    k = rng.choice([40.0, 86.9, 200.0], n_windows)
    v = rng.choice([0.05, 0.2], n_windows)
    t1 = rng.uniform(0.5, 2.0, n_windows)
    omega0 = np.sqrt(k * 9806.65 / w)  # standard gravity in mm/s^2
    start = np.cumsum(np.r_[0.0, t1[:-1] + 2 * np.pi / omega0[:-1]])
    span = t1 + 1.6 * np.pi / omega0
    time = start[:, None] + np.linspace(0, 1, samples)[None, :] * span[:, None]
    return types.SimpleNamespace(
        mask=np.ones((n_windows, samples), bool), time=time, start_time=start,
        stick_time=t1, speed=v, stiffness=k, weight=w), omega0


def test_phase_coordinates_follow_the_measured_cycle():
    data, omega0 = _windows()
    phi, psi, climb = phase_coordinates(data)
    phi, psi = phi.reshape(data.mask.shape), psi.reshape(data.mask.shape)
    np.testing.assert_allclose(phi[:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(psi[:, -1], 1.6, rtol=1e-12)
    # the breakaway: phi 1 where psi 0
    at = np.argmin(np.abs(psi), axis=1)
    np.testing.assert_allclose(phi[np.arange(len(at)), at], 1.0, atol=0.01)
    np.testing.assert_allclose(climb.reshape(data.mask.shape)[:, 0],
                               data.speed * data.stick_time)


def _residual_problem(pattern, seed=1):
    """Whitened residuals: a phase-locked pattern (mm, per sample) plus unit noise at
    sd 0.5 um, and a base Jacobian of 6 smooth columns in time."""
    data, _ = _windows(seed=seed)
    rng = np.random.default_rng(seed)
    n = data.mask.sum()
    sd = np.full(n, 5e-4)
    phi, psi, climb = phase_coordinates(data)
    r0 = pattern(phi, psi, climb) / sd + rng.standard_normal(n)
    t = np.asarray(data.time).ravel()
    Jb = np.stack([np.cos(j * t / t.max()) for j in range(6)], axis=1)
    return data, r0, Jb, sd


def test_a_phase_locked_creep_is_learned_and_located():
    """A creep of 3 um over the last quarter of every stick (fixed size, not scaled by the
    climb): the correction closes nearly the whole excess and names the late stick."""
    def creep(phi, psi, climb):
        return np.where(psi < 0, 3e-3 * np.clip((phi - 0.75) / 0.25, 0, 1) ** 2, 0.0)

    data, r0, Jb, sd = _residual_problem(creep)
    learned = fit_cycle_correction(data, r0, Jb, sd, noise=5e-4)
    assert learned.gap_before > 1.5 * learned.noise
    assert learned.closes > 0.9, learned
    assert learned.gap_after < 1.05 * learned.noise
    assert "stick, late" in learned.signature
    doc = learned.to_json()
    assert doc["gap_unit"] == "mm" and doc["n_parameters"] == learned.n_parameters
    assert len(doc["profile_mm"]["stick_phase"]) == len(doc["profile_mm"]["stick_fixed_mm"])
    # the fixed stick part carries the creep: 3 um at phase 1
    assert doc["profile_mm"]["stick_fixed_mm"][-1] == pytest.approx(3e-3, rel=0.1)


def test_a_slip_shape_scaled_by_the_climb_is_learned():
    def slip(phi, psi, climb):
        return np.where((psi >= 0) & (psi <= 1), 0.02 * climb * np.sin(np.pi * psi), 0.0)

    data, r0, Jb, sd = _residual_problem(slip, seed=2)
    learned = fit_cycle_correction(data, r0, Jb, sd, noise=5e-4)
    assert learned.closes > 0.9 and "slip" in learned.signature


def test_a_residual_not_locked_to_the_cycle_is_not_learned():
    """White noise twice the stated noise: the correction closes almost nothing (it has
    22 coefficients against 4800 samples)."""
    data, r0, Jb, sd = _residual_problem(lambda phi, psi, climb: 0.0 * phi, seed=3)
    r0 = 2.0 * r0
    learned = fit_cycle_correction(data, r0, Jb, sd, noise=5e-4)
    assert learned.closes < 0.02, learned


def test_columns_are_zero_outside_their_phase():
    phi = np.array([0.0, 0.5, 1.0, 1.2, 1.2])
    psi = np.array([-1.0, -0.5, 0.0, 0.5, 2.0])
    cols, labels = correction_columns(phi, psi, np.ones(5))
    assert len(labels) == cols.shape[1]
    slip = [i for i, lab in enumerate(labels) if lab.startswith("slip")]
    stick = [i for i, lab in enumerate(labels) if lab.startswith("stick")]
    assert np.all(cols[:2][:, slip] == 0) and np.all(cols[3:][:, stick] == 0)
    assert np.all(cols[4] == 0)  # beyond SLIP_SPAN
    np.testing.assert_allclose(cols[:2][:, [i for i, lab in enumerate(labels)
                                            if lab.startswith("stick_scaled")]].sum(1), 1.0)


def test_correction_profile_over_the_cycle():
    """`correction_at`: the fitted correction at the median climb, stick then slip phase
    (the discover figure's panel)."""
    def creep(phi, psi, climb):
        return np.where(psi < 0, 3e-3 * np.clip((phi - 0.75) / 0.25, 0, 1) ** 2, 0.0)

    data, r0, Jb, sd = _residual_problem(creep)
    learned = fit_cycle_correction(data, r0, Jb, sd, noise=5e-4)
    phase, corr = learned.correction_at()
    assert phase.shape == corr.shape and phase[0] == 0.0 and phase[-1] == pytest.approx(2.5)
    late = (phase > 0.9) & (phase < 1.0)
    early = phase < 0.5
    assert np.mean(corr[late]) > 1.5e-3 > 5 * np.max(np.abs(corr[early]))
