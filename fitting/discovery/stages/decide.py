"""Stage 5 of the per-cycle discovery, `decision`: the winner among the eligible physical
refits, every other refit compared with it (`decision.decide`), and, far from the data,
the winner's fit continued and its shape refined (`cycle_workflow`, module doc). A
per-record screw is judged as the machine's one screw (`one_screw`).

In the first search the winner is one of the families the calibrated test let through
(a contender that explains more makes the answer uncertain or joint). A later search
runs only where its calibrated test (`stages.more`, the sign-flip min-p) found
something, so the chance of naming an effect that is not there is alpha whichever family
then answers; the family whose test passed may be a weak stand-in for a partner that
explains more, so there every physical contender with evidence of its own (robust
window p < alpha) may win (measured, 12 records, a damping ratio of 0.2 and a Stribeck
drop of 0.06 on A, seed 600: after the damping a sensor low-pass passed the
calibrated test with chi-square -20, the Stribeck drop, robust p 0.0074, lowered it by
259 and was needed given the sensor, p 0.0058, the sensor not given it, p 0.057)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..cycle_effects import neighbour_shapes
from ..decision import Contender, Decision, decide, paired_z, rms_gap
from ..scores import principal_cosine
from ..subproblems import SharedScrewProblem, SubProblem, with_shape
from .rank import held_test, relevant_drop
from .refit import ranked_refits, continued, judge, refine_shape
from .state import Choice, Clock, FamilyRefit, Fits, Refitted

__all__ = ["choose", "needed_given", "one_screw", "price", "price_of", "told_apart"]


def price(fx: Fits, rf) -> float:
    """What the refit `rf`'s flexibility costs in chi-square: ln n for each parameter it
    adds to the base (Schwarz's criterion over the `n_used` samples), times the base's
    chi2/n where that is above 1 (far from the data every chi-square is that much larger).
    A per-record family (the screw: four harmonic coefficients per record, on records
    shorter than a pitch a smooth drive error of its own in each) fits part of any slow
    residual; its drop is judged net of this price."""
    return price_of(fx.base, int(np.size(rf.fit.z)) - int(np.size(fx.base.cols)))


def price_of(base, k: int) -> float:
    """`price` of `k` parameters added to `base` (at least one)."""
    scale = max((base.fit.rss + base.within) / max(base.n_used, 1), 1.0)
    return float(max(int(k), 1) * np.log(max(base.n_used, 2)) * scale)


def one_screw(fx: Fits, rf: FamilyRefit) -> FamilyRefit:
    """The per-record screw refit `rf` judged as the machine's one lead screw: refitted
    with one amplitude per harmonic and a phase per record (`SharedScrewProblem`) from
    its coefficients, so that its drop and its price are those of 2 + 2G parameters. Per
    record, four coefficients are a smooth drive error of each record's own on records
    shorter than a pitch, and they fit part of any slow residual, such as a partner
    effect the model misses (measured, 4 records: a screw named in place of a damping or
    a Stribeck drop beside a 12 Hz sensor, chi-square -202 and -264); one screw cannot
    bend record by record. Returns the shared refit, marked unphysical where no one
    screw lowers chi-square physically; `rf` itself for any other refit."""
    if (rf.family.name != "drive_periodic_error" or type(rf.sub) is not SubProblem
            or rf.unphysical is not None or not rf.drop > 0):
        return rf
    G, nb = fx.prep.G, fx.base.cols.size
    shared = SharedScrewProblem(fx.base.model, fx.base.z.copy(), rf.sub.cols, rf.shape,
                                rf.sensor, None, nb)
    w0 = np.concatenate([rf.fit.z[:nb], SharedScrewProblem.start(rf.fit.z[nb:], G)])
    try:
        fit = shared.solve(w0, max_evals=fx.opts.refit_evals, lam0=1e-3, stall_evals=8)
    except ValueError:
        return dataclasses.replace(rf, unphysical="one screw leaves the simulator's domain")
    one = judge(fx, rf.family, rf.shape, fit, rf.sensor, shared)
    if one.unphysical is None and not one.drop > 0:
        one.unphysical = "one screw for all records does not lower chi-square"
    return one


def needed_given(fx: Fits, f_rf: FamilyRefit, at: FamilyRefit) -> tuple[float, float]:
    """The robust window test's p-value of `f_rf`'s family at the refit `at` of another
    family, and the chi-square drop its score step predicts there (`rank.held_test`, the
    named effects and `at`'s family free): whether the one is still needed given the
    other."""
    base = fx.base
    shape = with_shape(at.shape, f_rf.family, f_rf.shape)
    value = f_rf.sub.full(f_rf.fit.z)[base.model.cols(f_rf.family)]
    return held_test(base, fx.prep.starts, at.fit, at.sub.full(at.fit.z), f_rf.family,
                     shape, at.sensor, value, others=(*base.held, at.family))


def told_apart(fx: Fits, chosen: FamilyRefit, refits, decision: Decision,
               clock: Clock) -> Decision:
    """The `decision` without the joint partners that the records tell apart from the
    winner `chosen`: those given whose refit the winner is still needed (`needed_given`),
    by either route of the ranking's significance (robust window p < `alpha`, or a
    predicted drop of at least `relevant` of the samples whose per-sample test has
    p < `alpha`). Such a partner is no other description of the winner's effect: a
    collinear family that lowered chi-square only by taking up part of it (measured, a
    friction drift of -2e-5/s on A, 9 records: a drive speed drift and one screw, cosine
    0.98, paired z 1.6 and 1.2, chi-square -24,325 and -23,919 against the drift's -25,016;
    given them the drift has robust p 0.0054 and 0.0079). Whether it is a further effect
    is the next search's question, its test given the winner (`stages.more`)."""
    if not decision.joint:
        return decision
    opts, base = fx.opts, fx.base
    by_name = {rf.family.name: rf for rf in refits}
    dof = np.size(chosen.values)
    kept, said = [], []
    for c in decision.joint:
        rf = by_name.get(c.name)
        if rf is None:  # a contender without a refit of its own: not told apart
            kept.append(c)
            continue
        try:
            p, predicted = needed_given(fx, chosen, rf)
        except ValueError:  # outside the simulator's domain: not told apart
            kept.append(c)
            continue
        s2 = max((rf.fit.rss + base.within) / max(base.n_used, 1), 1.0)
        apart = p < opts.alpha or relevant_drop(predicted, s2, dof, base.n_used, opts,
                                                opts.alpha)
        said.append(f"{chosen.family.name} given {c.name}: p {p:.2g}, predicted chi2 "
                    f"-{predicted:.0f} ({'told apart' if apart else 'joint'})")
        if not apart:
            kept.append(c)
    if said:
        clock.say("joint partners: " + "; ".join(said))
    return dataclasses.replace(decision, joint=tuple(kept))


def choose(fx: Fits, refitted: Refitted, *, clock: Clock) -> Choice:
    """The winner and the decision (module doc of `cycle_workflow`, stage 5)."""
    opts, n, misfit = fx.opts, fx.base.n, fx.base.misfit
    refits = [one_screw(fx, rf) for rf in refitted.refits]
    for was, rf in zip(refitted.refits, refits):
        if rf is not was:
            clock("one screw", f"{rf.family.name} chi2 {-rf.drop:+.0f} with one amplitude "
                               f"(per record {-was.drop:+.0f})"
                               + (f" (unphysical: {rf.unphysical})" if rf.unphysical else ""))
    # the winner among the families the calibrated test let through; in a later search
    # (an effect already named) among every physical refit with evidence of its own
    # (the contenders' robust p < alpha): the search runs only where its calibrated test
    # found something, so which family answers does not change the false-alarm rate, and
    # the family that found it may be a weak stand-in for the one that explains most
    # (module doc)
    later = bool(fx.base.held)
    physical = [rf for rf in ranked_refits(refits)
                if later or rf.family.name in refitted.eligible]
    chosen = max(physical, default=None, key=lambda rf: rf.drop - price(fx, rf))
    rivals, decision, compared = [], None, {}
    if chosen is not None:
        direction = {sc.family.name: sc.direction for sc in fx.ranking.scores}
        r_win = chosen.fit.r[:n]
        others = [Contender(rf.family.name, rf.drop,
                            principal_cosine(direction[chosen.family.name],
                                             direction[rf.family.name]),
                            paired_z(r_win, rf.fit.r[:n], fx.prep.starts),
                            rf.unphysical is None)
                  for rf in refits if rf is not chosen and rf.drop > 0]
        decision = told_apart(fx, chosen, refits, decide(
            chosen.drop, others, joint=opts.joint, collinear=opts.collinear,
            clear=opts.clear), clock)
        compared = {c.name: c for c in others}
        rivals = [c.to_json() for c in decision.joint]
    if chosen is not None and misfit and not chosen.fit.converged:
        # far from the data the winner's refit ran out of evaluations: continue it (after
        # the decision, which compares refits of equal budgets) so that the gap after and
        # the estimates are those of the fitted effect (its restart from the start's
        # friction is `sharpen`'s, before the decision)
        polished = continued(fx, chosen)
        if polished is not None:
            chosen = polished
            clock("polish", f"{chosen.family.name} chi2 -{chosen.drop:.0f}, "
                            f"{polished.fit.n_evals} more evaluations")
    described = fx.base.described
    if (chosen is not None and misfit and chosen.family.name not in refitted.shaped
            and neighbour_shapes(chosen.family, chosen.shape)
            and rms_gap(chosen.fit.r[:n][described], fx.base.sd[described],
                      fx.base.samples[described])
            > opts.refine_gap * fx.base.noise):
        # far from the data the named family's grid shape may not be the records' own
        # (a real Stribeck curve is not one of ours): a local search over its continuous
        # shape parameters, after the decision (which compared the grid)
        refined, tried = refine_shape(fx, chosen)
        if refined is not chosen:
            clock("shape", f"{refined.family.name} {refined.shape.label(refined.family)} "
                           f"(from {chosen.shape.label(chosen.family)}), chi2 "
                           f"-{refined.drop:.0f}, {tried} short refits")
            chosen = refined
    return Choice(chosen=chosen, decision=decision, rivals=rivals, compared=compared,
                  decided_drop=chosen.drop if chosen is not None else 0.0,
                  judged=tuple(refits))
