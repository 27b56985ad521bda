r"""Joint least-squares fit of the friction parameters to a campaign of records.

One verb, `fit_features(features, ...)` (or `fit_records(records, ...)`), returns a
`FitResult`. The residuals are the whitened features objective of
`fitting.objectives` (its sum of squares is $-2\log$ likelihood up to a constant), so
the Levenberg-Marquardt optimum is the maximum-likelihood estimate.

- Parameters: `fitting.params.CampaignParams` (friction in unconstrained coordinates,
  one gauge offset per record); the free leaves are chosen with `eqx.partition`
  (`free_spec(fixed=..., offsets=...)`).
- Solver: `optimistix.least_squares` with `LevenbergMarquardt`, the whole multi-start
  run (a `vmap` over starting points) inside one `eqx.filter_jit`, so a campaign
  compiles once.
- Starts ("features first"): mu_d and mu_s from the measured per-cycle $\mu_m$ and
  $\mu_0$, and a grid over gamma, m and delta (n = 1, the paper's value), so that a poor
  guess does not end in a local minimum; the best converged start wins.
- Objective (`objective=`): the cycle features (default), the full trace through the
  exact simulator restarted per cycle (`fitting.trace_objective`), or both
  (`fitting.combined`); the trace and combined fits start from the features optimum.
"""

from __future__ import annotations

import dataclasses
import itertools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import jax.flatten_util  # noqa: F401

from .combined import CampaignObjective
from .features import RecordFeatures, record_features
from .objectives import FeatureData, feature_data
from .trace_objective import trace_data, window_failures
from .params import NAMES, CampaignParams, EmpiricalFriction, free_spec, names_of

__all__ = ["FitResult", "fit_features", "fit_records", "initial_guesses"]


@dataclasses.dataclass(frozen=True)
class FitResult:
    """Outcome of a campaign fit.

    - `params`: the best `CampaignParams`; `spec`: the filter spec of the free leaves.
    - `data`: the `FeatureData` fitted; `features`: the per-record `RecordFeatures`.
    - `chi2`: sum of squared whitened residuals at the optimum; `dof`: residuals with
      data minus free parameters; `result`: optimistix result of the best start;
      `converged`: that result is successful; `n_starts`, `n_steps`.
    - `slip_time`: the $T_2$ mode of eq (3) used.
    - `objective`: the `fitting.combined.CampaignObjective` minimised (features, trace
      or both); `trace_failures`: windows of the trace objective whose simulation did not
      succeed at the optimum (0 when all ran).
    """

    params: CampaignParams
    spec: CampaignParams
    data: FeatureData
    features: list[RecordFeatures]
    chi2: float
    dof: int
    result: optx.RESULTS
    converged: bool
    n_starts: int
    n_steps: int
    slip_time: str
    start_chi2: np.ndarray
    objective: CampaignObjective | None = None
    trace_failures: int = 0

    @property
    def values(self) -> dict[str, float]:
        v = np.asarray(self.params.friction.values())
        return {n: float(x) for n, x in zip(names_of(self.params.friction), v)}

    @property
    def reduced_chi2(self) -> float:
        return self.chi2 / max(self.dof, 1)

    def residuals(self) -> jnp.ndarray:
        return self.residuals_at(self.params)

    def residuals_at(self, params: CampaignParams) -> jnp.ndarray:
        """Whitened residuals of the fitted objective at other parameters."""
        return self.objective.residuals(params)


def _mu_levels(features, offsets):
    mu0, mum = [], []
    for f, c in zip(features, offsets):
        mu0.append(f.stiffness * (f.peak - c) / f.weight)
        mum.append(f.stiffness * (0.5 * (f.peak + f.trough) - c) / f.weight)
    return np.concatenate(mu0), np.concatenate(mum)


def initial_guesses(features: list[RecordFeatures], offsets=None) -> list[EmpiricalFriction]:
    """Starting points: mu_d, mu_s from the measured mu_m, mu_0; a grid in gamma, m, delta."""
    offsets = np.zeros(len(features)) if offsets is None else np.asarray(offsets)
    mu0, mum = _mu_levels(features, offsets)
    mu_d = max(0.9 * float(np.min(mum)), 1e-3)
    top = float(np.max(mu0))
    mu_s = max(top + 0.2 * (top - mu_d), mu_d * 1.05 + 1e-3)
    t2 = float(np.median([np.pi / f.omega0 for f in features]))
    starts = []
    for gamma, m, dt2 in itertools.product((0.05, 0.5, 3.0), (0.35, 0.8), (0.3, 1.5)):
        starts.append(EmpiricalFriction.from_values(mu_s, mu_d, gamma, m, dt2 / t2, 1.0))
    return starts


def _stack(trees):
    return jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *trees)


@eqx.filter_jit
def _solve_starts(free_starts, static, objective, rtol, atol, max_steps):
    def residuals(free, args):
        static, objective = args
        return objective.residuals(eqx.combine(free, static))

    solver = optx.LevenbergMarquardt(rtol=rtol, atol=atol)

    def solve(y0):
        sol = optx.least_squares(
            residuals, solver, y0, args=(static, objective), max_steps=max_steps, throw=False
        )
        r = residuals(sol.value, (static, objective))
        return sol.value, jnp.sum(r * r), sol.result, sol.stats["num_steps"]

    return jax.vmap(solve)(free_starts)


def fit_features(
    features: list[RecordFeatures],
    *,
    fixed: dict[str, float] | None = None,
    offset: str = "zero",
    slip_time: str = "paper",
    starts: list[EmpiricalFriction] | None = None,
    rtol: float = 1e-10,
    atol: float = 1e-10,
    max_steps: int = 400,
    pad_cycles: int = 0,
    objective: str = "features",
    records=None,
    weights: tuple[float, float] = (0.5, 0.5),
    pad_length: int = 0,
    pad_windows: int = 0,
) -> FitResult:
    """Fit mu_s, mu_d, gamma, m, delta, n jointly to the cycle features of a campaign.

    - `fixed`: {name: value} held fixed (e.g. {"n": 1.0}).
    - `offset`: "zero" (trust the gauge zero) or "start" (each record starts with the
      spring relaxed: its first plateau gives the offset, fitted as a nuisance).
    - `slip_time`: $T_2$ in eq (3), "paper" ($\\pi/\\omega_0$) or "self_consistent".
    - `starts`: starting `EmpiricalFriction`s (default `initial_guesses`).
    - `pad_cycles`: pad the cycle axis (campaigns of other lengths reuse the compilation).
    - `objective`: "features" (default), "trace" or "both" (`fitting.combined`); the
      last two need `records` (the `Record`s the features came from) and start from the
      features fit's optimum ("features first"); `weights` = (w_features, w_trace) for
      "both"; `pad_length`, `pad_windows` pad the trace windows (`trace_data`).
    """
    if offset not in ("zero", "start"):
        raise ValueError(f"--offset must be 'zero' or 'start', got {offset!r}")
    fixed = dict(fixed or {})
    if objective not in ("features", "trace", "both"):
        raise ValueError(f"--objective must be features, trace or both, got {objective!r}")
    if objective != "features":
        if records is None:
            raise ValueError(f"objective {objective!r} needs the records (records=...)")
        first = fit_features(features, fixed=fixed, offset=offset, slip_time=slip_time,
                             starts=starts, rtol=rtol, atol=atol, max_steps=max_steps,
                             pad_cycles=pad_cycles)
        tdata = trace_data(records, features, pad_length=pad_length, pad_windows=pad_windows)
        obj = CampaignObjective(first.data, tdata, kind=objective,
                                weight_features=float(weights[0]),
                                weight_trace=float(weights[1]), slip_time=slip_time)
        # the trace has kinks at the phase boundaries: LM converges linearly near the
        # optimum, so its tolerances are not tighter than 1e-8 and its steps at most 100
        # (convergence is then judged by the Gauss-Newton decrement, see _refine)
        return _refine(first, obj, max(rtol, 1e-8), max(atol, 1e-8), min(max_steps, 100))
    data = feature_data(features, offset_from_start=(offset == "start"), pad_cycles=pad_cycles)
    obj = CampaignObjective(data, None, kind="features", slip_time=slip_time)
    R = data.n_records
    offsets0 = (np.asarray(data.start_level) if offset == "start" else np.zeros(R))
    starts = initial_guesses(features, offsets0) if starts is None else list(starts)
    if fixed:
        starts = [_with_fixed(s, fixed) for s in starts]
    params0 = [CampaignParams(s, jnp.asarray(offsets0)) for s in starts]
    spec = free_spec(params0[0], fixed=tuple(fixed), offsets=(offset == "start"))
    frees, statics = zip(*(eqx.partition(p, spec) for p in params0))
    free_stack = _stack(frees)
    values, chi2s, results, steps = _solve_starts(
        free_stack, statics[0], obj, rtol, atol, max_steps
    )
    chi2s = np.asarray(chi2s)
    ok = np.asarray(results == optx.RESULTS.successful)
    score = np.where(np.isfinite(chi2s), chi2s, np.inf)
    best = int(np.argmin(np.where(ok, score, score + 1e300)))
    free_best = jax.tree_util.tree_map(lambda x: x[best], values)
    params = eqx.combine(free_best, statics[0])
    n_free = sum(int(np.size(x)) for x in jax.tree_util.tree_leaves(eqx.filter(free_best,
                                                                              eqx.is_array)))
    return FitResult(
        params=params, spec=spec, data=data, features=list(features),
        chi2=float(chi2s[best]), dof=data.n_residuals() - n_free,
        result=jax.tree_util.tree_map(lambda x: x[best], results), converged=bool(ok[best]), n_starts=len(starts),
        n_steps=int(np.asarray(steps)[best]), slip_time=slip_time, start_chi2=chi2s,
        objective=obj,
    )


@eqx.filter_jit
def _gn_terms(free, static, objective):
    flat, unravel = jax.flatten_util.ravel_pytree(free)

    def res(v):
        return objective.residuals(eqx.combine(unravel(v), static))

    J = jax.jacfwd(res)(flat)
    return J.T @ res(flat), J.T @ J


def _gn_decrement(free, static, objective) -> float:
    """Predicted chi2 decrease of a Gauss-Newton step, g^T (J^T J)^+ g (g = J^T r)."""
    g, F = (np.asarray(x) for x in _gn_terms(free, static, objective))
    return float(g @ np.linalg.pinv(F, rcond=1e-13, hermitian=True) @ g)


def _refine(first: FitResult, obj: CampaignObjective, rtol, atol, max_steps) -> FitResult:
    """One Levenberg-Marquardt run of `obj` from the features fit's optimum."""
    free, static = eqx.partition(first.params, first.spec)
    values, chi2s, results, steps = _solve_starts(
        _stack([free]), static, obj, rtol, atol, max_steps
    )
    free_opt = jax.tree_util.tree_map(lambda x: x[0], values)
    params = eqx.combine(free_opt, static)
    n_free = sum(int(np.size(x)) for x in jax.tree_util.tree_leaves(eqx.filter(free, eqx.is_array)))
    result = jax.tree_util.tree_map(lambda x: x[0], results)
    # At a minimum on a kink LM may keep rejecting steps without meeting its own
    # tolerance; the fit has converged when the Gauss-Newton step would lower chi2 by
    # less than 1e-3 (stationarity, measured in units of the noise).
    ok = bool(np.asarray(result == optx.RESULTS.successful)) or _gn_decrement(
        free_opt, static, obj) < 1e-3
    return dataclasses.replace(
        first, params=params, chi2=float(np.asarray(chi2s)[0]),
        dof=int(round(obj.dof())) - n_free, result=result,
        converged=ok,
        n_steps=int(np.asarray(steps)[0]), start_chi2=np.asarray(chi2s), objective=obj,
        trace_failures=window_failures(params, obj.trace, obj.slip_time),
    )


def _with_fixed(s: EmpiricalFriction, fixed: dict[str, float]) -> EmpiricalFriction:
    if hasattr(s, "with_values"):  # other friction-parameter modules (microsqueeze)
        return s.with_values(**fixed)
    v = dict(zip(NAMES, np.asarray(s.values()).tolist()))
    v.update({k: float(x) for k, x in fixed.items()})
    if v["mu_s"] <= v["mu_d"]:
        v["mu_s"] = v["mu_d"] * 1.5
    return EmpiricalFriction.from_values(**v)


def fit_records(records, **kwargs) -> FitResult:
    """`fit_features` on `stickslip_jax.records.Record`s (features extracted first)."""
    return fit_features([record_features(r) for r in records], records=records, **kwargs)
