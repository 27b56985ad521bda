r"""Stage 5b of the per-cycle discovery, `more`: the sequential search for several effects
at once (`cycle_workflow`, module doc).

After an effect is named it joins the base: its coordinates become base columns (free in
every later fit), its shape settings are held (`subproblems.with_shape`), and the refit
that named it is the extended base's fit. The ranking, refits and decision run again
on the extended base over the families not yet in it (nor named as indistinguishable
from one in it), with the same programs (the same model, shapes traced, the sensor
program where the sensor is named).

**Stopping rule and the family-wise error.** Every search runs the same test as the
first: the ranking's sign-flip min-p test over every remaining family-shape test, on
the efficient scores with the extended base projected out. The
sequence stops at the first search in which no family is significant (or no significant
family refits physically), or after `max_effects` effects. This is a sequential gate:
under the paper's model alone, an effect is named only if the first search's min-p falls
below alpha (probability alpha); once every effect present is in the model, one more is
named only if that search's min-p does (again alpha), and the sequence stops at the
first search that does not, so at most one test at level alpha is ever run on a complete
model and the chance of naming an effect that is not there stays at alpha. So a later
search takes a family by that test alone: the first search's second route (a relevant
predicted drop with the per-sample test, which counts the samples of a cycle window as
independent) is not calibrated, and after an effect is named what it admits is a
flexible family fitting the windows' shared errors (measured: a gauge drift named third
at family-wise p 0.2 after a screw error and rate-and-state friction, 2 records).
(Before the model is complete, a wrong family can win a search only by standing in for a
missing effect: that is the shadow below, not a false alarm.)

**Shadows.** A family can win a search only because another effect was missing (a
flexible family absorbing part of it). So after each new effect, every effect named
before it is tested again given it (`drop_one`): the model without it is refitted, and
its robust window test at that fit (`rank.held_p`) must stay below alpha, or its removal
raise chi-square beyond its confirmation level (`level`, below); an effect that no longer
helps is dropped (its step is kept, marked). Families once named are never
candidates again, so the search ends. Nor are the families that describe the same physics
as one in the model (`ALTERNATIVES`: a Stribeck curve and rate-and-state friction are two
laws of one kinetic friction that depends on the slip speed): with one of them named, the
other fits what the first one's shape leaves (measured: a rational Stribeck drop b = 0.1,
4 records, named stribeck, then rate_state for 744 of the remaining chi-square).
A named effect's shape was chosen on the records too (a grid shape, refined locally far
from the data), and what the chosen shape leaves of the records' own is a residual that
other families fit: every later test, the ranking's and drop-one's, counts the named
effects' continuous shape parameters among the base's (`rank.shape_columns`, their
derivatives projected out with the base columns). A later family that only takes up the
shape's remainder is then no longer significant (measured: a rational Stribeck drop b = 0.1
alone, 4 records, fitted as the library's rational curve at v_s 6.25 mm/s; with the shape
free the best later family, load coupling, has family-wise p 0.2 instead of 0.00025, and
stribeck alone is the answer, where a sensor low-pass and load coupling followed it).

**Confirmation.** A later effect joins only when its refit confirms the score test
(`confirmed`): its chi-square drop exceeds the chi-square quantile at `alpha` for its
parameter count, scaled by the extended base's chi2/n when that is above 1 (far from the
data every chi-square is that much larger). A family whose score passed but whose refit
changes nothing (a per-record screw whose coefficients stay at 1e-8 um on a campaign the
model misses by 6 x the noise) is not named and the search stops. It must also remove a
share (`DiscoveryOptions.later_share`) of the excess chi-square the extended base leaves over
the noise: far from the data a significant drop can still be irrelevant (on the real records
a Stribeck curve and a friction drift after a gauge drift removed 0.8 % and 1.8 % of it, a
gap of 7.77 -> 7.67 um against 1.26 um of noise), and such an effect is not what is missing.
The level is raised by the family's price (`decide.price`, ln n per parameter), the same
price the decision charges: a flexible family (a per-record screw, four coefficients per
record) joins only where its drop pays for its parameters. Drop-one keeps an earlier
effect by the same measure: its removal must raise chi-square beyond its level plus its
price. The price does not stop a screw that stands in for a partner the first effect
absorbed (measured, 4 records: after a 12 Hz sensor the screw lowered chi-square by 202
and 264 where the damping or the Stribeck drop was missing, both above level and price).

A later effect must also beat clearly every physical contender that explains a comparable
share (the decision's `unbeaten`: paired z below `clear`, a drop from `joint` x the
winner's; a law of the same physics aside). The paired test compares the two refits each
alone, and the one that lowers chi-square most may be a flexible family standing in for
the partner the first effect bent. So the two are then tested given each other
(`given_each_other`): the robust window test of each at the other's refit (`held_p`, the
other's parameters and the named effects free, as in drop-one). Where the winner is
still needed given the rival (p below alpha), it stood in for nothing the rival
describes: it is named, and the rival, if it is needed as well, must pass the next
search's calibrated test like any other family (measured, 4 records, a Stribeck drop
b 0.06 and a 2 um screw: after the screw the Stribeck drop -489 against load coupling's
-334, paired z 2.2; the Stribeck drop given load coupling p 1.1e-5, load coupling given
it p 0.0018: the Stribeck drop is named, and load coupling in the third search has
family-wise p 0.018, not named). Where only the rival is still needed it is the later
effect (if the calibrated test let it through) and meets the winner's other rivals in
turn. Where neither is, the records do not say which family is missing, and the search
stops there: the answer is not certain (both are listed as not clearly beaten); the
first effect is still named when it is not clear (with low confidence), a later one is
not.

**Size.** A later effect must also change the traces by at least `SMALLEST` standard
errors (`trace_size`: the change when its parameters are set to zero at its refit, every
other parameter held, as the RMS per sample in units of the samples' standard errors, over
the sticks and over the slips of the described records, the larger of the two). The later
search's calibrated test assumes that the model with the named effects is the records'
own; it is not (on a clean campaign the paper's model leaves 1.04-1.05 x the noise, a
systematic misfit of about 0.3 x the noise), and what the named effects' forms leave of
the generator's is a systematic residual of that order too, which a flexible family fits
significantly on 100,000 samples. An effect below the standard errors of every phase is
then no evidence of further physics. The size is taken phase by phase because an effect
of the slip speed acts in the slips alone, 2-6 % of the samples, and over all of them its
change is diluted by the sticks: a Stribeck drop after a 2 um screw on A (618, the screw's
refit leaving 1.076 x the noise) changes the slips by 1.41 standard errors, 0.32 x the
noise over all samples, and is named.
The slips' standard errors hold the timing term (a slip's timing error moves the fast
trace; 1.7-2.9 x the noise there), so a family that only shifts the slips' timing stays
small there (measured, 12 records: after a 20 Hz sensor and the damping a
per-record screw of 0.01-0.04 um, chi-square -688 and -322 on 610 and 612, family-wise p
0.0025 on 612: 0.79 and 0.61 in the slips, 0.31 x the noise over all samples; after a
12 Hz sensor on C (613) a per-record screw in the damping's place, chi-square -365 as one
screw: 0.85, the nearest to the limit; after a 12 um screw and the damping on C a sensor
low-pass: 0.12 and 0.08 in the slips of 605 and 609). The true second effects: the
damping 7.4-15.1 in the slips, Stribeck drops 1.41-5.55 (618, 620, 623, 600), a 12 um
screw after a Stribeck drop on C 2.77 (617). The first
search keeps its own rules: a single effect at the library's detectable size is named
however small against the noise.

**Either law of one physics.** Where a later search's calibrated test lets through a
family that describes its physics in one of two laws (`ALTERNATIVES`), the other law is
refitted too (`either_law`) and may be the winner: the test named the physics, the refits choose
the law, and no further effect is claimed (measured, 4 records, a Stribeck drop and a
20 Hz sensor: after the sensor rate-and-state friction was significant, family-wise p
0.001, chi-square -155, the Stribeck curve, a contender, -314; with rate-and-state named,
load coupling took up what its shape left, family-wise p 0.0012, and was named third).
The physics of a slip-speed dependence is its sign (`speed_sign`): a force that rises with
the slip speed (a viscous damping; rate-and-state friction whose direct effect a exceeds
its evolution effect b) or one that falls (a Stribeck drop; rate-and-state with b > a).
A later refit of the same sign as an effect kept before describes that effect again in
another law and is set aside (`new_physics`): it takes up what the named effect's own law
leaves, not a further effect (measured, 12 records, a damping ratio of 0.2 and a 20 Hz
sensor on A, seed 610: after the sensor the damping refits at zeta 0.08 from every start
up to 0.3, the sensor absorbing the rest; rate-and-state friction with a 0.0038,
b 0.0009 then lowers chi-square by 174, family-wise p 0.00075, and is set aside).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from stickslip_jax.lsq import gauss_newton_covariance

from ..decision import Contender, Decision, decide, paired_z, rms_gap
from ..scores import principal_cosine
from ..subproblems import SubProblem, with_shape
from .rank import held_p, rank
from .refit import judge, prior_of, ranked_refits, refit, refit_family, said
from .sharpen import sharpen
from .decide import choose, needed_given, one_screw, price, price_of
from .state import Base, Choice, Clock, FamilyRefit, Fits, Refitted, Step

__all__ = ["ALTERNATIVES", "SMALLEST", "SPEED_SIGN", "confirmed", "drop_one", "either_law",
           "extended", "given_each_other", "level", "more_effects", "new_physics", "settled",
           "speed_sign", "trace_size", "unbeaten_rival"]

ALTERNATIVES = (frozenset({"stribeck", "rate_state"}),)
"""Families that describe one physical effect in two laws (module doc): never both named."""
SMALLEST = 1.0
"""The smallest change of the traces a later effect must make to be named: RMS per sample
in units of the samples' standard errors, in the phase (sticks or slips) where it is
largest (module doc, Size)."""
SPEED_SIGN = {"viscous_damping": 1, "stribeck": -1}
"""The sign of the slip-speed dependence of a family's force: +1 rises with the slip speed
(a viscous damping), -1 falls (a Stribeck drop); rate-and-state friction's is its fitted
steady state's (`speed_sign`)."""


def _same_physics(name: str) -> set:
    """`name` and its alternatives (`ALTERNATIVES`)."""
    return set().union({name}, *(a for a in ALTERNATIVES if name in a))


def speed_sign(name: str, values) -> int:
    r"""+1 where the effect `name` with its fitted natural `values` is a force that rises
    with the slip speed, -1 where it falls, 0 for an effect that does not depend on it
    (`SPEED_SIGN`). Rate-and-state friction's steady state, $a\ln(1 + V/V_\mathrm{ref})
    - b\ln V$ + const, rises where the direct effect a exceeds the evolution effect b
    (velocity strengthening, a viscous damping's physics) and falls where b exceeds a
    (velocity weakening, a Stribeck drop's): Dieterich and Ruina's a - b."""
    if name == "rate_state":
        a, b = np.asarray(values, float)[:2]
        return 1 if a > b else -1
    return SPEED_SIGN.get(name, 0)


def new_physics(refitted: Refitted, steps: list[Step], clock: Clock) -> Refitted:
    """The refits without those that describe again, in another law, the physics of an
    effect kept before (module doc, Either law): a force of the same slip-speed dependence
    (`speed_sign`), such as rate-and-state friction whose steady state rises with the slip
    speed after a viscous damping. Such a refit takes up what the named effect's own law
    leaves (its linear or logarithmic form, its size where another effect bent it), not a
    further effect."""
    kept = {speed_sign(s.family.name, s.values): s.family.name for s in steps if s.kept}
    kept.pop(0, None)
    same = [(rf, kept[speed_sign(rf.family.name, rf.values)]) for rf in refitted.refits
            if rf.unphysical is None and speed_sign(rf.family.name, rf.values) in kept]
    if not same:
        return refitted
    clock.say("set aside: " + ", ".join(
        f"{rf.family.name} (chi2 -{rf.drop:.0f}), a force that "
        f"{'rises' if speed_sign(rf.family.name, rf.values) > 0 else 'falls'} with the slip "
        f"speed as {name}'s named before" for rf, name in same))
    gone = {rf.family.name for rf, _ in same}
    return dataclasses.replace(refitted, refits=[rf for rf in refitted.refits
                                                 if rf.family.name not in gone])


def extended(fx: Fits, rf: FamilyRefit, held) -> Base:
    """The base with the effects `held` (the last of them `rf`'s family) at the refit
    `rf`: its fit over the base columns, the gap and the misfit there."""
    base, model, n, opts = fx.base, fx.base.model, fx.base.n, fx.opts
    new = dataclasses.replace(base, held=tuple(held), shape=rf.shape, sensor=rf.sensor)
    cols, z = new.cols, rf.sub.full(rf.fit.z)
    if type(rf.sub) is SubProblem and np.array_equal(rf.sub.cols, cols):
        J = rf.fit.J[:n]
    else:  # a shared screw or a reduced fit: the Jacobian over the base columns
        J = model.evaluate(z, cols, rf.shape, rf.sensor)[1]
    r, d = rf.fit.r[:n], base.described
    gap = rms_gap(r[d], base.sd[d], base.samples[d])
    # rss with the screw's prior rows: the next refits carry them too
    fit = dataclasses.replace(rf.fit, params=z[cols], residuals=r, jacobian=J)
    return dataclasses.replace(
        new, fit=fit, z=z, gap_before=gap, gap_all_before=rms_gap(r, base.sd, base.samples),
        misfit=((rf.fit.rss + base.within) / base.n_used > opts.misfit
                or gap > opts.misfit * base.noise))


def drop_one(fx: Fits, rf: FamilyRefit, clock: Clock) -> tuple[FamilyRefit, tuple, list]:
    """Every effect named before `rf`'s family (`fx.base.held`) tested again given it
    (module doc): refitted without it from `rf`'s fit, its robust window test there.
    Returns the fit of the effects kept (`rf` where none went), the effects before the
    new one that stay, and the dropped ones as (name, p-value)."""
    model, base, opts = fx.base.model, fx.base, fx.opts
    held, dropped, said = list(base.held), [], []
    for h in list(held):
        keep = [f for f in held if f is not h]
        cols = np.concatenate([np.arange(model.n_base)] + [model.cols(f) for f in keep]
                              + [model.cols(rf.family)])
        z_all = rf.sub.full(rf.fit.z)
        z = z_all.copy()
        z[model.cols(h)] = 0.0
        sensor = rf.sensor and h.name != "sensor_lowpass"
        sub = SubProblem(model, z, cols, rf.shape, sensor, prior_of(fx, cols))
        try:
            fit = sub.solve(z[cols], max_evals=opts.refit_evals, lam0=1e-3, stall_evals=8)
            p = held_p(base, fx.prep.starts, fit, sub.full(fit.z), h, rf.shape, sensor,
                       z_all[model.cols(h)], others=(*keep, rf.family))
        except ValueError:  # the model without it leaves the simulator's domain: kept
            continue
        one = judge(fx, rf.family, rf.shape, fit, sensor, sub)
        # and its removal must not raise chi-square beyond its confirmation level (a
        # per-record screw's window test has little power on a few records: measured, a
        # screw dropped given a Stribeck drop, the gap 1.05 -> 2.2 x the noise)
        gone = (p >= opts.alpha and one.unphysical is None
                and fit.rss - rf.fit.rss <= level(base, len(model.cols(h)), opts.alpha)
                + price_of(base, len(model.cols(h))))
        said.append(f"{h.name} {'dropped' if gone else 'kept'} (p {p:.2g})")
        if gone:
            dropped.append((h.name, p))
            held, rf = keep, one
    clock("drop-one", f"given {rf.family.name}: " + ", ".join(said))
    return rf, tuple(held), dropped


def _step(fx: Fits, choice: Choice, rf: FamilyRefit, dropped=()) -> Step:
    """The step of the effect `rf` named in the search of `fx` (`Step`)."""
    base, opts = fx.base, fx.opts
    sc = next(s for s in fx.ranking.scores if s.family.name == rf.family.name)
    excess = max(base.fit.rss + base.within - base.n_used, 0.0)
    high = (choice.decision.clear and sc.significant_by == "family-wise"
            and rf.drop >= opts.explained_share * excess)
    d = base.described
    return Step(rf.family, rf.shape, rf.values, rf.stderr,
                rms_gap(rf.fit.r[:base.n][d], base.sd[d], base.samples[d]), sc.p_family,
                "high" if high else "low", rf.drop, choice.rivals, tuple(dropped))


def more_effects(fx: Fits, choice: Choice, fams, *, max_effects: int, clock: Clock
                 ) -> tuple[Fits, Choice, list[Step]]:
    """The sequential search (module doc) from the first search's `fx` and `choice` over
    the families `fams`: the last search's `Fits`, the choice of the final model (its
    chosen fit holds every effect kept; `decided_drop` against the paper's model, the
    decision's unbeaten contenders of every search) and the steps."""
    first, chosen = fx, choice.chosen
    if chosen is None:
        return fx, choice, []
    steps = [_step(fx, choice, chosen)]
    named = _same_physics(chosen.family.name) | {c["name"] for c in choice.rivals}
    held, unbeaten = (chosen.family,), list(choice.decision.unbeaten)
    joint = {chosen.family.name: choice.decision.joint}  # partners, by the effect named
    while len(held) < max_effects:
        clock.suffix = f", effect {len(steps) + 1}"
        base = extended(fx, chosen, held)
        left = [f for f in fams if f.name not in named]
        ranking = rank(fx.prep, base, left, opts=fx.opts, clock=clock) if left else None
        if ranking is not None:  # a later effect by the calibrated test only (module doc)
            ranking = dataclasses.replace(ranking, significant=[
                s for s in ranking.significant if s.significant_by == "family-wise"])
        if ranking is None or not ranking.significant:
            break
        fx_k = Fits(opts=fx.opts, prep=fx.prep, base=base, ranking=ranking)
        refitted = sharpen(fx_k, refit(fx_k, clock=clock), clock=clock)
        refitted = new_physics(either_law(fx_k, refitted, clock), steps, clock)
        choice_k = choose(fx_k, refitted, clock=clock)
        if choice_k.chosen is not None and unbeaten_rival(choice_k) is not None:
            choice_k = given_each_other(fx_k, choice_k, refitted, clock)
        if choice_k.chosen is None or not confirmed(
                base, choice_k.chosen, fx.opts.alpha, fx.opts.later_share,
                price(fx_k, choice_k.chosen)):
            clock.say("stop: no physical refit lowers chi-square" if choice_k.chosen is None
                      else f"stop: {choice_k.chosen.family.name} lowers chi-square by only "
                      f"{choice_k.chosen.drop:.3g}, below its confirmation level and price "
                      f"or {fx.opts.later_share:.0%} of the excess left")
            break
        size = trace_size(fx_k, choice_k.chosen)
        if size < SMALLEST:
            clock.say(f"stop: {choice_k.chosen.family.name} (chi2 -{choice_k.chosen.drop:.0f}) "
                      f"changes the traces by only {size:.2g} standard errors in the "
                      f"sticks or the slips, below {SMALLEST:g}: no further effect")
            break
        rival = unbeaten_rival(choice_k)
        if rival is not None:
            clock.say(f"stop: {choice_k.chosen.family.name} (chi2 -{choice_k.chosen.drop:.0f}) "
                      f"does not clearly beat {rival.name} (chi2 -{rival.drop:.0f}, paired z "
                      f"{rival.z:.2g}): the records do not say which effect is missing")
            unbeaten += [Contender(choice_k.chosen.family.name, choice_k.chosen.drop, 1.0,
                                   0.0), rival]  # something significant is left unnamed
            break
        new, kept, dropped = drop_one(fx_k, choice_k.chosen, clock)
        gone = {name for name, _ in dropped}
        steps = [dataclasses.replace(s, kept=False) if s.family.name in gone else s
                 for s in steps] + [_step(fx_k, choice_k, new, sorted(gone))]
        named |= _same_physics(new.family.name) | {c["name"] for c in choice_k.rivals}
        held, fx, chosen = kept + (new.family,), fx_k, new
        unbeaten += choice_k.decision.unbeaten
        joint[new.family.name] = choice_k.decision.joint
    clock.suffix = ""
    lead = next(s for s in steps if s.kept)
    return fx, Choice(chosen=chosen, decision=Decision(joint[lead.family.name], tuple(unbeaten)),
                      rivals=lead.rivals, compared=choice.compared,
                      decided_drop=first.base.fit.rss - chosen.fit.rss), steps


def either_law(fx: Fits, refitted: Refitted, clock: Clock) -> Refitted:
    """The refits with the other law of every eligible family's physics (`ALTERNATIVES`)
    refitted where it was not, and eligible as well (module doc, Either law)."""
    eligible = frozenset().union(*(_same_physics(name) for name in refitted.eligible))
    done = {rf.family.name for rf in refitted.refits}
    lead = max([rf.drop for rf in ranked_refits(refitted.refits)
                if rf.family.name in refitted.eligible], default=0.0)
    new = [refit_family(fx, sc, lead) for sc in fx.ranking.scores
           if sc.family.name in eligible - done]
    if new:
        clock("other law", ", ".join(said(rf) for rf in new))
    return dataclasses.replace(refitted, refits=[*refitted.refits, *new], eligible=eligible)


def _decided(fx: Fits, refits, chosen: FamilyRefit, aside) -> Decision:
    """The decision (`decision.decide`) of the winner `chosen` against the other refits
    that lower chi-square, those of the families `aside` left out."""
    n, starts = fx.base.n, fx.prep.starts
    direction = {sc.family.name: sc.direction for sc in fx.ranking.scores}
    others = [Contender(rf.family.name, rf.drop,
                        principal_cosine(direction[chosen.family.name],
                                         direction[rf.family.name]),
                        paired_z(chosen.fit.r[:n], rf.fit.r[:n], starts), rf.unphysical is None)
              for rf in refits if rf.family.name not in aside | {chosen.family.name}
              and rf.drop > 0]
    return decide(chosen.drop, others, joint=fx.opts.joint, collinear=fx.opts.collinear,
                  clear=fx.opts.clear)


def given_each_other(fx: Fits, choice: Choice, refitted: Refitted, clock: Clock) -> Choice:
    """A later winner and each physical rival it does not beat clearly (`unbeaten_rival`),
    in turn, tested given each other (module doc, Confirmation): the robust window test
    of the one at the other's refit. Where the winner is still needed given the rival,
    the rival is set aside (a later search tests it given the winner); where only the
    rival is, the winner is set aside and the rival, if it is a family the calibrated
    test let through, is decided anew against the refits not set aside. Returns the
    choice where every rival is settled, else the choice with the first rival left
    unsettled (neither needed given the other)."""
    # the refits as the decision judged them (a screw as the machine's one screw)
    refits = list(choice.judged) or [one_screw(fx, rf) for rf in refitted.refits]
    aside, alpha = set(), fx.opts.alpha
    while (rival := unbeaten_rival(choice)) is not None:
        win = choice.chosen
        other = next((rf for rf in refits if rf.family.name == rival.name), None)
        if other is None or other.unphysical is not None or other.failed:
            return choice
        try:
            p_win, p_other = needed_given(fx, win, other)[0], needed_given(fx, other, win)[0]
        except ValueError:  # a model outside the simulator's domain
            return choice
        clock("given each other", f"{win.family.name} given {other.family.name}: p "
                                  f"{p_win:.2g}, {other.family.name} given "
                                  f"{win.family.name}: p {p_other:.2g}")
        if p_win < alpha:  # the winner is no stand-in for the rival: the rival, if it is
            aside.add(other.family.name)  # still needed, meets the next search's test
        elif p_other < alpha <= p_win and other.family.name in refitted.eligible:
            aside.add(win.family.name)
            win = other
        else:
            return choice
        decision = _decided(fx, refits, win, aside)
        choice = dataclasses.replace(choice, chosen=win, decision=decision,
                                     rivals=[c.to_json() for c in decision.joint],
                                     decided_drop=win.drop)
    return choice


def unbeaten_rival(choice: Choice):
    """The physical contender (`decision.Contender`) a later effect does not beat clearly
    although it explains a comparable share (the decision's `unbeaten`, not a law of the
    same physics, `ALTERNATIVES`), or None (module doc, Confirmation)."""
    same = _same_physics(choice.chosen.family.name)
    return next((c for c in choice.decision.unbeaten if c.physical and c.name not in same),
                None)


def trace_size(fx: Fits, rf: FamilyRefit) -> float:
    """The size of `rf`'s effect (module doc, Size): the change of the traces when the
    parameters of its family are set to zero at its refit, every other parameter and shape
    held, as the RMS per sample of that change in units of the samples' standard errors
    over each phase of the cycles (the sticks, the slips; `Base.slipping`) of the described
    records, the larger of the two; inf where the model without it leaves the simulator's
    domain. A residual that stands for a bin of samples (`thinning`) changes each of
    them by its own change: its whitened change squared is their chi-square."""
    base, model = fx.base, fx.base.model
    z = np.array(rf.sub.full(rf.fit.z), float)
    without = z.copy()
    without[model.cols(rf.family)] = 0.0
    sensor = rf.sensor and rf.family.name != "sensor_lowpass"
    r = np.asarray(model.residuals(z, rf.shape, rf.sensor)[0])
    r0 = np.asarray(model.residuals(without, rf.shape, sensor)[0])
    d = base.described
    change = (r0 - r)[d]  # whitened
    if not np.all(np.isfinite(change)):
        return float("inf")
    count = np.ones(change.size) if base.samples is None else base.samples.count[d]
    slipping = np.asarray(base.slipping, bool)[d]
    return max((float(np.sqrt(np.sum(change[m] ** 2) / np.sum(count[m])))
                for m in (slipping, ~slipping) if m.any()), default=0.0)


def level(base: Base, dof: int, alpha: float) -> float:
    """The chi-square quantile at `alpha` for `dof` parameters, times the `base`'s chi2/n
    where that is above 1 (module doc)."""
    from scipy.stats import chi2

    scale = max((base.fit.rss + base.within) / max(base.n_used, 1), 1.0)
    return float(scale * chi2.ppf(1.0 - alpha, max(int(dof), 1)))


def confirmed(base: Base, rf: FamilyRefit, alpha: float, share: float = 0.0,
              cost: float = 0.0) -> bool:
    """Whether the refit `rf` on the extended `base` lowers chi-square by more than its
    `level` plus its flexibility's `cost` (`decide.price`) and by at least `share` of the
    base's excess chi-square over the noise (module doc)."""
    excess = max(base.fit.rss + base.within - base.n_used, 0.0)
    return bool(rf.drop - cost > level(base, np.size(rf.values), alpha)
                and rf.drop >= share * excess)


def settled(fx: Fits, rf: FamilyRefit | None, steps: list[Step]) -> list[Step]:
    """The steps with every kept effect's values and standard errors those of the final
    fit `rf` (all effects fitted together; its own family's from `judge`)."""
    if rf is None:
        return steps
    model, z = fx.base.model, rf.sub.full(rf.fit.z)
    try:
        scale = (rf.fit.rss + fx.base.within) / (fx.base.n_used - rf.fit.z.size)
        cov = gauss_newton_covariance(rf.fit.J, max(scale, 1.0))
    except np.linalg.LinAlgError:
        cov = None
    out = []
    for s in steps:
        if s.kept and s.family is rf.family:
            s = dataclasses.replace(s, values=rf.values, stderr=rf.stderr)
        elif s.kept:
            cols = model.cols(s.family)
            at = np.flatnonzero(np.isin(rf.sub.cols, cols))
            se = (np.full(cols.size, np.nan) if cov is None else
                  np.sqrt(np.clip(np.diag(cov)[at], 0, None)) * model.scales[cols])
            s = dataclasses.replace(s, values=z[cols] * model.scales[cols], stderr=se)
        out.append(s)
    return out
