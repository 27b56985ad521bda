"""Candidate effects: neutral at zero, each changes the traces, JSON-able metadata."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import stickslip_jax as ss
from stickslip_fitting.discovery.effects import CANDIDATES, EffectSet
from stickslip_fitting.discovery.model import (
    EFFECT_PARAMS,
    effects_from_vector,
    effects_to_vector,
    slot_matrix,
)
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.lubricants import lubricant
from stickslip_jax.simulation.smooth import SmoothModel, simulate_smooth

W, K = 36.0, 86.9
FR = lubricant("A")
V = 0.3 * float(ss.critical_speed(FR, W, K))


def _run(model, ts):
    return simulate_smooth(model, ConstantSpeed(V), ts, smoothing=1e-2, rtol=1e-6, formulation="rigid_stick",
                           atol=1e-8, initial_deflection=0.05).deflection


@pytest.fixture(scope="module")
def run():
    return eqx.filter_jit(_run)


@pytest.fixture(scope="module")
def ts():
    return jnp.arange(0.0, 0.6, 2e-3)


def test_library_metadata():
    assert set(CANDIDATES) == {"viscous_damping", "stribeck", "drive_periodic_error",
                               "sensor_lowpass", "friction_drift", "gauge_drift",
                               "load_coupling", "rate_state"}
    for name in CANDIDATES:
        cls = getattr(EffectSet(), name)  # the library's part of effect `name`
        assert cls.NAME == name
        assert len(cls.EXPLANATION) > 40 and cls.EXPLANATION.endswith(".")
        assert 1 <= len(cls.PARAMS) <= 2 and len(cls.UNITS) == len(cls.PARAMS)
    with pytest.raises(ValueError, match="unknown effect"):
        EffectSet().with_effect("magic")


def test_zero_effects_are_the_paper_model(run, ts):
    sw = ss.Slideway(FR, W, K)
    plain = run(SmoothModel(sw), ts)
    allzero = run(EffectSet.zeros().smooth_model(sw), ts)
    # only the 10 us floor of the low-pass and the solver's steps differ: far below
    # the 0.5 um gauge noise of the campaigns
    assert float(jnp.max(jnp.abs(plain - allzero))) < 1e-4
    assert float(jnp.sqrt(jnp.mean((plain - allzero) ** 2))) < 2e-5


@pytest.mark.parametrize("name", CANDIDATES)
def test_each_effect_changes_the_trace(run, ts, name):
    sw = ss.Slideway(FR, W, K)
    base = run(EffectSet.zeros().smooth_model(sw), ts)
    part = getattr(EffectSet(), name)
    vals = {p: 2 * s for p, s in zip(part.PARAMS, part.SCALES)}
    eff = EffectSet.zeros().with_effect(name, **vals)
    x = run(eff.smooth_model(sw), ts)
    assert np.all(np.isfinite(np.asarray(x)))
    assert float(jnp.sqrt(jnp.mean((x - base) ** 2))) > 1e-4  # > 0.1 um


def test_vector_round_trip_and_slots():
    eff = EffectSet.zeros().with_effect("drive_periodic_error", a_sin=3e-4, a_cos=-1e-4)
    v = effects_to_vector(eff)
    back = effects_from_vector(EffectSet.zeros(), v)
    assert float(back.drive_periodic_error.a_cos) == pytest.approx(-1e-4)
    S = slot_matrix("drive_periodic_error")
    assert S.shape == (len(EFFECT_PARAMS), 2) and S.sum() == 2
    assert slot_matrix("viscous_damping").sum() == 1
    assert slot_matrix(None).sum() == 0


def test_physical_signs():
    from stickslip_fitting.discovery.effects import RateState, SensorLowpass, Stribeck, ViscousDamping

    assert ViscousDamping.unphysical({"c": -0.006}) == "c = -0.006 < 0"
    assert ViscousDamping.unphysical({"c": 0.01}) is None
    assert SensorLowpass.unphysical({"time_constant": -1e-4}) is not None
    assert RateState.unphysical({"b": -1e-3}) is not None
    assert Stribeck.unphysical({"b": -1e-3}) is None  # rising friction is physical
    for name in CANDIDATES:
        part = getattr(EffectSet(), name)
        assert len(part.SIGNS) == len(part.PARAMS)


def test_unphysical_score_direction_is_ranked_last():
    from stickslip_fitting.discovery.ranking import CandidateScore

    good = CandidateScore("stribeck", 5.0, 1, 0.03, {"b": 1e-3})
    bad = CandidateScore("viscous_damping", 50.0, 1, 1e-12, {"c": -1e-3},
                         unphysical="c = -0.001 < 0")
    assert bad.rank_statistic == 0.0 and good.rank_statistic == 5.0
    ranked = sorted([bad, good], key=lambda c: (-c.rank_statistic, -c.statistic))
    assert [c.name for c in ranked] == ["stribeck", "viscous_damping"]


def test_lowpass_time_constant_has_slope_one_at_zero():
    import jax

    from stickslip_fitting.discovery.effects import SensorLowpass

    def tau_eff(t):
        return SensorLowpass(time_constant=t).effective_time_constant()

    tmin = SensorLowpass.TAU_MIN
    # value and slope continuous at 0; the slope is the physical one (1), so the score
    # test and the first refit step see the real effect of a small positive time constant
    assert float(tau_eff(0.0)) == pytest.approx(tmin)
    assert float(jax.grad(tau_eff)(0.0)) == pytest.approx(1.0)
    assert float(jax.grad(tau_eff)(-1e-9)) == pytest.approx(1.0, rel=1e-3)
    assert float(tau_eff(2e-3)) == pytest.approx(2e-3 + tmin)
    # negative trial values stay positive (a stable filter) and finite in gradient
    assert 0.0 < float(tau_eff(-1e-2)) < tmin
    assert np.isfinite(float(jax.grad(tau_eff)(-1e-2)))


def test_load_referred_friction_keeps_the_breakaway_and_slip_centre_forces():
    from stickslip_fitting.discovery.effects import load_referred_friction

    kappa, T1, T2 = 0.2, jnp.asarray([0.01, 0.1, 1.0]), 0.02
    phys = load_referred_friction(FR, kappa)
    mu0 = phys.static(T1)
    # breakaway at k x = N mu_0 with N = W + kappa k x  <=>  k x / W = mu_0 / (1 - kappa mu_0)
    np.testing.assert_allclose(mu0 / (1 - kappa * mu0), FR.static(T1), rtol=1e-12)
    # slip centre k x_c = N mu_m: the same in apparent terms
    mum = phys.kinetic(mu0, phys.mu_d, T2)
    np.testing.assert_allclose(mum / (1 - kappa * mum), FR.mean_kinetic(T1, T2), rtol=1e-12)
    assert float(phys.mu_d / (1 - kappa * phys.mu_d)) == pytest.approx(float(FR.mu_d))
    # kappa = 0 is the same law
    same = load_referred_friction(FR, 0.0)
    np.testing.assert_allclose(same.mean_kinetic(T1, T2), FR.mean_kinetic(T1, T2), rtol=1e-14)


def test_smooth_base_drives_a_record_by_its_measured_drive():
    """`--base smooth` takes a record whose drive is measured (a `drive` column, or a
    `drive_speed` column integrated on reading): its traces carry the drive's knots, and
    a measured drive u = v t gives the constant speed's model readings."""
    from stickslip_fitting.discovery.model import (DiscoveryParams, Settings, campaign_traces,
                                                   simulate_campaign)
    from stickslip_fitting.params import EmpiricalFriction
    from stickslip_jax.records import Record, parse_record

    t = np.arange(0.0, 0.6, 2e-3)
    x = 0.05 + 0.01 * np.sin(7.0 * t)
    kw = dict(time=t, deflection=x, stiffness=K, weight=W)
    speed = campaign_traces([Record(drive_speed=V, **kw)] * 2)
    column = campaign_traces([Record(drive=V * t, **kw)] * 2)
    assert speed.drive_knots is None and column.drive_knots.shape == (2, 513, 2)
    rows = "\n".join(f"{a:.3f},{b:.6f},{V}" for a, b in zip(t, x))
    tacho = parse_record(f"# stickslip-record: 1\n# stiffness: {K} kgf/mm\n# slider_weight: "
                         f"{W} kgf\ntime [s],deflection [mm],drive_speed [mm/s]\n{rows}\n")
    knots = np.asarray(campaign_traces([tacho] * 2).drive_knots)
    np.testing.assert_allclose(knots[0, :-1, 1], V * knots[0, :-1, 0], atol=1e-9)  # mm
    params = DiscoveryParams(EmpiricalFriction.from_friction(FR), EffectSet.zeros(),
                             speed.start_level)
    a, ok_a = simulate_campaign(params, speed, Settings())
    b, ok_b = simulate_campaign(params, column, Settings())
    assert bool(np.all(ok_a)) and bool(np.all(ok_b))
    gap = float(jnp.max(jnp.abs(a - b)))
    # mm: the two drives take their own solver steps (rtol 1e-6), so the readings agree to
    # the solve's accuracy (measured 1e-5 mm), not bitwise: within 1/5 of a gauge's 0.5 um
    # noise, where a drive one sample (2 ms) late moves them by V x 2 ms = 5e-4 mm
    assert gap < 1e-4, gap
