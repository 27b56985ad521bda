r"""The project's one least-squares solver, Levenberg-Marquardt for whitened residuals,
and `least_squares`, the one verb every fit calls.

Every fit of the project (cycle features, trace, combined, pitching, experiment design,
the contact calibration, the discovery refits) minimises $\|r(y)\|^2$ with this
algorithm, assembled from public optimistix pieces:

- `MarquardtDescent` (an `optimistix.AbstractDescent`): the damped step with Marquardt's
  scaling $D = \mathrm{diag}(J^TJ)$ (each parameter on its own scale: log friction
  parameters and gauge offsets in mm alike), minimum-norm on a rank-deficient problem;
- `NielsenDamping` (an `optimistix.AbstractSearch`): acceptance within rounding (at the
  optimum the predicted decreases of a sum of up to a million squares fall below its
  rounding, and a strict rule would reject steps on the sign of rounding noise) and
  Nielsen's damping update;
- `LevenbergMarquardt` (an `optimistix.AbstractLeastSquaresSolver`, so it runs inside
  `optimistix.least_squares` and one compiled program): the two composed, the Jacobian
  built once per evaluated point by forward mode (the parameters are few, the residuals
  many) and only $J^TJ$ and $J^Tr$ kept between steps. (Not an
  `optimistix.AbstractGaussNewton`: that class stops on changes of the iterate and of
  the residuals, and carries the Jacobian as a linear operator from step to step, the
  whole linearisation of a trace simulator.)
- `least_squares(fn, params, free)` -> `LeastSquaresSolution` (fitted parameters,
  result code, step count, aux): the verb, over the leaves of a parameter pytree that
  `free` selects;
- options as objects: `JacobianMode` (forward or reverse mode), `Stall` (stop at an
  objective's noise floor), `HostResiduals` (an objective that is not one traceable
  function: the discovery models evaluate residuals and Jacobian blocks by several
  compiled programs; the verb then drives the same rules from Python), a start damping `lam0` (a warm restart from a solution's `stats["lam"]`);
  `linearise=True` returns the residuals and Jacobian at the optimum (a solve over a
  `HostResiduals` always has them, and reads as a flat vector: `z`, `r`, `J`, `rss`,
  `covariance`).

Each rule is one function over an array namespace `xp` (`damped_step`,
`gauss_newton_decrease`, `acceptance`, `nielsen_update`): `jax.numpy` in the pieces,
`numpy` for a `HostResiduals` (no program compiled per parameter count).

```python
sol = least_squares(lambda p, _: model(p) - data, params, lambda p: (p.a, p.b))
sol.params, sol.result, sol.stats["num_steps"]
```
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.tree_util as jtu
import lineax as lx
import numpy as np
import optimistix as optx
from jax.flatten_util import ravel_pytree
from jaxtyping import Array, Bool, Float, Int, PyTree, Scalar

from .modes import AbstractMode

__all__ = [
    "LAMBDA_MAX",
    "HostResiduals",
    "JacobianMode",
    "LeastSquaresSolution",
    "LevenbergMarquardt",
    "MarquardtDescent",
    "MarquardtState",
    "NielsenDamping",
    "NielsenState",
    "Stall",
    "acceptance",
    "damped_step",
    "free_filter",
    "gauss_newton_covariance",
    "gauss_newton_decrease",
    "least_squares",
    "nielsen_update",
]

LAMBDA_MIN = 1e-12
"""Smallest damping (relative to Marquardt's scaling)."""

LAMBDA_MAX = 1e16
"""Damping beyond which no step can lower the cost at this precision: the solve stops,
successfully when the last trial cost was finite (steps down to round-off along the
descent direction raise the cost: a minimum of the cost as computed), with
`RESULTS.nonfinite` when the model failed there (the point is at the edge of the region
where the model runs, not at a minimum)."""

LAMBDA_AFTER_REJECT = 1e-3
"""A rejected step raises a smaller damping to at least this."""


# ------------------------------------------------------------------------ the rules
def _eigen(A, g, active, xp):
    """Eigen-decomposition of the Marquardt-scaled normal matrix over the `active`
    parameters: (w, V, scaled gradient, scale)."""
    d = xp.where(active, xp.diag(A), 1.0)
    d = xp.where(d > 0, d, 1.0)
    s = 1.0 / xp.sqrt(d)
    mask = active[:, None] & active[None, :]
    w, V = xp.linalg.eigh(xp.where(mask, A * s[:, None] * s[None, :], 0.0))
    return w, V, xp.where(active, g * s, 0.0), s


def _damped(eigen, lam, active, xp):
    w, V, gs, s = eigen
    w = xp.maximum(w, 0.0)
    floor = xp.finfo(w.dtype).eps * xp.max(w) * w.size
    coef = (V.T @ gs) / xp.where(w + lam > floor, w + lam, xp.inf)
    return xp.where(active, -(V @ coef) * s, 0.0)


def _decrease(eigen, rcond, xp):
    w, V, gs, _ = eigen
    keep = w > rcond * xp.max(xp.abs(w))
    proj = V.T @ gs
    return xp.sum(xp.where(keep, proj**2 / xp.where(keep, w, 1.0), 0.0))


def _mask(active, size, xp):
    return xp.ones(size, bool) if active is None else xp.asarray(active, bool)


def damped_step(A: Float[Array, "P P"], g: Float[Array, " P"], lam, active=None, xp=jnp):
    r"""The Levenberg-Marquardt step $\delta = -(A + \lambda D)^{-1} g$ ($A = J^TJ$,
    $g = J^Tr$, $D$ = diag(A)) over the `active` parameters (others 0), and the cost
    decrease its linear model predicts, $-(2g^T\delta + \delta^TA\delta)$. Through the
    eigen-decomposition of the scaled $A$: a zero eigenvalue (a direction the data do not
    determine) gets no step even at $\lambda = 0$. `xp`: the array namespace (`numpy`
    over a `HostResiduals`: no program compiled per parameter count)."""
    active = _mask(active, g.shape, xp)
    step = _damped(_eigen(A, g, active, xp), lam, active, xp)
    return step, -(2.0 * g @ step + step @ (A @ step))


def gauss_newton_decrease(A, g, active=None, rcond: float = 1e-12, xp=jnp):
    r"""Cost decrease of the full Gauss-Newton step, $g^TA^+g$ (pseudo-inverse over the
    `active` parameters; singular values below `rcond` of the largest dropped): the
    stationarity test (for whitened residuals, a chi-square still to gain). `xp`: as in
    `damped_step`."""
    return _decrease(_eigen(A, g, _mask(active, g.shape, xp), xp), rcond, xp)


def acceptance(cost, cost_new, finite, rounding, xp=jnp):
    """(accept, within rounding): a trial point whose cost `cost_new` is `finite` is
    accepted when it lowers `cost`, or changes it by at most `rounding` of it. `xp`: as
    in `damped_step`."""
    flat = finite & (xp.abs(cost_new - cost) <= rounding * xp.abs(cost))
    return finite & ((cost_new < cost) | flat), flat


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
    `stickslip_fitting.uncertainty.laplace.sandwich_covariance`."""
    J = np.asarray(J, float)
    return np.linalg.pinv(J.T @ J, rcond=rcond, hermitian=True) * float(scale)


# ------------------------------------------------------------------------ optimistix pieces
def _flat(tree):
    return ravel_pytree(tree)[0]


def _dot(a, b):
    return sum(jnp.vdot(x, y) for x, y in zip(jtu.tree_leaves(a), jtu.tree_leaves(b)))


def _normal_equations(f_info):
    """($J^TJ$, $J^Tr$) of the Gauss-Newton model that `f_info` carries, flattened: a
    `FunctionInfo.ResidualJac` (residuals and Jacobian) or a `FunctionInfo.
    EvalGradHessian` (value 0.5 cost, gradient $J^Tr$, Hessian $J^TJ$)."""
    if isinstance(f_info, optx.FunctionInfo.ResidualJac):
        J = f_info.jac.as_matrix()
        return J.T @ J, J.T @ _flat(f_info.residual)
    if isinstance(f_info, optx.FunctionInfo.EvalGradHessian):
        return f_info.hessian.as_matrix(), _flat(f_info.grad)
    raise ValueError("MarquardtDescent needs residuals and their Jacobian, or a gradient "
                     f"and a (Gauss-Newton) Hessian; got {type(f_info).__name__}")


def _predicted(f_info, y, y_eval):
    """Decrease of `f_info.as_min()` the quadratic model predicts for the step y -> y_eval."""
    delta = jtu.tree_map(lambda a, b: a - b, y_eval, y)
    if isinstance(f_info, optx.FunctionInfo.ResidualJac):
        u = f_info.jac.mv(delta)
        return -(_dot(f_info.residual, u) + 0.5 * _dot(u, u))
    return -(_dot(f_info.grad, delta) + 0.5 * _dot(delta, f_info.hessian.mv(delta)))


def _finite(f_info):
    ok = jnp.isfinite(f_info.as_min())
    if isinstance(f_info, optx.FunctionInfo.EvalGradHessian):
        ok = ok & jnp.all(jnp.isfinite(_flat(f_info.grad)))
    return ok


class MarquardtState(eqx.Module):
    """`MarquardtDescent`'s state at the accepted point `y`: the eigen-decomposition
    (`w`, `V`) of the Marquardt-scaled normal matrix, the scaled gradient `gs`, the
    scale `s`, and `newton_decrease`, $g^TA^+g$: the decrease of $\\|r\\|^2$ the full
    Gauss-Newton step predicts (`gauss_newton_decrease`)."""

    y: PyTree
    w: Float[Array, " P"]
    V: Float[Array, "P P"]
    gs: Float[Array, " P"]
    s: Float[Array, " P"]
    newton_decrease: Float[Array, ""]


class MarquardtDescent(optx.AbstractDescent):
    r"""The Levenberg-Marquardt descent with Marquardt's scaling: the step
    $\delta = -(J^TJ + \lambda\,\mathrm{diag}(J^TJ))^{-1}J^Tr$ over the `active`
    parameters (`damped_step`), through one eigen-decomposition per accepted point (a
    rejected step's retry costs no factorisation; an undetermined direction gets no
    step). The step size is $1/\lambda$ (as in `optimistix.DampedNewtonDescent`: the
    step grows with it; infinity is the Gauss-Newton step). Reads a `FunctionInfo.
    ResidualJac` or a `FunctionInfo.EvalGradHessian`; `rcond`: the relative eigenvalue
    below which `MarquardtState.newton_decrease` drops a direction."""

    active: Bool[Array, " P"] | None = None
    rcond: float = 1e-12

    def init(self, y, f_info_struct) -> MarquardtState:
        v = _flat(y)
        zero = jnp.zeros(v.size, v.dtype)
        return MarquardtState(y, zero, jnp.zeros((v.size, v.size), v.dtype), zero,
                              jnp.ones(v.size, v.dtype), jnp.zeros((), v.dtype))

    def query(self, y, f_info, state: MarquardtState) -> MarquardtState:
        A, g = _normal_equations(f_info)
        eigen = _eigen(A, g, _mask(self.active, g.shape, jnp), jnp)
        return MarquardtState(y, *eigen, _decrease(eigen, self.rcond, jnp))

    def step(self, step_size: Scalar, state: MarquardtState):
        active = _mask(self.active, state.gs.shape, jnp)
        step = _damped((state.w, state.V, state.gs, state.s), 1.0 / step_size, active, jnp)
        return ravel_pytree(state.y)[1](step), optx.RESULTS.successful


class NielsenState(eqx.Module):
    """`NielsenDamping`'s state: the damping `lam`, Nielsen's factor `nu`, and `flat`:
    the last step was accepted for changing the cost only within rounding."""

    lam: Float[Array, ""]
    nu: Float[Array, ""]
    flat: Bool[Array, ""]


class NielsenDamping(optx.AbstractSearch):
    r"""Nielsen's damping for a Levenberg-Marquardt descent (`nielsen_update`): accepts a
    step when it lowers the cost or changes it by at most `rounding` of it
    (`acceptance`; a non-finite cost or gradient is rejected), then scales the damping
    $\lambda$ by the ratio $\rho$ of the actual to the predicted decrease. Returns the
    step size $1/\lambda$ (`MarquardtDescent`, `optimistix.DampedNewtonDescent`).
    `lam0`: the initial damping (relative to Marquardt's scaling; an array may be
    traced); 0 starts with the Gauss-Newton step (a start where the quadratic model is
    trusted)."""

    lam0: float | Float[Array, ""] = 1e-3
    rounding: float = 1e-10

    def init(self, y, f_info_struct) -> NielsenState:
        dtype = _flat(y).dtype
        return NielsenState(jnp.asarray(self.lam0, dtype), jnp.asarray(2.0, dtype),
                            jnp.array(False))

    def step(self, first_step, y, y_eval, f_info, f_eval_info, state: NielsenState):
        f, f_eval = f_info.as_min(), f_eval_info.as_min()
        accept, flat = acceptance(f, f_eval, _finite(f_eval_info), self.rounding)
        accept, flat = first_step | accept, ~first_step & flat
        pred = _predicted(f_info, y, y_eval)
        rho = jnp.where(pred > 0, (f - f_eval) / jnp.where(pred > 0, pred, 1.0), 0.0)
        lam, nu = nielsen_update(state.lam, state.nu, accept, rho)
        lam = jnp.where(first_step, state.lam, lam)
        return 1.0 / lam, accept, optx.RESULTS.successful, NielsenState(lam, nu, flat)


# ------------------------------------------------------------------------ the solver
class Stall(eqx.Module):
    """Stopping at an objective's noise floor (objectives with solver noise: below it
    steps are not worth their cost): a solve ends, successfully, on an accepted step
    when its last `evals` accepted steps lowered the cost by less than `tol` (a
    chi-square) together. Rejected trial points do not count: a run of rejections (the
    damping rising after failed or worse evaluations) says nothing about the floor, and
    ends a solve only by the damping limit or the step budget.

    `window` and `update` are the rule for both drivers over an array namespace `xp`:
    the accepted costs of the last `evals + 1` accepted points, oldest first."""

    evals: int = eqx.field(default=4, static=True)
    tol: float = 0.5

    def window(self, dtype=float, xp=jnp):
        """No accepted point yet: `evals + 1` infinite costs."""
        return xp.full(self.evals + 1, xp.inf, dtype)

    def update(self, window, cost, accept, xp=jnp):
        """(window, stalled): `cost` appended to the `window` when the step is accepted
        (else the window as it was), and whether this accepted step ends the solve."""
        window = xp.where(accept, xp.append(window[1:], cost), window)
        return window, accept & (window[0] - cost < self.tol)


_NO_STALL = Stall(0, -np.inf)  # no stall rule: the window never stops a solve


class _State(eqx.Module):
    y: Float[Array, " P"]  # the accepted point (flat)
    y_try: Float[Array, " P"]  # the point the next step evaluates
    f_info: optx.FunctionInfo.EvalGradHessian  # Gauss-Newton model at y
    aux: Any
    search: NielsenState
    descent: MarquardtState
    first: Bool[Array, ""]
    num_steps: Int[Array, ""]
    terminate: Bool[Array, ""]
    failed: Bool[Array, ""]  # stopped at the damping limit after a failed evaluation
    recent: Float[Array, " S"]  # the Stall rule's window of accepted costs


def _model(cost, g, A):
    """The Gauss-Newton model of $\\frac12\\|r\\|^2$ at a point: value, gradient $J^Tr$,
    Hessian $J^TJ$."""
    return optx.FunctionInfo.EvalGradHessian(
        0.5 * cost, g, lx.MatrixLinearOperator(A, lx.positive_semidefinite_tag))


class JacobianMode(AbstractMode):
    """How `least_squares` builds the Jacobian at each evaluated point.

    - `FORWARD` ("fwd", the default): forward mode, one tangent per parameter (the
      parameters are few, the residuals many).
    - `REVERSE` ("bwd"): reverse mode, for residuals through a `jax.custom_vjp`.
    """

    FORWARD = "fwd"
    REVERSE = "bwd"
    option = classmethod(lambda cls: "jac")

    @classmethod
    def check(cls, jac) -> JacobianMode:
        """`jac` if it is a member; a TypeError naming the option otherwise (a string
        becomes a member where it is parsed, `JacobianMode.parse`)."""
        if not isinstance(jac, cls):
            raise TypeError(f"jac: a member of JacobianMode, got {jac!r} (a string becomes "
                            "one with JacobianMode.parse)")
        return jac


def _value_and_jacobian(fn, unravel, v, args, jac: JacobianMode = JacobianMode.FORWARD):
    """r, J^T [P, N] and aux at the flat point v, by `jac` (forward mode: the tangent axis
    leading)."""

    def f(x):
        return fn(unravel(x), args)

    if JacobianMode.check(jac) is JacobianMode.REVERSE:
        def f2(x):
            r, aux = f(x)
            return r, (r, aux)

        jac_rows, (r, aux) = jax.jacrev(f2, has_aux=True)(v)
        return r, jnp.moveaxis(jac_rows, -1, 0), aux

    def push(t):
        return jax.jvp(f, (v,), (t,), has_aux=True)

    r, jac_t, aux = jax.vmap(push, out_axes=(None, 0, None))(jnp.eye(v.size, dtype=v.dtype))
    return r, jac_t, aux


class LevenbergMarquardt(optx.AbstractLeastSquaresSolver):
    """Levenberg-Marquardt: `MarquardtDescent` and `NielsenDamping`, for
    `optimistix.least_squares`. It stops (successfully) when the full Gauss-Newton step
    would lower the cost by less than `atol + rtol * cost` (stationarity in units of the
    whitened cost: a chi-square), when an accepted step changed the cost only within
    rounding, when the damping has grown past `LAMBDA_MAX` after a finite trial cost
    (no descent direction left at this precision), at a `Stall` rule's floor (counted
    over accepted steps only), or after `cap` steps (a traced value: screening runs
    share one compilation with full runs). Past `LAMBDA_MAX` after a failed evaluation
    (non-finite residuals or gradient) it stops with `RESULTS.nonfinite`.

    - `rtol`, `atol`: the stationarity test (cost = sum of squared residuals).
    - `rounding`: relative cost change treated as no change (accepted; ends the solve).
    - `lam0`: the initial damping (relative to Marquardt's scaling); 0 starts with the
      plain Gauss-Newton step (a start where the quadratic model is trusted).
    - `cap`: stop after this many steps (a traced integer; None: only `max_steps`).
    - `active`: boolean mask of the flattened parameters to move (None: all).
    - `stall`: a `Stall` rule (None: none).

    `options={"jac": JacobianMode.REVERSE}` builds the Jacobian by reverse mode (residuals
    through a `jax.custom_vjp`); the default is forward mode.

    Its `Solution.stats` add `num_steps`; `Solution.result` is `RESULTS.successful` when a
    stopping rule above ended the solve, `nonfinite` at the damping limit after a failed
    evaluation, `nonlinear_max_steps_reached` after `max_steps`.
    """

    rtol: float
    atol: float
    descent: MarquardtDescent
    search: NielsenDamping
    cap: Int[Array, ""] | None
    stall: Stall
    norm: Callable  # optimistix's interface; unused by the stopping rules

    def __init__(self, rtol: float, atol: float, rounding: float = 1e-10, lam0=1e-3,
                 cap=None, active=None, stall: Stall | None = None,
                 norm: Callable = optx.max_norm):
        self.rtol = rtol
        self.atol = atol
        self.descent = MarquardtDescent(active=active)
        self.search = NielsenDamping(lam0=lam0, rounding=rounding)
        self.cap = cap
        self.stall = _NO_STALL if stall is None else stall
        self.norm = norm

    def init(self, fn, y, args, options, f_struct, aux_struct, tags):
        v, _ = ravel_pytree(y)
        P = v.size
        model = _model(jnp.asarray(jnp.inf, v.dtype), jnp.zeros(P, v.dtype),
                       jnp.zeros((P, P), v.dtype))
        aux0 = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), aux_struct)
        return _State(y=v, y_try=v, f_info=model, aux=aux0, search=self.search.init(v, model),
                      descent=self.descent.init(v, model), first=jnp.array(True),
                      num_steps=jnp.array(0), terminate=jnp.array(False),
                      failed=jnp.array(False),
                      recent=self.stall.window(v.dtype))

    def step(self, fn, y, args, options, state: _State, tags):
        _, unravel = ravel_pytree(y)
        r, jac_t, aux = _value_and_jacobian(fn, unravel, state.y_try, args,
                                            options.get("jac", JacobianMode.FORWARD))
        r = r.ravel() if r.ndim != 1 else r
        jac_t = jac_t.reshape(jac_t.shape[0], -1)
        trial = _model(jnp.sum(r * r), jac_t @ r, jac_t @ jac_t.T)
        step_size, accept, _, search = self.search.step(
            state.first, state.y, state.y_try, state.f_info, trial, state.search)

        def pick(new, old):
            return jax.tree_util.tree_map(lambda a, b: jnp.where(accept, a, b), new, old)

        y_new, f_info, aux = pick((state.y_try, trial, aux), (state.y, state.f_info, state.aux))
        descent = self.descent.query(y_new, f_info, state.descent)
        step, _ = self.descent.step(step_size, descent)
        num_steps = state.num_steps + 1
        stationary = descent.newton_decrease < self.atol + self.rtol * (2.0 * f_info.f)
        limit = search.lam > LAMBDA_MAX
        stop = (accept & (stationary | search.flat)) | limit
        if self.cap is not None:
            stop = stop | (num_steps >= self.cap)
        recent, stalled = self.stall.update(state.recent, 2.0 * f_info.f, accept)
        stop = stop | stalled
        new = _State(y=y_new, y_try=y_new + step, f_info=f_info, aux=aux, search=search,
                     descent=descent, first=jnp.array(False), num_steps=num_steps,
                     terminate=stop, failed=limit & ~_finite(trial), recent=recent)
        return unravel(y_new), new, aux

    def terminate(self, fn, y, args, options, state: _State, tags):
        return state.terminate, optx.RESULTS.where(state.failed, optx.RESULTS.nonfinite,
                                                   optx.RESULTS.successful)

    def postprocess(self, fn, y, aux, args, options, state: _State, tags, result):
        return y, aux, {}


# ------------------------------------------------------------------------ the verb
def free_filter(params: PyTree, free=None) -> PyTree:
    """The boolean filter spec of the free leaves: `free` a function `params -> leaf or
    tuple of leaves` (like `eqx.tree_at`'s `where`), a spec already, or None (every leaf)."""
    if free is None:
        return jax.tree_util.tree_map(lambda _: True, params)
    if callable(free):
        none = jax.tree_util.tree_map(lambda _: False, params)
        return eqx.tree_at(free, none, replace_fn=lambda _: True)
    return free


class HostResiduals(eqx.Module):
    """An objective evaluated from Python, not one traceable function (its residuals and
    Jacobian blocks come from several compiled programs): `evaluate(z) -> (r, J, ok)` at a
    flat vector z (J: [N, P] over all coordinates; ok False where the model failed).
    `first`: an (r, J, ok) already evaluated at the start. `least_squares` runs the
    solver's rules over it in NumPy, one evaluation per step (an accepted trial point
    already carries the next step's Jacobian)."""

    evaluate: Callable
    first: tuple | None = None


class LeastSquaresSolution(eqx.Module):
    """What `least_squares` returns: the fitted `params` (free leaves at the optimum, the
    others as given), the `result` code (`optimistix.RESULTS`), the solver's `stats`
    (`num_steps`; over a `HostResiduals` also `lam`, the damping at the end (a warm
    restart starts there), `cost` there, `history`, the cost of every evaluation,
    `seconds` and `ok`),
    the `aux` output of the residual function at the optimum (None without `has_aux`), and
    the `residuals` and `jacobian` [N, P] there (with `linearise`, or over a
    `HostResiduals`; None otherwise)."""

    params: PyTree
    result: optx.RESULTS
    stats: dict
    aux: Any = None
    residuals: Any = None
    jacobian: Any = None

    @property
    def successful(self):
        return self.result == optx.RESULTS.successful

    # the flat-vector reading of a solve over a `HostResiduals` (or with `linearise`)
    z = property(lambda self: self.params)
    r = property(lambda self: self.residuals)
    J = property(lambda self: self.jacobian)
    converged = property(lambda self: bool(self.successful))
    n_evals = property(lambda self: int(self.stats["num_steps"]))
    lam = property(lambda self: self.stats["lam"])  # the damping at the end: a warm lam0
    ok = property(lambda self: self.stats["ok"])
    rss = property(lambda self: float(self.stats["cost"] if "cost" in self.stats
                                      else self.residuals @ self.residuals))
    n_data = property(lambda self: int(self.residuals.shape[0]))

    def covariance(self, active: np.ndarray) -> np.ndarray:
        r"""Gauss-Newton covariance of the `active` coordinates, $(J^TJ)^{-1}$ scaled by
        the reduced chi-square (so it holds whatever the true noise level)."""
        scale = self.rss / max(self.n_data - int(active.sum()), 1)
        return gauss_newton_covariance(self.jacobian[:, active], scale)


@eqx.filter_jit
def _solve(fn, free, static, args, solver, has_aux, max_steps, jac, linearise):
    def residual(f, a):
        out = fn(eqx.combine(f, static), a)
        return out if has_aux else (out, None)

    sol = optx.least_squares(residual, solver, free, args=args, has_aux=True,
                             max_steps=max_steps, throw=False, options=dict(jac=jac))
    if not linearise:
        return sol, None, None
    v, unravel = ravel_pytree(sol.value)
    r, jac_t, _ = _value_and_jacobian(residual, unravel, v, args, jac)
    return sol, r.ravel(), jac_t.reshape(v.size, -1).T


def _host_finite(r, J, ok) -> bool:
    """A host evaluation the solver can use: the model ran (`ok`) and its residuals and
    Jacobian are finite (a non-finite Jacobian with finite residuals would be accepted and
    break the next step's eigendecomposition), as `_finite` asks of a traced one."""
    return bool(ok) and bool(np.all(np.isfinite(r))) and bool(np.all(np.isfinite(J)))


def _host(problem: HostResiduals, z0, active, rtol, atol, max_steps, lam0, rounding,
          stall) -> LeastSquaresSolution:
    t0 = time.perf_counter()
    z = np.asarray(z0, float).copy()
    active = np.ones(z.size, bool) if active is None else np.asarray(active, bool)
    r, J, ok = problem.evaluate(z) if problem.first is None else problem.first
    n_evals = int(problem.first is None)
    if not _host_finite(r, J, ok):
        raise ValueError("the model failed at the starting point of the fit; check the "
                         "records (stick-slip present) and the start")
    cost = float(r @ r)
    lam, nu = float(lam0), 2.0
    converged = failed = False
    stall = _NO_STALL if stall is None else stall
    history, (window, _) = [cost], stall.update(stall.window(xp=np), cost, True, xp=np)
    while n_evals < max_steps:
        A, g = J.T @ J, J.T @ r
        eigen = _eigen(A, g, active, np)  # one decomposition: the stationarity test, the step
        if float(_decrease(eigen, 1e-12, np)) < atol + rtol * cost:
            converged = True
            break
        step = _damped(eigen, lam, active, np)  # `damped_step`
        pred = -(2.0 * g @ step + step @ (A @ step))
        r_try, J_try, ok_try = problem.evaluate(z + step)
        n_evals += 1
        good = _host_finite(r_try, J_try, ok_try)
        cost_try = float(r_try @ r_try) if good else np.inf
        history.append(cost_try)
        accept, flat = (bool(x) for x in acceptance(cost, cost_try, good, rounding, np))
        rho = (cost - cost_try) / float(pred) if (good and pred > 0) else 0.0
        lam, nu = (float(x) for x in nielsen_update(lam, nu, accept, rho, xp=np))
        if accept:
            z, r, J, ok, cost = z + step, r_try, J_try, ok_try, cost_try
        window, stalled = stall.update(window, cost, accept, xp=np)
        failed = lam > LAMBDA_MAX and not good
        converged = (accept and flat) or lam > LAMBDA_MAX or bool(stalled)
        if converged:
            break
    result = (optx.RESULTS.nonlinear_max_steps_reached if not converged
              else optx.RESULTS.nonfinite if failed else optx.RESULTS.successful)
    stats = dict(num_steps=n_evals, lam=lam, history=history, ok=bool(ok), cost=cost,
                 seconds=time.perf_counter() - t0)
    return LeastSquaresSolution(z, result, stats, residuals=r, jacobian=J)


def least_squares(fn, params: PyTree, free=None, *, args=None, has_aux: bool = False,
                  rtol: float = 1e-10, atol: float = 1e-10, max_steps: int = 200,
                  jac: JacobianMode = JacobianMode.FORWARD, lam0=1e-3, cap=None,
                  rounding: float = 1e-10, stall: Stall | None = None,
                  linearise: bool = False) -> LeastSquaresSolution:
    """Minimise the sum of squares of `fn(params, args)` (a residual array; with
    `has_aux`, a pair (residuals, aux)) over the leaves of `params` that `free` selects
    (`free_filter`), by `LevenbergMarquardt(rtol, atol, rounding, lam0, cap, stall=stall)`
    in one compiled `optimistix.least_squares` (jit-compatible: `lam0` and `cap` may be
    traced). `fn` may be an `eqx.Module` (an objective: its arrays are traced, not baked
    in), or a `HostResiduals` over the flat vector `params` (`free`: a boolean mask over
    it or None; `max_steps` counts evaluations). `jac`: a `JacobianMode`
    (`JacobianMode.REVERSE` for residuals through a `jax.custom_vjp`). `linearise`: also return the
    residuals and Jacobian at the optimum. Never raises on a failed solve: read `result`
    (a `HostResiduals` that fails at its start raises ValueError)."""
    JacobianMode.check(jac)
    if isinstance(fn, HostResiduals):
        return _host(fn, params, free, rtol, atol, max_steps, lam0, rounding, stall)
    free_part, static = eqx.partition(params, free_filter(params, free))
    solver = LevenbergMarquardt(rtol=rtol, atol=atol, rounding=rounding, lam0=lam0, cap=cap,
                                stall=stall)
    sol, r, J = _solve(fn, free_part, static, args, solver, has_aux, max_steps, jac,
                       linearise)
    return LeastSquaresSolution(eqx.combine(sol.value, static), sol.result, sol.stats,
                                sol.aux if has_aux else None, r, J)
