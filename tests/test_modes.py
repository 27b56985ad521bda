"""Mode options are small str-valued enums: plain strings work too, a bad
value is refused once where it enters, JSON carries the value."""

from __future__ import annotations

import json

import pytest

from stickslip_jax.modes import GaugeOffset, SlipTime


def test_strings_and_members_are_interchangeable():
    assert SlipTime("paper") is SlipTime.PAPER
    assert SlipTime.parse(SlipTime.SELF_CONSISTENT) is SlipTime.SELF_CONSISTENT
    assert SlipTime.PAPER == "paper" and GaugeOffset.START == "start"
    # hashed like the string: a jit cache or a static field sees one value
    assert hash(SlipTime.PAPER) == hash("paper")
    assert {"start": 1}[GaugeOffset.START] == 1
    assert str(SlipTime.SELF_CONSISTENT) == f"{SlipTime.SELF_CONSISTENT}" == "self_consistent"
    assert json.dumps({"slip_time": SlipTime.PAPER}) == '{"slip_time": "paper"}'
    assert SlipTime.choices() == ("paper", "self_consistent")
    assert GaugeOffset.choices() == ("zero", "start")


def test_bad_values_name_the_argument_and_the_choices():
    with pytest.raises(ValueError, match=r"slip_time must be one of \('paper', 'self_consistent'\)"):
        SlipTime.parse("exact")
    with pytest.raises(ValueError, match="offset must be one of"):
        GaugeOffset.parse("middle", "offset")


def test_objectives_convert_once_when_built():
    import numpy as np

    from stickslip_fitting.combined import FeaturesObjective
    from stickslip_fitting.objectives import feature_data
    from stickslip_fitting.synthetic import synthetic_campaign
    from stickslip_fitting.features import record_features
    from stickslip_jax import lubricant

    records = synthetic_campaign(lubricant("A"), cycles=3, speed_fractions=(0.1,),
                                 conditions=((36.0, 40.0),), sample_rate=200.0)
    data = feature_data([record_features(r) for r in records])
    obj = FeaturesObjective(data, "self_consistent")
    assert obj.slip_time is SlipTime.SELF_CONSISTENT
    assert FeaturesObjective(data).slip_time is SlipTime.PAPER
    with pytest.raises(ValueError, match="slip_time must be one of"):
        FeaturesObjective(data, "bogus")
    assert json.loads(json.dumps(records[0].truth))["slip_time"] == "paper"
    assert np.isfinite(obj.dof())


def test_fitting_modes_accept_their_old_strings():
    from stickslip_fitting.modes import DesignCriterion, Objective
    from stickslip_jax.modes import Formulation

    assert Objective.choices() == ("features", "trace", "both", "smooth")
    assert DesignCriterion.choices() == ("D", "A")
    assert Formulation.choices() == ("rigid_stick", "velocity", "latch")
    for enum in (Objective, DesignCriterion, Formulation):
        for value in enum.choices():
            member = enum.parse(value)
            assert member is enum(value) and member == value and f"{member}" == value
            assert hash(member) == hash(value)
            assert json.dumps([member]) == json.dumps([value])
    assert [m.needs_records for m in Objective] == [False, True, True, True]
    import stickslip_fitting
    import stickslip_jax

    assert stickslip_fitting.Objective is Objective
    assert stickslip_fitting.DesignCriterion is DesignCriterion
    assert stickslip_jax.Formulation is Formulation


@pytest.mark.parametrize("enum_name, bad, message", [
    ("Objective", "samples",
     r"objective must be one of \('features', 'trace', 'both', 'smooth'\), got 'samples'"),
    ("DesignCriterion", "E", r"criterion must be one of \('D', 'A'\), got 'E'"),
    ("Covariance", "hessian",
     r"covariance must be one of \('auto', 'fisher', 'sandwich', 'two_level'\), got 'hessian'"),
    ("DiscoveryBase", "ode", r"base must be one of \('cycle', 'smooth'\), got 'ode'"),
    ("Formulation", "bristle",
     r"formulation must be one of \('rigid_stick', 'velocity', 'latch'\), got 'bristle'"),
])
def test_fitting_modes_refuse_a_bad_value_with_the_choices(enum_name, bad, message):
    import stickslip_fitting.modes as fm
    import stickslip_jax.modes as jm

    enum = getattr(fm, enum_name, None) or getattr(jm, enum_name)
    with pytest.raises(ValueError, match=message):
        enum.parse(bad)


def test_cli_choices_come_from_the_enums():
    """`--objective` of fit and mcmc, `--criterion` of plan: the same choices and defaults
    as before (user contracts), taken from the enums."""
    import argparse

    from stickslip_fitting.commands import fit, mcmc, plan

    def option(module, flag):
        parser = argparse.ArgumentParser()
        module.add_arguments(parser)
        return next(a for a in parser._actions if flag in a.option_strings)

    for module in (fit, mcmc):
        action = option(module, "--objective")
        assert tuple(action.choices) == ("features", "trace", "both", "smooth")
        assert action.default == "features" and type(action.default) is str
    action = option(plan, "--criterion")
    assert tuple(action.choices) == ("D", "A") and action.default == "D"
    from stickslip_fitting.commands import discover

    action = option(discover, "--base")
    assert tuple(action.choices) == ("cycle", "smooth") and action.default == "cycle"


def test_covariance_mode_takes_strings_and_reports_a_member():
    """`laplace(covariance=...)` accepts the old strings and reports the member it used;
    the mcmc likelihood scale compares members (one Fisher path)."""
    from stickslip_fitting.modes import Covariance

    assert Covariance.choices() == ("auto", "fisher", "sandwich", "two_level")
    assert [m.robust for m in Covariance] == [False, False, True, True]
    from stickslip_fitting.uncertainty import COVARIANCES

    assert COVARIANCES == Covariance.choices()


def test_objective_factory_and_weighted_sum_take_strings_or_members():
    from stickslip_fitting.combined import (OBJECTIVES, FeaturesObjective, TraceObjective,
                                            WeightedSum, make_objective)
    from stickslip_fitting.modes import Objective

    assert OBJECTIVES == ("features", "trace", "both")
    assert FeaturesObjective.kind is Objective.FEATURES and TraceObjective.kind == "trace"
    with pytest.raises(ValueError, match="objective must be one of"):
        make_objective("samples", None)
    with pytest.raises(ValueError, match="needs the records' traces"):
        make_objective(Objective.TRACE, None)
    with pytest.raises(ValueError, match="SmoothObjective"):
        make_objective("smooth", None)
    assert make_objective("features", None).kind is Objective.FEATURES
    assert make_objective(Objective.FEATURES, None).kind is Objective.FEATURES
    both = WeightedSum((FeaturesObjective(None), FeaturesObjective(None)), (0.25, 0.5))
    assert both.kind == "features+features"
    assert both.weight_of("features") == both.weight_of(Objective.FEATURES) == 0.75
    assert both.weight_of("trace") == 0.0
    with pytest.raises(ValueError, match="objective must be one of"):
        both.weight_of("trcae")


def test_fit_features_validates_the_objective_before_fitting():
    from stickslip_fitting.fit import fit_features
    from stickslip_fitting.modes import Objective

    with pytest.raises(ValueError, match=r"objective must be one of \('features'"):
        fit_features([], objective="samples")
    for objective in ("smooth", Objective.TRACE):
        with pytest.raises(ValueError, match="needs the records"):
            fit_features([], objective=objective)


def test_design_criterion_string_or_member_picks_the_same_branch():
    """"A" minimises the posterior covariance trace (its criterion values are minus a
    trace: negative), "D" maximises log det of the precision (>= 0 with a unit prior)."""
    import numpy as np

    import stickslip_jax as ss
    from stickslip_fitting.design import Campaign, greedy_design, log_params
    from stickslip_fitting.modes import DesignCriterion
    from stickslip_jax.units import from_mm_per_min

    u = log_params(ss.lubricant("A"))
    cands = Campaign(np.full(3, 36.0), np.full(3, 86.9),
                     from_mm_per_min(np.array([0.01, 1.0, 10.0])))
    with pytest.raises(ValueError, match=r"criterion must be one of \('D', 'A'\), got 'E'"):
        greedy_design(u, cands, 1, criterion="E")
    # (a dict keyed by criterion would merge "D" and DesignCriterion.D: they hash alike)
    by_string = [greedy_design(u, cands, 2, criterion=c) for c in ("D", "A")]
    by_member = [greedy_design(u, cands, 2, criterion=c)
                 for c in (DesignCriterion.D, DesignCriterion.A)]
    for s, m in zip(by_string, by_member):
        np.testing.assert_array_equal(s.indices, m.indices)
        np.testing.assert_array_equal(s.log_det, m.log_det)
    assert np.all(by_string[0].log_det > 0) and np.all(by_string[1].log_det < 0)


def test_formulation_string_or_member_one_compilation():
    """The smoothed simulator's `formulation`: the old string and the member run the same
    equations, and a jitted simulator compiles once for both (they hash alike)."""
    import equinox as eqx
    import jax.numpy as jnp
    import numpy as np

    import stickslip_jax as ss
    from stickslip_jax.drives import ConstantSpeed
    from stickslip_jax.modes import Formulation
    from stickslip_jax.simulation import simulate_smooth
    from stickslip_jax.units import from_mm_per_min

    sw = ss.Slideway(ss.lubricant("A"), 36.0, 86.9)
    ts = jnp.linspace(0.0, 2.0, 201)

    @eqx.filter_jit
    @eqx.debug.assert_max_traces(max_traces=1)
    def run(formulation):
        return simulate_smooth(sw, ConstantSpeed(from_mm_per_min(30.0)), ts, smoothing=1e-2,
                               formulation=formulation, rtol=1e-6, atol=1e-8)

    old = run("latch")
    new = run(Formulation.LATCH)
    np.testing.assert_array_equal(np.asarray(old.deflection), np.asarray(new.deflection))
    assert float(jnp.ptp(old.deflection)) > 0  # it moved
    with pytest.raises(ValueError, match=r"formulation must be one of \('rigid_stick'"):
        simulate_smooth(sw, ConstantSpeed(1.0), ts, formulation="bristle")
