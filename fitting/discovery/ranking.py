r"""Cheap ranking of the candidate effects: the score (Lagrange-multiplier) test, no refit.

At the base model's maximum-likelihood fit $\hat\theta$ (all effects zero), with the
whitened residuals $r$ and the Jacobian $J = [J_b, J_c]$ (base coordinates, the
candidate's one or two parameters), the Gaussian log-likelihood's gradient with respect
to the candidate's parameters is $U = -J_c^T r$ and its Fisher information is
$J_c^T J_c$. Removing what the base parameters can already absorb (the efficient score:
$J_c^\perp = (I - P_b) J_c$, $P_b$ the projection on the columns of $J_b$),

$$S = \frac{r^T J_c^\perp\,(J_c^{\perp T} J_c^\perp)^{-1}\,J_c^{\perp T} r}{\hat s^2}, \qquad
\hat s^2 = \|r\|^2 / N,$$

which is $\chi^2$ with as many degrees of freedom as the candidate has parameters when
the candidate is absent. It equals the drop of $-2\log L$ that one Gauss-Newton step
in the candidate's direction would give, so it predicts the refit's gain; the step
itself is the predicted size of the effect. One Jacobian evaluation per candidate,
all with the same compiled function (`model.Problem`).

**Physical signs.** For an effect whose parameter physics requires to be >= 0
(`SIGNS` in effects.py), a predicted step of the wrong sign is no evidence for it: the
likelihood's maximum over the physical half-line is at zero (the one-sided score test),
so such a candidate is ranked with statistic 0 (`rank_statistic`; `unphysical` says
why) and gets no refit slot; its two-sided `statistic` is still reported.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.stats

from .effects import CANDIDATES, EffectSet
from .model import Problem
from .scores import base_basis, project_out

__all__ = ["CandidateScore", "score_candidates"]


@dataclasses.dataclass
class CandidateScore:
    """name, statistic S, dof, p_value (chi-square), predicted size {param: natural value},
    the efficient-score direction and `unphysical` (None, or why the predicted size breaks
    a sign that physics requires)."""

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
        part = getattr(EffectSet(), name)
        pred = {p: float(step[j] * part.SCALES[j]) for j, p in enumerate(part.PARAMS)}
        out.append(CandidateScore(name, stat, len(cand), float(scipy.stats.chi2.sf(stat, len(cand))),
                                  pred, Jp, type(part).unphysical(pred)))
    return sorted(out, key=lambda c: (-c.rank_statistic, -c.statistic))
