"""Discovery's cost: compiled programs built only when a stage needs them (`cycle_model`), fits
stopped once they cannot win (`refit`, `subproblems`)."""

from __future__ import annotations

import threading

from stickslip_fitting.discovery.cycle_model import Later


def test_a_later_program_compiles_only_once_asked_for():
    calls = []
    started = threading.Event()

    def compile_(x):
        started.set()
        calls.append(x)
        return 2 * x

    later = Later(compile_, 3)
    assert not started.wait(0.05) and calls == []  # nothing runs until a stage asks
    assert later.start() is later
    assert later.result() == 6 and calls == [3]
    assert later.start().result() == 6 and calls == [3]  # once, however often asked


def test_a_cancelled_program_is_never_started_but_still_answers():
    calls = []
    later = Later(lambda: calls.append(1) or "program")
    assert later.cancel()
    later.start()
    assert calls == []
    assert later.result() == "program" and calls == [1]  # asked for after all: run then


def test_a_family_that_cannot_win_far_from_the_data_is_not_refitted():
    """`refit.cannot_win`: far from the data, a family whose refit could not reach the
    stop rule's target even with `HOPE` times its Gauss-Newton decrease at the start (the
    base's own, none at a converged base, plus the score's predicted drop) is skipped; a
    family with large starts, near the data, or before any lead is refitted."""
    from types import SimpleNamespace as NS

    import numpy as np

    from stickslip_fitting.discovery.cycle_effects import family
    from stickslip_fitting.discovery.options import DEFAULTS
    from stickslip_fitting.discovery.stages.refit import CANNOT_WIN, cannot_win
    from stickslip_fitting.discovery.stages.state import Base
    from stickslip_fitting.discovery.subproblems import HOPE

    def NS_base(**kw):  # a stand-in base with its own decrease as `Base` computes it
        b = NS(**kw)
        b.own_decrease = Base.own_decrease.func(b)
        return b

    J = np.eye(3)
    base = NS_base(misfit=True, sensor=False, fit=NS(J=J, r=np.zeros(3)))  # converged
    fx = NS(base=base, opts=DEFAULTS, ranking=NS(shape_scores={}))
    lead = 1e6
    edge = CANNOT_WIN * DEFAULTS.joint * lead / HOPE  # the predicted drop that could win

    def score(name, predicted):
        return NS(family=family(name), shape=None, chi2_predicted=predicted, p_value=1e-3)

    assert cannot_win(fx, score("sensor_lowpass", 0.9 * edge), lead)
    assert not cannot_win(fx, score("sensor_lowpass", 1.1 * edge), lead)
    assert not cannot_win(fx, score("sensor_lowpass", 0.9 * edge), 0.0)  # no lead yet
    assert not cannot_win(fx, score("stribeck", 0.0), lead)  # also from large starts
    # the base's own decrease counts: a base that has chi-square left to gain
    bent = NS(base=NS_base(misfit=True, sensor=False, fit=NS(J=J, r=np.full(3, np.sqrt(edge)))),
              opts=DEFAULTS, ranking=fx.ranking)
    assert not cannot_win(bent, score("sensor_lowpass", 0.0), lead)
    near = NS(base=NS_base(misfit=False, sensor=False, fit=base.fit), opts=DEFAULTS,
              ranking=fx.ranking)
    assert not cannot_win(near, score("sensor_lowpass", 0.0), lead)


def test_a_fit_too_slow_for_its_target_stops():
    """`subproblems.PACE`: a fit whose Gauss-Newton decrease keeps promising its whole
    chi-square (so `HOPE` never judges) but which gains one unit an evaluation stops once
    twice that pace over the evaluations left cannot reach its target; a target its
    budget reaches leaves the fit as it is."""
    import numpy as np

    from stickslip_fitting.discovery.subproblems import PACE_AFTER, AbstractProblem

    class Slow(AbstractProblem):  # chi-square 100, 99, 98, ...: one unit an evaluation
        def __init__(self):
            self.calls = 0

        def evaluate(self, z):
            self.calls += 1
            return np.array([np.sqrt(101.0 - self.calls)]), np.ones((1, 1)), True

    kw = dict(max_evals=20)
    free = Slow().solve(np.zeros(1), **kw)
    assert free.n_evals == 20 and free.rss == 81.0 and not free.converged
    reached = Slow().solve(np.zeros(1), target=85.0, **kw)
    assert reached.rss == free.rss and not reached.stats.get("hopeless")
    p = Slow()
    stopped = p.solve(np.zeros(1), target=70.0, **kw)
    # after n evaluations the best is 101 - n; 2 x 1 x (20 - n) below it misses 70 from n = 10
    assert stopped.stats["hopeless"] and p.calls == 10 > PACE_AFTER
    assert stopped.rss == 91.0
