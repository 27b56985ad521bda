r"""Laplace (Gauss-Newton) uncertainty and identifiability of a campaign fit.

At the optimum the whitened residuals $r(\theta)$ give the Fisher information
$F = J^\top J$ and the covariance $F^{-1}$, scaled by $\max(1, \chi^2/\mathrm{dof})$ so
that a misfit does not shrink the intervals. $\theta$ are the logarithms of the natural
parameters and the free gauge offsets, so standard errors are relative (0.1 in
$\log\gamma$ is about 10 % of $\gamma$) and intervals log-normal, $p\,e^{\pm z\,\mathrm{se}}$.

For the trace and combined objectives $F^{-1}$ is too narrow: the samples of one stick
phase share the error of the measured restart state, and "both" reads every sample
twice. Their covariance is the cluster-robust sandwich $H^{-1} M H^{-1}$
(`sandwich_covariance`): one cluster per stick phase (`objectives.combined.residual_cycles`),
neighbouring phases of a record correlated (lag 1), jackknife scores against the
small-sample bias. Measured on campaigns drawn from a prior (tests/test_combined.py,
slow; 18 of 20 counted, two features fits in a local minimum): 90 % intervals covered
the truth in 92 % ("both") and 89 % ("trace") of 108 cases, against 55 % and 62 % with
$F^{-1}$.

Identifiability, reported in plain language: by the numbers, a relative standard error
over `MAX_RELATIVE_SE` (0.5: a 95 % interval wider than a factor 2.7 either way), pairs
with |correlation| > 0.95, and the eigenvalues of the friction block of $F$ (offsets
marginalised) with the weakest direction; by the design, one slip time $T_2 =
\pi/\omega_0$ for all records (one $k/W$) determines only $\delta T_2^n$ ($n$ and
$\delta$ apart from it cannot be found), and stick times within a factor 1.5 (one speed)
leave $\mu_s$, $\gamma$ and $m$ undetermined.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from stickslip_jax.lsq import gauss_newton_covariance
from stickslip_jax.stored_programs import stored_jit

from ..solve.fit import QUICK_OPTIONS, FitResult
from ..objectives.losses import HeavyTailed
from ..modes import Covariance, SmallSample, check_member
from ..params import CampaignParams, free_mask
from ..report.rows import Z95, ParameterEstimate

__all__ = ["Uncertainty", "LogJacobian", "laplace", "Z95"]


@dataclasses.dataclass(frozen=True)
class LogJacobian:
    """Whitened residuals `r` and their Jacobian `J` = dr/dtheta at an optimum, theta =
    (logs of the free friction parameters, then free gauge offsets in mm, then any
    further coordinates of the fitted model); `free` (P bools) and `idx` (their indices)
    say which friction parameters are free, `values` (P) their natural values. `record`
    and `cycle` label every residual's stick-phase cluster (-1: in none) for the robust
    covariances; None takes them from the fit's objective."""

    J: np.ndarray
    r: np.ndarray
    free: np.ndarray
    idx: np.ndarray
    values: np.ndarray
    record: np.ndarray | None = None
    cycle: np.ndarray | None = None


@dataclasses.dataclass(frozen=True)
class Uncertainty:
    """Laplace uncertainty of the friction parameters (NAMES order).

    `value`, `stderr` (natural units), `log_se` (relative), `ci95` (low, high), `free`,
    `corr` (correlation in log coordinates, NaN for fixed), `fisher_eigenvalues`
    (friction block, offsets marginalised, ascending), `weakest_direction` ({name:
    weight}), `identifiable` ({name: bool}), `warnings` (plain-language lines), `scale`
    (the chi2/dof factor applied), `reasons` ({name: why the records do not determine
    it}, a short phrase for tables and the JSON's "reason").
    """

    value: np.ndarray
    stderr: np.ndarray
    log_se: np.ndarray
    ci95: np.ndarray
    free: np.ndarray
    corr: np.ndarray
    cov_log: np.ndarray
    fisher_eigenvalues: np.ndarray
    weakest_direction: dict
    identifiable: dict
    warnings: list
    scale: float
    units: dict | None = None
    covariance: Covariance = Covariance.FISHER
    reasons: dict = dataclasses.field(default_factory=dict)

    def estimates(self, truth: dict | None = None) -> list[ParameterEstimate]:
        """One `report.rows.ParameterEstimate` per parameter, with the truth when given."""
        rows = []
        for i, n in enumerate(self.identifiable):
            ok = bool(self.identifiable[n])
            shown = ok and bool(self.free[i])
            # a held value is stored as its log: 15 digits give back 67, not 66.99999999999997
            value = float(self.value[i]) if self.free[i] else float(f"{self.value[i]:.15g}")
            rows.append(ParameterEstimate(
                name=n, unit=self.units[n], value=value,
                stderr=float(self.stderr[i]) if shown else None,
                ci95=(float(self.ci95[i, 0]), float(self.ci95[i, 1])) if shown else None,
                fixed=not bool(self.free[i]), identifiable=ok,
                reason=None if ok or not self.free[i] else self.reasons.get(
                    n, "the records do not determine it")).with_truth(truth))
        return rows

    def table(self) -> list[dict]:
        """`estimates()` as dicts (name, unit, value, stderr, ci95, fixed, identifiable)."""
        return [dict(name=e.name, **{k: v for k, v in e.to_json().items()})
                for e in self.estimates()]


@stored_jit(compiler_options=QUICK_OPTIONS)
def _jacobian_log(params, idx: tuple, objective, fit_offsets: bool):
    """(J, r, values): residuals and their Jacobian in (log friction, free offsets)
    coordinates at `params`, the friction parameters `idx` (static) free, and the natural
    values of `params`. One program for fits of one campaign layout."""
    k = len(idx)
    logs0 = params.friction.log_values()
    sel = jnp.asarray(idx, dtype=jnp.int32)
    offset0 = params.offset
    theta0 = jnp.concatenate([logs0[sel], offset0 if fit_offsets else jnp.zeros(0)])

    def residuals(theta):
        logs = logs0.at[sel].set(theta[:k])
        off = theta[k:] if fit_offsets else offset0
        r = objective.residuals(CampaignParams(params.friction.from_log_values(logs), off))
        return r, r

    J, r = jax.jacfwd(residuals, has_aux=True)(theta0)  # one trace of the residuals
    return J, r, params.friction.values()


def jacobian_log(fit: FitResult, objective=None) -> LogJacobian:
    """The `LogJacobian` of `objective` (default the fit's) at the fit's optimum. A fit of
    another model of these parameters (discovery's per-cycle fits) passes its own, with
    every residual's (record, cycle) cluster, as `laplace(fit, jacobian=LogJacobian(...))`:
    its further coordinates, after the offsets, are then marginalised as the offsets are."""
    free = free_mask(fit.spec)
    idx = np.flatnonzero(free)
    J, r, value = _jacobian_log(fit.params, tuple(int(i) for i in idx),
                                fit.objective if objective is None else objective,
                                bool(fit.spec.offset))
    return LogJacobian(np.asarray(J), np.asarray(r), free, idx, np.asarray(value))


def sandwich_covariance(J, r, record, cycle, *, lag: int = 1,
                        small_sample: SmallSample = SmallSample.JACKKNIFE) -> np.ndarray:
    r"""Cluster-robust covariance $H^{-1} M H^{-1}$ of a least-squares estimate.

    $H = J^\top J$; $M = \sum_{c,c'} \tilde g_c \tilde g_{c'}^\top$ over clusters $c$
    (the (record, cycle) labels of `objectives.combined.residual_cycles`, $G$ of them) and
    $c'$ = $c$ or a neighbour of the same record within `lag` cycles (the slip between
    two stick phases moves both), with the scores $g_c = \sum_{i \in c} J_i r_i$. The
    fit shrinks the residuals, which biases the plain estimate low when a few clusters
    carry most of the information; `small_sample`: JACKKNIFE (default) undoes that with
    the leave-one-cluster-out scores $\tilde g_c = (I - A_c H^{-1})^{-1} g_c$,
    $A_c = J_c^\top J_c$, times $(G-1)/G$ ("CR3"); CR2 (Bell-McCaffrey) scales each
    cluster's residuals by $(I - P_{cc})^{-1/2}$, $P_{cc} = J_c H^{-1} J_c^\top$ (the
    usual choice with few, large clusters); NONE: $\tilde g_c = g_c$ times $G/(G-1)$.
    M is clipped to be positive semi-definite; record -1 (padding) is left out.
    """
    check_member("small_sample", small_sample, SmallSample)
    J, r = np.asarray(J), np.asarray(r)
    record, cycle = np.asarray(record), np.asarray(cycle)
    keep = record >= 0
    keys = np.stack([record[keep], cycle[keep]], axis=1)
    uniq, inv = np.unique(keys, axis=0, return_inverse=True)
    inv = np.asarray(inv).ravel()
    G, p = uniq.shape[0], J.shape[1]
    g = np.zeros((G, p))
    np.add.at(g, inv, J[keep] * r[keep, None])
    Hinv = gauss_newton_covariance(J)
    if small_sample is SmallSample.JACKKNIFE:
        A = np.zeros((G, p, p))
        Jk = J[keep]
        np.add.at(A, inv, Jk[:, :, None] * Jk[:, None, :])
        # every cluster's minimum-norm solve at once (pseudo-inverse, as lstsq's rcond)
        g = np.einsum("cij,cj->ci", np.linalg.pinv(np.eye(p) - A @ Hinv, rcond=1e-12), g)
        factor = (G - 1) / max(G, 1)
    elif small_sample is SmallSample.CR2:  # Bell-McCaffrey: residuals scaled by (I - P_cc)^(-1/2)
        Jk, rk = J[keep], r[keep]
        g = np.zeros((G, p))
        for c in range(G):
            sel = inv == c
            Jc, rc = Jk[sel], rk[sel]
            # P_cc = Jc Hinv Jc^T has rank <= p: with Jc = Q R and R Hinv R^T = W lam W^T,
            # (I - P_cc)^(-1/2) is 1 plus (1 - lam)^(-1/2) - 1 along U = Q W (n p^2 work
            # instead of an n x n eigendecomposition per cluster: n is a record's samples)
            Q, R = np.linalg.qr(Jc)
            lam, W = np.linalg.eigh(R @ (0.5 * (Hinv + Hinv.T)) @ R.T)
            U = Q @ W
            scale = 1.0 / np.sqrt(np.maximum(1.0 - lam, 1e-12)) - 1.0
            g[c] = Jc.T @ (rc + U @ (scale * (U.T @ rc)))
        factor = 1.0
    else:
        factor = G / max(G - 1, 1)
    M = g.T @ g
    pos = {(int(a), int(b)): i for i, (a, b) in enumerate(uniq)}
    for d in range(1, int(lag) + 1):
        pairs = [(i, pos[(int(a), int(b) + d)]) for i, (a, b) in enumerate(uniq)
                 if b >= 0 and (int(a), int(b) + d) in pos]
        if pairs:
            a_idx, b_idx = (np.asarray(x) for x in zip(*pairs))
            cross = g[a_idx].T @ g[b_idx]
            M = M + cross + cross.T
    M *= factor
    w, V = np.linalg.eigh(0.5 * (M + M.T))
    M = (V * np.maximum(w, 0.0)) @ V.T
    return Hinv @ M @ Hinv


def _design_warnings(fit: FitResult, free) -> tuple[dict, list]:
    """({name: reason} of the parameters the campaign's design leaves undetermined,
    the warnings that say so)."""
    flagged, msgs = {}, []
    feats = fit.features
    names = fit.params.friction.NAMES
    shape = fit.params.friction.SHAPE_NAMES
    t2 = np.array([math.pi / f.omega0 for f in feats])
    if t2.max() / t2.min() < 1.05 and free[names.index("n")]:
        flagged.update(dict.fromkeys(("n", "delta"), f"one slip time T2 = {t2.mean():.4g} s "
                                     "for every record (one k/W)"))
        msgs.append(
            f"n, delta: every record has the same slip time T2 = {t2.mean():.4g} s (one k/W), "
            "so only delta*T2^n is determined; use springs or weights with different k/W, "
            "or fix n (--fix n=1).")
    t1 = np.concatenate([f.stick_time[f.complete] for f in feats])
    t1 = t1[t1 > 0]  # a slip from rest at once (no stick) says nothing of the rise
    rise = [s for s in shape if s in names and s not in ("mu_s", "mu_d")]  # held: mu_s known
    if t1.size and t1.max() / t1.min() < 1.5 and any(free[names.index(s)] for s in rise):
        flagged.update(dict.fromkeys(shape, "all stick times within a factor 1.5 (one drive "
                                     "speed)"))
        msgs.append(
            f"{', '.join(shape)}: all stick times lie within {t1.min():.3g}-{t1.max():.3g} s (one drive "
            "speed), so the rise of mu_0 with stick time (eq 1) cannot be resolved; "
            "add drive speeds an order of magnitude apart."
        )
    return flagged, msgs


def _two_level(cov_stick, J, r, record) -> np.ndarray:
    r"""Covariance for records the model does not describe to their noise: per parameter
    the larger variance of the stick-phase sandwich (`cov_stick`) and the record-level
    sandwich (one cluster per record, Bell-McCaffrey "cr2") widened by
    $(t_{0.975, G-1}/z_{0.975})^2$ for G records (few clusters), with the stick-phase
    correlations. A record-level systematic error (a drive or sensor imperfection left in
    the features) shows only between records. Measured on 24 independent campaigns
    (tests/test_real_world_coverage.py): 90 % coverage of mu_s / mu_d 0.62 / 0.71 with the
    stick-phase sandwich alone, 0.79 / 0.83 with the record-level CR2 alone, 0.83 / 0.92
    with both (the larger; 0.91 / 0.92 with the final cycle extraction), 1.00 / 0.96
    with the record-level jackknife (CR3)."""
    from scipy.stats import t as t_dist

    keep = record >= 0
    G = int(np.unique(record[keep]).size)
    cov_rec = sandwich_covariance(J, r, record, np.where(keep, 0, -1), lag=0,
                                  small_sample=SmallSample.CR2)
    cov_rec = cov_rec * (float(t_dist.ppf(0.975, max(G - 1, 1))) / Z95) ** 2
    d_stick, d_rec = np.diag(cov_stick), np.diag(cov_rec)
    sd = np.sqrt(np.maximum(np.maximum(d_stick, d_rec), 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        s0 = np.sqrt(np.maximum(d_stick, 0.0))
        corr = np.where(np.outer(s0, s0) > 0, cov_stick / np.outer(s0, s0), 0.0)
    np.fill_diagonal(corr, 1.0)
    return corr * np.outer(sd, sd)


PHYSICAL_RANGE = {"mu_s": (1e-3, 3.0), "mu_d": (1e-3, 3.0), "gamma": (1e-4, 1e4),
                  "m": (0.02, 5.0), "delta": (1e-3, 1e5), "n": (0.02, 5.0)}
"""Plausible values of the empirical law's parameters (units of `stickslip_fitting.params.UNITS`):
a fit outside them is reported as not identifiable, never with an interval."""

SANDWICH_CHI2 = 4.0
"""Above this chi2/dof the features fit's intervals use the cluster-robust covariance."""


MAX_RELATIVE_SE = 0.5
"""A free parameter's relative standard error above this is not identified (module doc)."""
NULL_SHARE = 1e-3
"""A parameter whose unit vector has more than this squared share in the null space of
the information is not identifiable."""

NULL_RCOND = 1e-10
"""The null space: eigenvalues of the information below `NULL_RCOND` times the largest
(rounding) and below 1 (a standard error above 1 in the log coordinates, a factor e,
along that direction: a badly conditioned but well determined campaign, e.g. the
microsqueeze law's eigenvalues 2.9e3 to 1.6e14, has none)."""


def _null_share(F) -> np.ndarray:
    """Squared share of every coordinate in the null space of the information `F`."""
    F = np.asarray(F)
    if F.size == 0:
        return np.zeros(0)
    w, V = np.linalg.eigh(0.5 * (F + F.T))
    null = (w <= NULL_RCOND * max(float(w.max()), 0.0)) & (w < 1.0)
    return np.sum(V[:, null] ** 2, axis=1)


def laplace(fit: FitResult, *, covariance: Covariance = Covariance.AUTO, lag: int = 1,
            small_sample: SmallSample = SmallSample.JACKKNIFE,
            jacobian: LogJacobian | None = None) -> Uncertainty:
    """Laplace covariance, intervals and identifiability report of a fit (module doc).

    `covariance` (a `modes.Covariance`): FISHER ($F^{-1}$ scaled by max(1, chi2/dof)),
    SANDWICH (per stick phase, `sandwich_covariance` with `lag` and `small_sample`),
    TWO_LEVEL (`_two_level`), or AUTO: the sandwich for the trace and combined objectives;
    for features FISHER, or TWO_LEVEL with 3 records or more when chi2/dof >
    `SANDWICH_CHI2` or some record's errors were scaled to its scatter
    (`fit.RECORD_CHI2`): the residuals of records the model does not describe to their
    noise are correlated within each stick phase and a scaled Fisher matrix undercovers
    (on an independent SciPy campaign, chi2/dof 426, its 95 % interval missed mu_s). A
    heavy-tailed loss (`objectives.losses.HeavyTailed`) gets TWO_LEVEL with 3 records or
    more, the stick-phase sandwich otherwise. `jacobian`: a `LogJacobian` of another
    model of these parameters (default: the fit's objective at `fit.params`).
    """
    check_member("covariance", covariance, Covariance)
    if covariance is Covariance.AUTO:
        traced = fit.objective is not None and fit.objective.robust
        misfit = fit.objective is not None and (fit.reduced_chi2 > SANDWICH_CHI2
                                                or fit.record_scale is not None)
        # with fewer than 3 records the between-record scatter cannot be estimated (and a
        # stick-phase sandwich of a badly described pair collapses): Fisher at the scaled
        # errors then (measured, tests/test_real_world_coverage.py)
        heavy = isinstance(fit.objective, HeavyTailed)
        many = len(fit.features) >= 3
        covariance = (Covariance.TWO_LEVEL if heavy and many else Covariance.SANDWICH if traced
                      else Covariance.TWO_LEVEL if misfit and many else Covariance.FISHER)
    if isinstance(fit.objective, HeavyTailed) and jacobian is None:  # Huber's sandwich
        inner = jacobian_log(fit, fit.objective.inner)
        J, r = fit.objective.loss.score_form(inner.J, inner.r)
        jacobian = dataclasses.replace(inner, J=J, r=r)
    jacobian = jacobian_log(fit) if jacobian is None else jacobian
    J, r, free, idx, value = jacobian.J, jacobian.r, jacobian.free, jacobian.idx, jacobian.values
    F = J.T @ J
    k = idx.size
    if covariance.robust:
        from ..objectives.combined import residual_cycles

        rec, cyc = (residual_cycles(fit.objective, fit.features) if jacobian.record is None
                    else (jacobian.record, jacobian.cycle))
        cov = sandwich_covariance(J, r, rec, cyc, lag=lag, small_sample=small_sample)
        if covariance is Covariance.TWO_LEVEL:
            cov = _two_level(cov, J, r, rec)
        scale = 1.0
    else:
        scale = max(1.0, fit.reduced_chi2)
        cov = gauss_newton_covariance(J, scale)
    names = fit.params.friction.NAMES
    P = len(names)
    cov_log = np.full((P, P), np.nan)
    cov_log[np.ix_(idx, idx)] = cov[:k, :k]
    log_se = np.zeros(P)
    log_se[idx] = np.sqrt(np.maximum(np.diag(cov[:k, :k]), 0.0))
    stderr = value * log_se
    with np.errstate(over="ignore"):
        ci95 = np.stack([value * np.exp(-Z95 * log_se), value * np.exp(Z95 * log_se)], axis=1)
    sd = np.sqrt(np.diag(cov_log))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov_log / np.outer(sd, sd)
    # friction block of F with offsets marginalised (Schur complement)
    Fff = F[:k, :k]
    if F.shape[0] > k:
        Foo, Ffo = F[k:, k:], F[:k, k:]
        Fff = Fff - Ffo @ np.linalg.pinv(Foo, hermitian=True) @ Ffo.T
    null = _null_share(Fff)
    if covariance is Covariance.SANDWICH:  # the information the robust covariance implies
        Fff = np.linalg.pinv(cov[:k, :k], rcond=1e-13, hermitian=True)
    eig, vec = np.linalg.eigh(Fff / scale)
    weakest = {names[i]: float(w) for i, w in zip(idx, vec[:, 0])} if k else {}
    flagged, warnings = _design_warnings(fit, free)
    identifiable = {}
    reasons = {n: r for n, r in flagged.items() if free[names.index(n)]}
    for i, n in enumerate(names):
        bad_num = bool(free[i]) and not (log_se[i] <= MAX_RELATIVE_SE)
        # a standard error of exactly 0: the data do not move the fit in that direction at
        # all (e.g. eq (1) saturated, exp(-gamma T1^m) = 0 at every stick): the
        # pseudo-inverse dropped it; not a perfectly determined value
        flat = bool(free[i]) and not (log_se[i] > 0)
        lo_hi = PHYSICAL_RANGE.get(n)
        wild = bool(free[i]) and lo_hi is not None and not lo_hi[0] <= value[i] <= lo_hi[1]
        if wild:  # the value is not printed: it is no estimate
            reasons.setdefault(n, f"the fit left the physical range {lo_hi[0]:g}-{lo_hi[1]:g}")
        identifiable[n] = not (bad_num or flat or wild or (n in flagged and free[i]))
        if flat:
            reasons.setdefault(n, "the residuals do not change with it")
        elif bad_num:
            reasons.setdefault(n, f"relative standard error {log_se[i]:.2g} > "
                                  f"{MAX_RELATIVE_SE}")
    # a parameter with a share in a direction the records do not see at all (a zero
    # eigenvalue of the information: e.g. m = 0 makes mu_s and gamma one number) has no
    # standard error, whatever the pseudo-inverse gives it
    for j, a in enumerate(idx):
        if identifiable[names[a]] and null[j] > NULL_SHARE:
            identifiable[names[a]] = False
            partners = [names[b] for jj, b in enumerate(idx) if b != a and null[jj] > NULL_SHARE]
            reasons[names[a]] = ("determined only together with " + ", ".join(partners)
                                 if partners else "the residuals do not change with it")
    # a parameter tied (|r| > 0.999) to one the campaign does not determine is not
    # determined either (the pseudo-inverse gives it the other's sliver of variance)
    for a in range(P):
        if free[a] and identifiable[names[a]]:
            tied = [names[b] for b in range(P) if b != a and free[b]
                    and not identifiable[names[b]] and abs(corr[a, b]) > 0.999]
            if tied:
                identifiable[names[a]] = False
                reasons[names[a]] = f"determined only together with {', '.join(tied)}"
    # one line per parameter the records do not determine (the design's own lines above
    # say why for those it flagged); its value is never given
    warnings += [f"{n}: not identifiable ({why}); no value is given."
                 for n, why in reasons.items() if n not in flagged]
    for a in range(P):
        for b in range(a + 1, P):
            if identifiable[names[a]] and identifiable[names[b]] and abs(corr[a, b]) > 0.95:
                warnings.append(
                    f"{names[a]} and {names[b]} are strongly correlated (r = {corr[a, b]:+.3f}): "
                    "the campaign determines a combination of them better than either.")
    if not fit.converged:
        warnings.append("the optimiser did not report convergence; treat the values with care.")
    if covariance is Covariance.FISHER and fit.objective is not None and fit.objective.robust:
        warnings.append(
            f"objective '{fit.objective.kind}' with the Fisher covariance: samples of one stick "
            "phase share the error of its restart state (and 'both' reads them twice), so "
            "these intervals are too narrow (90 % intervals covered 55-62 % in a calibration); "
            "use the default robust covariance.")
    if fit.trace_failures:
        warnings.append(f"{fit.trace_failures} cycle simulation(s) of the trace objective did not "
                        "succeed at the optimum (see trace_window_failures).")
    if fit.reduced_chi2 > 2.0:
        warnings.append(
            f"chi2/dof = {fit.reduced_chi2:.3g}: the model does not fit the records to their noise "
            "level; " + ("the intervals are widened by that factor's square root." if
                         covariance is Covariance.FISHER else "the robust intervals follow the actual "
                         "scatter, but a model error also biases the values.")
        )
    return Uncertainty(
        value=value, stderr=stderr, log_se=log_se, ci95=ci95, free=free, corr=corr,
        cov_log=cov_log, fisher_eigenvalues=eig, weakest_direction=weakest,
        identifiable=identifiable, warnings=warnings, scale=scale,
        units=dict(fit.params.friction.UNITS), covariance=covariance, reasons=reasons)

