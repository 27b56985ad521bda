"""The standard errors of the named effects' sizes in the per-cycle discovery's answer.

A refit's own covariance (`stickslip_jax.lsq.gauss_newton_covariance`, `stages.refit`)
counts every sample as independent; the samples of one cycle window share its restart
state and its slip, so it is far too small (a load coupling of kappa -0.395 +- 1e-5 on
12 records). The answer's effects take the covariance path of its friction rows instead
(`result.friction_rows`): the cluster-robust sandwich of the final model's fit
(`uncertainty.laplace.sandwich_covariance`, one cluster per cycle window, a window and the
next one of its record correlated, the leave-one-cluster-out small-sample correction).
The decisions never read these errors: only the answer's rows and steps change.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...uncertainty.laplace import sandwich_covariance
from ..cycle_model import per_sample

__all__ = ["robust_errors"]


def _covariance(fit, data) -> np.ndarray | None:
    """The sandwich covariance of `fit`'s free coordinates (None where its derivatives or
    residuals are not finite, or the sandwich cannot be formed). The rows after the data's
    samples (a prior's) are in no cluster."""
    J, r = np.asarray(fit.J, float), np.asarray(fit.r, float)
    if not (np.all(np.isfinite(J)) and np.all(np.isfinite(r))):
        return None
    record, window = per_sample(data, "record", "window")
    extra = J.shape[0] - record.size
    record, window = (np.r_[np.asarray(c, int), -np.ones(extra, int)] for c in (record, window))
    try:
        return sandwich_covariance(J, r, record, window)
    except np.linalg.LinAlgError:
        return None


def _se(cov, at, scales) -> np.ndarray:
    return np.sqrt(np.clip(np.diag(cov)[at], 0.0, None)) * scales


def robust_errors(model, chosen, steps):
    """`chosen` (the final model's refit, `FamilyRefit`, or None) and the sequential
    search's `steps` with the standard errors of the sandwich (module doc), in natural
    units; unchanged where the sandwich cannot be formed. `model` is the per-cycle model
    (its `data`, `cols(family)` and `scales`)."""
    if chosen is None:
        return chosen, steps
    cov = _covariance(chosen.fit, model.data)
    if cov is None:
        return chosen, steps
    cols = model.cols(chosen.family)
    _, cov_f = chosen.sub.family_part(chosen.fit.z, cov, cols.size)
    se = _se(cov_f, np.arange(cols.size), model.scales[cols])
    out = []
    for s in steps:
        if s.kept and s.family is chosen.family:
            s = dataclasses.replace(s, stderr=se)
        elif s.kept:  # an effect named before, fitted in the final model beside it
            c = model.cols(s.family)
            at = np.flatnonzero(np.isin(chosen.sub.cols, c))
            s = dataclasses.replace(s, stderr=_se(cov, at, model.scales[c]))
        out.append(s)
    return dataclasses.replace(chosen, stderr=se), out
