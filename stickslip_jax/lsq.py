r"""The project's one least-squares solver: Levenberg-Marquardt for whitened residuals.

Every fit of the project (cycle features, trace, combined, pitching, experiment design,
the contact calibration, the discovery refits) minimises $\|r(y)\|^2$ with this
algorithm. Two drivers share its update (`damped_step`, `nielsen_update`,
`gauss_newton_decrease`):

- `LevenbergMarquardt`, an `optimistix.AbstractLeastSquaresSolver` built only on
  optimistix's public solver interface (`init`, `step`, `terminate`, `postprocess`), so
  it runs inside `optimistix.least_squares` and one compiled program; its state is its
  own (no other solver's private state is read);
- `solve_host(evaluate, z0, ...)`, the same iteration driven from Python for objectives
  that are not one traceable function (the discovery workflow evaluates its residuals and
  Jacobian blocks by several compiled programs).

The iteration:

- the Jacobian is built once per evaluated point, by forward mode with one tangent per
  parameter (the parameters are few, the residuals many);
- the damped step solves $(J^TJ + \lambda D)\,\delta = -J^Tr$ with Marquardt's scaling
  $D = \mathrm{diag}(J^TJ)$ (each parameter on its own scale: log friction parameters
  and gauge offsets in mm alike), through the eigen-decomposition of the scaled normal
  matrix, so a rank-deficient problem gives the minimum-norm step;
- Nielsen's damping update: after an accepted step
  $\lambda \leftarrow \lambda \max(1/3, 1 - (2\rho - 1)^3)$ ($\rho$: actual over predicted
  decrease), after a rejected one $\lambda \leftarrow \lambda\nu$, $\nu \leftarrow 2\nu$;
- a step is accepted when it lowers the cost, or changes it only within rounding
  (`rounding` of the cost: at the optimum the predicted decreases of a sum of up to a
  million squares fall below its rounding, and a strict rule would reject steps on the
  sign of rounding noise);
- it stops (successfully) when the full Gauss-Newton step would lower the cost by less
  than `atol + rtol * cost` (stationarity in units of the whitened cost: the cost is a
  chi-square), when an accepted step changed the cost only within rounding, when the
  damping has grown past `LAMBDA_MAX` (no descent direction left at this precision), or
  after `cap` steps when a cap is given (a traced value: screening runs share one
  compilation with full runs).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jax.flatten_util import ravel_pytree
from jaxtyping import Array, Bool, Float, Int

__all__ = [
    "LAMBDA_MAX",
    "gauss_newton_covariance",
    "HostResult",
    "LevenbergMarquardt",
    "damped_step",
    "gauss_newton_decrease",
    "nielsen_update",
    "solve_host",
]

LAMBDA_MIN = 1e-12
"""Smallest damping (relative to Marquardt's scaling)."""

LAMBDA_MAX = 1e16
"""Damping beyond which no step can lower the cost at this precision: the solve stops."""

LAMBDA_AFTER_REJECT = 1e-3
"""A rejected step raises a smaller damping to at least this."""


# ------------------------------------------------------------------------ shared update
def _scaled(A, active, xp=jnp):
    d = xp.where(active, xp.diag(A), 1.0)
    d = xp.where(d > 0, d, 1.0)
    s = 1.0 / xp.sqrt(d)
    mask = active[:, None] & active[None, :]
    As = xp.where(mask, A * s[:, None] * s[None, :], 0.0)
    return As, s


def damped_step(A: Float[Array, "P P"], g: Float[Array, " P"], lam, active=None, xp=jnp):
    r"""The Levenberg-Marquardt step $\delta = -(A + \lambda D)^{-1} g$ ($A = J^TJ$,
    $g = J^Tr$, $D$ = diag(A)) over the `active` parameters (others 0), and the cost
    decrease its linear model predicts, $-(2g^T\delta + \delta^TA\delta)$. Through the
    eigen-decomposition of the scaled $A$: a zero eigenvalue (a direction the data do not
    determine) gets no step even at $\lambda = 0$. `xp`: the array namespace (`numpy`
    for the host driver `solve_host`: no program compiled per parameter count)."""
    active = xp.ones(g.shape, bool) if active is None else xp.asarray(active, bool)
    As, s = _scaled(A, active, xp)
    gs = xp.where(active, g * s, 0.0)
    w, V = xp.linalg.eigh(As)
    w = xp.maximum(w, 0.0)
    floor = xp.finfo(w.dtype).eps * xp.max(w) * w.size
    coef = (V.T @ gs) / xp.where(w + lam > floor, w + lam, xp.inf)
    step = xp.where(active, -(V @ coef) * s, 0.0)
    predicted = -(2.0 * g @ step + step @ (A @ step))
    return step, predicted


def gauss_newton_decrease(A, g, active=None, rcond: float = 1e-12, xp=jnp):
    r"""Cost decrease of the full Gauss-Newton step, $g^TA^+g$ (pseudo-inverse over the
    `active` parameters; singular values below `rcond` of the largest dropped): the
    stationarity test (for whitened residuals, a chi-square still to gain). `xp`: as in
    `damped_step`."""
    active = xp.ones(g.shape, bool) if active is None else xp.asarray(active, bool)
    As, s = _scaled(A, active, xp)
    gs = xp.where(active, g * s, 0.0)
    w, V = xp.linalg.eigh(As)
    keep = w > rcond * xp.max(xp.abs(w))
    proj = V.T @ gs
    return xp.sum(xp.where(keep, proj**2 / xp.where(keep, w, 1.0), 0.0))


def nielsen_update(lam, nu, accept, rho, xp=jnp):
    r"""Nielsen's damping update: after an accepted step
    $\lambda\max(1/3, 1 - (2\rho-1)^3)$ and $\nu = 2$; after a rejected one $\lambda\nu$
    (at least `LAMBDA_AFTER_REJECT`) and $\nu \leftarrow 2\nu$. `xp`: as in
    `damped_step`."""
    lam_acc = xp.maximum(lam * xp.maximum(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3),
                         LAMBDA_MIN)
    lam_rej = xp.where(lam < LAMBDA_AFTER_REJECT, xp.maximum(lam * nu, LAMBDA_AFTER_REJECT),
                       lam * nu)
    return xp.where(accept, lam_acc, lam_rej), xp.where(accept, 2.0, 2.0 * nu)


def gauss_newton_covariance(J, scale: float = 1.0, rcond: float = 1e-13) -> np.ndarray:
    r"""The Gauss-Newton (Laplace) covariance $s\,(J^TJ)^+$ of least-squares estimates
    ($J$: [N, P] Jacobian of the residuals; pseudo-inverse, singular values below
    `rcond` of the largest dropped: an undetermined direction gets no variance from
    round-off). `scale` $s$: 1 for whitened residuals with trusted errors,
    max(1, chi2/dof) to widen for a misfit, sigma^2 for unwhitened residuals. The one
    covariance of the project's fits; the cluster-robust alternative is
    `stickslip_fitting.uncertainty.sandwich_covariance`."""
    J = np.asarray(J, float)
    return np.linalg.pinv(J.T @ J, rcond=rcond, hermitian=True) * float(scale)


def _flat(cost, cost_new, rounding, xp=jnp):
    return xp.abs(cost_new - cost) <= rounding * xp.abs(cost)


# ------------------------------------------------------------------------ optimistix solver
class _State(eqx.Module):
    y: Float[Array, " P"]  # the accepted point (flat)
    y_try: Float[Array, " P"]  # the point the next step evaluates
    cost: Float[Array, ""]
    g: Float[Array, " P"]
    A: Float[Array, "P P"]
    aux: Any
    lam: Float[Array, ""]
    nu: Float[Array, ""]
    first: Bool[Array, ""]
    num_steps: Int[Array, ""]
    terminate: Bool[Array, ""]


def _value_and_jacobian(fn, unravel, v, args, jac: str = "fwd"):
    """r, J^T [P, N] and aux at the flat point v: forward mode, one tangent per parameter,
    tangent axis leading (`jac="fwd"`), or reverse mode (`"bwd"`, for residuals through a
    `jax.custom_vjp`)."""

    def f(x):
        return fn(unravel(x), args)

    if jac == "bwd":
        def f2(x):
            r, aux = f(x)
            return r, (r, aux)

        jac_rows, (r, aux) = jax.jacrev(f2, has_aux=True)(v)
        return r, jnp.moveaxis(jac_rows, -1, 0), aux
    if jac != "fwd":
        raise ValueError(f"options['jac'] must be 'fwd' or 'bwd', got {jac!r}")

    def push(t):
        return jax.jvp(f, (v,), (t,), has_aux=True)

    r, jac_t, aux = jax.vmap(push, out_axes=(None, 0, None))(jnp.eye(v.size, dtype=v.dtype))
    return r, jac_t, aux


class LevenbergMarquardt(optx.AbstractLeastSquaresSolver):
    """Levenberg-Marquardt with Marquardt scaling and Nielsen damping (module docstring),
    for `optimistix.least_squares`.

    - `rtol`, `atol`: stop when the full Gauss-Newton step would lower the cost by less
      than `atol + rtol * cost` (cost = sum of squared residuals).
    - `rounding`: relative cost change treated as no change (accepted; ends the solve).
    - `lam0`: the initial damping (relative to Marquardt's scaling); 0 starts with the
      plain Gauss-Newton step (a start where the quadratic model is trusted).
    - `cap`: stop after this many steps (a traced integer; None: only `max_steps`).
    - `active`: boolean mask of the flattened parameters to move (None: all).

    `options={"jac": "bwd"}` builds the Jacobian by reverse mode (residuals through a
    `jax.custom_vjp`); the default is forward mode.

    Its `Solution.stats` add `num_steps`; `Solution.result` is `RESULTS.successful` when a
    stopping rule above ended the solve, `max_steps_reached` otherwise.
    """

    rtol: float
    atol: float
    rounding: float = 1e-10
    lam0: float = 1e-3
    cap: Int[Array, ""] | None = None
    active: Bool[Array, " P"] | None = None
    norm: Callable = optx.max_norm  # optimistix's interface; unused by the stopping rules

    def init(self, fn, y, args, options, f_struct, aux_struct, tags):
        v, _ = ravel_pytree(y)
        P = v.size
        aux0 = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), aux_struct)
        return _State(
            y=v, y_try=v, cost=jnp.asarray(jnp.inf, v.dtype), g=jnp.zeros(P, v.dtype),
            A=jnp.zeros((P, P), v.dtype), aux=aux0, lam=jnp.asarray(self.lam0, v.dtype),
            nu=jnp.asarray(2.0, v.dtype), first=jnp.array(True), num_steps=jnp.array(0),
            terminate=jnp.array(False))

    def step(self, fn, y, args, options, state: _State, tags):
        _, unravel = ravel_pytree(y)
        active = (jnp.ones(state.y.shape, bool) if self.active is None
                  else jnp.asarray(self.active, bool))
        r, jac_t, aux = _value_and_jacobian(fn, unravel, state.y_try, args,
                                            options.get("jac", "fwd"))
        r = r.ravel() if r.ndim != 1 else r
        jac_t = jac_t.reshape(jac_t.shape[0], -1)
        cost_t = jnp.sum(r * r)
        g_t, A_t = jac_t @ r, jac_t @ jac_t.T
        finite = jnp.isfinite(cost_t) & jnp.all(jnp.isfinite(g_t))
        delta = state.y_try - state.y
        pred = -(2.0 * state.g @ delta + delta @ (state.A @ delta))
        actual = state.cost - cost_t
        flat = ~state.first & finite & _flat(state.cost, cost_t, self.rounding)
        accept = state.first | (finite & ((actual > 0) | flat))
        rho = jnp.where(pred > 0, actual / jnp.where(pred > 0, pred, 1.0), 0.0)
        lam, nu = nielsen_update(state.lam, state.nu, accept, rho)
        lam = jnp.where(state.first, state.lam, lam)

        def pick(new, old):
            return jax.tree_util.tree_map(lambda a, b: jnp.where(accept, a, b), new, old)

        y_new, cost, g, A = pick((state.y_try, cost_t, g_t, A_t),
                                 (state.y, state.cost, state.g, state.A))
        aux = pick(aux, state.aux)
        num_steps = state.num_steps + 1
        step, _ = damped_step(A, g, lam, active)
        stationary = gauss_newton_decrease(A, g, active) < self.atol + self.rtol * cost
        stop = (accept & (stationary | flat)) | (lam > LAMBDA_MAX)
        if self.cap is not None:
            stop = stop | (num_steps >= self.cap)
        new = _State(y=y_new, y_try=y_new + step, cost=cost, g=g, A=A, aux=aux, lam=lam,
                     nu=nu, first=jnp.array(False), num_steps=num_steps, terminate=stop)
        return unravel(y_new), new, aux

    def terminate(self, fn, y, args, options, state: _State, tags):
        return state.terminate, optx.RESULTS.successful

    def postprocess(self, fn, y, aux, args, options, state: _State, tags, result):
        return y, aux, {}


# ------------------------------------------------------------------------ host driver
@dataclasses.dataclass
class HostResult:
    """`solve_host`'s outcome: z (the optimum, all coordinates), rss = ||r||^2, r and J at
    z, n_evals, converged, seconds, ok (the objective succeeded at z), history (cost of
    every evaluation), lam (the damping at the end: a later continuation starts there)."""

    z: np.ndarray
    rss: float
    r: np.ndarray
    J: np.ndarray
    n_evals: int
    converged: bool
    seconds: float
    ok: bool
    history: list = dataclasses.field(default_factory=list)
    lam: float = 1e-3

    @property
    def n_data(self) -> int:
        return int(self.r.shape[0])

    def covariance(self, active: np.ndarray) -> np.ndarray:
        r"""Gauss-Newton covariance of the active coordinates, $(J^TJ)^{-1}$ scaled by the
        reduced chi-square (so it holds whatever the true noise level)."""
        scale = self.rss / max(self.n_data - int(active.sum()), 1)
        return gauss_newton_covariance(self.J[:, active], scale)


def solve_host(evaluate, z0, *, active=None, max_evals: int = 25, chi2_tol: float = 0.05,
               first=None, lam0: float = 1e-3, stall_evals: int = 4,
               stall_tol: float = 0.5, rounding: float = 1e-10) -> HostResult:
    r"""The same Levenberg-Marquardt iteration as `LevenbergMarquardt`, driven from Python:
    minimise ||r(z)||^2 over the `active` coordinates of z from `z0`, where
    `evaluate(z) -> (r, J, ok)` (J: [N, P] over all coordinates; ok False when the
    objective failed there). One evaluation per iteration: an accepted trial point
    already carries the Jacobian of the next.

    Converged when the full Gauss-Newton step would lower the cost by less than
    `chi2_tol` (a chi-square), when an accepted step changed it only within `rounding`,
    when the damping passed `LAMBDA_MAX`, or when the last `stall_evals` evaluations
    lowered it by less than `stall_tol` together (objectives with solver noise: below
    that floor steps are not worth their cost); otherwise it stops after `max_evals`
    evaluations, not converged. `first`: an (r, J, ok) already evaluated at z0. A small
    `lam0` (0: the plain Gauss-Newton step) suits a start where the quadratic model is
    trusted, such as a refit from a base optimum whose Gauss-Newton step is a score
    test's."""
    t0 = time.perf_counter()
    z = np.asarray(z0, float).copy()
    active = np.ones(z.size, bool) if active is None else np.asarray(active, bool)
    r, J, ok = evaluate(z) if first is None else first
    n_evals = 0 if first is not None else 1
    if not ok or not np.all(np.isfinite(r)):
        raise ValueError("the model failed at the starting point of the fit; check the "
                         "records (stick-slip present) and the start")
    cost = float(r @ r)
    lam, nu = float(lam0), 2.0
    converged = False
    history, best = [cost], [cost]
    while n_evals < max_evals:
        A, g = J.T @ J, J.T @ r
        if float(gauss_newton_decrease(A, g, active, xp=np)) < chi2_tol:
            converged = True
            break
        step, pred = damped_step(A, g, lam, active, xp=np)
        pred = float(pred)
        z_try = z + step
        r_try, J_try, ok_try = evaluate(z_try)
        n_evals += 1
        good = bool(ok_try) and bool(np.all(np.isfinite(r_try)))
        cost_try = float(r_try @ r_try) if good else np.inf
        history.append(cost_try)
        flat = good and bool(_flat(cost, cost_try, rounding, np))
        accept = good and (cost_try < cost or flat)
        rho = (cost - cost_try) / float(pred) if (good and pred > 0) else 0.0
        lam, nu = (float(x) for x in nielsen_update(lam, nu, accept, rho, xp=np))
        if accept:
            z, r, J, ok, cost = z_try, r_try, J_try, ok_try, cost_try
        best.append(cost)
        if (accept and flat) or lam > LAMBDA_MAX:
            converged = True
            break
        if len(best) > stall_evals and best[-stall_evals - 1] - cost < stall_tol:
            converged = True  # stalled at the objective's noise floor
            break
    return HostResult(z=z, rss=cost, r=r, J=J, n_evals=n_evals, converged=converged,
                      seconds=time.perf_counter() - t0, ok=bool(ok), history=history, lam=lam)
