"""The missing-physics workflow end to end on synthetic campaigns.

Fast (default suite): a 4-record campaign with a drifting gauge zero is named, the
gap closes to the noise (on so small a campaign the six friction parameters absorb
slip-phase effects such as viscous damping, so the fast check uses a drift); a campaign with no effect answers "none" through the CLI with
the JSON contract; one compilation serves every candidate.

Slow (`-m slow`): 12-record campaigns (noise 0.5 um), one per library effect, two
with no effect (lubricants A of Table 6 and D of Table 9), and one with an effect
outside the library (a hardening spring) with the learned correction.
"""

import json
import math

import numpy as np
import pytest

from stickslip_fitting.discovery import CANDIDATES, discover
from stickslip_fitting.discovery import model as dmodel
from stickslip_fitting.discovery.synthetic import HardeningSpring, hidden_effect_campaign
from stickslip_jax.lubricants import lubricant

TINY = dict(conditions=((36.0, 86.9), (12.4, 40.0)), speed_fractions=(0.26, 0.36), cycles=3)
FRICTION_A = lubricant("A")

SIZES = {
    "viscous_damping": {"c": 0.01},
    "stribeck": {"b": 0.005},
    "drive_periodic_error": {"a_sin": 4e-4, "a_cos": 2e-4},
    "sensor_lowpass": {"time_constant": 2e-3},
    "friction_drift": {"rate": 1e-3},
    "gauge_drift": {"rate": 2e-3},
    "load_coupling": {"kappa": 0.2},
    "rate_state": {"b": 0.005},
}
"""Hidden-effect sizes of the slow campaigns (natural units, see effects.py). Each changes
the noise-free traces by 1.9 to 37 times the noise (RMS, README); load coupling needs
kappa = 0.2: its change is mostly a rescaling of the friction, which the base model
absorbs, and at 0.02 what is left is far below the noise."""


def _report(name, recs, res):
    """One line for the README (shown with `pytest -rA`)."""
    truth = recs[0].truth["friction"]
    size = {p: f"{v['value']:.3g} +- {v['stderr']:.1g}" for p, v in res.effect_size.items()}
    print(f"{name}: answer {res.effect} ({res.confidence}) {size}; gap "
          f"{res.gap_before * 1e3:.3f} -> {res.gap_after * 1e3:.3f} um (noise "
          f"{res.noise * 1e3:.3f}); p {res.test_before['p_value']:.2g} -> "
          f"{res.test_after['p_value']:.2g}; base-parameter error "
          f"{_log_error(res.parameters_before, truth):.3f} -> "
          f"{_log_error(res.parameters_after, truth):.3f}; steps "
          f"{ {k: round(v) for k, v in res.timings.items()} }")
    if res.learned is not None:
        print("learned:", res.learned.to_json())


def _log_error(values, truth):
    names = ("mu_s", "mu_d", "gamma", "m", "delta", "n")
    return float(np.sqrt(sum(math.log(values[n] / truth[n]) ** 2 for n in names)))


@pytest.fixture(scope="module")
def damped():
    recs = hidden_effect_campaign(FRICTION_A, effect="gauge_drift", values={"rate": 4e-3},
                                  seed=3, **TINY)
    return recs, discover(recs, top=2, max_evals=20)


@pytest.mark.slow  # the whole-record workflow's campaign: 60 s with its fixture
def test_tiny_campaign_names_gauge_drift(damped):
    recs, res = damped
    assert res.effect == "gauge_drift"
    assert res.gap_after < 1.2 * res.noise < res.gap_before
    c = res.effect_size["rate"]
    assert abs(c["value"] - 4e-3) < 3 * c["stderr"] + 4e-4
    assert res.candidates[0]["name"] == "gauge_drift"
    assert set(res.timings) >= {"base_fit", "ranking", "refit", "total"}


@pytest.mark.slow  # the whole-record workflow's campaign: 60 s with its fixture
def test_tiny_campaign_without_effect_answers_none_through_the_cli(tmp_path, damped):
    from stickslip_jax.cli import main
    from stickslip_jax.records import write_record

    recs = hidden_effect_campaign(FRICTION_A, seed=4, **TINY)
    files = []
    for i, r in enumerate(recs):
        path = tmp_path / f"r{i}.csv"
        write_record(r, path)
        files.append(str(path))
    out = tmp_path / "d.json"
    before = dmodel.TRACE_COUNT["evaluate"]
    assert main(["discover", *files, "--base", "smooth", "--crop", "none", "--top", "2",
                 "--max-evals", "20", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["effect"] == "none"
    for key in ("explanation", "gap_before", "gap_after", "criterion", "candidates",
                "parameters_before", "parameters_after"):
        assert key in doc
    assert {c["name"] for c in doc["candidates"]} == set(CANDIDATES)
    assert all({"name", "score", "delta_criterion"} <= set(c) for c in doc["candidates"])
    assert doc["gap_after"] < 1.2 * doc["noise"]
    assert set(doc["base_fit"]) >= {"converged", "evaluations", "criterion"}
    assert doc["base_fit"]["evaluations"] <= 20 and doc["indistinguishable_from"] == []
    # the records read back have the damped campaign's shapes: no new compilation,
    # although the base model and eight candidates were evaluated
    assert dmodel.TRACE_COUNT["evaluate"] == before


def test_direction_cosine_is_the_smallest_principal_angle():
    from stickslip_fitting.discovery.scores import principal_cosine

    rng = np.random.default_rng(0)
    a = rng.normal(size=(200, 1))
    b = np.concatenate([a + 0.1 * rng.normal(size=(200, 1)), rng.normal(size=(200, 1))], 1)
    cos = principal_cosine(a, 3.0 * b)  # scale-free
    ref = abs(float(a[:, 0] @ b[:, 0])) / np.linalg.norm(a) / np.linalg.norm(b[:, 0])
    assert ref - 1e-12 <= cos <= 1.0  # the best pair is at least as close as column 0
    assert cos > 0.99
    assert principal_cosine(a, rng.normal(size=(200, 1))) < 0.3


def test_bad_input_is_one_clear_error():
    from stickslip_jax.records import Record

    t = np.arange(10) * 0.01
    short = Record(time=t, deflection=0.01 * t, stiffness=86.9, weight=36.0, drive=0.01 * t)
    with pytest.raises(ValueError, match="too few samples"):
        dmodel.campaign_traces([short])
    with pytest.raises(TypeError, match="crop: a member of Crop"):
        dmodel.campaign_traces([short], crop="slip_end")
    from stickslip_fitting.discovery.workflow import SmoothBase
    from stickslip_fitting.modes import Crop

    assert SmoothBase(crop="slip_end").crop is Crop.SLIP_END
    with pytest.raises(ValueError, match="crop must be"):
        SmoothBase(crop="start")


@pytest.mark.slow
@pytest.mark.parametrize("name", CANDIDATES)
def test_each_hidden_effect_is_named_and_closes_the_gap(name):
    recs = hidden_effect_campaign(FRICTION_A, effect=name, values=SIZES[name], seed=11)
    res = discover(recs)
    _report(name, recs, res)
    assert res.effect == name, res.candidates
    assert res.gap_after < 1.2 * res.noise
    assert res.gap_after < res.gap_before
    truth = recs[0].truth["friction"]
    assert _log_error(res.parameters_after, truth) <= _log_error(res.parameters_before, truth)


@pytest.mark.slow
@pytest.mark.parametrize("lub", [("A", 6), ("D", 9)])
def test_no_hidden_effect_answers_none(lub):
    recs = hidden_effect_campaign(lubricant(lub[0], table=lub[1]), seed=21)
    res = discover(recs)
    _report(f"none ({lub[0]})", recs, res)
    assert res.effect == "none", res.candidates
    assert res.test_before["p_value"] > 1e-3


@pytest.mark.slow
def test_effect_outside_the_library_is_not_named_confidently_and_is_learned():
    recs = hidden_effect_campaign(FRICTION_A, extra_force_terms=(HardeningSpring(beta=3.0),),
                                  hidden_name="hardening_spring", seed=31)
    res = discover(recs, learn=True)
    _report("hardening_spring", recs, res)
    assert res.effect == "none" or res.confidence == "low", res.candidates
    if res.effect != "none":  # never a physically impossible size (such as c < 0)
        from stickslip_fitting.discovery.effects import EffectSet

        size = {p: v["value"] for p, v in res.effect_size.items()}
        assert getattr(EffectSet(), res.effect).unphysical(size) is None
    if res.test_after["p_value"] < 1e-3:  # residuals still unexplained
        assert res.learned is not None
        assert res.learned.gap_after < 0.9 * res.learned.gap_before
