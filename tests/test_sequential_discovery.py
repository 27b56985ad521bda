"""The sequential search of the per-cycle discovery (`discovery.stages.more`): after an
effect is named it joins the model and the search runs again, until nothing
significant remains. A campaign of the independent generator with two effects at once
names both, with a staircase of falling gaps in the JSON, the explanation and the
figure; `--max-effects 1` gives the single best effect. The one-effect and clean
campaigns of `test_cycle_discovery.py` run with the default (3 effects) and check that
no second effect (a shadow of the first) and no effect at all are named there.

`python tests/test_sequential_discovery.py [SEEDS] [--reduced]` prints a row per pair
campaign (slow; `--reduced`: 4 records each).
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))
import independent_records as ir  # noqa: E402

SMALL = dict(runs=((36.0, 86.9), (20.0, 27.3)), speeds=(5.0, 10.0), cycles=5.0)
TWO = dict(physics=ir.Physics(damping_ratio=0.15),
           imp=ir.Imperfections(screw_amp_mm=0.004))
"""A small campaign with a damping ratio and a lead-screw error at once."""
CHEAP = dict(runs=((20.0, 27.3),), speeds=(5.0, 10.0), cycles=5.0)
THREE = ("viscous_damping", "drive_periodic_error", "friction_drift")
"""The default run's campaign: two of `SMALL`'s records, three candidate families (the
two effects and a drift that stands in for the screw)."""


def kept(res) -> list[str]:
    return [s["effect"] for s in res.steps if s["kept"]]


@pytest.fixture(scope="module")
def two_effects():
    from stickslip_fitting.discovery.cycle_workflow import discover_cycles

    return discover_cycles(ir.campaign(seed=12, **CHEAP, **TWO), candidates=THREE)


@pytest.mark.slow
def test_two_effects_are_both_named_among_every_family():
    """`SMALL` over the whole library: the screw, then the damping, then nothing
    significant."""
    from stickslip_fitting.discovery.cycle_workflow import discover_cycles

    res = discover_cycles(ir.campaign(seed=12, **SMALL, **TWO))
    assert set(kept(res)) == {"viscous_damping", "drive_periodic_error"}, res.explanation
    gaps = [res.gap_before] + [s["gap_after"] for s in res.steps if s["kept"]]
    assert all(b < a for a, b in zip(gaps, gaps[1:])), gaps
    assert res.gap_after < 0.5 * res.gap_before


def test_two_effects_make_a_staircase(two_effects):
    """The sequential search's output on a small campaign (`CHEAP`, `THREE`): both
    effects named one after another, a staircase of falling gaps in the JSON, the
    explanation and the figure, the first effect tested again given the second."""
    res = two_effects
    assert set(kept(res)) == {"viscous_damping", "drive_periodic_error"}, res.explanation
    # the staircase: every step lowers the gap, and the JSON says so
    gaps = [res.gap_before] + [s["gap_after"] for s in res.steps if s["kept"]]
    assert all(b < a for a, b in zip(gaps, gaps[1:])), gaps
    assert res.gap_after < 0.5 * res.gap_before
    doc = res.to_json()
    assert doc["effect"] == kept(res)[0]  # the first effect kept
    for step in doc["steps"]:
        assert {"effect", "shape", "values", "stderr", "gap_after", "p_family",
                "confidence", "dropped", "kept"} <= set(step)
    assert res.effect_of == kept(res)[0]
    # every effect's parameters after the fit, as "family.parameter"
    prefixes = {k.split(".")[0] for k in res.parameters_after if "." in k}
    assert set(kept(res)) <= prefixes, res.parameters_after
    for name in kept(res):
        assert name in res.explanation
    # each search's stages are timed under their own names, reusing the programs
    assert any(k.endswith(", effect 2") for k in res.timings), res.timings
    # the first effect was tested again given the second (drop-one) and kept
    assert "drop-one, effect 2" in res.timings and not res.steps[1]["dropped"]
    # the figure: a staircase panel of the gap after each step, with the noise line
    fig = res.figure()
    stair = [ax for ax in fig.axes if any(t.get_text().startswith("+ ")
                                           for t in ax.get_xticklabels())]
    assert stair and len(stair[0].get_xticklabels()) == 1 + len(res.steps)


def test_max_effects_is_checked_before_any_fit(capsys):
    from stickslip_jax.cli import main

    assert main(["discover", "nothing*.csv", "--max-effects", "0"]) == 2
    assert "--max-effects: must be at least 1" in capsys.readouterr().err
    import stickslip_fitting as sf

    with pytest.raises(ValueError, match="max_effects"):
        sf.discover(["a.csv", "b.csv"], max_effects=0)


def test_with_shape_keeps_the_named_effects_settings():
    from stickslip_fitting.discovery.cycle_effects import Shape, family
    from stickslip_fitting.discovery.subproblems import with_shape

    held = Shape(damping="ratio", pitch=2.5)
    s = with_shape(held, family("stribeck"), Shape(vs=3.0, p=2.0, form="rational"))
    assert (s.damping, s.pitch, s.vs, s.p, s.form) == ("ratio", 2.5, 3.0, 2.0, "rational")
    assert with_shape(held, family("gauge_drift"), Shape(vs=1.0)) == held


def test_a_later_effect_joins_only_when_its_refit_confirms_it():
    """The refit's chi-square drop must pass the chi-square quantile at alpha for its
    parameter count, scaled by the extended base's chi2/n above 1, and remove a share of the
    excess chi-square over the noise (`more.confirmed`)."""
    import types

    from scipy.stats import chi2

    from stickslip_fitting.discovery.stages.more import confirmed

    base = types.SimpleNamespace(fit=types.SimpleNamespace(rss=3500.0), within=0.0,
                                 n_used=100)  # chi2/n 35: a campaign far from the model
    level = 35.0 * chi2.ppf(0.99, 2)
    for drop, ok in ((0.0, False), (0.99 * level, False), (1.01 * level, True)):
        rf = types.SimpleNamespace(drop=drop, values=np.zeros(2))
        assert confirmed(base, rf, 0.01) is ok
    near = types.SimpleNamespace(fit=types.SimpleNamespace(rss=90.0), within=0.0, n_used=100)
    rf = types.SimpleNamespace(drop=1.01 * chi2.ppf(0.99, 2), values=np.zeros(2))
    assert confirmed(near, rf, 0.01)  # chi2/n below 1: the plain quantile
    # significant but irrelevant: chi2/n 100, the drop passes its level (921) but removes
    # 1 % of the excess over the noise, below a 5 % share (the option's default: 3 %)
    far = types.SimpleNamespace(fit=types.SimpleNamespace(rss=1e6), within=0.0, n_used=10_000)
    for drop, ok in ((0.01 * 990_000, False), (0.06 * 990_000, True)):
        rf = types.SimpleNamespace(drop=drop, values=np.zeros(2))
        assert confirmed(far, rf, 0.01) and confirmed(far, rf, 0.01, 0.05) is ok


def test_a_later_effect_pays_for_its_flexibility():
    """The confirmation level is raised by the family's price (`decide.price_of`: ln n per
    parameter, times chi2/n above 1): a per-record screw of 16 coefficients on 4 records
    needs a drop 16 ln n above its chi-square quantile, a one-parameter family ln n."""
    import types

    from scipy.stats import chi2

    from stickslip_fitting.discovery.stages.decide import price_of
    from stickslip_fitting.discovery.stages.more import confirmed, level

    base = types.SimpleNamespace(fit=types.SimpleNamespace(rss=20_000.0), within=0.0,
                                 n_used=20_000)
    assert np.isclose(price_of(base, 16), 16 * np.log(20_000))
    assert np.isclose(price_of(base, 0), np.log(20_000))  # at least one parameter
    screw = types.SimpleNamespace(drop=chi2.ppf(0.99, 16) + 100.0, values=np.zeros(16))
    assert confirmed(base, screw, 0.01)
    assert not confirmed(base, screw, 0.01, 0.0, price_of(base, 16))
    one = types.SimpleNamespace(drop=level(base, 1, 0.01) + 11.0, values=np.zeros(1))
    assert confirmed(base, one, 0.01, 0.0, price_of(base, 1))


def test_a_later_effect_far_below_the_noise_is_not_named():
    """A later effect's size is the change of the traces when its parameters are set to
    zero at its refit, as the RMS per sample in units of the samples' standard errors over
    each phase (sticks, slips) of the described records, the larger of the two
    (`more.trace_size`); below `more.SMALLEST` the search stops (610, 612: a screw of
    0.01-0.04 um after a sensor and the damping, 0.79 and 0.61 in the slips;
    618: a Stribeck drop after a screw, 1.41 in the slips, is named)."""
    import types

    from stickslip_fitting.discovery.stages.more import SMALLEST, trace_size
    from stickslip_fitting.discovery.thinning import Samples

    shape = object()

    def residuals(z, shape_, sensor=False):  # whitened: 2 records of 4 residuals, the
        assert shape_ is shape  # family at z[1:5]: its stick part z[1], its slip part z[2]
        return np.r_[z[1], z[1], z[2], z[2], z[3], z[3], z[4], z[4]] + 0.1 * sensor, None, True

    model = types.SimpleNamespace(residuals=residuals, cols=lambda f: np.array([1, 2, 3, 4]))
    # record 1: two stick bins of 9 samples each (whitened by the bin's standard error),
    # two slip samples; record 2 set aside
    base = types.SimpleNamespace(
        model=model, described=np.r_[np.ones(4, bool), np.zeros(4, bool)],
        slipping=np.tile([False, False, True, True], 2), noise=0.5e-3,
        samples=Samples(np.array([9, 9, 1, 1] * 2, float), np.zeros(8)))
    fx = types.SimpleNamespace(base=base)

    def rf(name, stick, slip, sensor=False, aside=9.0):
        z = np.array([3.0, stick, slip, aside, aside])
        return types.SimpleNamespace(family=types.SimpleNamespace(name=name), shape=shape,
                                     sensor=sensor, fit=types.SimpleNamespace(z=z),
                                     sub=types.SimpleNamespace(full=lambda z_: z_))

    # a bin's whitened change 0.6 is 0.2 per sample of its 9
    assert np.isclose(trace_size(fx, rf("drive_periodic_error", 0.6, 0.0)), 0.2)
    assert trace_size(fx, rf("drive_periodic_error", 0.6, 0.0)) < SMALLEST
    # an effect of the slips alone is measured over the slips (not diluted by the sticks'
    # 18 samples: 0.47 over all 20)
    assert np.isclose(trace_size(fx, rf("stribeck", 0.0, 1.5)), 1.5) and SMALLEST < 1.5
    assert np.isclose(trace_size(fx, rf("stribeck", 0.6, 1.5)), 1.5)
    assert np.isclose(trace_size(fx, rf("gauge_drift", 6.0, -0.3)), 2.0)
    # the sensor's own size: without it the traces are read without the low-pass
    assert np.isclose(trace_size(fx, rf("sensor_lowpass", 0.0, 0.0, sensor=True)), 0.1)
    assert np.isclose(trace_size(fx, rf("gauge_drift", 0.0, 0.0, sensor=True)), 0.0)


def test_a_later_effect_must_clearly_beat_its_physical_rivals():
    """A later effect meets every physical contender that explains a comparable share and
    that it does not clearly beat (`more.unbeaten_rival`, then `given_each_other`); an
    unphysical one, or a law of the same physics (rate-and-state beside a Stribeck drop),
    is no rival."""
    import types

    from stickslip_fitting.discovery.decision import Contender, decide
    from stickslip_fitting.discovery.stages.more import unbeaten_rival

    def choice(name, others):
        return types.SimpleNamespace(chosen=types.SimpleNamespace(
            family=types.SimpleNamespace(name=name)), decision=decide(162.0, others))

    shadow = Contender("stribeck", 88.0, 0.4, 1.2)
    assert unbeaten_rival(choice("load_coupling", [shadow])) is shadow
    assert unbeaten_rival(choice("load_coupling", [Contender("stribeck", 88.0, 0.4, 3.5)])
                          ) is None  # beaten clearly
    assert unbeaten_rival(choice("load_coupling", [Contender("stribeck", 40.0, 0.4, 1.2)])
                          ) is None  # not a comparable share
    assert unbeaten_rival(choice("viscous_damping", [
        Contender("stribeck", 120.0, 0.4, 1.2, physical=False)])) is None
    assert unbeaten_rival(choice("stribeck", [Contender("rate_state", 150.0, 0.5, 0.3)])) is None


def test_a_later_effect_and_its_rivals_are_tested_given_each_other(monkeypatch):
    """Where a later winner does not clearly beat a physical rival, each is tested at the
    other's refit (`more.given_each_other`): a winner still needed given the rival is
    named (the rival set aside, for the next search to test); where only the rival is
    needed it wins (if the calibrated test let it through) and meets the next rival;
    neither needed: that rival stays unsettled (the search stops)."""
    import types

    from stickslip_fitting.discovery.decision import Contender, decide
    from stickslip_fitting.discovery.options import DEFAULTS
    from stickslip_fitting.discovery.stages import more
    from stickslip_fitting.discovery.stages.state import Choice, Refitted

    def refit(name, drop):
        return types.SimpleNamespace(family=types.SimpleNamespace(name=name), drop=drop,
                                     unphysical=None, failed=None)

    lc, st = refit("load_coupling", 162.0), refit("stribeck", 88.0)
    rs = refit("rate_state", 90.0)
    every = Refitted(refits=[lc, st, rs], eligible=frozenset({"load_coupling", "stribeck",
                                                             "rate_state"}))
    # the contenders of each winner: z 0.8 (not clearly beaten) between all three
    monkeypatch.setattr(more, "_decided", lambda fx_, refits, win, aside: decide(
        win.drop, [Contender(rf.family.name, rf.drop, 0.4, 0.8) for rf in refits
                   if rf.family.name not in aside | {win.family.name}]))
    monkeypatch.setattr(more, "one_screw", lambda fx_, rf: rf)
    fx, clock = types.SimpleNamespace(opts=DEFAULTS), (lambda *a: None)

    def given(ps, refitted=every):
        monkeypatch.setattr(more, "needed_given", lambda fx_, one, at: (
            ps[one.family.name, at.family.name], 0.0))
        win = refitted.refits[0]
        choice = Choice(chosen=win, decision=more._decided(fx, refitted.refits, win, set()),
                        rivals=[], compared={}, decided_drop=win.drop)
        return more.given_each_other(fx, choice, refitted, clock)

    two = Refitted(refits=[lc, st], eligible=every.eligible)
    # only the rival is needed given the winner: it wins, no rival left
    out = given({("load_coupling", "stribeck"): 0.034, ("stribeck", "load_coupling"): 0.0037},
                two)
    assert out.chosen is st and more.unbeaten_rival(out) is None
    # the winner is needed given its rival, whether or not the rival is given it
    for p in (0.44, 1e-4):
        out = given({("load_coupling", "stribeck"): 1e-4, ("stribeck", "load_coupling"): p},
                    two)
        assert out.chosen is lc and more.unbeaten_rival(out) is None
    # neither needed: the rival stays
    out = given({("load_coupling", "stribeck"): 0.3, ("stribeck", "load_coupling"): 0.3}, two)
    assert out.chosen is lc and more.unbeaten_rival(out).name == "stribeck"
    # the rival needed but not let through by the calibrated test: unsettled
    out = given({("load_coupling", "stribeck"): 0.034, ("stribeck", "load_coupling"): 0.0037},
                Refitted(refits=[lc, st], eligible=frozenset({"load_coupling"})))
    assert out.chosen is lc and more.unbeaten_rival(out).name == "stribeck"
    # every rival in turn: rate-and-state only stood in for load coupling (set aside),
    # then the Stribeck drop is needed given load coupling and not the reverse
    out = given({("load_coupling", "rate_state"): 1e-4, ("rate_state", "load_coupling"): 0.5,
                 ("load_coupling", "stribeck"): 0.034, ("stribeck", "load_coupling"): 0.0037})
    assert out.chosen is st and more.unbeaten_rival(out) is None


def test_a_later_search_names_the_contender_that_explains_most():
    """In the first search the winner is a family the calibrated test let through; in a
    later one (the test has already found something) every physical contender with
    evidence of its own may win (`decide.choose`): a weak family that passed the test
    does not stand in for one that explains ten times more."""
    import types

    from stickslip_fitting.discovery.options import DEFAULTS
    from stickslip_fitting.discovery.stages.decide import choose
    from stickslip_fitting.discovery.stages.state import Refitted

    rng = np.random.default_rng(0)
    starts = np.arange(0, 40, 4)

    def refit(name, drop):
        return types.SimpleNamespace(
            family=types.SimpleNamespace(name=name), drop=drop, unphysical=None,
            failed=None, fit=types.SimpleNamespace(r=rng.normal(size=40),
                                                   z=np.zeros(9), converged=True),
            shape=None)

    sensor, stribeck = refit("sensor_lowpass", 20.0), refit("stribeck", 259.0)
    refitted = Refitted(refits=[sensor, stribeck], eligible=frozenset({"sensor_lowpass"}))

    def fx(held):
        base = types.SimpleNamespace(held=held, n=40, misfit=False, cols=np.arange(8),
                                     described=np.ones(40, bool),
                                     fit=types.SimpleNamespace(rss=40.0), within=0.0,
                                     n_used=40)
        scores = [types.SimpleNamespace(family=rf.family, direction=rng.normal(size=(40, 1)))
                  for rf in refitted.refits]
        return types.SimpleNamespace(opts=DEFAULTS, base=base, prep=types.SimpleNamespace(
            starts=starts), ranking=types.SimpleNamespace(scores=scores))

    clock = (lambda *a: None)
    assert choose(fx(()), refitted, clock=clock).chosen is sensor
    assert choose(fx(("viscous_damping",)), refitted, clock=clock).chosen is stribeck


def test_a_later_effect_of_the_same_slip_speed_physics_is_set_aside():
    """A later refit that describes again, in another law, the slip-speed dependence of an
    effect kept before is no further effect (`more.new_physics`): rate-and-state friction
    whose steady state rises with the slip speed (a > b) after a viscous damping; one
    that falls (b > a), a Stribeck drop's physics, remains a candidate, as does every
    family without a slip-speed dependence."""
    import types

    from stickslip_fitting.discovery.stages.more import new_physics, speed_sign
    from stickslip_fitting.discovery.stages.state import Refitted

    def refit(name, *values, unphysical=None):
        return types.SimpleNamespace(family=types.SimpleNamespace(name=name), drop=174.0,
                                     values=np.array(values), unphysical=unphysical)

    assert speed_sign("rate_state", [0.0038, 0.0009]) == 1  # velocity strengthening
    assert speed_sign("rate_state", [0.001, 0.004]) == -1  # velocity weakening
    assert (speed_sign("viscous_damping", [0.2]), speed_sign("stribeck", [0.06]),
            speed_sign("load_coupling", [0.1])) == (1, -1, 0)
    damping = types.SimpleNamespace(family=types.SimpleNamespace(name="viscous_damping"),
                                    values=np.array([0.1]), kept=True)
    refits = [refit("rate_state", 0.0038, 0.0009), refit("stribeck", 0.008),
              refit("load_coupling", 0.01)]
    said = []
    out = new_physics(Refitted(refits=refits, eligible=frozenset({"rate_state"})),
                      [damping], types.SimpleNamespace(say=said.append))
    assert [rf.family.name for rf in out.refits] == ["stribeck", "load_coupling"]
    assert "rate_state" in said[0] and "viscous_damping" in said[0]
    weakening = [refit("rate_state", 0.001, 0.004), refit("load_coupling", 0.01)]
    out = new_physics(Refitted(refits=weakening, eligible=frozenset()), [damping],
                      types.SimpleNamespace(say=said.append))
    assert out.refits == weakening
    # an effect dropped before is no longer in the model: nothing is set aside for it
    gone = types.SimpleNamespace(family=damping.family, values=damping.values, kept=False)
    out = new_physics(Refitted(refits=refits, eligible=frozenset()), [gone],
                      types.SimpleNamespace(say=said.append))
    assert out.refits == refits


def test_confirmed_effects_that_explain_the_records_are_not_replaced_by_a_form():
    """Several effects the sequential search confirmed, leaving at most `explained_gap` x
    the noise together, are the answer: no sparse form is fitted in their place
    (`stages.form.outside_form`); a single low-confidence family still meets it."""
    import types

    from stickslip_fitting.discovery.options import DEFAULTS
    from stickslip_fitting.discovery.stages.form import outside_form

    fx = types.SimpleNamespace(opts=DEFAULTS, base=types.SimpleNamespace(noise=0.5))
    assert outside_form(fx, "viscous_damping", "low", 0.51, several=True) == (None, False)
    assert outside_form(fx, "viscous_damping", "high", 0.9) == (None, False)
    with pytest.raises(AttributeError):  # the form is fitted (no records here)
        outside_form(fx, "viscous_damping", "low", 0.9, several=True)


def test_a_named_effects_shape_is_a_nuisance_of_the_later_tests():
    """The later searches' score tests project out the derivatives over the named
    effects' continuous shape parameters (`rank.shape_columns`): the Stribeck speed scale
    (relative step) and exponent (rational and exponential forms only), the screw pitch,
    the second-order sensor's damping ratio; none for a family without shape."""
    import types

    from stickslip_fitting.discovery.cycle_effects import Shape, family
    from stickslip_fitting.discovery.stages.rank import shape_columns

    t = np.linspace(0.0, 1.0, 50)

    def residuals(z, shape, sensor=False):  # depends on vs, p and the pitch
        return (np.exp(-t * shape.vs / 10.0) * shape.p + np.sin(t / shape.pitch), None, True)

    model = types.SimpleNamespace(residuals=residuals)
    shape = Shape(vs=10.0, p=2.0, form="rational", pitch=2.0)
    S = shape_columns(model, None, shape, False, (family("stribeck"),))
    assert S.shape == (50, 2)
    # d r / d ln vs and d r / d p, forward differences
    assert np.allclose(S[:, 0], -t * np.exp(-t) * 2.0, atol=0.05)
    assert np.allclose(S[:, 1], np.exp(-t), atol=1e-9)
    S = shape_columns(model, None, Shape(form="log"), False, (family("stribeck"),))
    assert S.shape == (50, 1)  # the logarithmic form has no exponent
    S = shape_columns(model, None, shape, False, (family("drive_periodic_error"),))
    assert np.allclose(S[:, 0], -np.cos(t / 2.0) * t / 2.0, atol=0.01)
    assert shape_columns(model, None, shape, False, (family("friction_drift"),)).size == 0


# -- rates over pairs of four common families (slow, targets) --

PAIRS_OF = {
    "viscous_damping": ("physics", {"A": {"damping_ratio": 0.2}, "C": {"damping_ratio": 0.3}}),
    "stribeck": ("physics", {"A": {"stribeck_b": 0.06}, "C": {"stribeck_b": 0.12}}),
    "drive_periodic_error": ("imp", {"A": {"screw_amp_mm": 0.002},
                                     "C": {"screw_amp_mm": 0.012}}),
    "sensor_lowpass": ("imp", {"A": {"sensor_order": 2, "sensor_hz": 20.0},
                               "C": {"sensor_order": 2, "sensor_hz": 12.0}}),
}
"""Four common families, each at about 3x the noise in the traces by itself
(`test_cycle_discovery_rates.CALIBRATED`'s small sizes, per lubricant). Each alone is
named at these sizes on the damping + Stribeck seeds (600-604, 12 records): the damping
at family-wise p 0.00025 on A (600, 604) and C (603) and 0.0045 on C (601, near the
limit), the Stribeck drop on A (600, 1.09 -> 1.05 x the noise) and C (601, 2.27 ->
1.03). Together damping and a Stribeck drop cancel in the slips' speed dependence: the
pair leaves 1.04-1.09 x the noise at the paper's model (docs/validation.md)."""
def counts_for(step: dict) -> set:
    """The families of `PAIRS_OF` an effect named (a step of the JSON's "steps") counts
    for: its own family; rate-and-state friction counts as the Stribeck drop only where
    its fitted steady state falls with the slip speed (evolution effect b above the
    direct effect a: a velocity-weakening friction, the Stribeck drop's physics). With
    a >= b its friction rises with the slip speed (a viscous damping's physics): it is
    then no name of a Stribeck drop, and the pair test counts it as another effect."""
    if step["effect"] != "rate_state":
        return {step["effect"]}
    a, b = (step["values"].get(k) for k in ("a", "b"))
    return {"stribeck"} if a is not None and b is not None and b > a else set()


def pair_campaigns(seeds: int = 5, first: int = 600):
    """`seeds` campaigns of every pair, seeds from `first`, lubricants A and C in turn."""
    names, out = list(PAIRS_OF), []
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            for s in range(seeds):
                lube = "AC"[len(out) % 2]
                phys, imp = {}, {}
                for n in (a, b):
                    kind, by_lube = PAIRS_OF[n]
                    (phys if kind == "physics" else imp).update(by_lube[lube])
                out.append(((a, b), first + len(out), ir.LUBRICANT_A if lube == "A"
                            else ir.LUBRICANT_C, dict(physics=ir.Physics(**phys),
                                                      imp=ir.Imperfections(**imp))))
    return out


REDUCED = dict(runs=SMALL["runs"], speeds=SMALL["speeds"])
"""The reduced pair campaigns (`--reduced`): 4 records instead of 12, as measured on a
loaded 2-core machine (docs/validation.md)."""


def run_pair(pair, seed, lube, kw, design=None):
    """One pair campaign: the effects kept, whether both families of `pair` are named and
    whether any other effect is (`counts_for`), the gaps over the noise (before, then
    after each step) and the seconds."""
    from stickslip_fitting.discovery.cycle_workflow import discover_cycles

    t = time.perf_counter()
    res = discover_cycles(ir.campaign(lube, seed=seed, cycles=4.0, **(design or {}), **kw))
    steps = [s for s in res.to_json()["steps"] if s["kept"]]
    counts = [counts_for(s) for s in steps]
    return dict(pair=pair, seed=seed, named=sorted(s["effect"] for s in steps),
                both=all(any(n in c for c in counts) for n in pair),
                third=len(steps) > 2 or any(not c & set(pair) for c in counts),
                gaps=[res.gap_before / res.noise] + [s["gap_after"] / res.noise
                                                     for s in res.steps],
                seconds=time.perf_counter() - t)


def test_rate_and_state_counts_as_a_stribeck_drop_only_where_it_weakens():
    """The pair test's counting (`counts_for`): a family counts for itself; rate-and-state
    friction for the Stribeck drop only where its steady state falls with the slip speed
    (b > a), else for no family of the pair (another effect named)."""
    def step(name, **values):
        return {"effect": name, "values": values}

    assert counts_for(step("viscous_damping", zeta=0.2)) == {"viscous_damping"}
    assert counts_for(step("rate_state", a=0.001, b=0.004)) == {"stribeck"}
    assert counts_for(step("rate_state", a=0.0038, b=0.0009)) == set()  # strengthening
    assert counts_for(step("rate_state", a=0.0084, b=-0.0022)) == set()
    assert counts_for(step("rate_state", a=None, b=0.004)) == set()  # not determined


@pytest.mark.slow
@pytest.mark.targets
def test_pairs_of_effects_are_both_named():
    """Every pair of four families, 5 campaigns each: both named in >= 80 %, no third
    (nor any other) effect named in >= 95 %."""
    rows = [run_pair(*c) for c in pair_campaigns()]
    for r in rows:
        print(r)
    assert np.mean([r["both"] for r in rows]) >= 0.8
    assert np.mean([not r["third"] for r in rows]) >= 0.95


if __name__ == "__main__":
    # `python tests/test_sequential_discovery.py [SEEDS] [--reduced] [--from=FIRST_SEED]`
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    first = [int(a.split("=")[1]) for a in sys.argv[1:] if a.startswith("--from=")]
    for c in pair_campaigns(int(args[0]) if args else 1, *first):
        print(run_pair(*c, REDUCED if "--reduced" in sys.argv else None), flush=True)
