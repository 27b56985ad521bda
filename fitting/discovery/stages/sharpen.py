"""Stage 4b of the per-cycle discovery, far from the data only: the close refits' shapes
refined, their fits continued, and restarted from the start's friction before the
decision compares them (`cycle_workflow`, module doc)."""

from __future__ import annotations

import numpy as np

from ..cycle_effects import neighbour_shapes
from ..decision import rms_gap
from ..starts import lift_mu_d
from .refit import ranked_refits, continued, refine_shape
from .state import Clock, Fits, Refitted

__all__ = ["sharpen"]


def _close(refits, eligible) -> list:
    """The physical refits of eligible families, the largest drop first."""
    return [rf for rf in ranked_refits(refits) if rf.family.name in eligible]


def _leaders(fx: Fits, close: list) -> list:
    """The close refits worth continuing and restarting: in a later search (an effect
    named) the leader only, whose fit the gap after and the estimates are read from.
    There every refit first regains what the named effects' freed coordinates leave of
    the extended base (a named screw's per-record coefficients), so the contenders'
    budgets end alike and short of their optima, and continuing and restarting them (30
    and up to 4 x 60 evaluations each) changed no answer (measured: 315 of 1,842 model
    calls on 4 records with a 6 um screw error, the same answer; on the rates guard's 12
    effect and outside campaigns every answer, confidence and gap the same)."""
    return close[:1] if fx.base.held else close


def _gap_of(fx: Fits, rf) -> float:
    """The refit's gap (mm) over the described records."""
    described = fx.base.described
    return rms_gap(rf.fit.r[:fx.base.n][described], fx.base.sd[described],
                   fx.base.samples[described])


def _refine_close(fx: Fits, refits: list, eligible, shaped: set, clock: Clock) -> None:
    """Far from the data the grid shapes decide between families (a rational Stribeck
    curve against the exponential grid lost to a per-record screw on C): the physical
    refits within reach of the best (drop >= `joint` of it) with a shape to refine are
    refined before the choice (`refine_contenders` at most). Updates `refits`, `shaped`."""
    close = _close(refits, eligible)
    if not (len(close) > 1 and _gap_of(fx, close[0]) > fx.opts.refine_gap * fx.base.noise):
        return
    lead = close[0].drop
    for rf in close[:fx.opts.refine_contenders]:
        if rf.drop < fx.opts.joint * lead or not neighbour_shapes(rf.family, rf.shape):
            continue
        better, tried = refine_shape(fx, rf)
        shaped.add(rf.family.name)
        if better is not rf:
            refits[refits.index(rf)] = better
            clock("shape", f"{rf.family.name} {better.shape.label(better.family)} "
                           f"(from {rf.shape.label(rf.family)}), chi2 -{better.drop:.0f}, "
                           f"{tried} short refits")


def _restart_due(fx: Fits, close: list, rf) -> bool:
    """Whether `_restart_close` starts the close refit `rf` again: one of the first
    `refine_contenders`, a drop from `joint` of the lead, a gap above `refine_gap` x the
    noise."""
    return (any(rf is c for c in close[:fx.opts.refine_contenders])
            and rf.drop >= fx.opts.joint * close[0].drop
            and _gap_of(fx, rf) > fx.opts.refine_gap * fx.base.noise)


def _continue_close(fx: Fits, refits: list, eligible, clock: Clock) -> set:
    """Far from the data the refits' budget (`refit_evals`) ends some of them short of
    their optimum, and the decision would compare where each stopped: the close ones
    (drop >= `joint` of the lead) are continued first (measured: a friction drift of
    2e-5/s on A stopped at a drop of 18870 and lost "clearly", z 3.1, to a per-record
    screw error at 27928; continued, it lowers chi-square by 27965). A refit that
    `_restart_close` starts again is continued there, only where no restart lowers its
    chi-square: the restarts replace its friction, and its own continuation gained
    little beside them (measured, 12 records: a 6 um screw error's refit -8,144,900 ->
    -8,145,932 over 26 evaluations, restarted -11,458,134; with a damping ratio of 0.1
    and a 4 um screw error -970,946 -> -971,573 over 30, restarted -999,562). Updates
    `refits`; returns the families left to `_restart_close`."""
    close = _leaders(fx, _close(refits, eligible))
    lead = close[0].drop if close else 0.0
    polished_, later = [], set()
    for rf in close:
        if rf.drop < fx.opts.joint * lead or rf.fit.converged:
            continue
        if _restart_due(fx, close, rf):
            later.add(rf.family.name)
            continue
        _continue_one(fx, refits, rf, polished_)
    if polished_:
        clock("continue", ", ".join(polished_))
    return later


def _continue_one(fx: Fits, refits: list, rf, polished_: list) -> None:
    """`rf` continued from its own fit (`continued`): where that succeeds it replaces
    `rf` in `refits` and its progress line joins `polished_`."""
    one = continued(fx, rf)
    if one is not None:
        refits[refits.index(rf)] = one
        polished_.append(f"{one.family.name} chi2 -{one.drop:.0f} (was "
                         f"-{rf.drop:.0f}, {one.fit.n_evals} more evaluations)")


def _restart_points(fx: Fits, rf) -> list[np.ndarray]:
    """Where a close refit starts again: the start's friction with the effect at its
    fitted size, at `large_starts` of its bound, and (per record) at none of it; its own
    fit with mu_d lifted off 0 (`lift_mu_d`); each with the offsets of that friction."""
    model = fx.base.model
    f, k = rf.family, len(model.cols(rf.family))
    ws = [np.array(rf.fit.z, float)]
    if f.signs[0] > 0 and not f.per_record and f.name != "sensor_lowpass":
        for frac in fx.opts.large_starts:
            w = np.array(rf.fit.z, float)
            w[-k] = frac * f.bound[0] / f.scales[0]
            ws.append(w)
    if f.per_record:
        # a per-record family fitted in the bent basin carries the bend in its
        # coefficients: also from none of the effect (measured: a 15 um screw error on
        # A, from the features' friction with no screw error, 0.535 um against 0.5 um
        # noise; from the refit's coefficients, 0.63 um)
        ws.append(rf.sub.without_effect(rf.fit.z, k))
    for w in ws:
        w[:6] = lift_mu_d(fx.prep.z_start[:6])
    here = lift_mu_d(rf.fit.z[:6])
    if not np.array_equal(here, rf.fit.z[:6]):
        # and from its own fit, mu_d lifted off 0 (`lift_mu_d`)
        ws.append(np.array(rf.fit.z, float))
        ws[-1][:6] = here
    for w in ws:
        # with the offsets of that friction (`CycleModel.breakaway_offsets`)
        w[6:model.n_base] = model.breakaway_offsets(w[:6], w[6:model.n_base])
    return ws


def _restart_close(fx: Fits, refits: list, eligible, shaped: set, clock: Clock,
                   later: set = frozenset()) -> None:
    """A large effect bends the base friction and the refits start there: the close
    contenders that still leave more than `refine_gap` x the noise are refitted from the
    friction the base started from (the features fit), before the decision compares them
    (measured: a rational Stribeck drop b = 0.2 on A, the right shape, ended with mu_d 0,
    n 0 and delta infinite, gap after 18.5x the noise). A refit of `later` (its
    continuation left to the restarts, `_continue_close`) that no restart improves is
    continued from its own fit. Updates `refits`, `shaped`."""
    close = _leaders(fx, _close(refits, eligible))
    fresh_, polished_ = [], []
    for rf in list(close):
        restart = _restart_due(fx, close, rf)
        best_ = rf
        for w in _restart_points(fx, rf) if restart else ():
            one = continued(fx, best_, w, 2 * fx.opts.max_evals, margin=1.0)
            best_ = one if one is not None else best_
        if best_ is not rf:
            refits[refits.index(rf)] = best_
            # a shape refined in the bent basin is refined again from here
            shaped.discard(rf.family.name)
            fresh_.append(f"{rf.family.name} chi2 -{best_.drop:.0f} (was -{rf.drop:.0f})")
        elif rf.family.name in later:
            _continue_one(fx, refits, rf, polished_)
    if fresh_:
        clock("restart", "from the start's friction: " + ", ".join(fresh_))
    if polished_:
        clock("continue", ", ".join(polished_))


def sharpen(fx: Fits, refitted: Refitted, *, clock: Clock) -> Refitted:
    """Far from the data (`Base.misfit`), the close refits made comparable before the
    decision: shapes refined, fits continued, restarts from the start's friction. Near
    the data the refits are handed on as they are."""
    if not fx.base.misfit:
        return refitted
    refits, eligible, shaped = list(refitted.refits), refitted.eligible, set()
    _refine_close(fx, refits, eligible, shaped, clock)
    later = _continue_close(fx, refits, eligible, clock)
    _restart_close(fx, refits, eligible, shaped, clock, later)
    return Refitted(refits=refits, eligible=refitted.eligible, shaped=frozenset(shaped))
