r"""Campaign fit of another base friction law through whole records (`stickslip fit --law`).

`fit_law(features, records, law)` fits a `modes.FrictionLaw` other than the paper's: the
features fit of eqs (1), (3) first (its gauge offsets), starts for the law from the cycle
features (`law_starts`), then the smoothed-simulator objective (`objectives.smooth`), the
only one that expresses a law of the slider velocity or of a state variable.

Starts (the one of least chi-square on the records is refined, within `LAW_STEPS`
Levenberg-Marquardt steps; the next one too when that fit converged and misses the records
by more than `FAR_MISS` times their noise), from the per-cycle
breakaway level $\mu_0 = k x_{peak}/W$, the mid-slip level
$\mu_m = k (x_{peak} + x_{trough})/(2W)$, the stick time $T_1$, the drive speed $V$ and the
slip speed $v_s = \omega_0 (x_{peak} - x_{trough})/2$ (mm/s):
- rate-and-state: the breakaway level of the aging law at rest,
  $\mu_0 = \mu_* + a\ln(V/v_0) + b\ln(v_0 T_1/D_c)$, whose slope against $\ln V$ is $a - b$
  ($T_1 \propto 1/V$), on a grid $a/b \in \{0.3, 0.45, 0.6\}$,
  $D_c \in \{1, 2.5, 6, 16\} \times 10^{-4}$ mm, with $\mu_*$ from the mean level; and at
  each $D_c$ the $(\mu_*, a, b)$ of bounded linear least squares on both levels, the
  breakaway level as above and the mid-slip level as the steady state at the slip speed,
  $\mu_m = \mu_* + (a - b)\ln(v_s/v_0)$ (the slip levels then bound $b - a$ too:
  records whose peaks fall with the drive speed while their mid-slip level hardly moves,
  as under the paper's law, get a far smaller $b - a$ than from the peaks alone, whose
  steady state at the slip speed would fall far below the mid-slip level);
- log aging: $t_c$ = (0.01, 0.1, 1) x the shortest stick and $v_c$ = (0.3, 3) x the median
  slip speed, $\mu_d$ and $\beta$ from the least squares of $\mu_0$ on $\ln(1 + T_1/t_c)$,
  $c$ from the mean $\mu_m$.
All clipped into the prior bounds.
"""

from __future__ import annotations

import dataclasses
import itertools

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from stickslip_jax.modes import GaugeOffset

from ..law_params import LogAgingFriction, RateStateAgingFriction, RateStateSlipFriction
from ..modes import FrictionLaw, ModelModes, SolverOptions
from ..params import CampaignParams, EmpiricalFriction, Hold, free_spec
from .fit import MAX_ROUNDS, FitResult, fit_features, fit_objective

__all__ = ["LAW_PARAMS", "fit_law", "law_starts"]

RETRIES = 2
"""Starts refined at most, in the order of their chi-square."""
D_C_GRID = (1e-4, 2.5e-4, 6e-4, 1.6e-3)
"""D_c (mm) of the rate-and-state starts."""
FAR_MISS = 3.0
"""chi2/dof above which the fit from the next start is tried too."""
LAW_STEPS = 240
"""Levenberg-Marquardt steps at most from a start of a law other than the paper's, over
the reweighting rounds of `fit.fit_objective` (`MAX_ROUNDS`, an equal share each); the
next start is refined only after a fit that converged (to a far miss, `FAR_MISS`). Each
step costs a simulation per free parameter through the records (10,000-20,000 solver
steps each on records of the paper's law with few long cycles, about 3 CPU s a step), so
a fit that has not converged within them is returned as not converged instead of running
on to a second start (six rounds of 40 steps from each of two starts took more than 45
minutes there). 20 steps a round stopped a rate-and-state fit to rate-and-state records
at chi2/n 277 where 40 converge to 1.03 (seed 5)."""

LAW_PARAMS = {FrictionLaw.PAPER: EmpiricalFriction,
              FrictionLaw.RATE_STATE_AGING: RateStateAgingFriction,
              FrictionLaw.RATE_STATE_SLIP: RateStateSlipFriction,
              FrictionLaw.LOG_AGING: LogAgingFriction}
"""The `AbstractFrictionParams` class of each law."""


def _cycles(features, offsets):
    """Per-cycle (mu_0, mu_m, T1 s, V mm/s, slip speed mm/s) of the complete cycles."""
    rows = []
    for f, c in zip(features, offsets):
        ok = np.asarray(f.complete, bool) & (np.asarray(f.stick_time) > 0)
        pk, tr = np.asarray(f.peak)[ok] - c, np.asarray(f.trough)[ok] - c
        k_w = f.stiffness / f.load  # the normal load, which may differ from the weight
        rows.append(np.stack([k_w * pk, k_w * 0.5 * (pk + tr), np.asarray(f.stick_time)[ok],
                              np.full(pk.shape, f.drive_speed),
                              np.maximum(f.omega0 * 0.5 * (pk - tr), 1e-9)], axis=1))
    return np.concatenate(rows).T


def _levels_start(cls, mu0, mum, t1, v, vs, v0, d_c) -> dict:
    """(mu_ref, a, b) of least squares within the prior bounds on both levels at `d_c`
    (module doc): linear in them at a given D_c."""
    from scipy.optimize import lsq_linear

    one = np.ones_like(mu0)
    A = np.concatenate([np.stack([one, np.log(v / v0), np.log(v0 * t1 / d_c)], 1),
                        np.stack([one, np.log(vs / v0), -np.log(vs / v0)], 1)])
    lo, hi = zip(*(cls.PRIOR_BOUNDS[n] for n in ("mu_ref", "a", "b")))
    mu_ref, a, b = lsq_linear(A, np.concatenate([mu0, mum]), bounds=(lo, hi)).x
    return dict(mu_ref=mu_ref, a=a, b=b, d_c=d_c)


def law_starts(law: FrictionLaw, features, offsets=None) -> list:
    """Starting points of `law`'s parameters from the cycle features (module doc)."""
    cls = LAW_PARAMS[law]
    offsets = np.zeros(len(features)) if offsets is None else np.asarray(offsets)
    mu0, mum, t1, v, vs = _cycles(features, offsets)
    out = []
    if law is FrictionLaw.LOG_AGING:
        for t_c, vf in itertools.product(np.array([0.01, 0.1, 1.0]) * np.min(t1), (0.3, 3.0)):
            A = np.stack([np.ones_like(t1), np.log1p(t1 / t_c)], axis=1)
            (mu_d, beta), *_ = np.linalg.lstsq(A, mu0, rcond=None)
            v_c = vf * np.median(vs)
            c = (mu_d - np.mean(mum)) / np.mean(np.log1p(vs / v_c))
            out.append(dict(mu_d=mu_d, beta=max(beta, 1e-3), t_c=t_c, c=max(c, 1e-3), v_c=v_c))
    else:
        v0 = 1e-3
        # the peaks give a - b only (T1 ~ 1/V): a/b and D_c on a grid
        slope = np.polyfit(np.log(v / v0), mu0, 1)[0] if np.ptp(v) > 0 else -0.005
        for r, d_c in itertools.product((0.3, 0.45, 0.6), D_C_GRID):
            b = -min(slope, -1e-3) / (1.0 - r)
            a = r * b
            mu_ref = np.mean(mu0 - a * np.log(v / v0) - b * np.log(v0 * t1 / d_c))
            out.append(dict(mu_ref=mu_ref, a=a, b=b, d_c=d_c))
        out += [_levels_start(cls, mu0, mum, t1, v, vs, v0, d_c) for d_c in D_C_GRID]
    return [cls.from_values(**{n: float(np.clip(x[n], *cls.PRIOR_BOUNDS[n])) for n in cls.NAMES})
            for x in out]


def fit_law(features, records, law: FrictionLaw, *, hold: Hold | None = None,
            modes: ModelModes = ModelModes(), solver: SolverOptions = SolverOptions(),
            objective=None) -> FitResult:
    """Fit `law` (a `FrictionLaw`) to the whole `records` (module doc); `hold`, `modes`,
    `solver` as in `fit_features`. `FrictionLaw.PAPER` is `fit_features` with
    `Objective.SMOOTH`. `objective`: a `SmoothObjective` to fit in place of the records'
    own (a held-out mask, other tolerances)."""
    from ..objectives.smooth import SmoothObjective, smooth_data

    first = fit_features(features, modes=modes, hold=hold if law is FrictionLaw.PAPER else None,
                         solver=solver)
    obj = objective if objective is not None else SmoothObjective(
        smooth_data(records, features), slip_time=modes.slip_time)
    starts = [first.params.friction] if law is FrictionLaw.PAPER else law_starts(
        law, features, first.params.offset)
    if hold is not None and law is not FrictionLaw.PAPER:
        starts = [hold.apply(s) for s in starts]
    chi2 = eqx.filter_jit(lambda p: jnp.sum(obj.residuals(p) ** 2))
    trials = [CampaignParams(s, first.params.offset) for s in starts]
    scores = np.array([float(chi2(p)) if len(trials) > 1 else 0.0 for p in trials])
    order = np.argsort(np.where(np.isfinite(scores), scores, np.inf))
    spec = free_spec(trials[0], hold=hold, offsets=modes.offset is GaugeOffset.START)
    best, errors = None, []
    opts = solver.refine()
    if law is not FrictionLaw.PAPER:  # within `LAW_STEPS`
        opts = dataclasses.replace(opts, max_steps=min(opts.max_steps, LAW_STEPS // MAX_ROUNDS))
    for i in order[:RETRIES]:  # the next start only while the fit misses the records far
        if not np.isfinite(scores[i]):
            break
        try:
            fit = fit_objective(obj, trials[i], spec, solver=opts, base=first)
        except eqx.EquinoxRuntimeError as err:  # a non-finite value inside the solve
            errors.append(_first_message(err))
            continue
        best = fit if best is None or fit.chi2 < best.chi2 else best
        if best.reduced_chi2 < FAR_MISS or not fit.converged:
            break
    if best is None and errors:
        raise ValueError(f"--law {law}: the fit failed from every start refined "
                         f"({len(errors)} of {len(trials)}: {errors[0]})")
    if best is None:
        raise ValueError(f"--law {law}: no start of the law could be simulated through the "
                         f"records within {obj.max_steps} solver steps")
    return best


def _first_message(err: Exception) -> str:
    """The message of an `EquinoxRuntimeError` on one line, without the stacks and hints
    that equinox adds around it."""
    text = str(err)
    key = "EquinoxRuntimeError: "
    text = text[text.rfind(key) + len(key):] if key in text else text
    return " ".join(text.strip().split("\n\n")[0].split())
