"""Smoothed simulator: convergence to the exact one, gradients vs finite differences,
parts plug in, vmap over padded records, reported failures."""

import diffrax as dfx
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stickslip_jax import Slideway, lubricant
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.simulation import (
    DEFAULT_SMOOTHING,
    SimulationResult,
    SmoothModel,
    ViscousDamping,
    pad_times,
    simulate_exact,
    simulate_smooth,
)

SW = Slideway(lubricant("A"), 36.0, 86.9)
V = 0.05  # mm/s (3 mm/min): stick time about 1.6 s
a = jnp.asarray


@pytest.fixture(scope="module")
def smooth():
    return eqx.filter_jit(simulate_smooth)


def _amplitude(x, ts, t_from):
    sel = np.asarray(ts) >= t_from
    x = np.asarray(x)[sel]
    return 0.5 * (x.max() - x.min())


def test_converges_to_exact_as_smoothing_shrinks(smooth):
    ts = jnp.linspace(0.0, 6.5, 6501)
    ex = simulate_exact(SW, ConstantSpeed(V), ts, max_events=16)
    c = ex.cycles
    t_from = float(c.breakaway_time[int(c.valid.sum()) - 1]) - 0.2  # last cycle
    amp_exact = _amplitude(ex.deflection, ts, t_from)
    errors = []
    for eta in (0.1, DEFAULT_SMOOTHING, 0.01):
        tr = smooth(SW, ConstantSpeed(V), ts, smoothing=a(eta))
        assert tr.result == SimulationResult.successful
        errors.append(abs(_amplitude(tr.deflection, ts, t_from) / amp_exact - 1))
    assert errors[0] > errors[1] > errors[2], errors
    assert errors[1] < 0.01, errors  # the default smoothing


LEAVES = {
    "mu_s": lambda s: s.friction.static.mu_s,
    "mu_d": lambda s: s.friction.static.mu_d,
    "gamma": lambda s: s.friction.static.gamma,
    "m": lambda s: s.friction.static.m,
    "delta": lambda s: s.friction.kinetic.delta,
    "n": lambda s: s.friction.kinetic.n,
}
TS_GRAD = jnp.linspace(0.0, 1.2, 121)


def _loss(sw, eta, rtol, atol):
    # aged contact (stuck 2 s already): one breakaway and one slip inside the window
    tr = simulate_smooth(sw, ConstantSpeed(V), TS_GRAD, smoothing=eta, rtol=rtol, atol=atol,
                         initial_deflection=0.12, initial_stick_time=2.0, max_steps=20000)
    return jnp.mean(tr.deflection**2)


@pytest.mark.parametrize("eta", [0.1, 0.05, DEFAULT_SMOOTHING])
def test_gradients_match_finite_differences(eta):
    grad = eqx.filter_jit(eqx.filter_grad(_loss))
    loss = eqx.filter_jit(_loss)
    tight = (a(1e-10), a(1e-12))
    grads = [grad(SW, a(eta), a(rtol), a(rtol * 1e-2)) for rtol in (1e-9, 1e-10)]
    h = 1e-5
    for name, get in LEAVES.items():
        p = get(SW)
        fd = (loss(eqx.tree_at(get, SW, p * (1 + h)), a(eta), *tight)
              - loss(eqx.tree_at(get, SW, p * (1 - h)), a(eta), *tight)) / (2 * h * p)
        for g in grads:
            gv = float(get(g))
            assert np.isfinite(gv), name
            assert abs(gv - float(fd)) <= 1e-4 * abs(float(fd)), (eta, name, gv, float(fd))


def test_loose_explicit_solver_gives_wrong_gradients():
    """The trap the tests guard against: a loose explicit solve is fast, finite, and its
    gradient is far from the finite difference of an accurate solve."""

    def loss_explicit(sw):
        tr = simulate_smooth(sw, ConstantSpeed(V), TS_GRAD, smoothing=0.1, rtol=1e-4,
                             atol=1e-6, solver=dfx.Tsit5(), initial_deflection=0.12,
                             initial_stick_time=2.0, max_steps=200000)
        return jnp.mean(tr.deflection**2)

    get = LEAVES["mu_s"]
    g = float(get(eqx.filter_jit(eqx.filter_grad(loss_explicit))(SW)))
    h, p = 1e-5, get(SW)
    loss = eqx.filter_jit(_loss)
    fd = float((loss(eqx.tree_at(get, SW, p * (1 + h)), a(0.1), a(1e-10), a(1e-12))
                - loss(eqx.tree_at(get, SW, p * (1 - h)), a(0.1), a(1e-10), a(1e-12)))
               / (2 * h * p))
    assert not abs(g - fd) <= 1e-4 * abs(fd)


def test_parts_plug_in_and_zero_parameters_are_neutral(smooth):
    ts = jnp.linspace(0.0, 1.0, 101)  # same shapes as the vmap test: one compile
    kw = dict(initial_deflection=0.12, initial_stick_time=2.0)
    base = smooth(SW, ConstantSpeed(V), ts, **kw)
    zero = smooth(SmoothModel(SW, force_terms=(ViscousDamping(0.0),)), ConstantSpeed(V), ts,
                  **kw)
    damped = smooth(SmoothModel(SW, force_terms=(ViscousDamping(0.05),)), ConstantSpeed(V),
                    ts, **kw)
    np.testing.assert_allclose(np.asarray(zero.deflection), np.asarray(base.deflection),
                               atol=1e-12)
    assert float(jnp.max(jnp.abs(damped.deflection - base.deflection))) > 1e-4


def test_vmap_over_padded_records_and_failure_code(smooth):
    times = [np.linspace(0.0, 0.8, 81), np.linspace(0.0, 1.0, 101)]
    ts, mask = pad_times(times)
    out = jax.vmap(lambda t, m: simulate_smooth(SW, ConstantSpeed(V), t, mask=m,
                                                initial_deflection=0.12,
                                                initial_stick_time=2.0))(ts, mask)
    assert out.deflection.shape == (2, 101)
    one = smooth(SW, ConstantSpeed(V), ts[0], initial_deflection=0.12, initial_stick_time=2.0)
    np.testing.assert_allclose(np.asarray(out.deflection[0, :81]),
                               np.asarray(one.deflection[:81]), atol=1e-7)
    # an impossible tolerance exhausts the step budget: reported, not silent
    bad = smooth(SW, ConstantSpeed(V), ts[1], rtol=a(1e-15), atol=a(1e-17),
                 initial_deflection=0.12, initial_stick_time=2.0)
    assert bad.result == SimulationResult.solver_failed
