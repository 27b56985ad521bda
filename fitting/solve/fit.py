r"""Joint least-squares fit of the friction parameters to a campaign of records.

One verb, `fit_features(features, ...)` (or `fit_records(records, ...)`), returns a
`FitResult`. The residuals are whitened (sum of squares $-2\log$ likelihood up to a
constant), so the Levenberg-Marquardt optimum is the maximum-likelihood estimate.

- Parameters: `stickslip_fitting.params.CampaignParams`; the free leaves are chosen with
  `eqx.partition` (`free_spec(hold=..., offsets=...)`).
- Options: `Objective`, `ModelModes`, `Weighting`, `Padding`, `SolverOptions`
  (`stickslip_fitting.modes`).
- Solver: `stickslip_jax.lsq.least_squares`, the whole multi-start run (a `lax.map` over
  starting points) inside one compiled program, so a campaign compiles once.
- Weights: the effective-variance standard errors depend on the parameters; each
  Levenberg-Marquardt run holds them fixed and a few reweighting rounds reach the
  estimate (`_solve_rounds`).
- Starts ("features first"): mu_d and mu_s from the measured per-cycle $\mu_m$ and
  $\mu_0$, and a grid over gamma, m and delta (n = 1, the paper's value), so that a poor
  guess does not end in a local minimum; short screening rounds, then the best few are
  polished.
- Objective: the cycle features (default), the trace (`objectives.trace`), both
  (`objectives.combined`) or whole records (`objectives.smooth`); all but the features
  start from the features optimum.
"""

from __future__ import annotations

import dataclasses
import itertools
from typing import NamedTuple

import equinox as eqx
import jax
import jax.flatten_util  # noqa: F401
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from stickslip_jax.lsq import free_filter, gauss_newton_decrease, least_squares
from stickslip_jax.modes import GaugeOffset, SlipTime
from stickslip_jax.programs import release_programs
from stickslip_jax.stored_programs import stored_jit

from ..objectives.combined import AbstractObjective, FeaturesObjective, make_objective
from ..data.features import RecordFeatures, record_features
from ..objectives.losses import AbstractLoss, Gaussian, with_loss
from ..modes import ModelModes, Objective, Padding, SolverOptions, Weighting, check_member
from ..objectives.cycle_features import FeatureData, feature_data, feature_residuals
from ..params import AbstractFrictionParams, CampaignParams, EmpiricalFriction, Hold, free_spec
from ..objectives.trace import trace_data

__all__ = ["FitResult", "fit_features", "fit_objective", "fit_records", "initial_guesses"]


@dataclasses.dataclass(frozen=True)
class FitResult:
    """Outcome of a campaign fit.

    - `params`: the best `CampaignParams`; `spec`: the filter spec of the free leaves;
      `data`: the `FeatureData` fitted; `features`: the per-record `RecordFeatures`.
    - `chi2` at the optimum; `dof`: residuals with data minus free parameters; `result`:
      optimistix result of the best start, `converged` when successful; `n_steps` (of
      the best start, all rounds), `n_rounds` (reweighting rounds).
    - `slip_time`: the $T_2$ mode of eq (3); `objective`: the `AbstractObjective`
      minimised; `trace_failures`: trace windows whose simulation failed at the optimum.
    - `record_chi2`: chi2/n of each record's features residuals before any rescaling;
      `record_scale`: the factor its standard errors were multiplied by
      (`RECORD_CHI2`), or None.
    """

    params: CampaignParams
    spec: CampaignParams
    data: FeatureData
    features: list[RecordFeatures]
    chi2: float
    dof: int
    result: optx.RESULTS
    converged: bool
    n_steps: int
    slip_time: SlipTime
    objective: AbstractObjective | None = None
    trace_failures: int = 0
    n_rounds: int = 1
    record_chi2: np.ndarray | None = None
    record_scale: np.ndarray | None = None

    @property
    def values(self) -> dict[str, float]:
        return self.params.friction.named_values()

    @property
    def reduced_chi2(self) -> float:
        return self.chi2 / max(self.dof, 1)

    def residuals(self) -> jnp.ndarray:
        return self.residuals_at(self.params)

    def residuals_at(self, params: CampaignParams) -> jnp.ndarray:
        """Whitened residuals of the fitted objective at other parameters."""
        return self.objective.residuals(params)


def mu_levels(features, offsets):
    mu0, mum = [], []
    for f, c in zip(features, offsets):
        mu0.append(f.stiffness * (f.peak - c) / f.load)
        mum.append(f.stiffness * (0.5 * (f.peak + f.trough) - c) / f.load)
    return np.concatenate(mu0), np.concatenate(mum)


def initial_guesses(features: list[RecordFeatures], offsets=None) -> list[EmpiricalFriction]:
    """Starting points: mu_d, mu_s from the measured mu_m, mu_0; a grid in gamma, m, delta."""
    offsets = np.zeros(len(features)) if offsets is None else np.asarray(offsets)
    mu0, mum = mu_levels(features, offsets)
    mu_d = max(0.9 * float(np.min(mum)), 1e-3)
    top = float(np.max(mu0))
    mu_s = max(top + 0.2 * (top - mu_d), mu_d * 1.05 + 1e-3)
    t2 = float(np.median([np.pi / f.omega0 for f in features]))
    EmpiricalFriction.check_values(mu_s=mu_s, mu_d=mu_d, delta=0.3 / t2)
    # on the host (`from_values` would compile a small program per operation)
    return [EmpiricalFriction(*jax.device_put(list(np.log([mu_d, mu_s - mu_d, g, m, d / t2, 1.0]))))
            for g, m, d in itertools.product((0.05, 0.5, 3.0), (0.35, 0.8), (0.3, 1.5))]


def _stack(trees):
    # on the host: an eager jnp.stack (or jnp.asarray of a NumPy array) would compile a
    # small program per campaign layout; device_put only copies
    return jax.tree_util.tree_map(lambda *xs: jax.device_put(np.stack(xs)), *trees)


def _n_free(free) -> int:
    """Number of free parameters: the array entries of a partitioned free part."""
    return sum(int(np.size(x)) for x in jax.tree_util.tree_leaves(eqx.filter(free, eqx.is_array)))


def _take(trees, i):
    """Entry `i` of every stacked leaf (on the host, like `_stack`)."""
    return jax.tree_util.tree_map(lambda x: jax.device_put(np.asarray(x)[i]), trees)


def _solve_starts_impl(free_starts, ref_starts, velocity, caps, lams, static, objective, rtol,
                       atol, max_steps):
    """Levenberg-Marquardt from every start (leading axis of `free_starts`), each with the
    weights frozen at its reference (`ref_starts`, `velocity`) and stopped after `caps`
    steps (traced, so screening and polish reuse the compilation), initial damping `lams`.
    Start after start (`lax.map`: a `vmap` would turn the solver's loop and branches into
    selects, about three times the compilation). Returns the optima, their chi2, results,
    success, step counts, the trace simulations' flags and slider velocities."""
    free0 = jax.tree_util.tree_map(lambda x: x[0], free_starts)
    _, unravel = jax.flatten_util.ravel_pytree(free0)
    flat_starts = jax.vmap(lambda f: jax.flatten_util.ravel_pytree(f)[0])(free_starts)

    def solve(args):
        y0, ref_free, vel, cap, lam0 = args
        ref = eqx.combine(ref_free, static)  # the weights frozen there

        def residuals(v, _):
            r, aux = objective.residuals_and_aux(eqx.combine(unravel(v), static), ref, vel)
            return r, (jnp.sum(r * r), aux)

        sol = least_squares(residuals, y0, has_aux=True, rtol=rtol, atol=atol,
                            max_steps=max_steps, lam0=lam0, cap=cap)
        chi2, (ok, vel_opt) = sol.aux
        return (unravel(sol.params), chi2, sol.result, sol.successful,
                sol.stats["num_steps"], ok, vel_opt)

    return jax.lax.map(solve, (flat_starts, ref_starts, velocity, caps, lams))


COMPILER_OPTIONS = ({"xla_cpu_use_fusion_emitters": False}
                    if tuple(int(p) for p in jax.__version__.split(".")[:2]) < (0, 11) else {})
"""XLA options of the compiled solves: on CPU, fusions emitted by the classic elemental
emitter instead of one MLIR kernel module each. Measured on benchmarks/fit.py's campaign
(2 cores): the features solve compiles in 1.8 s instead of 2.3 s and runs in 66 instead
of 94 ms; the trace solve's XLA compilation takes 1.2 instead of 2.4 s at the same run
time. (An option of XLA's CPU compiler up to JAX 0.10; JAX 0.11's XLA refuses it, so
there the solves compile with XLA's defaults.)"""

QUICK_OPTIONS = {**COMPILER_OPTIONS, "xla_backend_optimization_level": 0}
"""XLA options of programs run once (`compiled`, the Gauss-Newton terms, the Laplace
Jacobian): LLVM without its optimisation passes. Measured on benchmarks/fit.py's
campaign (2 cores): the trace Jacobian compiles in 1.1 instead of 3.2 s of CPU time and
runs in 0.13 instead of 0.036 s. The solves keep `COMPILER_OPTIONS`: they run the
Jacobian ten times or more, and the features solve, which would compile in 1.1 instead
of 2.1 s, would run twice as long (0.18 instead of 0.09 s)."""

_solve_starts = stored_jit(_solve_starts_impl, compiler_options=COMPILER_OPTIONS)


@stored_jit(compiler_options=QUICK_OPTIONS)
def compiled(fn, *args):
    """`fn(*args)` as one compiled program (with `QUICK_OPTIONS`; the function and
    non-array arguments are static): for evaluating an objective once outside the solve
    instead of dispatching its operations one by one."""
    return fn(*args)


MAX_ROUNDS = 6
"""Reweighting rounds at most (`_solve_rounds`), after the screening rounds."""

ROUND_TOL = 1e-6
"""Rounds stop when the best start's optimum moves less than this (log parameters, mm)."""

SCREEN_ROUNDS = 2
"""Rounds run from every start (of several) before only the best few are polished."""

SCREEN_STEPS = 30
"""Levenberg-Marquardt steps per start in a screening round at most."""

POLISH_STARTS = 4
"""Starts (those with the lowest chi2 after screening) polished to the tolerances."""

LAMBDA_START = 1e-3
"""Initial Levenberg-Marquardt damping (relative to Marquardt's scaling) from the grid
of starts."""

LAMBDA_NEAR = 1e-6
"""Initial damping from a previous optimum (a later reweighting round, the trace fit from
the features optimum): the quadratic model is trusted there, and a larger damping would
hold back the weakly determined directions (gamma against m) for several steps."""


def _solve_rounds(free_starts, static, objective, rtol, atol, max_steps):
    """Levenberg-Marquardt with effective-variance weights by iterative reweighting.

    The standard errors depend on the parameters (the timing errors propagate through the
    slope of eq (1)); they are held fixed in the derivative, so the estimate is the fixed
    point where the weights at the optimum give that same optimum. Each round freezes the
    weights at the previous optimum (the first: at the start, the trace's slider velocity
    0, every sample weighted as in a stick), so its Jacobian is exact and it converges
    quadratically; two or three rounds reach the fixed point on one compilation.

    With several starts, the first `SCREEN_ROUNDS` rounds run every start for at most
    `SCREEN_STEPS` steps (a start stuck on a plateau stops there); the `POLISH_STARTS`
    with the lowest chi2 then continue with `max_steps` until the best converged one
    moves less than `ROUND_TOL`.
    """
    ref = free_starts
    n_start = jax.tree_util.tree_leaves(free_starts)[0].shape[0]
    screen = SCREEN_ROUNDS if n_start > 1 else 0
    vel = None  # the first round: the trace's slider velocity 0
    if objective.velocity_shape() is not None:
        vel = jax.device_put(np.zeros((n_start,) + objective.velocity_shape()))
    caps = np.full(n_start, SCREEN_STEPS if screen else max_steps + 1, np.int32)
    lams = jax.device_put(np.full(n_start, LAMBDA_START if screen else LAMBDA_NEAR))
    total = np.zeros(n_start, int)
    polished = np.ones(n_start, bool)
    for k in range(screen + MAX_ROUNDS):
        values, chi2s, results, success, steps, flags, vel_opt = _solve_starts(
            free_starts, ref, vel, jax.device_put(caps), lams, static, objective, rtol, atol,
            max_steps)
        total += np.asarray(steps)
        chi2s_np = np.asarray(chi2s)
        ok = np.asarray(success)
        score = np.where(np.isfinite(chi2s_np) & polished, chi2s_np, np.inf)
        best = int(np.argmin(np.where(ok, score, score + 1e300)))
        move = max(float(np.max(np.abs(np.asarray(a)[best] - np.asarray(b)[best])))
                   for a, b in zip(jax.tree_util.tree_leaves(values),
                                   jax.tree_util.tree_leaves(ref)))
        free_starts = ref = values
        vel = vel_opt
        lams = jax.device_put(np.full(n_start, LAMBDA_NEAR))
        if k + 1 == screen:
            polished = np.zeros(n_start, bool)
            polished[np.argsort(score, kind="stable")[:POLISH_STARTS]] = True
            caps = np.where(polished, max_steps + 1, 0).astype(np.int32)
        if k >= screen and k > 0 and move < ROUND_TOL:
            break
    return values, chi2s_np, _take(results, best), ok, total, flags, best, k + 1


class _Options(NamedTuple):
    """The option objects of `fit_features`, passed on together inside this module."""

    hold: Hold | None
    modes: ModelModes
    weighting: Weighting
    padding: Padding
    solver: SolverOptions


def fit_features(
    features: list[RecordFeatures],
    *,
    records=None,
    objective: Objective = Objective.FEATURES,
    hold: Hold | None = None,
    starts: list[AbstractFrictionParams] | None = None,
    loss: AbstractLoss | None = None,
    modes: ModelModes = ModelModes(),
    weighting: Weighting = Weighting(),
    padding: Padding = Padding(),
    solver: SolverOptions = SolverOptions(),
) -> FitResult:
    r"""Fit mu_s, mu_d, gamma, m, delta, n jointly to the cycle features of a campaign.

    - `objective`: an `Objective`; all but FEATURES need `records` (the `Record`s the
      features came from) and start from the features fit's optimum.
    - `hold`: a `params.Hold`, e.g. `Hold(lambda f: f.log_n, 1.0)`; `starts`: starting
      friction modules (default `initial_guesses`).
    - `loss`: a heavy-tailed likelihood (`Huber()`, `StudentT()`; None or `Gaussian()`:
      least squares), fitted from the Gaussian fit (`_fit_heavy_tailed`).
    - `modes`, `weighting`, `padding`, `solver`: the option groups (`stickslip_fitting.modes`).

    Every option is an object: a string (a command line's) becomes a member where it is
    parsed (`Objective.parse`); held values by name are `Hold.named({"n": 1.0})`.

    JAX's compiled programs are dropped first when the process nears its memory-map
    limit (`stickslip_jax.programs`: XLA's compiler would otherwise die there).
    """
    release_programs()
    check_member("objective", objective, Objective)
    o = _Options(hold, modes, weighting, padding, solver)
    if objective.needs_records and records is None:
        raise ValueError(f"objective {objective.value!r} needs the records (records=...)")
    if not features:
        raise ValueError("fit_features: no records to fit (features is empty); a campaign "
                         "needs the features of at least one record (record_features)")
    if loss is not None and not isinstance(loss, Gaussian):
        return _fit_heavy_tailed(features, records, loss, objective, starts, o)
    if objective.needs_records:
        # the two solves compile one after the other (a background thread for the trace
        # solve saves nothing measurable: 3.1 s with compilation either way)
        first = _fit_problem(_features_problem(features, o, starts), features, o.solver)
        if objective is Objective.SMOOTH:
            from ..objectives.smooth import SmoothObjective, smooth_data

            obj = SmoothObjective(smooth_data(records, features), slip_time=o.modes.slip_time)
        else:
            tdata = trace_data(records, features, pad_length=o.padding.length,
                               pad_windows=o.padding.windows)
            obj = make_objective(objective, first.data, tdata, weights=o.weighting.pair,
                                 slip_time=o.modes.slip_time)
        return fit_objective(obj, first.params, first.spec, solver=o.solver.refine(),
                             base=first)
    if not o.weighting.rescale_records:
        fit = _fit_problem(_features_problem(features, o, starts), features, o.solver)
        return dataclasses.replace(fit, record_chi2=_record_chi2(fit))
    return _fit_rescaled(lambda fs: _features_problem(fs, o, starts), features, o.solver)


def _fit_heavy_tailed(features, records, loss, objective: Objective, starts,
                      o: _Options) -> FitResult:
    """`fit_features(..., loss=loss)` (not Gaussian).

    1. The Gaussian features fit (`fit_features`), whose residuals give each record's
       *robust* scatter: the median absolute deviation of its features residuals, not
       their root mean square as in the Gaussian fit's `RECORD_CHI2` scaling. A record the
       model describes worse than its noise gets its errors scaled to that scatter, so
       the loss discounts its irregular cycles, and one irregular slip does not cost the
       record's other cycles their weight.
    2. The features objective under the loss, from the grid of starts and the Gaussian
       optimum (a single run from the Gaussian optimum can follow a weakly determined
       direction, mu_s against gamma, far away: measured on an independent campaign,
       mu_s 378 for a truth of 0.38); the lowest wins.
    3. For the other objectives: their Gaussian fit from there, then the objective under
       the loss from its optimum.
    """
    rescale = dataclasses.replace(o.weighting, rescale_records=True)
    gauss = fit_features(features, records=records, starts=starts,
                         **o._replace(weighting=rescale)._asdict())
    before = 1.0 if gauss.record_scale is None else gauss.record_scale
    scale = np.sqrt(np.maximum(_record_chi2(gauss, robust=True) * before**2, 1.0))
    scaled = np.any(scale > 1.0) and len(features) > 1
    feats = _rescaled(features, scale) if scaled else list(features)
    problem = _features_problem(feats, o, starts, loss=loss,
                                extra_starts=[gauss.params.friction])
    fit = _fit_problem(problem, feats, o.solver)
    if objective is not Objective.FEATURES:
        once = dataclasses.replace(o.weighting, rescale_records=False)
        start = fit_features(feats, records=records, objective=objective,
                             starts=[fit.params.friction],
                             **o._replace(weighting=once)._asdict())
        fit = fit_objective(with_loss(start.objective, loss), start.params, start.spec,
                            solver=o.solver.refine(), base=start)
    return dataclasses.replace(fit, record_scale=scale if scaled else None,
                               record_chi2=_record_chi2(fit) * scale**2)


RECORD_CHI2 = 3.0
"""A record whose features residuals have chi2/n above this is described by the model
worse than its noise (irregular slips, an instrument the model lacks): its standard
errors are scaled by sqrt(chi2/n) and the campaign fitted again, so that it weighs by
its actual scatter and cannot pull the others (measured on independent campaigns with a
1 % cycle-to-cycle spread of mu_s in one record: mu_s 0.76 for a truth of 0.44 before,
see tests/test_real_world_coverage.py)."""


def _record_chi2(fit: FitResult, robust: bool = False) -> np.ndarray:
    """chi2/n of each record's features residuals at the fit's optimum; `robust`: the
    square of their normalised median absolute deviation instead (1.4826 median |r|:
    a few irregular cycles do not raise it)."""
    r = np.asarray(compiled(feature_residuals, fit.params, fit.data, fit.slip_time))
    rec, _ = FeaturesObjective(fit.data, fit.slip_time).clusters(fit.features)
    out = np.ones(len(fit.features))
    for i in range(len(fit.features)):
        sel = rec[: r.size] == i
        if sel.any():
            out[i] = (float((1.4826 * np.median(np.abs(r[sel]))) ** 2) if robust
                      else float(np.mean(r[sel] ** 2)))
    return out


def _rescaled(features, scale):
    return [dataclasses.replace(
        f, peak_sd=f.peak_sd * s, trough_sd=f.trough_sd * s,
        stick_time_sd=f.stick_time_sd * s, start_level_sd=f.start_level_sd * s)
        for f, s in zip(features, scale)]


def _fit_rescaled(problem_of, features, solver: SolverOptions, rounds: int = 4) -> FitResult:
    """The features fit; when some record's chi2/n exceeds `RECORD_CHI2`, again with each
    record's standard errors scaled by sqrt(max(1, chi2/n)) of its residuals at the
    latest optimum (its actual scatter), until the scales settle (within 10 %, at most
    `rounds` refits). Each refit starts afresh from the multi-start, so a record that
    pulled the first fit into a wrong basin no longer can."""
    fit = _fit_problem(problem_of(features), features, solver)
    chi = _record_chi2(fit)
    if len(features) < 2 or not np.any(chi > RECORD_CHI2):
        return dataclasses.replace(fit, record_chi2=chi)
    scale = np.ones(len(features))
    for _ in range(rounds):
        new = np.sqrt(np.maximum(chi, 1.0))
        if np.all(np.abs(new / scale - 1.0) < 0.1):
            break
        scale = new
        scaled = _rescaled(features, scale)
        fit = _fit_problem(problem_of(scaled), scaled, solver)
        chi = _record_chi2(fit) * scale**2  # in the records' own errors
    return dataclasses.replace(fit, record_chi2=chi, record_scale=scale)


class _FeaturesProblem(NamedTuple):
    """A features fit set up (`_features_problem`): its data and objective, the stacked
    free parts of the starts and their common static part, the filter spec."""

    data: FeatureData
    objective: AbstractObjective
    free_starts: CampaignParams
    static: CampaignParams
    spec: CampaignParams


def _fit_problem(problem: _FeaturesProblem, features, solver: SolverOptions) -> FitResult:
    """The multi-start features fit of `problem` (`fit_features` with `Objective.FEATURES`)."""
    values, chi2s, result, ok, steps, _, best, rounds = _solve_rounds(
        problem.free_starts, problem.static, problem.objective, solver.rtol, solver.atol,
        solver.max_steps)
    free_best = _take(values, best)
    params = eqx.combine(free_best, problem.static)
    return FitResult(
        params=params, spec=problem.spec, data=problem.data, features=list(features),
        chi2=float(chi2s[best]), dof=problem.data.n_residuals() - _n_free(free_best),
        result=result, converged=bool(ok[best]), n_steps=int(np.asarray(steps)[best]),
        slip_time=problem.objective.slip_time, objective=problem.objective, n_rounds=rounds,
    )


def _features_problem(features, o: _Options, starts=None, loss=None,
                      extra_starts=()) -> _FeaturesProblem:
    """Set up the features fit of `fit_features` (data, objective under `loss`, starts
    (default `initial_guesses`) followed by `extra_starts`, with `o.hold` applied, spec)."""
    from_start = o.modes.offset is GaugeOffset.START
    data = feature_data(features, offset_from_start=from_start, pad_cycles=o.padding.cycles,
                        reslip=o.modes.reslip)
    obj = with_loss(FeaturesObjective(data, o.modes.slip_time), loss)
    offsets0 = np.asarray(data.start_level) if from_start else np.zeros(data.n_records)
    starts = initial_guesses(features, offsets0) if starts is None else list(starts)
    starts = starts + list(extra_starts)
    if o.hold is not None:
        starts = [o.hold.apply(s) for s in starts]
    params0 = [CampaignParams(s, jax.device_put(offsets0)) for s in starts]
    spec = free_spec(params0[0], hold=o.hold, offsets=from_start)
    frees, statics = zip(*(eqx.partition(p, spec) for p in params0))
    return _FeaturesProblem(data, obj, _stack(frees), statics[0], spec)


@stored_jit(compiler_options=QUICK_OPTIONS)
def _gn_terms(free, static, objective):
    flat, unravel = jax.flatten_util.ravel_pytree(free)

    def res(v):
        return objective.residuals(eqx.combine(unravel(v), static))

    J = jax.jacfwd(res)(flat)
    return J.T @ res(flat), J.T @ J


def fit_objective(objective: AbstractObjective, params: CampaignParams, free, *,
                  solver: SolverOptions = SolverOptions().refine(),
                  base: FitResult | None = None) -> FitResult:
    """The fitting verb over any objective and a parameter pytree: Levenberg-Marquardt
    (`stickslip_jax.lsq`, with the reweighting rounds of `_solve_rounds`) of `objective`
    from `params`, moving only the leaves `free` selects: a function `params -> leaf or
    tuple of leaves` (like `eqx.tree_at`'s `where`), or a boolean filter spec
    (`free_spec`). For example, the friction level and shape with the rest held::

        fit_objective(obj, params, lambda p: (p.friction.log_mu_d, p.friction.log_gap))

    `solver`: tolerances and step cap (default `SolverOptions().refine()`). `base`: the
    `FitResult` this one refines (its features and data carry over to the report).
    Converged when the solver met its tolerances, or when a Gauss-Newton step would lower
    chi2 by less than 1e-3 (stationary in units of the noise) though the budget ran out."""
    spec = free_filter(params, free)
    part, static = eqx.partition(params, spec)
    values, chi2s, result, ok, steps, flags, _, rounds = _solve_rounds(
        _stack([part]), static, objective, solver.rtol, solver.atol, solver.max_steps)
    free_opt = _take(values, 0)
    # a Gauss-Newton step would lower chi2 by g^T (J^T J)^+ g (g = J^T r)
    converged = bool(ok[0]) or float(gauss_newton_decrease(
        *_gn_terms(free_opt, static, objective)[::-1])) < 1e-3
    fields = dict(
        params=eqx.combine(free_opt, static), spec=spec, chi2=float(np.asarray(chi2s)[0]),
        dof=int(round(objective.dof())) - _n_free(part), result=result, converged=converged,
        n_steps=int(np.asarray(steps)[0]), objective=objective, n_rounds=rounds,
        trace_failures=objective.failures(np.asarray(flags)[0]))
    if base is not None:
        return dataclasses.replace(base, **fields)
    return FitResult(data=None, features=[], slip_time=objective.slip_time, **fields)


def fit_records(records, **kwargs) -> FitResult:
    """`fit_features` on `stickslip_jax.records.Record`s (features extracted first)."""
    return fit_features([record_features(r) for r in records], records=records, **kwargs)
