"""Smoothed simulator, `formulation="latch"` (not stiff, explicit Tsit5): convergence to
the exact simulator, gradients against finite differences at three smoothing scales and
two tolerances, parts, padded vmap, reported failures."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.simulation import (
    DEFAULT_SMOOTHING,
    SimulationResult,
    SmoothModel,
    ViscousDamping,
    pad_times,
    simulate_smooth,
)
from slideway_leaves import FRICTION_LEAVES, SW, V, amplitude_error_against_exact

a = jnp.asarray
LATCH = dict(formulation="latch")
SHARPEST = 1e-4  # the sharpest smoothing whose gradients are verified here


@pytest.fixture(scope="module")
def smooth():
    return eqx.filter_jit(simulate_smooth)


def test_latch_converges_to_exact_as_smoothing_shrinks(smooth):
    ts, error = amplitude_error_against_exact()
    errors = []
    for eta in (1e-2, DEFAULT_SMOOTHING, SHARPEST):
        tr = smooth(SW, ConstantSpeed(V), ts, smoothing=a(eta), max_steps=4096, **LATCH)
        assert tr.result == SimulationResult.successful
        assert int(tr.num_events) < 1000  # about 130 steps per cycle, whatever eta
        errors.append(error(tr.deflection))
    assert errors[0] > errors[1] > errors[2], errors
    assert errors[1] < 0.01, errors  # the default smoothing
    assert errors[2] < 1e-3, errors


LEAVES = FRICTION_LEAVES
TS_GRAD = jnp.linspace(0.0, 1.2, 121)
# aged contact (stuck 2 s already): one breakaway and one slip inside the window
AGED = dict(initial_deflection=a(0.12), initial_stick_time=a(2.0), max_steps=4096)
TIGHT = (a(1e-12), a(1e-14))


def _run(fn, model, eta, rtol, atol, ts=TS_GRAD, **kw):
    return fn(model, ConstantSpeed(V), ts, smoothing=eta, rtol=rtol, atol=atol, **AGED,
              **LATCH, **kw)


def _loss(sw, eta, rtol, atol):
    return jnp.mean(_run(simulate_smooth, sw, eta, rtol, atol).deflection ** 2)


@pytest.fixture(scope="module")
def grads(smooth):
    grad_fn = eqx.filter_jit(eqx.filter_grad(_loss))

    def fd(eta, get, h=1e-5):
        """Central finite difference (relative step h) with a tight-tolerance solve (the
        compiled simulation of the parts test below)."""
        p = get(SW)
        lp, lm = (jnp.mean(_run(smooth, eqx.tree_at(get, SW, p * (1 + s * h)), a(eta),
                                *TIGHT).deflection ** 2) for s in (1, -1))
        return float((lp - lm) / (2 * h * p))

    return grad_fn, fd


@pytest.mark.parametrize("eta", [1e-2, DEFAULT_SMOOTHING, SHARPEST])
def test_latch_gradients_match_finite_differences(eta, grads):
    grad_fn, fd = grads
    gs = [grad_fn(SW, a(eta), a(rtol), a(rtol * 1e-2)) for rtol in (1e-9, 1e-10)]
    for name, get in LEAVES.items():
        ref = fd(eta, get)
        for rtol, g in zip((1e-9, 1e-10), gs):
            gv = float(get(g))
            assert np.isfinite(gv), (eta, name)
            assert abs(gv - ref) <= 1e-4 * abs(ref), (eta, rtol, name, gv, ref)


def test_latch_parts_plug_in_vmap_and_failure_code(smooth):
    std = (a(DEFAULT_SMOOTHING), a(1e-8), a(1e-10))
    base = _run(smooth, SW, *std)
    assert base.result == SimulationResult.successful
    zero = _run(smooth, SmoothModel(SW, force_terms=(ViscousDamping(0.0),)), *std)
    damped = _run(smooth, SmoothModel(SW, force_terms=(ViscousDamping(0.05),)), *std)
    np.testing.assert_allclose(np.asarray(zero.deflection), np.asarray(base.deflection),
                               atol=1e-12)
    assert float(jnp.max(jnp.abs(damped.deflection - base.deflection))) > 1e-4
    # one breakaway and one slip in the window, no creep while stuck
    assert int(base.cycles.valid.sum()) == 1
    assert float(jnp.max(jnp.abs(base.slider_velocity[:40]))) < 1e-9

    ts, mask = pad_times([np.linspace(0.0, 0.8, 81), np.asarray(TS_GRAD)])
    out = eqx.filter_jit(lambda ts, mask: jax.vmap(
        lambda t, m: _run(simulate_smooth, SW, *std, ts=t, mask=m))(ts, mask))(ts, mask)
    one = _run(smooth, SW, *std, ts=ts[0])
    np.testing.assert_allclose(np.asarray(out.deflection[0, :81]),
                               np.asarray(one.deflection[:81]), atol=1e-7)
    np.testing.assert_allclose(np.asarray(out.deflection[1]), np.asarray(base.deflection),
                               atol=1e-7)
    with pytest.raises(ValueError, match="non-decreasing"):  # checked before compiling
        simulate_smooth(SW, ConstantSpeed(V), TS_GRAD[::-1], smoothing=std[0], rtol=std[1],
               atol=std[2], initial_deflection=a(0.12), initial_stick_time=a(2.0),
               max_steps=4096, **LATCH)
    # a tolerance below float64's resolution exhausts the step budget (about 4,000 steps
    # where 1e-15 takes 2,800): reported, not silent
    bad = _run(smooth, SW, a(DEFAULT_SMOOTHING), a(1e-22), a(1e-24))
    assert bad.result == SimulationResult.solver_failed
