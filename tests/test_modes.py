"""Mode options are small str-valued enums: a user's string becomes a member once where it
enters (the command line, `api.fit`), a bad value is refused there, JSON carries the value;
inside the package the verbs take members, and a campaign fit's options are typed
objects."""

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

    from stickslip_fitting.objectives.combined import FeaturesObjective
    from stickslip_fitting.objectives.cycle_features import feature_data
    from stickslip_fitting.data.synthetic import synthetic_campaign
    from stickslip_fitting.data.features import record_features
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


def test_covariance_and_small_sample_modes():
    """`laplace(covariance=...)` and `sandwich_covariance(small_sample=...)` take members;
    a string is refused with the way to its member."""
    import numpy as np

    from stickslip_fitting.modes import Covariance, SmallSample
    from stickslip_fitting.uncertainty.laplace import laplace, sandwich_covariance

    assert Covariance.choices() == ("auto", "fisher", "sandwich", "two_level")
    assert [m.robust for m in Covariance] == [False, False, True, True]
    assert SmallSample.choices() == ("jackknife", "cr2", "none")
    with pytest.raises(TypeError, match=r"covariance: a member of Covariance.*Covariance\.parse"):
        laplace(None, covariance="fisher")
    J, r = np.eye(4, 2), np.arange(4.0)
    rec, cyc = np.zeros(4, int), np.arange(4)
    with pytest.raises(TypeError, match="small_sample: a member of SmallSample"):
        sandwich_covariance(J, r, rec, cyc, small_sample="cr2")
    with pytest.raises(ValueError, match="small_sample must be one of"):
        SmallSample.parse("cr1")
    by_member = sandwich_covariance(J, r, rec, cyc, small_sample=SmallSample.parse("none"))
    assert by_member.shape == (2, 2) and np.all(np.isfinite(by_member))


def test_objective_factory_and_weighted_sum_take_members():
    from stickslip_fitting.objectives.combined import (OBJECTIVES, FeaturesObjective,
                                            TraceObjective, WeightedSum, make_objective)
    from stickslip_fitting.modes import Objective

    assert OBJECTIVES == ("features", "trace", "both")
    assert FeaturesObjective.kind is Objective.FEATURES and TraceObjective.kind == "trace"
    with pytest.raises(TypeError, match="kind: a member of Objective"):
        make_objective("features", None)
    with pytest.raises(ValueError, match="needs the records' traces"):
        make_objective(Objective.TRACE, None)
    with pytest.raises(ValueError, match="SmoothObjective"):
        make_objective(Objective.SMOOTH, None)
    assert make_objective(Objective.FEATURES, None).kind is Objective.FEATURES
    both = WeightedSum((FeaturesObjective(None), FeaturesObjective(None)), (0.25, 0.5))
    assert both.kind == "features+features"
    assert both.weight_of(Objective.FEATURES) == 0.75
    assert both.weight_of(Objective.TRACE) == 0.0
    with pytest.raises(TypeError, match="kind: a member of Objective"):
        both.weight_of("trace")


def test_fit_features_validates_the_objective_before_fitting():
    from stickslip_fitting.solve.fit import fit_features
    from stickslip_fitting.modes import Objective

    with pytest.raises(TypeError, match="objective: a member of Objective"):
        fit_features([], objective="smooth")
    for objective in (Objective.SMOOTH, Objective.TRACE):
        with pytest.raises(ValueError, match="needs the records"):
            fit_features([], objective=objective)


def test_design_criterion_members_pick_their_branch():
    """A minimises the posterior covariance trace (its criterion values are minus a
    trace: negative), D maximises log det of the precision (>= 0 with a unit prior); the
    command line's value is parsed into the member."""
    import numpy as np

    import stickslip_jax as ss
    from stickslip_fitting.design import Campaign, greedy_design, log_params
    from stickslip_fitting.modes import DesignCriterion
    from stickslip_jax.units import from_mm_per_min

    u = log_params(ss.lubricant("A"))
    cands = Campaign(np.full(3, 36.0), np.full(3, 86.9),
                     from_mm_per_min(np.array([0.01, 1.0, 10.0])))
    with pytest.raises(ValueError, match=r"criterion must be one of \('D', 'A'\), got 'E'"):
        DesignCriterion.parse("E")
    with pytest.raises(TypeError, match="criterion: a member of DesignCriterion"):
        greedy_design(u, cands, 1, criterion="A")
    d, a = (greedy_design(u, cands, 2, criterion=DesignCriterion.parse(c)) for c in ("D", "A"))
    assert np.all(d.log_det > 0) and np.all(a.log_det < 0)
    default = greedy_design(u, cands, 2)
    np.testing.assert_array_equal(default.indices, d.indices)


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


def test_fit_option_groups_are_typed_frozen_and_have_defaults():
    import dataclasses

    from stickslip_fitting.modes import ModelModes, Padding, SolverOptions, Weighting

    assert ModelModes() == ModelModes(GaugeOffset.ZERO, SlipTime.PAPER, None)
    assert Weighting().pair == (0.5, 0.5) and Weighting().rescale_records
    assert Padding() == Padding(0, 0, 0)
    assert SolverOptions() == SolverOptions(1e-10, 1e-10, 400)
    # the solves over whole traces: not tighter than 1e-8, at most 100 steps a round
    assert SolverOptions().refine() == SolverOptions(1e-8, 1e-8, 100)
    assert SolverOptions(1e-6, 1e-12, 50).refine() == SolverOptions(1e-6, 1e-8, 50)
    with pytest.raises(dataclasses.FrozenInstanceError):
        SolverOptions().rtol = 1e-3
    with pytest.raises(TypeError, match="offset: a member of GaugeOffset"):
        ModelModes(offset="start")
    with pytest.raises(TypeError, match="slip_time: a member of SlipTime"):
        ModelModes(slip_time="paper")



def test_discovery_parameters_take_a_when_member_or_its_string():
    """`CampaignDiscovery.parameters(when)`: `When.BEFORE` / `When.AFTER` or their strings
    pick the estimates before or after the named effects; another value is a ValueError
    naming `when` and the choices (on a stand-in with the JSON document's two keys, no
    discovery run)."""
    import types

    import stickslip_fitting as sf
    from stickslip_fitting.api.discovery import CampaignDiscovery
    from stickslip_fitting.modes import When

    def entry(value):
        return {"value": value, "stderr": 0.01, "ci95": [value - 0.02, value + 0.02],
                "unit": "-", "identifiable": True}

    found = types.SimpleNamespace(report={"estimates_before": {"mu_d": entry(0.2)},
                                          "estimates_after": {"mu_d": entry(0.3)}})
    assert sf.When is When and When.parse("before") is When.BEFORE
    for when, value in ((When.BEFORE, 0.2), ("before", 0.2), (When.AFTER, 0.3),
                        ("after", 0.3)):
        assert CampaignDiscovery.parameters(found, when).loc["mu_d", "value"] == value
    assert CampaignDiscovery.parameters(found).loc["mu_d", "value"] == 0.3  # after
    with pytest.raises(ValueError, match=r"when must be one of \('before', 'after'\), "
                                         r"got 'later'"):
        CampaignDiscovery.parameters(found, "later")
