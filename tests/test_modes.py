"""Mode options are small str-valued enums (issue 16): old strings keep working, a bad
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
