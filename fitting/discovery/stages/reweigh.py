"""Stage 6 of the per-cycle discovery, `reweigh`: the records weighed by their scatter at
the base tried at full weight with the named effect (`cycle_workflow`, module doc)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..cycle_model import CycleModel
from ..decision import rms_gap, chi2_by_record
from .refit import judge
from .state import Choice, Clock, Fits, Reweighed

__all__ = ["reweigh"]


def reweigh(fx: Fits, choice: Choice, *, clock: Clock) -> Reweighed:
    """Records weighed by their scatter at the base (they misfit the paper's model) may be
    described to their noise with the named effect. Weighed by their scatter, the
    winner's fit does not try to describe them, so they are tried at full weight: the
    winner's fit continues with every record weighed fully, then the records still beyond
    the campaign's limit (`record_chi2` times its median chi2/n, in their own errors)
    weigh by their scatter again for a last continuation (measured on the power sweep's
    friction drift 5e-4/s: gap after 3.12 -> 1.2x the noise (A), 2.16 -> 1.35x (C)). A
    round is kept only while the gap over the described records stays within
    `reweigh_tolerance`."""
    opts, base, data, G = fx.opts, fx.base, fx.prep.data, fx.prep.G
    chosen, sd, n, described = choice.chosen, base.sd, base.n, base.described
    sd_after, reweighed = sd, []
    if chosen is None or not base.scaled:
        return Reweighed(chosen=chosen, sd_after=sd_after, reweighed=reweighed)
    scaled, rec_of = base.scaled, base.rec_of
    factor_now = np.ones(G)
    for _ in range(opts.reweigh_rounds):
        model_after = CycleModel(
            data, base.model.tref, base.sd_plain * factor_now[np.asarray(data.record)][:, None],
            G)
        sub_after = dataclasses.replace(chosen.sub, model=model_after)
        fit_after = sub_after.solve(chosen.fit.z, max_evals=2 * opts.max_evals, lam0=1e-3,
                                    stall_evals=8)
        one = judge(fx, chosen.family, chosen.shape, fit_after, chosen.sensor, sub_after)
        if one.unphysical is not None:
            break
        sd_one = np.asarray(model_after.sd).ravel()[model_after.mask]
        before_ = rms_gap(chosen.fit.r[:n][described], sd_after[described],
                          base.samples[described])
        after_ = rms_gap(one.fit.r[:n][described], sd_one[described], base.samples[described])
        if after_ > opts.reweigh_tolerance * before_:
            clock("reweigh", f"not kept: the gap over the records not set aside would "
                             f"go from {before_ * 1e3:.3g} to {after_ * 1e3:.3g} um with "
                             f"the records weighed by their scatter weighed fully")
            break
        chosen, sd_after = one, sd_one
        r_plain = chosen.fit.r[:n] * factor_now[rec_of]
        chi2_after = chi2_by_record(r_plain, rec_of, G, base.samples,
                                    sd_one / factor_now[rec_of])
        median_after = float(np.nanmedian(chi2_after))
        limit_after = max(opts.record_chi2, opts.record_chi2 * median_after)
        beyond = chi2_after > limit_after
        far = chi2_after > max(opts.set_aside_chi2, opts.set_aside_chi2 * median_after)
        reweighed = [g for g in scaled if not beyond[g]]
        clock("reweigh", f"{len(reweighed)} of {len(scaled)} record(s) weighed by their "
                         f"scatter at the base fit weigh fully with "
                         f"{chosen.family.name}; {fit_after.n_evals} evaluations")
        again = beyond & (factor_now == 1.0)
        factor_next = np.where(again, np.where(far, opts.set_aside, 1.0) * np.sqrt(chi2_after),
                               factor_now)
        if np.array_equal(factor_next, factor_now) and chosen.fit.converged:
            break
        factor_now = factor_next
    return Reweighed(chosen=chosen, sd_after=sd_after, reweighed=reweighed)
