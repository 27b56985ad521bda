"""Smoothed simulator: convergence to the exact one, gradients vs finite differences,
parts plug in, vmap over padded records, reported failures."""

import functools

import diffrax as dfx
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


@pytest.fixture(scope="module")
def smooth():
    # this file tests the stiff formulations (rigid stick unless a test says otherwise);
    # the latch default is tested in test_smooth_latch.py
    return eqx.filter_jit(functools.partial(simulate_smooth, formulation="rigid_stick"))


def test_converges_to_exact_as_smoothing_shrinks(smooth):
    ts, error = amplitude_error_against_exact()
    errors = []
    for eta in (1e-2, 3e-3, DEFAULT_SMOOTHING):
        tr = smooth(SW, ConstantSpeed(V), ts, smoothing=a(eta))
        assert tr.result == SimulationResult.successful
        errors.append(error(tr.deflection))
    assert errors[0] > errors[1] > errors[2], errors
    assert errors[2] < 0.01, errors  # the default smoothing


def test_velocity_formulation_still_converges(smooth):
    ts, error = amplitude_error_against_exact()
    tr = smooth(SW, ConstantSpeed(V), ts, smoothing=a(0.03), formulation="velocity")
    assert tr.result == SimulationResult.successful
    assert error(tr.deflection) < 0.01
    with pytest.raises(ValueError, match="formulation"):
        simulate_smooth(SW, ConstantSpeed(V), ts, formulation="bristle")


LEAVES = FRICTION_LEAVES
# One window for every short run (gradients, parts, vmap, failure code): the same shapes
# and argument types everywhere, so one compiled forward solve serves them all.
TS_GRAD = jnp.linspace(0.0, 1.2, 121)
AGED = dict(initial_deflection=a(0.12), initial_stick_time=a(2.0), max_steps=20000)
TIGHT = (a(1e-10), a(1e-12))


def _run(fn, model, eta, rtol, atol, ts=TS_GRAD, **kw):
    # aged contact (stuck 2 s already): one breakaway and one slip inside the window
    return fn(model, ConstantSpeed(V), ts, smoothing=eta, rtol=rtol, atol=atol, **AGED, **kw)


def _loss(sw, eta, rtol, atol, formulation):
    return jnp.mean(_run(simulate_smooth, sw, eta, rtol, atol, formulation=formulation,
                         adjoint=dfx.ForwardMode()).deflection ** 2)


@eqx.filter_jit
def _loss_and_slope(sw, tangent, eta, rtol, atol, formulation):
    """The loss and its derivative along `tangent` (forward mode, as the smoothed fits
    take their Jacobians): one compiled program per formulation gives both the finite
    differences and the derivatives (reverse mode through the default adjoint:
    test_smooth_latch.py)."""
    return eqx.filter_jvp(lambda s: _loss(s, eta, rtol, atol, formulation), (sw,), (tangent,))


def _unit(name):
    """The tangent of `SW` that moves friction parameter `name` alone (d/d name)."""
    zero = jax.tree_util.tree_map(lambda x: jnp.zeros_like(x) if eqx.is_inexact_array(x)
                                  else None, SW)
    return eqx.tree_at(LEAVES[name], zero, jnp.ones(()))


def _slope(eta, name, rtol, atol, formulation):
    return float(_loss_and_slope(SW, _unit(name), a(eta), a(rtol), a(atol), formulation)[1])


@pytest.fixture(scope="module")
def fd_grad():
    """Central finite differences of the loss with a tight-tolerance solve (cached): the
    difference at the relative step 1e-5 and its error, estimated as its change from the
    step 1e-4 (their truncation errors differ 100x; the tight solve's step choices move
    with the parameter and leave about 1e-4 of the slope in the difference at 1e-5,
    depending on how the CPU rounds)."""
    cache = {}

    def fd(eta, name, formulation):
        key = (eta, name, formulation)
        if key not in cache:
            get = LEAVES[name]
            p = get(SW)

            def central(h):
                lp, lm = (_loss_and_slope(eqx.tree_at(get, SW, p * (1 + s * h)), _unit(name),
                                          a(eta), *TIGHT, formulation)[0] for s in (1, -1))
                return float((lp - lm) / (2 * h * p))

            d = central(1e-5)
            cache[key] = d, abs(d - central(1e-4))
        return cache[key]

    return fd


def _check_slopes(eta, formulation, fd_grad, rtols, names=tuple(LEAVES)):
    """The friction parameters' (`names`) forward-mode slopes at the solver tolerances `rtols`
    (atol 1e-2 rtol) against the finite difference, within both sides' own errors: the
    difference's (twice its estimate) and the slope's (its change over `rtols`) and 1e-4
    of the slope, so that the check holds whatever the CPU's rounding; a slope that
    misses a term of the model is off by far more."""
    for name in names:
        fd, fd_error = fd_grad(eta, name, formulation)
        gs = [_slope(eta, name, r, r * 1e-2, formulation) for r in rtols]
        assert np.all(np.isfinite(gs)), name
        tol = 1e-4 * abs(fd) + 2 * fd_error + np.ptp(gs)
        for rtol, g in zip(rtols, gs):
            assert abs(g - fd) <= tol, (eta, name, rtol, g, fd, tol)


@pytest.mark.parametrize("eta, names", [(0.1, ("mu_d", "gamma", "n")),
                                        (0.03, ("mu_s", "m", "delta"))])
def test_gradients_match_finite_differences(eta, names, fd_grad):
    # the velocity formulation, every parameter once: the kinetic level, the aging
    # coefficient and the kinetic exponent at one smoothing, the static level, the aging
    # exponent and the kinetic decay at a sharper one (a parameter takes the same path
    # through the model at both, and the smoothing's own path is in every slope); every
    # parameter of the rigid-stick default is tested below, the latch formulation in
    # test_smooth_latch.py
    _check_slopes(eta, "velocity", fd_grad, (1e-9, 1e-10), names)


def test_rigid_stick_gradients_match_finite_differences(fd_grad):
    """The default formulation at the default smoothing (1e-3), derivatives at rtol 1e-10
    (the tolerance its gradients need, README) against the tight finite differences."""
    _check_slopes(DEFAULT_SMOOTHING, "rigid_stick", fd_grad, (1e-9, 1e-10))


def test_loose_explicit_solver_gives_unusable_gradients(fd_grad):
    """The trap the tests guard against: a loose explicit solve (Tsit5, rtol 1e-4) of the
    stiff smoothed model (the velocity formulation at smoothing 0.1: the rigid-stick one is
    so stiff that Tsit5 does not even finish in 500k steps). Given enough steps it succeeds, yet its derivative is no usable
    gradient: measured NaN in forward and reverse mode (a finite value would have to be
    far from the finite difference of an accurate solve for this test to pass)."""
    get = LEAVES["mu_s"]

    def loss_explicit(p):
        sw = eqx.tree_at(get, SW, p)
        tr = simulate_smooth(sw, ConstantSpeed(V), TS_GRAD, smoothing=0.1, rtol=1e-4,
                             atol=1e-6, solver=dfx.Tsit5(), initial_deflection=0.12,
                             initial_stick_time=2.0, max_steps=500_000,
                             adjoint=dfx.ForwardMode(), formulation="velocity")
        return jnp.mean(tr.deflection**2), tr.result == SimulationResult.successful

    p = get(SW)
    _, g, ok = eqx.filter_jit(
        lambda p: jax.jvp(loss_explicit, (p,), (jnp.ones_like(p),), has_aux=True))(p)
    assert bool(ok)  # the solve itself succeeds (it needs about 360k steps)
    fd = fd_grad(0.1, "mu_s", "velocity")[0]
    g = float(g)
    assert not (np.isfinite(g) and abs(g - fd) <= 1e-4 * abs(fd)), (g, fd)


def test_parts_plug_in_and_zero_parameters_are_neutral(smooth):
    std = (a(DEFAULT_SMOOTHING), a(1e-8), a(1e-10))
    base = _run(smooth, SW, *std)
    zero = _run(smooth, SmoothModel(SW, force_terms=(ViscousDamping(0.0),)), *std)
    damped = _run(smooth, SmoothModel(SW, force_terms=(ViscousDamping(0.05),)), *std)
    np.testing.assert_allclose(np.asarray(zero.deflection), np.asarray(base.deflection),
                               atol=1e-12)
    assert float(jnp.max(jnp.abs(damped.deflection - base.deflection))) > 1e-4


def test_vmap_over_padded_records_and_failure_code(smooth):
    times = [np.linspace(0.0, 0.8, 81), np.asarray(TS_GRAD)]
    ts, mask = pad_times(times)
    std = (a(DEFAULT_SMOOTHING), a(1e-8), a(1e-10))

    @eqx.filter_jit
    def batch(ts, mask):
        return jax.vmap(lambda t, m: _run(smooth, SW, *std, ts=t, mask=m))(ts, mask)

    out = batch(ts, mask)
    assert out.deflection.shape == (2, 121)
    one = _run(smooth, SW, *std, ts=ts[0])
    tight = _run(smooth, SW, std[0], *TIGHT, ts=ts[0])
    # the padded record and the record alone take their own steps (vectorised arithmetic
    # rounds otherwise, CPU by CPU), so they agree to the solve's accuracy (measured
    # 2e-7 mm at rtol 1e-8), not bitwise: both within 1e-6 mm (1/500 of the 0.5 um gauge
    # noise) of a tight solve; a padding that reached the record moves it by far more
    for x in (out.deflection[0, :81], one.deflection[:81]):
        np.testing.assert_allclose(np.asarray(x), np.asarray(tight.deflection[:81]), rtol=0,
                                   atol=1e-6)
    # an impossible tolerance exhausts the step budget: reported, not silent
    bad = _run(smooth, SW, a(DEFAULT_SMOOTHING), a(1e-15), a(1e-17))
    assert bad.result == SimulationResult.solver_failed
