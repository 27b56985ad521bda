"""The Levenberg-Marquardt pieces of stickslip_jax.lsq as optimistix objects: the Marquardt
descent against a direct solve, the Nielsen search's acceptance within rounding and its
damping update against the formula, the pieces inside optimistix's own Gauss-Newton
solver, and the one verb `least_squares` against MINPACK, optimistix's
Levenberg-Marquardt and the NumPy driver of the same rules."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
import optimistix as optx
import pytest
from scipy.optimize import least_squares as scipy_least_squares

from stickslip_jax.lsq import (LAMBDA_MAX, HostResiduals, LeastSquaresSolution,
                               LevenbergMarquardt, MarquardtDescent, NielsenDamping, Stall,
                               acceptance, least_squares)

RNG = np.random.default_rng(7)
J = RNG.normal(size=(40, 4)) * np.array([1.0, 30.0, 0.05, 4.0])
R = RNG.normal(size=40)
A, G = J.T @ J, J.T @ R


def hessian_info(f, g, H):
    """The Gauss-Newton model of a least-squares cost as optimistix describes it."""
    return optx.FunctionInfo.EvalGradHessian(
        jnp.asarray(f), jnp.asarray(g), lx.MatrixLinearOperator(jnp.asarray(H)))


def residual_info(r, jac):
    return optx.FunctionInfo.ResidualJac(jnp.asarray(r), lx.MatrixLinearOperator(jnp.asarray(jac)))


# ------------------------------------------------------------------------ the descent
@pytest.mark.parametrize("info", ["hessian", "residuals"])
@pytest.mark.parametrize("lam", [0.0, 1e-3, 0.7, 50.0])
def test_descent_solves_the_marquardt_scaled_system(info, lam):
    descent = MarquardtDescent()
    y = jnp.zeros(4)
    f_info = (hessian_info(0.5 * R @ R, G, A) if info == "hessian" else residual_info(R, J))
    state = descent.query(y, f_info, descent.init(y, f_info))
    step, result = descent.step(jnp.asarray(1.0 / lam if lam else np.inf), state)
    direct = -np.linalg.solve(A + lam * np.diag(np.diag(A)), G)
    np.testing.assert_allclose(np.asarray(step), direct, rtol=1e-9)
    assert result == optx.RESULTS.successful
    # the full Gauss-Newton step lowers ||r||^2 by g^T A^-1 g
    assert float(state.newton_decrease) == pytest.approx(G @ np.linalg.solve(A, G), rel=1e-9)


def test_descent_gives_the_minimum_norm_step_when_rank_deficient():
    Jd = np.concatenate([J[:, :2], J[:, :1]], axis=1)  # third column repeats the first
    Ad, gd = Jd.T @ Jd, Jd.T @ R
    descent = MarquardtDescent()
    y = jnp.zeros(3)
    state = descent.query(y, hessian_info(0.0, gd, Ad), descent.init(y, None))
    step, _ = descent.step(jnp.asarray(np.inf), state)
    np.testing.assert_allclose(np.asarray(step), -np.linalg.pinv(Ad) @ gd, rtol=1e-8)
    # a held parameter does not move; the others solve their own system
    held = MarquardtDescent(active=jnp.array([True, False, True]))
    state = held.query(y, hessian_info(0.0, gd, Ad), held.init(y, None))
    step, _ = held.step(jnp.asarray(np.inf), state)
    keep = np.array([0, 2])
    assert float(step[1]) == 0.0
    np.testing.assert_allclose(np.asarray(step)[keep],
                               -np.linalg.pinv(Ad[np.ix_(keep, keep)]) @ gd[keep], rtol=1e-8)


def test_descent_keeps_the_structure_of_a_pytree():
    y = {"a": jnp.zeros(2), "b": jnp.zeros(2)}
    grad = {"a": jnp.asarray(G[:2]), "b": jnp.asarray(G[2:])}
    operator = lx.PyTreeLinearOperator(
        {"a": {"a": jnp.asarray(A[:2, :2]), "b": jnp.asarray(A[:2, 2:])},
         "b": {"a": jnp.asarray(A[2:, :2]), "b": jnp.asarray(A[2:, 2:])}},
        jax.eval_shape(lambda: y))
    info = optx.FunctionInfo.EvalGradHessian(jnp.asarray(0.0), grad, operator)
    descent = MarquardtDescent()
    step, _ = descent.step(jnp.asarray(10.0), descent.query(y, info, descent.init(y, info)))
    direct = -np.linalg.solve(A + 0.1 * np.diag(np.diag(A)), G)
    np.testing.assert_allclose(np.concatenate([step["a"], step["b"]]), direct, rtol=1e-9)


# ------------------------------------------------------------------------ the search
def _search_step(search, f, f_eval, state, first=False, grad_eval=None, delta=None):
    """One search step from y = 0 (model: gradient G, Hessian A) to y_eval = delta."""
    delta = np.full(4, 1e-3) if delta is None else delta
    info = hessian_info(f, G, A)
    info_eval = hessian_info(f_eval, G if grad_eval is None else grad_eval, A)
    return search.step(jnp.asarray(first), jnp.zeros(4), jnp.asarray(delta), info, info_eval,
                       state)


def test_search_accepts_a_change_within_rounding():
    search = NielsenDamping(lam0=1e-2, rounding=1e-10)
    state = search.init(jnp.zeros(4), None)
    f = 1.0e5
    _, accept, _, new = _search_step(search, f, f * (1 + 5e-11), state)
    assert bool(accept) and bool(new.flat)  # higher, but within rounding: accepted
    _, accept, _, new = _search_step(search, f, f * (1 + 5e-10), state)
    assert not bool(accept) and not bool(new.flat)  # beyond rounding: rejected
    assert float(new.lam) == pytest.approx(1e-2 * 2.0) and float(new.nu) == 4.0
    _, accept, _, new = _search_step(search, f, f * (1 - 1e-6), state)
    assert bool(accept) and not bool(new.flat)  # a real decrease
    for f_eval, grad in ((np.nan, None), (f / 2, np.full(4, np.inf))):
        _, accept, _, _ = _search_step(search, f, f_eval, state, grad_eval=grad)
        assert not bool(accept)  # a failed evaluation is never accepted
    assert bool(acceptance(1.0, 1.0, True, 0.0)[0])  # equal cost at zero rounding: flat


def test_search_first_step_keeps_the_initial_damping():
    search = NielsenDamping(lam0=0.0)
    step_size, accept, _, state = _search_step(search, np.inf, 3.0, search.init(
        jnp.zeros(4), None), first=True)
    assert bool(accept) and not bool(state.flat)
    assert float(state.lam) == 0.0 and float(step_size) == np.inf  # the Gauss-Newton step


@pytest.mark.parametrize("fraction", [1.0, 0.7, 0.2, -0.5])
def test_search_updates_the_damping_by_nielsens_rule(fraction):
    """rho = actual / predicted decrease; accepted: lam max(1/3, 1 - (2 rho - 1)^3)."""
    search = NielsenDamping()
    state = search.init(jnp.zeros(4), None)
    state = eqx.tree_at(lambda s: (s.lam, s.nu), state, (jnp.asarray(0.05), jnp.asarray(8.0)))
    delta = -np.linalg.solve(A + 0.05 * np.diag(np.diag(A)), G)
    predicted = -(G @ delta + 0.5 * delta @ A @ delta)
    f = 0.5 * R @ R
    step_size, accept, _, new = _search_step(search, f, f - fraction * predicted, state,
                                             delta=delta)
    if fraction > 0:
        assert bool(accept)
        expected = 0.05 * max(1 / 3, 1 - (2 * fraction - 1) ** 3)
        assert float(new.nu) == 2.0
    else:
        assert not bool(accept)
        expected = 0.05 * 8.0
        assert float(new.nu) == 16.0
    assert float(new.lam) == pytest.approx(expected, rel=1e-9)
    assert float(step_size) == pytest.approx(1.0 / expected, rel=1e-12)


# ------------------------------------------------------------------------ composed
T = np.linspace(0.0, 4.0, 60)
Y = 2.0 * np.exp(-1.3 * T) + 0.5 + 0.01 * np.random.default_rng(1).normal(size=T.size)
P0 = np.array([1.0, 0.5, 0.0])


def decay(p, _=None):
    xp = jnp if isinstance(p, jax.Array) else np
    return (p[0] * xp.exp(-p[1] * T) + p[2] - Y) / 0.01


@pytest.fixture(scope="module")
def minpack():
    return scipy_least_squares(decay, P0, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)


class ComposedGaussNewton(optx.AbstractGaussNewton):
    """optimistix's own Gauss-Newton loop (its Cauchy termination) with the pieces."""

    rtol: float = 1e-12
    atol: float = 1e-12
    norm: object = optx.max_norm
    descent: object = MarquardtDescent()
    search: object = NielsenDamping()
    verbose: object = lambda **kw: None  # noqa: E731


def test_the_pieces_run_inside_optimistix_gauss_newton(minpack):
    sol = optx.least_squares(decay, ComposedGaussNewton(), jnp.asarray(P0), max_steps=200,
                             throw=False)
    assert sol.result == optx.RESULTS.successful
    np.testing.assert_allclose(np.asarray(sol.value), minpack.x, rtol=1e-8)
    # Nielsen's damping steers optimistix's damped-Newton descent too (step size 1/lam)
    mixed = eqx.tree_at(lambda s: s.descent, ComposedGaussNewton(), optx.DampedNewtonDescent())
    sol = optx.least_squares(decay, mixed, jnp.asarray(P0), max_steps=200, throw=False)
    np.testing.assert_allclose(np.asarray(sol.value), minpack.x, rtol=1e-8)


def test_verb_reaches_minpack_and_optimistix_minimum(minpack):
    sol = least_squares(decay, jnp.asarray(P0), rtol=1e-12, atol=1e-12)
    assert isinstance(sol, LeastSquaresSolution) and bool(sol.successful)
    np.testing.assert_allclose(np.asarray(sol.params), minpack.x, rtol=1e-9)
    ref = optx.least_squares(decay, optx.LevenbergMarquardt(rtol=1e-12, atol=1e-12),
                             jnp.asarray(P0), max_steps=200)
    np.testing.assert_allclose(np.asarray(sol.params), np.asarray(ref.value), rtol=1e-8)
    # the verb is the solver inside optimistix.least_squares, nothing more
    direct = optx.least_squares(decay, LevenbergMarquardt(rtol=1e-12, atol=1e-12),
                                jnp.asarray(P0), max_steps=200, throw=False)
    np.testing.assert_array_equal(np.asarray(sol.params), np.asarray(direct.value))
    assert int(sol.stats["num_steps"]) == int(direct.stats["num_steps"])


def evaluate(p):
    """The decay's residuals and Jacobian in NumPy: a `HostResiduals` objective."""
    e = np.exp(-p[1] * T)
    return decay(p), np.stack([e, -p[0] * T * e, np.ones_like(T)], axis=1) / 0.01, True


def test_jax_and_numpy_drivers_take_the_same_steps():
    """`LevenbergMarquardt` and the host driver run the same rules: same trial points, so
    the same number of evaluations and the same optimum."""
    host = least_squares(HostResiduals(evaluate), P0, rtol=0.0, atol=1e-9, rounding=0.0)
    sol = least_squares(decay, jnp.asarray(P0), rtol=0.0, atol=1e-9, rounding=0.0)
    assert host.converged and bool(sol.successful)
    assert int(sol.stats["num_steps"]) == host.n_evals
    np.testing.assert_allclose(np.asarray(sol.params), host.z, rtol=1e-10)


def test_stall_rule_linearisation_and_warm_restart_in_both_drivers():
    """A `Stall` rule ends the traced and the host solve after the same evaluations, both
    return the residuals and Jacobian at the optimum, and a restart from the host
    solve's final damping and evaluation goes on to the full optimum."""
    kw = dict(rtol=0.0, atol=1e-9, rounding=0.0)
    full = least_squares(HostResiduals(evaluate), P0, **kw)
    stall = Stall(evals=2, tol=600.0)  # the cost falls 516 -> 43.9 over the last two
    host = least_squares(HostResiduals(evaluate), P0, stall=stall, **kw)
    sol = least_squares(decay, jnp.asarray(P0), stall=stall, linearise=True, **kw)
    assert bool(host.successful) and bool(sol.successful)
    assert 2 < int(sol.stats["num_steps"]) == host.stats["num_steps"] < full.stats["num_steps"]
    np.testing.assert_allclose(np.asarray(sol.params), host.params, rtol=1e-10)
    np.testing.assert_allclose(np.asarray(sol.residuals), host.residuals, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(np.asarray(sol.jacobian), host.jacobian, rtol=1e-8, atol=1e-9)
    assert least_squares(decay, jnp.asarray(P0)).jacobian is None  # only when asked
    first = (host.residuals, host.jacobian, True)
    more = least_squares(HostResiduals(evaluate, first), host.params, lam0=host.stats["lam"],
                         **kw)
    np.testing.assert_allclose(more.params, full.params, rtol=1e-9)
    assert more.stats["num_steps"] + host.stats["num_steps"] <= full.stats["num_steps"] + 1


def test_verb_over_selected_leaves_with_aux_and_a_cap(minpack):
    params = {"amp": jnp.asarray(1.0), "rate": jnp.asarray(0.5), "level": jnp.asarray(0.5)}

    def residuals(p, scale):
        r = decay(jnp.stack([p["amp"], p["rate"], p["level"]])) * scale
        return r, jnp.sum(r * r)

    sol = least_squares(residuals, params, lambda p: (p["amp"], p["rate"]), args=1.0,
                        has_aux=True)
    assert bool(sol.successful) and float(sol.params["level"]) == 0.5  # held
    r, _ = residuals(sol.params, 1.0)
    assert float(sol.aux) == pytest.approx(float(jnp.sum(r * r)), rel=1e-12)
    capped = least_squares(decay, jnp.asarray(P0), cap=jnp.asarray(2), rtol=0.0, atol=0.0)
    assert int(capped.stats["num_steps"]) == 2 and bool(capped.successful)
    stuck = least_squares(decay, jnp.asarray(P0), max_steps=3, rtol=0.0, atol=0.0,
                          rounding=0.0)
    assert stuck.result == optx.RESULTS.nonlinear_max_steps_reached


@pytest.mark.parametrize("away, result", [(jnp.nan, optx.RESULTS.nonfinite),
                                           (2e3, optx.RESULTS.successful)])
def test_damping_limit_ends_a_solve_without_descent(away, result):
    """Every trial point is rejected (away from the start the residual is `away`): each
    rejection multiplies the damping by a doubling factor, and the solve stops once it
    passes LAMBDA_MAX instead of running out of steps, in both drivers. Where the model
    fails there (non-finite), the start is not a minimum: `RESULTS.nonfinite`; where the
    cost rises, the start is a minimum of the cost as computed: successful."""
    def residual(p, _=None):
        return jnp.where(p == 0.3, 1e3 + p, away)

    def evaluate(z):
        r = np.where(z == 0.3, 1e3 + z, away)
        return r, np.ones((1, 1)), bool(np.all(np.isfinite(r)))

    sol = optx.least_squares(residual, LevenbergMarquardt(rtol=0.0, atol=0.0),
                             jnp.asarray([0.3]), max_steps=500, throw=False)
    host = least_squares(HostResiduals(evaluate), np.array([0.3]), rtol=0.0, atol=0.0,
                         max_steps=500)
    assert sol.result == result and host.result == result
    assert float(sol.state.search.lam) > LAMBDA_MAX and host.stats["lam"] > LAMBDA_MAX
    assert int(sol.stats["num_steps"]) == host.n_evals < 20
    assert float(sol.value[0]) == 0.3 == host.z[0]


def test_fitting_exports_the_same_verb():
    import stickslip_fitting.solve.lsq as fsolve
    from stickslip_jax import lsq

    assert fsolve.least_squares is lsq.least_squares
    assert fsolve.LeastSquaresSolution is lsq.LeastSquaresSolution
    assert fsolve.free_filter is lsq.free_filter
