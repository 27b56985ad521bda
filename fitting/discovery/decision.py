"""Statistics and decision rules of the per-cycle discovery (`cycle_workflow`): the robust
score test over cycle windows (`hotelling`), the paired window test between two refits
(`paired_z`), which contenders are named with the winner (`decide`), and the gaps."""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.stats

from .flips import one_sided
from .options import DEFAULTS
from .thinning import Samples

__all__ = ["Contender", "Decision", "decide", "noise_of", "paired_z"]


@dataclasses.dataclass(frozen=True)
class Contender:
    """Another refit beside the winner: its chi-square drop, the principal cosine of its
    efficient-score directions with the winner's, the winner's `paired_z` advantage, and
    whether its fit is physical."""

    name: str
    drop: float
    cosine: float
    z: float
    physical: bool = True

    def to_json(self) -> dict:
        return {"name": self.name, "direction_cosine": self.cosine, "chi2_drop": self.drop,
                "z_winner": self.z, "physical": self.physical}


@dataclasses.dataclass(frozen=True)
class Decision:
    """The contenders named with the winner (`joint`) and those it does not beat clearly
    (`unbeaten`: the confidence is low)."""

    joint: tuple[Contender, ...]
    unbeaten: tuple[Contender, ...]

    @property
    def clear(self) -> bool:
        return not self.unbeaten


def paired_z(r_winner: np.ndarray, r_other: np.ndarray, starts: np.ndarray) -> float:
    r"""The winner's advantage over another refit in standard errors: the difference of
    their chi-squares $\Delta = \sum_w \delta_w$ over cycle windows w (the independent
    units) over its window-level standard error $\sqrt{n}\,\mathrm{sd}(\delta_w)$."""
    d = np.add.reduceat(np.asarray(r_other) ** 2 - np.asarray(r_winner) ** 2, starts)
    total = float(d.sum())
    se = float(np.sqrt(d.size) * d.std(ddof=1)) if d.size > 1 else 0.0
    if not se > 0:
        return float("inf") if total > 0 else 0.0
    return total / se


def decide(winner_drop: float, others, *, joint: float = DEFAULTS.joint,
           collinear: float = DEFAULTS.collinear, clear: float = DEFAULTS.clear) -> Decision:
    """Which contenders are named with the winner, and which keep the confidence low.

    Only contenders not clearly beaten (`paired_z` < `clear`) count. A physical one in a
    close direction (cosine >= `collinear`) that lowers chi-square at all is named
    jointly: the paired test, not the ratio of the drops, says whether the records prefer
    one (damping ratio 0.02: rate_state lowered chi-square by 32, damping by 13, cosine
    0.94, z 1.4). Any other that explains a comparable share (drop >= `joint` x the
    winner's) is `unbeaten`: the named one is not the whole story.

    >>> decide(30.0, [Contender("rate_state", 24.0, 0.46, 1.1)]).clear
    False
    """
    named, unbeaten = [], []
    for c in others:
        if c.z >= clear or not c.drop > 0:
            continue
        if c.physical and c.cosine >= collinear:
            named.append(c)
        elif c.drop >= joint * winner_drop:
            unbeaten.append(c)
    return Decision(tuple(sorted(named, key=lambda c: -c.drop)),
                    tuple(sorted(unbeaten, key=lambda c: -c.drop)))


def window_scores(Jp, r, starts) -> np.ndarray:
    """The efficient score's contribution of every cycle window (windows x columns)."""
    return np.add.reduceat(Jp * r[:, None], starts, axis=0)


def hotelling(Jp, r, starts, g=None, side: int = 0):
    """(F, p-value, dof, Gauss-Newton step, predicted chi-square drop) of the efficient
    score Jp^T r by Hotelling's T^2 over the windows (`starts`: their first samples); a
    test of one column one-sided where `side` is +1 or -1 (`flips.one_sided`: the effect's
    physical sign)."""
    p = Jp.shape[1]
    if not (np.all(np.isfinite(Jp)) and np.all(np.isfinite(r))):
        # the family's derivative is not finite at the base (the simulator left its
        # domain for this shape): no test (p NaN, never significant), not a crash
        return float("nan"), float("nan"), p, np.zeros(p), 0.0
    g = window_scores(Jp, r, starts) if g is None else g  # (`g`: already summed)
    g = g[np.any(g != 0, axis=1)]
    n = g.shape[0]
    info = Jp.T @ Jp
    U = Jp.T @ r
    # J is the residuals' derivative: the Gauss-Newton step lowers r + J step
    step = -np.linalg.lstsq(info, U, rcond=1e-12)[0]
    predicted = float(-U @ step)
    if n <= p + 1:
        return float("nan"), float("nan"), p, step, predicted
    gbar = g.mean(axis=0)
    cov = np.cov(g.T).reshape(p, p)
    t2 = n * float(gbar @ np.linalg.lstsq(cov, gbar, rcond=1e-10)[0])
    F = (n - p) / (p * (n - 1)) * t2
    p_value = scipy.stats.f.sf(F, p, n - p)
    if p == 1:
        p_value = one_sided(p_value, gbar[0], side)
    return F, float(p_value), p, step, predicted


def _samples(r, samples):
    """`samples` (`thinning.Samples`), or every residual a sample of its own."""
    return samples if samples is not None else Samples(np.ones(np.shape(r)),
                                                       np.zeros(np.shape(r)))


def chi2_by_record(r, rec_of, G, samples=None, sd=None) -> np.ndarray:
    """chi2/n of the whitened residuals `r` of every record (`rec_of`; NaN: none) over
    the `samples` they stand for (standard errors `sd`, mm)."""
    if samples is None:
        return np.array([np.mean(r[rec_of == g] ** 2) if np.any(rec_of == g) else np.nan
                         for g in range(G)])
    return np.array([samples[rec_of == g].chi2(r[rec_of == g], sd[rec_of == g])
                     / samples[rec_of == g].n if np.any(rec_of == g) else np.nan
                     for g in range(G)])


def rms_gap(r, sd, samples=None) -> float:
    """Residual RMS (mm) of whitened residuals `r` (standard errors `sd`) over `samples`."""
    return _samples(r, samples).rms(r * sd)


def rms_by_phase(r_mm, slipping, sd=None, samples=None):
    """Residual RMS (mm) and count by phase over `samples`; with the standard errors `sd`
    (mm) also the RMS they lead one to expect and the chi2/n (a slip's timing error moves
    the fast trace: a slip phase's residual exceeds the gauge noise, not its own)."""
    out = {}
    samples = _samples(r_mm, samples)
    for name, sel in (("stick", ~slipping), ("slip", slipping)):
        part = samples[sel]
        out[name] = {"rms": part.rms(r_mm[sel]) if sel.any() else None, "samples": part.n}
        if sd is not None:
            s = np.asarray(sd)[sel]
            out[name]["expected_rms"] = (float(np.sqrt(np.sum(part.count ** 2 * s ** 2)
                                                       / part.n)) if sel.any() else None)
            out[name]["chi2_per_sample"] = (part.chi2(r_mm[sel] / s, s) / part.n
                                            if sel.any() else None)
    return out


def noise_of(data, samples=None) -> float:
    """The campaign's noise (mm): RMS of the windows' record noise, each row weighing by
    its samples."""
    mask = np.asarray(data.mask)
    n = mask.any(1) if samples is None else np.where(mask, samples.count, 0.0).sum(1)
    return float(np.sqrt(np.sum(n * np.asarray(data.sigma) ** 2) / np.sum(n)))
