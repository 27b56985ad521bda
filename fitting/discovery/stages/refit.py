"""Stage 4 of the per-cycle discovery, `refit`: the significant families (and the
contenders with nominal evidence) refitted with the base, each judged physical or not
(`cycle_workflow`, module doc); the tools the later stages use on a refit (`judge`,
`continued`, `refine_shape`)."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np

from stickslip_jax.logs import logger
from stickslip_jax.lsq import gauss_newton_covariance

from ..cycle_effects import DRIVE_ERROR_MAX, drive_error_range, family, neighbour_shapes
from ..options import DEFAULTS, DiscoveryOptions
from ..subproblems import HOPE, SharedScrewProblem, SubProblem
from .base_fit import friction_values
from .state import Clock, FamilyRefit, FamilyScore, Fits, Refitted

__all__ = ["CANNOT_WIN", "cannot_win", "continued", "dead", "judge", "prior_of",
           "ranked_refits", "refine_shape", "refit", "refit_family", "said"]

CANNOT_WIN = 0.5
"""Far from the data, a refit stops once it cannot lower chi-square by this share of
`joint` x the lead (the largest physical drop of an eligible family so far; `HOPE`
times the Gauss-Newton decrease left at its best point): it could neither win nor make
the answer uncertain (a contender counts from `joint` x the winner's drop), and far from
the data every family is refitted, most of them to a small share of the lead."""


def _one_screw(coef, recs, pitch, spans, opts: DiscoveryOptions = DEFAULTS) -> str | None:
    """One lead screw has one error amplitude. Every record's harmonic amplitudes stay
    below `screw_amplitude_max`; among the records that travel at least one pitch, the
    first-harmonic amplitudes agree within a factor `screw_spread` (an error that fits
    each record with its own size is something else, e.g. a drift). A record that travels
    less than a pitch sees a piece of one period: its error over its own travel (`spans`,
    peak to peak per record, mm) must stay within `screw_spread` times the full swing
    2 (A1 + A2) of the largest screw error the long records show."""
    amp = np.hypot(coef[:, 0], coef[:, 1])
    amp2 = np.hypot(coef[:, 2], coef[:, 3])
    travel = np.array([r.nominal_drive_speed * (float(r.time[-1]) - float(r.time[0]))
                       for r in recs])
    long = travel >= pitch
    top, spread = opts.screw_amplitude_max, opts.screw_spread
    if max(amp.max(), amp2.max()) > top:
        return (f"screw error amplitude {1e3 * max(amp.max(), amp2.max()):.3g} um > "
                f"{1e3 * top:g} um (a broken drive, not an effect)")
    if long.any() and not long.all():
        swing = 2.0 * float(np.max(amp[long] + amp2[long]))
        short = float(np.max(np.asarray(spans)[~long]))
        if short > spread * max(swing, 1e-12):
            return (f"a record shorter than a pitch needs a drive error of "
                    f"{1e3 * short:.3g} um peak to peak, more than {spread:g} "
                    f"times the {1e3 * swing:.3g} um swing the longer records show; one "
                    "lead screw has one amplitude")
    a = amp[long]
    if a.size < 2 or a.max() <= spread * max(a.min(), 1e-12):
        return None
    return (f"the screw error's amplitude differs {a.max() / a.min():.3g}-fold between "
            f"records ({1e3 * a.min():.3g} to {1e3 * a.max():.3g} um); one lead screw has "
            "one amplitude")


def said(rf: FamilyRefit) -> str:
    """A refit in a progress line: its chi-square drop and why it is not a result."""
    why = (" (refit failed)" if rf.failed else " (unphysical)" if rf.unphysical
           else " (stopped: cannot win)" if rf.fit.stats.get("hopeless") else "")
    return f"{rf.family.name} chi2 {-rf.drop:+.0f}{why}"


def ranked_refits(refits) -> list[FamilyRefit]:
    """The physical refits that lower chi-square, the largest drop first."""
    return sorted([rf for rf in refits if not rf.unphysical and rf.drop > 0],
                  key=lambda rf: -rf.drop)


def dead(J_family) -> bool:
    """The family's columns of a refit's Jacobian (data rows) are all zero: the traces do
    not change with its parameters there (measured on the real campaign: a dashpot of
    0.05 kgf s/mm and more stops every slip of the windows, so chi-square is flat in every
    coordinate and the solver stops at its start), and the refit does not determine the
    effect's size."""
    J_family = np.asarray(J_family)
    return J_family.size > 0 and not np.any(J_family != 0)


def judge(fx: Fits, f, shape, fit, sensor, sub: SubProblem) -> FamilyRefit:
    """The refit `fit` of family `f` as a result: its chi-square drop against the base,
    the family's values and standard errors, and why it is unphysical (None: physical)."""
    model, G, recs = fx.base.model, fx.prep.G, fx.prep.recs
    k = len(model.cols(f))
    try:
        cov = gauss_newton_covariance(fit.J, max((fit.rss + fx.base.within)
                                                       / (fx.base.n_used - fit.z.size), 1.0))
    except np.linalg.LinAlgError:
        cov = None
    z_f, cov_f = sub.family_part(fit.z, cov, k)
    vals = z_f * model.scales[model.cols(f)]
    se = (np.full(k, np.nan) if cov_f is None else
          np.sqrt(np.clip(np.diag(cov_f), 0, None)) * model.scales[model.cols(f)])
    bad = f.unphysical(vals)
    if f.per_record and f.name == "drive_periodic_error":
        spans = np.array([drive_error_range(vals.reshape(G, -1)[g], recs[g].time,
                                            recs[g].nominal_drive_speed, shape.pitch)
                          for g in range(G)])
        if spans.max() > DRIVE_ERROR_MAX:
            bad = (f"drive error {spans.max() * 1e3:.3g} um peak to peak > "
                   f"{DRIVE_ERROR_MAX * 1e3:g} um (a broken drive, not an effect)")
        else:
            bad = _one_screw(vals.reshape(G, -1), recs, shape.pitch, spans, fx.opts)
    if bad is None and dead(sub.family_columns(fit.J[:fx.base.n], k)):
        bad = (f"the traces do not change with {', '.join(f.params)} at the refit (zero "
               "derivative: the effect's size there stops every slip of the windows, or "
               "leaves the model's reach), so the refit does not determine its size")
    return FamilyRefit(f, shape, fit, fx.base.fit.rss - fit.rss, vals, se, bad, sensor, sub)


def prior_of(fx: Fits, cols) -> np.ndarray | None:
    """Per free coordinate of the model columns `cols`: the prior sd (z units) of the
    screw coefficients among them (`drive_prior`: a record under a pitch draws huge
    coefficients of opposite sign), inf elsewhere; None without screw coefficients."""
    f = family("drive_periodic_error")
    on = np.isin(cols, fx.base.model.cols(f))
    if not on.any():
        return None
    return np.where(on, fx.opts.drive_prior / f.scales[0], np.inf)


def _better(one: FamilyRefit, best: FamilyRefit | None) -> bool:
    """A physical fit beats an unphysical one, then the lower chi-square wins."""
    return best is None or ((one.unphysical is not None, one.fit.rss)
                            < (best.unphysical is not None, best.fit.rss))


def _options(fx: Fits, sc: FamilyScore, wide: bool | None = None):
    """The (shape score, sensor) pairs a family is refitted with, and the starts of its
    first coordinate (None: from the score step or the base); `wide`: those of a base
    far from the data (default: whether it is)."""
    f, held = sc.family, fx.base.sensor  # held: the sensor named
    misfit = fx.base.misfit if wide is None else wide
    ranked_shapes = sorted(fx.ranking.shape_scores.get(f.name, [sc]),
                           key=lambda s: -s.chi2_predicted)
    if f.name == "sensor_lowpass":
        options = [(s_, True) for s_ in ranked_shapes[:2]]
    elif f.name == "drive_periodic_error":
        options = [(s_, held) for s_ in ranked_shapes[:3]]
    elif misfit and f.name == "stribeck":
        options = [(s_, held) for s_ in ranked_shapes[:3]]
    else:
        options = [(sc, held)]
    starts = [None]
    if misfit and f.signs[0] > 0 and f.name != "sensor_lowpass":
        # far from the data the effect may be large: its first coordinate (physically
        # one-sided) also starts at fractions of its bound (`large_starts`)
        starts += [frac * f.bound[0] / f.scales[0] for frac in fx.opts.large_starts]
    return options, starts


def _shared_screw(fx: Fits, f, cols, tried, best, target) -> FamilyRefit:
    """Far from the data (a large screw error bends the base): each shape again with one
    amplitude per harmonic and a phase per record (`SharedScrewProblem`), from the per-record
    fit's coefficients (records that travel a fraction of a pitch can no longer bend
    their own error). Not near the data: there the per-record form's bounds are what
    keeps noise from being named a screw (measured: with the shared form on every
    campaign, 9 of 20 clean campaigns were named drive_periodic_error)."""
    model, z_base, G = fx.base.model, fx.base.z, fx.prep.G
    nb = fx.base.cols.size
    for one in tried:
        shared = SharedScrewProblem(model, z_base.copy(), cols, one.shape, fx.base.sensor,
                                    None, nb)
        w0 = np.concatenate([one.fit.z[:nb], SharedScrewProblem.start(one.fit.z[nb:nb + 4 * G], G)])
        aim = target  # kept only if it beats the best so far
        if best.unphysical is None:
            aim = best.fit.rss if aim is None else min(aim, best.fit.rss)
        try:
            fit = shared.solve(w0, max_evals=fx.opts.refit_evals, lam0=1e-3, stall_evals=8,
                               target=aim)
        except ValueError:
            continue
        two = judge(fx, f, one.shape, fit, False, shared)
        if (two.unphysical is not None, two.fit.rss) < (best.unphysical is not None,
                                                         best.fit.rss):
            best = two
    return best


def cannot_win(fx: Fits, sc: FamilyScore, lead: float) -> bool:
    """Far from the data, whether the family of `sc` is not refitted at all: the stop rule
    of its refit (`CANNOT_WIN`, `HOPE`) judged at its start, before any evaluation. Its
    refit starts at the base fit, where the Gauss-Newton decrease over the base columns
    and the family's is the base's own (its fit's, no evaluation) plus the family's
    predicted drop (the score test's, over the shapes it would be refitted with); `HOPE`
    times that stays below `CANNOT_WIN` x `joint` x `lead`. A family also started at a
    large share of its bound (`large_starts`: beyond the linear model) is refitted.
    Measured on 4 records far from the data (refit's drop against the predicted one:
    a 6 um screw error, the sensor 25,328 against 28,122, the drifts 120,600 against
    117,050 and 64,791 against 71,668; a 4 um screw with damping, the sensor 10,480
    against 10,034): no refit beat its prediction by more than 1.06x but the leader's
    (the screw 708,614 against 430,070), and the sensor's refit needs a program of its
    own (about 18 s CPU to build)."""
    if not (fx.base.misfit and lead > 0):
        return False
    options, starts = _options(fx, sc)
    predicted = [option.chi2_predicted for option, _ in options]
    if len(starts) > 1 or not (np.all(np.isfinite(predicted)) and np.isfinite(sc.p_value)):
        return False
    own = fx.base.own_decrease
    return (np.isfinite(own)
            and HOPE * (own + max(predicted)) < CANNOT_WIN * fx.opts.joint * lead)


def _started(fx: Fits, sc: FamilyScore, cols, prior, target, wide: bool
             ) -> tuple[FamilyRefit, list[FamilyRefit]]:
    """`refit_family`'s fits of the family of `sc` over the model columns `cols` from each
    shape and start of `_options` (`wide`: those of a base far from the data, each fit
    started damped from the base or a start of its own); the best (`_better`) and every
    one tried."""
    f, model, z_base, G = sc.family, fx.base.model, fx.base.z, fx.prep.G
    refit_evals = fx.opts.refit_evals
    options, starts = _options(fx, sc, wide)
    if any(sensor for _, sensor in options):  # its program compiles while others refit
        fx.prep.warm["evaluate", True].result()
    best, tried = None, []
    for (option, sensor), start in itertools.product(options, starts):
        shape = option.shape
        aim = target
        if (wide and best is not None and best.unphysical is None
                and f.name != "drive_periodic_error"):
            # a later start is kept only if it beats the family's best so far (the
            # screw's starts are each continued as one screw: `_shared_screw`)
            aim = best.fit.rss if aim is None else min(aim, best.fit.rss)
        z1 = z_base.copy()
        step_cols = model.cols(f)
        if f.per_record:
            step_cols = step_cols.reshape(G, -1)[:, :2].ravel()
        if f.name == "sensor_lowpass":  # from the kernel's best probe
            z1[step_cols] = fx.ranking.sensor_probe.get(shape, fx.opts.sensor_probe)
        elif start is not None:
            z1[model.cols(f)[0]] = start
        elif not wide:  # from the score step
            z1[step_cols] += option.step
        s1 = SubProblem(model, z1, cols, shape, sensor, prior)
        try:
            # from a bent base the Gauss-Newton step overshoots: start damped and judge
            # the stall over 8 accepted steps (the first gain little while the damping falls)
            fit = s1.solve(z1[cols], max_evals=refit_evals, lam0=1.0 if wide else 1e-6,
                           stall_evals=8 if wide else 4, target=aim)
        except ValueError:  # the score step left the simulator's domain
            s1 = SubProblem(model, z_base, cols, shape, sensor, prior)
            fit = s1.solve(z_base[cols], max_evals=refit_evals, target=aim)
        one = judge(fx, f, shape, fit, sensor, s1)
        tried.append(one)
        if _better(one, best):
            best = one
    return best, tried


def refit_family(fx: Fits, sc: FamilyScore, lead: float = 0.0) -> FamilyRefit:
    """The family of `sc` refitted with the base: the sensor with its two kernels whose
    secants predicted the largest drops, the screw error with its three best pitches, the
    others with their best shape; a physical fit beats an unphysical one, then the lower
    chi-square wins. Far from the data, each fit stops once it cannot lower chi-square by
    `CANNOT_WIN` x `joint` x `lead` (the largest drop so far). Near the data, a one-sided
    family whose fit from its score step ends unphysical is also fitted from the shapes
    and starts of a base far from the data."""
    f, model, z_base = sc.family, fx.base.model, fx.base.z
    misfit, refit_evals, base_rss = fx.base.misfit, fx.opts.refit_evals, fx.base.fit.rss
    target = base_rss - CANNOT_WIN * fx.opts.joint * lead if misfit and lead > 0 else None
    cols = np.concatenate([fx.base.cols, model.cols(f)])
    prior = prior_of(fx, cols)
    best, tried = _started(fx, sc, cols, prior, target, misfit)
    if (best.unphysical is not None and not misfit and f.signs[0] > 0
            and f.name != "sensor_lowpass"):
        # a refit from the score step may end beyond the family's sign or bound where
        # another shape or a start at a share of its bound ends physical (measured: a
        # Stribeck drop beside a 12 um screw on C, 8 records: after the screw its refit
        # from the score step ended unphysical at chi-square -8,391, and load coupling
        # was named in its place)
        again, more = _started(fx, sc, cols, prior, target, True)
        tried += more
        if _better(again, best):
            best = again
    if f.name == "drive_periodic_error" and misfit:
        best = _shared_screw(fx, f, cols, tried, best, target)
    if best.fit.rss > base_rss:
        # every start ended above the base fit (a score step or a large start into a
        # basin the solver cannot leave; measured: load coupling "lowered" chi-square by
        # -1.2e6 to -1.8e7 on the slow guard's damping and Stribeck campaigns): once more
        # from the base itself, the family at its no-effect value, where the solver
        # cannot end worse than the base (closer to the base wins even if unphysical:
        # above it, neither is a result)
        s1 = SubProblem(model, z_base, cols, best.shape, best.sensor, prior)
        try:
            fit = s1.solve(z_base[cols], max_evals=refit_evals, target=target)
            one = judge(fx, f, best.shape, fit, best.sensor, s1)
            tried.append(one)
            if one.fit.rss < best.fit.rss:
                best = one
        except ValueError:
            pass
    if best.fit.rss > base_rss + 1e-6 * max(base_rss, 1.0):
        best.failed = (f"the refit ended {best.fit.rss - base_rss:.4g} above the base "
                       f"fit's chi-square from every start ({len(tried)} starts; "
                       f"{best.fit.n_evals} evaluations in the best), so it says nothing "
                       "about the family")
    return best


def refine_shape(fx: Fits, rf: FamilyRefit) -> tuple[FamilyRefit, int]:
    """A local search over the family's continuous shape parameters
    (`cycle_effects.neighbour_shapes`), each shape a short polish from the best fit so
    far; returns the best physical refit and the number of short refits tried."""
    refined, tried = rf, 0
    while tried < fx.opts.refine_fits:
        better = None
        for shape_ in neighbour_shapes(refined.family, refined.shape):
            if tried >= fx.opts.refine_fits:
                break
            tried += 1
            sub_ = dataclasses.replace(refined.sub, shape=shape_)
            try:
                # a shape is worth its polish only if it can end below the best so far
                fit_ = sub_.solve(refined.fit.z, max_evals=fx.opts.refit_evals, lam0=1e-3,
                                  stall_evals=8, target=(better or refined).fit.rss)
            except ValueError:  # this shape leaves the simulator's domain
                continue
            one = judge(fx, refined.family, shape_, fit_, refined.sensor, sub_)
            if one.unphysical is None and one.fit.rss < (better or refined).fit.rss:
                better = one
        if better is None:
            break
        refined = better
    return refined, tried


def continued(fx: Fits, rf: FamilyRefit, w=None, evals=None, margin=0.0) -> FamilyRefit | None:
    """`rf`'s problem solved on from its fit (its residuals and Jacobian there reused), or
    from `w` (stopped once it cannot end `margin` below `rf`: `HOPE`); `evals` evaluations,
    default `max_evals`: the physical result if it lowers chi-square by more than
    `margin`, else None."""
    evals = fx.opts.max_evals if evals is None else evals
    here = w is None
    try:
        more = rf.sub.solve(rf.fit.z if here else w, max_evals=evals, lam0=1e-3,
                            stall_evals=8, first=(rf.fit.r, rf.fit.J, rf.fit.ok) if here else None,
                            target=None if here else rf.fit.rss - margin)
    except ValueError:  # the start left the simulator's domain
        return None
    one = judge(fx, rf.family, rf.shape, more, rf.sensor, rf.sub)
    if w is not None:
        logger.debug(f"restart {rf.family.name} from "
                     f"{friction_values(rf.sub.full(w))}: chi2 -{one.drop:.0f}, "
                     f"{more.n_evals} evaluations"
                     f"{' (stopped: cannot win)' if more.stats.get('hopeless') else ''}, "
                     f"{one.unphysical or 'physical'}, at "
                     f"{friction_values(rf.sub.full(more.z))}")
    return one if one.unphysical is None and more.rss < rf.fit.rss - margin else None


def refit(fx: Fits, *, clock: Clock) -> Refitted:
    """The significant families refitted (module doc of `cycle_workflow`, stage 4), then
    the other significant ones when none is physical, then every contender with nominal
    evidence."""
    scores, significant = fx.ranking.scores, fx.ranking.significant
    to_refit = (sorted(scores, key=lambda s: -s.chi2_predicted) if fx.base.misfit
                else significant[:fx.opts.top])
    if fx.base.sensor or (not fx.base.misfit and "sensor_lowpass" in {
            sc.family.name for sc in scores if sc in to_refit or sc in significant
            or np.nan_to_num(sc.p_value, nan=1.0) < fx.opts.alpha}):
        # a refit with the sensor may come (below): its program compiles meanwhile (far
        # from the data the sensor's refit may be skipped, `cannot_win`: its program is
        # built when the refit comes)
        fx.prep.warm["evaluate", True].start()
    # the winner: the physical refit that lowers chi-square most among the families the
    # calibrated test let through (the first refits, and contenders that are significant
    # themselves: a significant family ranked below `top` by its p-value may explain most)
    eligible = frozenset({sc.family.name for sc in significant}
                         | {sc.family.name for sc in to_refit})
    refits, skipped = [], []

    def more_refits(scores_):  # each refit knows the lead so far (`refit_family`)
        made = []
        for sc in scores_:
            lead = max([rf.drop for rf in ranked_refits(refits)
                        if rf.family.name in eligible], default=0.0)
            if cannot_win(fx, sc, lead):
                skipped.append(sc.family.name)
                continue
            made.append(refit_family(fx, sc, lead))
            refits.append(made[-1])
        return made

    more_refits(to_refit)
    clock("refit", ", ".join([said(rf) for rf in refits] + [
        f"{name} not refitted (cannot win)" for name in skipped]) or "nothing to refit")
    physical = ranked_refits(refits)
    if not physical:
        # none of the `top` refits is physical: the other significant families are
        # refitted before the gap is called unexplained (measured: a 5 um screw on C,
        # significant by its predicted drop of 2.7 k, ranked below three slip-shape
        # families of drops 23-54 by their p-values, all three unphysical or diverged)
        done = {rf.family.name for rf in refits} | set(skipped)
        more = [sc for sc in significant if sc.family.name not in done]
        if more:
            clock("refit", "the next significant: " + ", ".join(
                said(rf) for rf in more_refits(more)))
            physical = ranked_refits(refits)
    if physical:
        # contenders: every family with nominal evidence (robust p < alpha without the
        # family-wise adjustment, or significant beyond `top`) is refitted too, so that
        # the winner is compared with each family that might explain the same residual;
        # the winner stays one of the families the calibrated test let through (a
        # contender that explains more can only make the answer uncertain or joint)
        done = {rf.family.name for rf in refits} | set(skipped)
        extra = [sc for sc in scores if sc.family.name not in done
                 and (sc in significant
                      or np.nan_to_num(sc.p_value, nan=1.0) < fx.opts.alpha)]
        if extra:
            clock("contenders", ", ".join(said(rf) for rf in more_refits(extra)))
    return Refitted(refits=refits, eligible=eligible)
