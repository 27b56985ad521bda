"""The other base friction laws: rate-and-state (aging and slip laws) and logarithmic aging.

Values and gradients of the laws against finite differences, the smoothed simulator on a
rate-and-state law against the independent SciPy generator (tests/rate_state_generator.py),
a gradient through that simulation, the fit parameters' conversions, and the paper's law
unchanged as the default."""

from __future__ import annotations

import sys
from pathlib import Path

import diffrax as dfx
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from stickslip_fitting.law_params import (
    LogAgingFriction,
    RateStateAgingFriction,
    RateStateSlipFriction,
)
from stickslip_fitting.modes import FrictionLaw
from stickslip_fitting.params import EmpiricalFriction
from stickslip_fitting.solve.laws import LAW_PARAMS

import stickslip_jax as ss
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.friction import (
    AgingLaw,
    LogAgingStatic,
    LogVelocityKinetic,
    SlipLaw,
    rate_state_friction,
)
from stickslip_jax.simulation import simulate_smooth

sys.path.insert(0, str(Path(__file__).parent))
import rate_state_generator as gen  # noqa: E402

LAW = gen.RateState()
W, K = 36.0, 86.9


def _fd(f, x, h):
    return (f(x + h) - f(x - h)) / (2 * h)


def test_rate_state_law_values():
    fr = rate_state_friction(0.2, 0.01, 0.02, 1e-3, 1e-3)
    kin = fr.kinetic
    # the regularised law equals the logarithmic one away from v = 0, is odd and 0 at rest
    v, theta = 0.5, 0.3
    plain = 0.2 + 0.01 * np.log(v / 1e-3) + 0.02 * np.log(1e-3 * theta / 1e-3)
    assert abs(float(kin.coefficient(v, theta, 0.2)) - plain) < 1e-12
    assert float(kin.coefficient(0.0, theta, 0.2)) == 0.0
    assert float(kin.coefficient(-v, theta, 0.2)) == pytest.approx(-plain, rel=1e-12)
    assert float(kin.velocity_at(plain, theta, 0.2)) == pytest.approx(v, rel=1e-10)
    # steady state: (a - b) ln(v / v0); aging heals at rest, the slip law does not
    assert float(kin.steady(1.0, 0.2)) == pytest.approx(0.2 - 0.01 * np.log(1e3), rel=1e-12)
    assert float(AgingLaw().rate(0.0, 2.0, 1e-3)) == 1.0
    assert float(SlipLaw().rate(0.0, 2.0, 1e-3)) == 0.0
    assert float(SlipLaw().rate(1e-3 / 2.0, 2.0, 1e-3)) == 0.0  # steady: v theta = D_c
    # the static law is the aging law's healing at rest read at v0: b ln(1 + v0 T1 / D_c)
    assert float(fr.static(10.0)) == pytest.approx(0.2 + 0.02 * np.log1p(10.0), rel=1e-12)


def test_rate_state_start_at_a_slip_end():
    """A slider at a slip end moves with the drive, in the state where the law balances the
    spring: state_at inverts the law, the start is at the drive speed (not the law's
    velocity at a slip's short contact age, which far outruns any physical speed), heals
    by the stick time, and stays finite for a level the law cannot reach near v_0."""
    kin = rate_state_friction(0.2, 0.0076, 0.025, 1e-4, 1e-3).kinetic
    V = 0.1
    for mu in (0.15, 0.22, 0.3):
        theta = float(kin.state_at(mu, V, 0.2))
        assert float(kin.coefficient(V, theta, 0.2)) == pytest.approx(mu, rel=1e-10)
        v0, theta0 = (float(x) for x in kin.start(mu, V, 0.0, 0.2))
        assert v0 == pytest.approx(V, rel=1e-9) and theta0 == pytest.approx(theta, rel=1e-12)
        v1, theta1 = (float(x) for x in kin.start(mu, V, 0.5, 0.2))
        assert theta1 == pytest.approx(theta + 0.5) and 0.0 < v1 < V
    assert [float(x) for x in kin.start(0.0, V, 0.0, 0.2)] == [0.0, pytest.approx(1e-3)]
    far = kin.state_at(5.0, V, 0.2)  # ln(v0 theta / D_c) clipped, not an overflow
    assert np.isfinite(float(far)) and float(far) > 0.0
    g = jax.grad(lambda m: kin.start(m, V, 0.0, 0.2)[1])(0.22)
    assert np.isfinite(float(g)) and float(g) > 0.0


def test_rate_state_law_is_finite_far_from_its_physical_states():
    """The law and its derivatives (in the parameters, the velocity and the state) stay
    finite for any velocity an implicit solver may try (a slip that runs away, 1e100
    mm/s) and any state (0, negative, 1e-300 s and 1e100 s): a forward-mode derivative
    of the simulation passes through them inside the solver's Newton stages."""
    def law(p, v, theta):
        a, b, d_c, mu = jnp.exp(p)
        kin = rate_state_friction(mu, a, b, d_c, 1e-3).kinetic
        return kin.coefficient(v, theta, mu)

    jac = jax.jit(jax.jacfwd(law, argnums=(0, 1, 2)))
    for a, b, d_c in [(2e-3, 1e-4, 1e-6), (7e-3, 0.012, 1e-4), (1e-4, 0.05, 5e-3)]:
        p = jnp.log(jnp.array([a, b, d_c, 0.25]))
        for v in (-1e100, -1.0, 0.0, 1e-300, 1e-3, 1e12, 1e100):
            for theta in (-1.0, 0.0, 1e-300, 1e-6, 1.0, 1e100):
                out = [law(p, v, theta), *jac(p, v, theta)]
                assert all(np.all(np.isfinite(np.asarray(o))) for o in out), (a, b, v, theta)


def test_log_aging_law_values():
    st, kin = LogAgingStatic(0.2, 0.03, 0.5), LogVelocityKinetic(0.02, 2.0)
    assert float(st(0.0)) == 0.2 and float(st(0.5)) == pytest.approx(0.2 + 0.03 * np.log(2))
    assert float(kin.at_velocity(0.0, 0.3, 0.2)) == 0.2
    assert float(kin.at_velocity(2.0, 0.3, 0.2)) == pytest.approx(0.2 - 0.02 * np.log(2))
    assert float(kin(0.3, 0.2, 0.02)) == float(kin.at_velocity(2.0, 0.3, 0.2))


@pytest.mark.parametrize("evolution", [AgingLaw(), SlipLaw()])
def test_rate_state_gradients_match_finite_differences(evolution):
    def mu(p, v, theta):
        a, b, d_c, mu_ref = p
        kin = rate_state_friction(mu_ref, a, b, d_c, 1e-3, evolution).kinetic
        return kin.coefficient(v, theta, mu_ref) + kin.state_rate(v, theta)

    p = jnp.array([0.01, 0.02, 5e-4, 0.2])
    for v, theta in [(0.3, 0.01), (1e-4, 2.0), (-0.05, 0.1), (0.0, 1.0)]:
        g = np.asarray(jax.grad(mu)(p, v, theta))
        assert np.all(np.isfinite(g))
        for i in range(4):
            h = 1e-6 * float(p[i])
            fd = _fd(lambda x: mu(p.at[i].set(x), v, theta), float(p[i]), h)
            assert abs(g[i] - fd) <= 1e-6 * max(1.0, abs(fd)), (v, theta, i)
        if v != 0.0:
            gv = float(jax.grad(mu, argnums=1)(p, v, theta))
            assert abs(gv - _fd(lambda x: mu(p, x, theta), v, 1e-7 * abs(v))) <= 1e-5 * abs(gv)
    # at rest the regularised law's slope is a / (2 v0) exp(psi / a), finite
    kin = rate_state_friction(0.2, 0.01, 0.02, 5e-4, 1e-3, evolution).kinetic
    slope = float(jax.grad(kin.coefficient)(0.0, 1.0, 0.2))
    psi = 0.2 + 0.02 * np.log(1e-3 * 1.0 / 5e-4)
    assert slope == pytest.approx(0.01 / 2e-3 * np.exp(psi / 0.01), rel=1e-10)


def test_log_aging_gradients_match_finite_differences():
    def f(p, t1, v):
        mu_d, beta, t_c, c, v_c = p
        return LogAgingStatic(mu_d, beta, t_c)(t1) + LogVelocityKinetic(c, v_c).at_velocity(
            v, 0.3, mu_d)

    p = jnp.array([0.2, 0.03, 0.5, 0.02, 2.0])
    for t1, v in [(0.0, 0.0), (1.0, 0.5), (30.0, 20.0)]:
        g = np.asarray(jax.grad(f)(p, t1, v))
        for i in range(5):
            fd = _fd(lambda x: f(p.at[i].set(x), t1, v), float(p[i]), 1e-6 * float(p[i]))
            assert abs(g[i] - fd) <= 1e-7 * max(1.0, abs(fd))


@pytest.fixture(scope="module")
def generated():
    # 2 mm/min, 8 s: three stick-slip cycles of the independent generator, noise-free
    V = 2.0 / 60
    t, x = gen.simulate(LAW, weight=W, stiffness=K, speed=V, duration=8.0, rate_hz=1000.0,
                        noise_mm=0.0, seed=0)
    dx = np.diff(x)
    i0 = int(np.flatnonzero(dx < -1e-4)[0])
    j = i0 + int(np.argmin(x[i0:i0 + 200]))  # the first slip end (deepest sample)
    return V, t[j:] - t[j], x[j:]


_smooth = eqx.filter_jit(simulate_smooth)
"""The smoothed simulator compiled whole (op by op, its first run compiles some 170 small
programs: 17 s of CPU against 7 s whole for `test_paper_law_is_the_default`'s run)."""


def test_smooth_simulator_follows_the_independent_generator(generated):
    V, ts, x = generated
    fr = rate_state_friction(LAW.mu_ref, LAW.a, LAW.b, LAW.d_c, LAW.v_0, AgingLaw())
    tr = _smooth(ss.Slideway(fr, W, K), ConstantSpeed(V), jnp.asarray(ts),
                 initial_deflection=x[0], smoothing=1e-4, rtol=1e-9, atol=1e-11)
    d = np.asarray(tr.deflection) - x
    assert tr.result == ss.simulation.SimulationResult.successful
    # the same limit cycle: sub-micrometre RMS, a few um only at the samples of a slip
    assert np.sqrt(np.mean(d**2)) < 3e-4 and np.median(np.abs(d)) < 5e-5
    assert int(jnp.sum(tr.cycles.valid)) >= 2


def test_rate_state_simulation_gradient_matches_finite_differences(generated):
    V, ts, x = generated
    ts = jnp.asarray(ts[:600])  # the first stick and its breakaway

    def out(log_a):
        fr = rate_state_friction(LAW.mu_ref, jnp.exp(log_a), LAW.b, LAW.d_c, LAW.v_0)
        tr = simulate_smooth(ss.Slideway(fr, W, K), ConstantSpeed(V), ts,
                             initial_deflection=x[0], smoothing=1e-4, rtol=1e-10, atol=1e-12,
                             adjoint=dfx.ForwardMode())
        return jnp.sum(tr.deflection[::50])

    # one compiled program: the value and its forward-mode derivative (the finite
    # differences read the values at la +- h from it)
    value_and_slope = eqx.filter_jit(lambda la: jax.jvp(out, (la,), (jnp.ones_like(la),)))
    la = jnp.asarray(np.log(LAW.a))  # an array: la +- h reuse the one program
    g = float(value_and_slope(la)[1])
    fd = float(_fd(lambda v: value_and_slope(v)[0], la, 1e-5))
    assert np.isfinite(g) and abs(g - fd) <= 1e-3 * abs(fd)


@pytest.mark.parametrize("cls,values", [
    (RateStateAgingFriction, dict(mu_ref=0.2, a=0.01, b=0.02, d_c=5e-4)),
    (RateStateSlipFriction, dict(mu_ref=0.2, a=0.01, b=0.02, d_c=5e-4)),
    (LogAgingFriction, dict(mu_d=0.2, beta=0.03, t_c=0.5, c=0.02, v_c=2.0)),
])
def test_law_params_round_trip(cls, values):
    p = cls.from_values(**values)
    assert p.named_values() == pytest.approx(values, rel=1e-12)
    assert p.from_log_values(p.log_values()).named_values() == pytest.approx(values)
    assert p.with_fixed({cls.NAMES[1]: 0.05}).named_values()[cls.NAMES[1]] == pytest.approx(0.05)
    assert isinstance(p.friction(), ss.Friction) and set(cls.UNITS) == set(cls.NAMES)
    with pytest.raises(ValueError, match="positive"):
        p.with_values(**{cls.NAMES[0]: -1.0})
    assert LAW_PARAMS[FrictionLaw(cls.MODEL)] is cls


def test_paper_law_is_the_default():
    # the paper's law is the parser's default and its fit parameters are eqs (1), (3)
    import argparse

    from stickslip_fitting.commands import fit as fit_cmd

    parser = argparse.ArgumentParser()
    fit_cmd.add_arguments(parser)
    assert FrictionLaw.parse(parser.parse_args(["x.csv"]).law) is FrictionLaw.PAPER
    assert LAW_PARAMS[FrictionLaw.PAPER] is EmpiricalFriction
    # the smoothed simulator on the paper's law gives the numbers it gives without the other
    # laws (reference values of the same run computed op by op by the simulator without
    # them), compiled whole: the same to the solver's tolerance (rtol 1e-8), its accepted
    # steps within 1 % (measured: 3e-10, 2e-9 and 8 steps apart)
    sw = ss.Slideway(ss.lubricant("A"), W, K)
    tr = _smooth(sw, ConstantSpeed(3.0 / 60), jnp.linspace(0.0, 20.0, 4001),
                 initial_deflection=0.05)
    assert float(jnp.sum(tr.deflection)) == pytest.approx(397.98401821909454, rel=1e-8)
    assert tr.limit_cycle()[0] == pytest.approx(0.039482480236357934, rel=1e-7)
    assert abs(int(tr.num_events) - 2065) <= 20
