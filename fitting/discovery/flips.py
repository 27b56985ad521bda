r"""Family-wise p-values of many correlated score tests by sign flips of the cycle windows.

Discovery runs 30-50 score tests (`cycle_workflow`, stage 3) that are far from
independent (a family's shapes; Stribeck, rate-and-state and damping change the slips
alike): Bonferroni's alpha / K loses power, so the false-alarm rate of "the smallest
p-value of all tests" is measured on the data (Westfall & Young's single-step min-p).

Test k has window contributions $g_{k,w}$ (its efficient score summed over cycle window
w). Under the base model the windows are independent and symmetric about zero, so
flipping every window's sign (the same $s_w = \pm 1$ for all tests: their correlation
kept) gives equally likely data. $U_k(s) = s^\top g_k (g_k^\top g_k)^{-1} g_k^\top s$ is a
monotone function of Hotelling's $T^2$, so each flip's p-values come from the transform
of `decision.hotelling`'s. The adjusted p-value of test k is the share of flips whose
smallest p-value over all tests is at most k's observed one (NumPy; a fixed seed).

A test of one coordinate whose effect has a physical sign (a damper's c >= 0, a Stribeck
drop b >= 0, a sensor's delay tau >= 0; `Family.signs`) is one-sided: its p-value is
Student's one-sided one, half the two-sided where the score points to the physical side
and one minus that where it points away (`one_sided`). A score to the wrong side is no
evidence of the effect, so the test loses nothing there and has more power at the same
level where the effect is; each flip's p-value is the one-sided one of the flipped score,
so the min-p stays calibrated.

A test of several columns may instead weigh its summed score by the model's information
$I_k = J_k^\top J_k$ (the efficient columns' Gram matrix): $T_k(s) = t_k(s)^\top I_k^{+}
t_k(s)$, $t_k(s) = g_k^\top s$, the chi-square drop its Gauss-Newton step predicts
(`metrics`). Hotelling's statistic weighs it by the windows' own scatter $g_k^\top g_k$,
which an effect itself inflates where its score turns from window to window (a screw
error's first harmonic: each window sees another phase of the screw), so a large effect
can leave Hotelling's test without power (measured, a 20 Hz sensor and a 2 um screw on 8
records: after the sensor the screw's 16 columns over 94 windows predicted a chi-square
drop of 1.5e5 at Hotelling's p 0.11). Both statistics are quadratic forms in the flipped
score whose weight does not depend on the flip, so each is exact under the flips; the
information-weighed one's p-value is its rank among the flips' own values (no closed
form), and the min-p over all tests compares every test on its own p-value scale.
"""

from __future__ import annotations

import numpy as np
import scipy.stats

__all__ = ["FLIPS", "family_wise_p", "flip_p", "hotelling_p_of_u", "one_sided"]

FLIPS = 4000
"""Sign-flip draws (the adjusted p-value's resolution is 1 / (FLIPS + 1))."""


def hotelling_p_of_u(u: np.ndarray, n: int, p: int) -> np.ndarray:
    """Hotelling's p-value (F(p, n - p), as `decision.hotelling`) of window contributions
    whose self-normalised statistic is `u` = n gbar' (g'g/n)^-1 gbar, in [0, n)."""
    u = np.minimum(np.asarray(u, float), n * (1.0 - 1e-12))
    a = u / (1.0 - u / n)  # n gbar' C^-1 gbar with the biased covariance C
    t2 = a * (n - 1) / n
    F = (n - p) / (p * (n - 1)) * t2
    return scipy.stats.f.sf(F, p, n - p)


def one_sided(p_two, total, side: int):
    """The one-sided p-value of a one-coordinate test from its two-sided `p_two`, its
    summed score `total` (J^T r, J the residuals' derivative, so the Gauss-Newton step of
    the coordinate has the sign of -`total`) and the sign `side` the coordinate must have
    (+1, -1; 0: two-sided, `p_two` itself) (module doc)."""
    p_two = np.asarray(p_two, float)
    if side == 0:
        return p_two
    return np.where(np.sign(total) == -np.sign(side), 0.5 * p_two, 1.0 - 0.5 * p_two)


def _basis(g: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the columns of g (numerical rank)."""
    u, s, _ = np.linalg.svd(g, full_matrices=False)
    keep = s > 1e-10 * (s[0] if s.size else 0.0)
    return u[:, keep]


def flip_p(values: np.ndarray, observed: float) -> tuple[float, np.ndarray]:
    """The p-value of a statistic's `observed` value among its values over the flips
    (`values`, larger: more evidence), and each flip's own p-value on that scale (the
    share of flips at least as large, the observed data counted as one of them)."""
    order = np.sort(values)
    at_least = values.size - np.searchsorted(order, values, side="left")
    p_obs = (1.0 + np.sum(values >= observed)) / (values.size + 1.0)
    return float(p_obs), (1.0 + at_least) / (values.size + 1.0)


def _informed(g: np.ndarray, metric: np.ndarray, S: np.ndarray) -> tuple[float, np.ndarray]:
    """The information-weighed statistic (module doc) of the window contributions `g`
    (windows seen x p) with the Gram matrix `metric`: its observed p-value and every
    flip's (`flip_p`)."""
    lam, V = np.linalg.eigh(0.5 * (metric + metric.T))
    keep = lam > 1e-10 * max(float(lam.max()), 0.0)
    W = g @ (V[:, keep] / np.sqrt(lam[keep]))
    return flip_p(np.sum((W.T @ S) ** 2, axis=0), float(np.sum(W.sum(axis=0) ** 2)))


def family_wise_p(contributions: list[np.ndarray], *, sides=None, metrics=None,
                  flips: int = FLIPS, seed: int = 0) -> np.ndarray:
    """Adjusted p-values (module doc) of the tests of window `contributions` (each n x
    p_k over the same windows; zero rows: windows a test does not see), a test of one
    column one-sided where its entry of `sides` is +1 or -1 (`one_sided`), a test of
    several columns weighed by its entry of `metrics` where that is a p_k x p_k Gram
    matrix (module doc; None: Hotelling's). A test with non-finite contributions or fewer
    than p_k + 2 windows gets NaN and takes no part."""
    if not contributions:
        return np.zeros(0)
    n_rows = contributions[0].shape[0]
    if any(g.shape[0] != n_rows for g in contributions):
        raise ValueError("family_wise_p: every test needs the same windows (rows); got "
                         f"{sorted({g.shape[0] for g in contributions})}")
    rng = np.random.default_rng(seed)
    S = rng.integers(0, 2, size=(n_rows, flips), dtype=np.int8).astype(float) * 2.0 - 1.0
    observed = np.full(len(contributions), np.nan)
    min_p = np.ones(flips)
    for k, g in enumerate(contributions):
        if not np.all(np.isfinite(g)):
            continue
        seen = np.any(g != 0, axis=1)
        n = int(seen.sum())
        side = 0 if sides is None or g.shape[1] != 1 else int(sides[k])
        metric = None if metrics is None or g.shape[1] < 2 else metrics[k]
        if metric is not None:
            if n <= g.shape[1] + 1 or not np.all(np.isfinite(metric)):
                continue
            observed[k], p_flips = _informed(g[seen], np.asarray(metric, float), S[seen])
            min_p = np.minimum(min_p, p_flips)
            continue
        # a one-sided test keeps its column's sign (an SVD basis may flip it)
        Q = _basis(g[seen]) if side == 0 else g[seen] / np.linalg.norm(g[seen])
        p = Q.shape[1]
        if p == 0 or n <= p + 1 or not np.all(np.isfinite(Q)):
            continue
        total = Q.sum(axis=0)
        observed[k] = one_sided(hotelling_p_of_u(np.sum(total ** 2), n, p), total[0], side)
        t = Q.T @ S[seen]
        min_p = np.minimum(min_p, one_sided(hotelling_p_of_u(np.sum(t ** 2, axis=0), n, p),
                                            t[0], side))
    adjusted = (1.0 + np.sum(min_p[None, :] <= observed[:, None], axis=1)) / (flips + 1.0)
    return np.where(np.isfinite(observed), np.minimum(adjusted, 1.0), np.nan)
