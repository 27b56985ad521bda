"""The one least-squares solver (stickslip_jax.lsq): both drivers against SciPy's
MINPACK Levenberg-Marquardt, its stopping rules, caps, masks and the shared update."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest
from scipy.optimize import least_squares

from stickslip_jax.lsq import (HostResiduals, JacobianMode, LevenbergMarquardt, Stall,
                               damped_step, gauss_newton_decrease, nielsen_update)
from stickslip_jax.lsq import least_squares as lsq

T = np.linspace(0.0, 3.0, 200)
TRUE = np.array([1.0, 1.3, 2.0, 1.2])
SIGMA = 1e-3
Y = TRUE[2] * np.exp(-TRUE[0] * T) + TRUE[3] * np.exp(-TRUE[1] * T) + SIGMA * \
    np.random.default_rng(0).normal(size=T.size)
Z0 = np.array([0.5, 2.5, 1.0, 1.0])


def residuals(z, _=None):
    """Nearly collinear sum of two exponentials, whitened (sigma 1e-3)."""
    xp = jnp if isinstance(z, jax.Array) else np
    return (z[2] * xp.exp(-z[0] * T) + z[3] * xp.exp(-z[1] * T) - Y) / SIGMA


def evaluate(z):
    e0, e1 = np.exp(-z[0] * T), np.exp(-z[1] * T)
    J = np.stack([-z[2] * T * e0, -z[3] * T * e1, e0, e1], axis=1) / SIGMA
    return residuals(z), J, True


def canonical(z):
    """The model is symmetric under swapping the two exponentials: order by rate."""
    z = np.asarray(z)
    return z if z[0] <= z[1] else z[[1, 0, 3, 2]]


@pytest.fixture(scope="module")
def scipy_ref():
    return least_squares(residuals, Z0, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)


def test_host_driver_reaches_scipy_minimum(scipy_ref):
    fit = lsq(HostResiduals(evaluate), Z0, rtol=0.0, atol=1e-10, max_steps=400,
              stall=Stall(4, 0.0))
    assert fit.converged
    assert fit.rss == pytest.approx(2 * scipy_ref.cost, rel=1e-9)
    np.testing.assert_allclose(canonical(fit.z), canonical(scipy_ref.x), rtol=1e-6)
    # the default stop at the noise floor (< 0.5 gained over 4 evaluations) ends earlier,
    # within a few chi-square units of the minimum
    early = lsq(HostResiduals(evaluate), Z0, rtol=0.0, atol=0.05, max_steps=400, stall=Stall())
    assert early.converged and early.n_evals < fit.n_evals
    assert early.rss < 2 * scipy_ref.cost + 5.0


def test_host_driver_respects_active_mask():
    active = np.array([True, True, False, True])
    fit = lsq(HostResiduals(evaluate), Z0, active, rtol=0.0, atol=0.05, max_steps=200,
              stall=Stall(4, 0.0))
    assert fit.z[2] == Z0[2]
    # the best fit with z2 held: every free gradient component vanishes
    r, J, _ = evaluate(fit.z)
    g = J.T @ r
    assert np.all(np.abs(g[active]) < 1e-3 * np.abs(J.T @ evaluate(Z0)[0])[active])


STALL_RTOL = 1e-5
"""How close (relative) a solve ended by the stall rule (cost falling by less than 1e-3 over
four accepted steps) stands to SciPy's minimum in its flattest parameter: its cost equals
the minimum's to 1e-9, and the parameter sits about 1e-6 away, which the order of
floating-point sums (CPU or GPU) moves by as much again."""


RATE_MIN = 0.7
"""The failing model below runs only where the second rate exceeds this (s^-1): the first
four trial points from Z0 (damping 1e-3 to 0.06) lie beyond it, the fifth (damping 1)
inside."""


def evaluate_or_fail(z):
    """`evaluate`, failing (ok False) where the second rate is below `RATE_MIN`."""
    r, J, _ = evaluate(z)
    return r, J, bool(z[1] > RATE_MIN)


def residuals_or_nan(z, _=None):
    """`residuals`, non-finite where the second rate is below `RATE_MIN`."""
    return jnp.where(z[1] > RATE_MIN, residuals(z), jnp.nan)


def accepted_costs(history):
    """The costs of the accepted points of a solve without rounding (strict decreases)."""
    kept = [history[0]]
    for cost in history[1:]:
        if cost < kept[-1]:
            kept.append(cost)
    return np.array(kept)


def test_rejected_steps_never_end_a_solve_by_the_stall_rule(scipy_ref):
    """Four failed trial points in a row from the start: the stall rule counts accepted
    steps only, so both drivers go on to the minimum (instead of ending at the start as
    converged), and a looser rule still ends the solve at its floor on an accepted step."""
    kw = dict(rtol=0.0, atol=0.0, rounding=0.0, max_steps=400)  # no other rule can stop
    for stall in (Stall(4, 1e-3), Stall(4, 0.5)):
        host = lsq(HostResiduals(evaluate_or_fail), Z0, stall=stall, **kw)
        traced = lsq(residuals_or_nan, jnp.asarray(Z0), stall=stall, **kw)
        history = host.stats["history"]
        assert np.all(np.isinf(history[1:5])) and np.any(np.isfinite(history[5:]))
        assert host.converged and bool(traced.successful)
        assert host.n_evals == int(traced.stats["num_steps"]) < 400
        np.testing.assert_allclose(np.asarray(traced.params), host.z, rtol=1e-8)
        # ended by the rule: on an accepted step, whose last `evals` accepted steps
        # lowered the cost by less than `tol` together, and not one accepted step earlier
        kept = accepted_costs(history)
        assert history[-1] == kept[-1] == host.rss
        assert kept[-5] - kept[-1] < stall.tol <= kept[-6] - kept[-2]
        assert host.lam < 1.0
        if stall.tol < 0.5:
            assert host.rss == pytest.approx(2 * scipy_ref.cost, rel=1e-9)
            np.testing.assert_allclose(canonical(host.z), canonical(scipy_ref.x), rtol=STALL_RTOL)
        else:  # the floor: a few chi-square units above the minimum, in fewer steps
            assert 2 * scipy_ref.cost < host.rss < 2 * scipy_ref.cost + 5.0
            assert host.n_evals < 30


def test_a_non_finite_jacobian_is_a_failed_evaluation(scipy_ref):
    """Finite residuals with a non-finite Jacobian (a model whose derivative overflows
    there): the host driver rejects the trial point, as the traced driver does through
    the gradient, and reaches the minimum instead of breaking on the next step."""
    def evaluate_nan_jacobian(z):
        r, J, _ = evaluate(z)
        return r, J if z[1] > RATE_MIN else np.full_like(J, np.nan), True

    host = lsq(HostResiduals(evaluate_nan_jacobian), Z0, rtol=0.0, atol=0.0, rounding=0.0,
               max_steps=400, stall=Stall(4, 1e-3))
    assert np.all(np.isinf(host.stats["history"][1:5])) and host.converged
    np.testing.assert_allclose(canonical(host.z), canonical(scipy_ref.x), rtol=STALL_RTOL)


@pytest.mark.parametrize("jac", list(JacobianMode))
def test_optimistix_solver_reaches_scipy_minimum(scipy_ref, jac):
    solver = LevenbergMarquardt(rtol=1e-12, atol=1e-10)
    sol = optx.least_squares(residuals, solver, jnp.asarray(Z0), max_steps=400, throw=False,
                             options={"jac": jac})
    assert sol.result == optx.RESULTS.successful
    np.testing.assert_allclose(canonical(sol.value), canonical(scipy_ref.x), rtol=1e-6)
    r = np.asarray(residuals(sol.value))
    assert float(r @ r) == pytest.approx(2 * scipy_ref.cost, rel=1e-9)


def test_the_jacobian_mode_is_an_object():
    """Forward and reverse mode reach the same optimum through the verb; a string is
    refused, naming the mode to give."""
    fwd, bwd = (lsq(residuals, jnp.asarray(Z0), rtol=1e-12, atol=1e-10, max_steps=400,
                    jac=jac) for jac in JacobianMode)
    np.testing.assert_allclose(canonical(fwd.params), canonical(bwd.params), rtol=1e-8)
    with pytest.raises(TypeError, match="jac: a member of JacobianMode"):
        lsq(residuals, jnp.asarray(Z0), jac="bwd")
    with pytest.raises(ValueError, match=r"jac must be one of \('fwd', 'bwd'\)"):
        JacobianMode.parse("central")


def test_optimistix_solver_cap_and_budget():
    capped = optx.least_squares(residuals, LevenbergMarquardt(rtol=1e-12, atol=0.0,
                                                              cap=jnp.asarray(3)),
                                jnp.asarray(Z0), max_steps=400, throw=False)
    assert int(capped.stats["num_steps"]) == 3
    out = optx.least_squares(residuals, LevenbergMarquardt(rtol=0.0, atol=0.0, rounding=0.0),
                             jnp.asarray(Z0), max_steps=5, throw=False)
    assert out.result == optx.RESULTS.nonlinear_max_steps_reached  # reported, not silent


def test_damped_step_is_the_marquardt_step():
    rng = np.random.default_rng(1)
    J = rng.normal(size=(30, 4)) * np.array([1.0, 10.0, 0.1, 3.0])
    r = rng.normal(size=30)
    A, g = J.T @ J, J.T @ r
    lam = 0.3
    step, pred = (np.asarray(x) for x in damped_step(jnp.asarray(A), jnp.asarray(g), lam))
    direct = -np.linalg.solve(A + lam * np.diag(np.diag(A)), g)
    np.testing.assert_allclose(step, direct, rtol=1e-10)
    new = r + J @ step
    assert pred == pytest.approx(r @ r - new @ new, rel=1e-10)  # the linear model's decrease
    # lam = 0 is Gauss-Newton: the decrease is the full g^T A^-1 g
    gn, _ = damped_step(jnp.asarray(A), jnp.asarray(g), 0.0)
    assert float(gauss_newton_decrease(jnp.asarray(A), jnp.asarray(g))) == pytest.approx(
        float(-g @ np.asarray(gn)), rel=1e-10)


def test_rank_deficient_problem_gives_a_finite_minimum_norm_step():
    J = np.array([[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]])  # two identical columns
    r = np.array([1.0, 0.5, -0.2])
    step, _ = damped_step(jnp.asarray(J.T @ J), jnp.asarray(J.T @ r), 0.0)
    step = np.asarray(step)
    assert np.all(np.isfinite(step)) and step[0] == pytest.approx(step[1])


def test_nielsen_update():
    lam, nu = nielsen_update(1e-2, 2.0, True, 1.0)  # perfect model: divide by 3
    assert float(lam) == pytest.approx(1e-2 / 3) and float(nu) == 2.0
    lam, nu = nielsen_update(1e-5, 4.0, False, 0.0)  # rejected: at least 1e-3, nu doubles
    assert float(lam) == pytest.approx(1e-3) and float(nu) == 8.0


def test_host_namespace_gives_the_same_update():
    """The host driver runs the shared update in NumPy (`xp=np`: no program compiled per
    parameter count); it is the same update as the JAX one."""
    rng = np.random.default_rng(3)
    J = rng.normal(size=(50, 5)) * np.array([1.0, 10.0, 1e-3, 2.0, 1.0])
    J[:, 4] = J[:, 0]  # rank deficient
    r = rng.normal(size=50)
    A, g = J.T @ J, J.T @ r
    active = np.array([True, True, True, False, True])
    for lam in (0.0, 1e-3, 10.0):
        s_np, p_np = damped_step(A, g, lam, active, xp=np)
        s_j, p_j = damped_step(jnp.asarray(A), jnp.asarray(g), lam, jnp.asarray(active))
        assert isinstance(s_np, np.ndarray)
        np.testing.assert_allclose(s_np, np.asarray(s_j), rtol=1e-8, atol=1e-12)
        np.testing.assert_allclose(p_np, float(p_j), rtol=1e-8)
    np.testing.assert_allclose(gauss_newton_decrease(A, g, active, xp=np),
                               float(gauss_newton_decrease(A, g, active)), rtol=1e-8)
    for accept, rho in ((True, 0.9), (False, 0.0), (True, 0.1)):
        np.testing.assert_allclose(nielsen_update(1e-2, 2.0, accept, rho, xp=np),
                                   [float(x) for x in nielsen_update(1e-2, 2.0, accept, rho)])
