r"""The smoothed whole-record base's statistics (`workflow.SmoothBase`): the score test of
every candidate at the base fit, refits of the best few, and the BIC choice or "none".

**Score test** (no refit). At the base model's maximum-likelihood fit $\hat\theta$ (all
effects zero), with the whitened residuals $r$ and the Jacobian $J = [J_b, J_c]$ (base
coordinates, the candidate's one or two parameters), the Gaussian log-likelihood's
gradient with respect to the candidate's parameters is $U = -J_c^T r$ and its Fisher
information is $J_c^T J_c$. Removing what the base parameters can already absorb (the
efficient score: $J_c^\perp = (I - P_b) J_c$, $P_b$ the projection on the columns of
$J_b$, `scores.project_out`),

$$S = \frac{r^T J_c^\perp\,(J_c^{\perp T} J_c^\perp)^{-1}\,J_c^{\perp T} r}{\hat s^2}, \qquad
\hat s^2 = \|r\|^2 / N,$$

is $\chi^2$ with the candidate's parameter count when it is absent, and the drop of
$-2\log L$ one Gauss-Newton step would give (the step: the effect's predicted size). One
Jacobian per candidate, all with the same compiled function (`model.Problem`).

**Refits and BIC.** The `top` candidates are refitted (Levenberg-Marquardt from the base
optimum: its first, practically undamped step is the score step). With $N$ samples,
$\mathrm{RSS}$ the whitened residual sum of squares and $d$ parameters, the Gaussian
likelihood with the noise level profiled out gives

$$\Delta\mathrm{BIC} = N \ln(\mathrm{RSS}_c / \mathrm{RSS}_0) + d \ln N,$$

and the likelihood-ratio statistic $\Lambda = N\ln(\mathrm{RSS}_0/\mathrm{RSS}_c)$
($\chi^2_d$ under "no effect"). The lowest $\Delta\mathrm{BIC}$ is named only if below
$-$`threshold`, else "none": naming an effect that is not there is the worst failure, so
the threshold (10: $\Lambda > 18.6$ for one parameter on 5000 samples) was chosen on
campaigns with no hidden effect.

**Physical signs.** Where physics requires a parameter >= 0 (`SIGNS`), a predicted step
of the wrong sign is no evidence: the one-sided maximum is at zero, so the candidate
ranks with statistic 0 (`rank_statistic`, `unphysical` says why) and gets no refit; a
refit of the wrong sign gets $\Lambda = 0$, $\Delta\mathrm{BIC} = d\ln N$ (never named).

Confidence is "high" when the named effect's residuals pass the misspecification test
(p >= `p_explained`), it beats the runner-up by `margin` in BIC and was first in the
score ranking; otherwise "low".
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.stats

from stickslip_jax.lsq import LeastSquaresSolution as Solution

from ..report.rows import ParameterEstimate
from .effects import CANDIDATES, EffectSet
from .model import Problem
from .scores import base_basis, project_out

__all__ = ["CandidateScore", "Refit", "choose", "effect_rows", "refit_candidates",
           "score_candidates"]


def _natural(name: str, coords) -> tuple[object, dict]:
    """Effect `name`'s part and its {param: natural value} at slot coordinates `coords`."""
    part = getattr(EffectSet(), name)
    return part, {p: float(coords[j] * part.SCALES[j]) for j, p in enumerate(part.PARAMS)}


@dataclasses.dataclass
class CandidateScore:
    """A candidate's score test (module doc): statistic S, dof, p-value, predicted size
    {param: natural value}, efficient-score direction, why it is `unphysical` (or None)."""

    name: str
    statistic: float
    dof: int
    p_value: float
    predicted: dict
    direction: np.ndarray | None = None  # efficient-score direction J_c^perp [N, dof]
    unphysical: str | None = None  # why the predicted size breaks a required sign

    @property
    def rank_statistic(self) -> float:
        """The statistic used for ranking: 0 when the predicted size is unphysical."""
        return 0.0 if self.unphysical else self.statistic


def score_candidates(base_problem: Problem, base_z: np.ndarray, base_rss: float,
                     candidates=CANDIDATES) -> list[CandidateScore]:
    """Score test of every candidate at the base fit `base_z`, sorted by
    `rank_statistic` (largest first; unphysical directions last)."""
    out = []
    for name in candidates:
        pc = dataclasses.replace(base_problem, effect=name)
        r, J, ok = pc.evaluate(base_z)
        act = pc.active()
        nb, ns = pc.n_base, pc.n_slots
        cand = [nb + j for j in range(ns) if act[nb + j]]
        base = [i for i in range(J.shape[1]) if act[i] and i not in cand]
        # the efficient score (module doc) and its Gauss-Newton step
        Jp = project_out(base_basis(J[:, base]), J[:, cand])
        U = Jp.T @ r
        step = -np.linalg.lstsq(Jp.T @ Jp, U, rcond=1e-12)[0]
        stat = float(-U @ step) / (base_rss / r.shape[0])
        part, pred = _natural(name, step)
        out.append(CandidateScore(name, stat, len(cand), float(scipy.stats.chi2.sf(stat, len(cand))),
                                  pred, Jp, type(part).unphysical(pred)))
    return sorted(out, key=lambda c: (-c.rank_statistic, -c.statistic))


@dataclasses.dataclass
class Refit:
    """A candidate refitted and judged (module doc)."""

    name: str
    problem: Problem
    fit: Solution
    delta_bic: float
    lr: float
    lr_p_value: float
    dof: int
    unphysical: str | None = None

    @classmethod
    def judged(cls, name: str, problem: Problem, fit: Solution, base_fit: Solution,
               dof: int) -> Refit:
        """The refit `fit` of effect `name` judged against the base fit (module doc)."""
        N, nb = base_fit.n_data, problem.n_base
        part, values = _natural(name, fit.z[nb:nb + problem.n_slots])
        bad = part.unphysical(values)
        lr = 0.0 if bad else N * math.log(base_fit.rss / min(fit.rss, base_fit.rss))
        return cls(name, problem, fit, -lr + dof * math.log(N), lr,
                   float(scipy.stats.chi2.sf(lr, dof)), dof, bad)


def refit_candidates(base_problem: Problem, base_fit: Solution, scores: list[CandidateScore],
                     *, top: int = 3, max_evals: int = 12) -> list[Refit]:
    """Refit the `top` candidates by score (those whose predicted size is physical);
    sorted by delta BIC (best first)."""
    out = []
    for sc in [s for s in scores if not s.unphysical][:top]:
        pc = dataclasses.replace(base_problem, effect=sc.name)
        # from the base optimum, undamped (lam0 1e-9): Marquardt's damping acts on each
        # column's own scale, so an effect nearly collinear with the base (load coupling:
        # its efficient part ~1e-3 of its column) would see its step damped away
        fit = pc.solve(base_fit.z, max_evals=max_evals, lam0=1e-9)
        # little progress (under a tenth of the drop the score test predicts: a damped
        # crawl of 6750 -> 6749 on the stribeck campaign after the features program
        # changed its rounding) although the score is large: backtrack
        if base_fit.rss - fit.rss < 0.1 * sc.statistic and sc.statistic > 10.0 * sc.dof:
            fit = _backtracked_refit(pc, base_fit, fit, max_evals)
        out.append(Refit.judged(sc.name, pc, fit, base_fit, sc.dof))
    return sorted(out, key=lambda c: c.delta_bic)


def _backtracked_refit(pc, base_fit: Solution, fit: Solution, max_evals: int) -> Solution:
    """A refit that made little progress though the score predicts a large drop: its
    Gauss-Newton step overshoots (quadratic over a few per cent of it) and damping turns
    it away. Continue from the best fraction of it that lowers chi-square (stribeck
    campaign: the full step raises chi-square 6750 -> 1.3e6, 3 % of it lowers it to 6743)."""
    r, J, ok = pc.evaluate(base_fit.z)
    act = pc.active()
    Ja = J[:, act]
    step = -np.linalg.lstsq(Ja.T @ Ja, Ja.T @ r, rcond=1e-12)[0]
    best = None
    for t in (0.1, 0.03, 0.01):
        z = base_fit.z.copy()
        z[act] += t * step
        r_t, J_t, ok_t = pc.evaluate(z)
        cost = float(r_t @ r_t) if ok_t and np.all(np.isfinite(r_t)) else np.inf
        if cost < base_fit.rss and (best is None or cost < best[0]):
            best = (cost, z, (r_t, J_t, ok_t))
    if best is None:
        return fit
    more = pc.solve(best[1], max_evals=max_evals, first=best[2])
    return more if more.rss < fit.rss else fit


def choose(refits: list[Refit], *, threshold: float = 10.0) -> Refit | None:
    """The best refit if its delta BIC is below -threshold, else None ("none")."""
    if not refits:
        return None
    best = refits[0]
    return best if best.delta_bic < -threshold else None


def effect_rows(refit: Refit) -> list[ParameterEstimate]:
    """The chosen effect's parameters (natural units) with Gauss-Newton standard errors."""
    pc, fit = refit.problem, refit.fit
    act = pc.active()
    cov = fit.covariance(act)
    idx = np.flatnonzero(act)
    part, values = _natural(refit.name, fit.z[pc.n_base:pc.n_base + pc.n_slots])
    out = []
    for j, (p, unit, scale) in enumerate(zip(part.PARAMS, part.UNITS, part.SCALES)):
        k = int(np.flatnonzero(idx == pc.n_base + j)[0])
        out.append(ParameterEstimate.from_normal(p, unit, values[p],
                                                 math.sqrt(max(cov[k, k], 0.0)) * scale))
    return out
