"""Stage 7 of the per-cycle discovery: the answer (effect and confidence, or an
unexplained gap with the learned phase correction, `cycle_learned`), its explanation and
the result (`cycle_workflow`, module doc)."""

from __future__ import annotations

import dataclasses

from ...params import EmpiricalFriction
from ...report.rows import DiscoveryEstimates
from ..cycle_effects import Shape
from ..cycle_learned import fit_cycle_correction
from ..decision import rms_by_phase, rms_gap
from ..flips import FLIPS
from ..misfit import LEFT, misfit_left
from ..result import (CycleDiscovery, effect_rows, explanation_text, phase_misfit,
                      phase_text, steps_text)
from .base_fit import friction_values
from .errors import robust_errors
from .form import form_text, outside_form
from .state import Choice, Clock, Fits, Refitted, Reweighed

__all__ = ["conclude"]


def _verdict(fx: Fits, choice: Choice, chosen, gap_after) -> tuple[str, str]:
    """The effect named ("none", "unexplained" or a family) and the confidence. The
    excess chi-square over the samples' count is the misfit to explain; below
    `small_excess` x n it is within what the weights' approximations leave on clean data."""
    opts, base = fx.opts, fx.base
    excess = max(base.fit.rss + base.within - base.n_used, 0.0)
    decided_drop = choice.decided_drop
    explains = chosen is not None and (excess <= opts.small_excess * base.n_used
                                       or decided_drop >= opts.explained_share * excess)
    unexplained = excess > opts.small_excess * base.n_used and not explains
    if chosen is None:
        return ("unexplained", "low") if unexplained else ("none", "high")
    if unexplained:
        return "unexplained", "low"
    # a gap within the weights' approximations (small excess) is no evidence for one cause
    # over another: the family is then named by its score test alone, with low confidence
    # (else a weak stiffening spring at 1.02 x the noise takes rate_state, "high")
    confidence = ("high" if (decided_drop >= opts.explained_share * excess
                             and excess > opts.small_excess * base.n_used
                             and choice.decision.clear
                             and gap_after <= opts.explained_gap * base.noise) else "low")
    return chosen.family.name, confidence


def _notes(fx: Fits, chosen, reweighed, gap_all_after) -> str:
    """The explanation's notes on records weighed by their scatter, windows set aside
    and re-slips kept."""
    opts, base, prep, recs = fx.opts, fx.base, fx.prep, fx.prep.recs
    text = ""
    if base.scaled_notes:
        text += (f" {len(base.scaled_notes)} record(s) are described worse than their "
                 "noise: " + "; ".join(base.scaled_notes) + ".")
        if base.aside:
            text += (" The gaps above and the tests are over the records not set "
                     "aside; over every record the gap goes from "
                     f"{base.gap_all_before * 1e3:.3g} to {gap_all_after * 1e3:.3g} um.")
    if reweighed:
        text += (f" With {chosen.family.name}, {len(reweighed)} of them weigh fully "
                 "again (described to within " + f"{opts.record_chi2:g}" + " x the campaign's "
                 "chi2/n): " + ", ".join(recs[g].note or recs[g].source or f"record {g}"
                                         for g in reweighed) + ".")
    if prep.windows_set_aside:
        text += " Set aside: " + "; ".join(prep.windows_set_aside) + "."
    if prep.keep_reslips:
        text += (f" {prep.n_reslip} of {prep.n_complete} slips last longer than a single slip "
                 "of their size (read as re-slips elsewhere): taken as slips that the "
                 "measurement chain or a damping lengthens, so every cycle is used.")
    return text


def _candidates(scores, refits, compared) -> list[dict]:
    """The `candidates` of the JSON: every family's score test and refit."""
    out = []
    by_family = {rf.family.name: rf for rf in refits}
    for sc in scores:
        rf = by_family.get(sc.family.name)
        out.append({
            # the refit's shape where it was refitted (refined or chosen among the grid's)
            "name": sc.family.name, "shape": (rf or sc).shape.label(sc.family),
            "score": sc.statistic, "score_p_value": sc.p_value,
            "family_wise_p_value": sc.p_family, "per_sample_p_value": sc.p_sample,
            "significant": sc.significant_by is not None,
            "significant_by": sc.significant_by, "dof": sc.dof,
            "chi2_drop_predicted": sc.chi2_predicted,
            "delta_criterion": (-rf.drop if rf else None),
            "chi2_drop": (rf.drop if rf else None),
            "unphysical": rf.unphysical if rf else None,
            "refit_failed": rf.failed if rf else None,
            "direction_cosine": (compared[sc.family.name].cosine
                                 if sc.family.name in compared else None),
            "z_winner": compared[sc.family.name].z if sc.family.name in compared else None,
            "explanation": sc.family.explanation})
    return out


def conclude(fx: Fits, refitted: Refitted, choice: Choice, after: Reweighed, *, learn: bool,
             clock: Clock, steps=()) -> CycleDiscovery:
    """The answer, the learned correction where asked or unexplained, and the result
    (module doc of `cycle_workflow`, stage 5's confidence and the learned correction);
    `steps`: the effects of the sequential search (`more`; `choice` then holds the final
    model, every effect kept in it)."""
    opts, base, prep = fx.opts, fx.base, fx.prep
    chosen, steps = robust_errors(base.model, after.chosen, steps)  # the answer's errors
    kept = [s for s in steps if s.kept]
    sd_after, n, described = after.sd_after, base.n, base.described
    r0, sd, noise, gap_before = base.r, base.sd, base.noise, base.gap_before
    if chosen is not None:
        z_after = chosen.sub.full(chosen.fit.z)
        r1 = chosen.fit.r[:n]  # without the prior's rows
        final_fit, shape, sensor = chosen.fit, chosen.shape, chosen.sensor
    else:
        z_after, r1, final_fit, shape, sensor = base.z, r0, base.fit, Shape(), False
    # over the same records as the gap before (a record set aside at the base that the
    # named effect describes weighs fully again in the fit, `reweigh`, and counts in
    # `gap_all_after`; counted here it made the gap "grow": a Stribeck drop of 0.16 on C,
    # 0.604 -> 1.08 um, while the records of the gap before went to the noise)
    gap_after = rms_gap(r1[described], sd_after[described], base.samples[described])
    gap_all_after = rms_gap(r1, sd_after, base.samples)
    effect, confidence = _verdict(fx, choice, chosen, gap_after)
    several = len(kept) > 1 and effect != "unexplained"
    if several:  # "effect" is the first effect kept; the steps name them all
        effect = kept[0].family.name
    # a form outside the library answers where it leaves less than every family named
    form, by_form = outside_form(fx, effect, confidence, gap_after, several)
    if by_form:  # answered by its form (`stages.form`): the base with the form's terms
        named, effect, confidence, chosen, sd_after = effect, "sparse_form", "low", None, sd
        several = False
        z_after, r1, final_fit, shape, sensor = form.z, form.r, base.fit, Shape(), False
        gap_after, gap_all_after = form.gap_after, rms_gap(form.r, sd, base.samples)
    phases_before = rms_by_phase(r0 * sd, base.slipping, sd, base.samples)
    phases_after = rms_by_phase(r1 * sd_after, base.slipping, sd_after,
                                 base.samples)
    pattern = max(phases_before, key=lambda k: phases_before[k]["rms"] or 0.0)
    explanation = (form_text(form, named) if by_form else steps_text(
        kept, choice.decision, gap_before, gap_after, noise, opts.explained_gap) if several
        else explanation_text(effect, chosen, choice.decision, gap_before, gap_after, noise,
                              pattern, phases_before, opts.explained_gap))
    if effect != "unexplained":
        # a phase the answer leaves above the noise, said (and "none" is then not certain
        # where that phase exceeds its own standard errors)
        explanation += phase_text(phases_after, noise, opts.explained_gap, opts.phase_chi2,
                                  "any family" if effect == "none" else
                                  " + ".join(s.family.name for s in kept) if several
                                  else effect)
        if effect == "none" and phase_misfit(phases_after, opts.phase_chi2):
            confidence = "low"
    left = None
    if gap_after > LEFT * noise:  # where the final model still misses, and in what form
        left = misfit_left(base.model, z_after, r1, sd_after, noise, described,
                           base.samples, shape, sensor)
        explanation += " " + left.words
    learned = None
    if learn or effect == "unexplained":
        learned = fit_cycle_correction(prep.data, r0, base.fit.J[:n], sd, noise, described,
                                       base.samples)
        explanation += (f" A learned correction over the cycle phase ({learned.n_parameters} "
                        "spline coefficients, fitted with the base parameters) lowers the "
                        f"gap to {learned.gap_after * 1e3:.3g} um, closing "
                        f"{100 * learned.closes:.0f} % of its excess over the noise; "
                        f"{learned.signature}.")
        clock("learned", f"gap {gap_before * 1e3:.3g} -> {learned.gap_after * 1e3:.3g} um "
                         f"({100 * learned.closes:.0f} % of the excess)")
    explanation += _notes(fx, chosen, after.reweighed if chosen else [], gap_all_after)
    cand_json = _candidates(fx.ranking.scores, refitted.refits, choice.compared)
    rows_before, rows_after = (DiscoveryEstimates.value_rows(friction_values(z),
                                                             EmpiricalFriction.UNITS)
                               for z in (base.z, z_after))
    clock("decision", f"{' + '.join(s.family.name for s in kept) if several else effect} "
                      f"({confidence}); gap {gap_before * 1e3:.3g} -> "
                      f"{gap_after * 1e3:.3g} um")
    return CycleDiscovery(
        effect=effect, explanation=explanation, confidence=confidence,
        gap_before=gap_before, gap_after=gap_after, noise=noise,
        criterion=(f"robust score test (Hotelling T^2 over {prep.starts.size} cycle windows), "
                   f"significant at family-wise p < {opts.alpha:g} (the smallest p-value of "
                   f"{fx.ranking.n_tests} family-shape tests under {FLIPS} sign flips of the "
                   "windows), or by a predicted chi-square drop of at least "
                   f"{opts.relevant:g} of the samples whose per-sample score test has p < "
                   f"{fx.ranking.level:.2g} (alpha / number of "
                   "tests; `significant_by` of each candidate); delta_criterion = "
                   "-(chi-square drop of the refit)"),
        candidates=cand_json, estimates_before=rows_before, estimates_after=rows_after,
        effect_estimates=effect_rows(kept[0] if several else chosen, prep.G),
        effect_of=(kept[0].family.name if several
                   else chosen.family.name if chosen is not None else ""),
        more_estimates=[dataclasses.replace(e, name=f"{s.family.name}.{e.name}")
                        for s in (kept[1:] if several else []) for e in effect_rows(s, prep.G)],
        # partners of a named effect only (an unexplained gap has no name to share)
        indistinguishable_from=(choice.rivals if effect not in ("none", "unexplained",
                                                                 "sparse_form") else []),
        phases_before=phases_before,
        phases_after=phases_after, timings=clock.timings, base_fit=base.fit,
        final_fit=final_fit, campaign=prep.campaign, model=base.model, z_before=base.z,
        z_after=z_after, shape=shape, sensor=sensor, records_scaled=base.scaled_notes,
        windows_set_aside=prep.windows_set_aside, learned=learned, sparse_form=form,
        misfit_left=left,
        gap_all_before=base.gap_all_before, gap_all_after=gap_all_after,
        steps=([] if effect in ("none", "unexplained", "sparse_form")
               else [s.to_json(prep.G) for s in steps]))
