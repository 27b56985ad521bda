"""The NumPy/SciPy reference model of the benchmarks (benchmarks/scipy_reference.py) against the
JAX exact simulator and trace objective: an independent check of both (brentq + DOP853
against closed forms), including the re-slip (k x_1 > W mu_d after a slip) and the
event budget of the trace windows."""

import functools
import pathlib
import sys

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.flatten_util import ravel_pytree

import stickslip_jax as ss
from stickslip_fitting.data.features import record_features
from stickslip_fitting.params import CampaignParams, EmpiricalFriction, free_spec
from stickslip_fitting.data.synthetic import synthetic_campaign
from stickslip_fitting.objectives.trace import trace_data, trace_residuals_and_flags, trace_sd
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.simulation import SimulationResult, simulate_exact

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "benchmarks"))
from scipy_reference import (  # noqa: E402
    friction_values,
    reference_windows,
    scipy_record,
    scipy_trace_residuals,
    scipy_trace_simulation,
    simulate_window,
    values_from_free,
)

# a prior draw whose stiff-spring (k = 200 kgf/mm) slips end above mu_d W / k: re-slip
RESLIP = ss.Friction(ss.KatoStatic(mu_s=0.5698, mu_d=0.2174, gamma=0.3446, m=0.5057),
                     ss.KatoKinetic(delta=33.84, n=0.9216))


@functools.partial(jax.jit, static_argnames="max_events")
def _exact(fr, W, k, v, ts, x0, t0, max_events=40):
    return simulate_exact(ss.Slideway(fr, W, k), ConstantSpeed(v), ts, initial_deflection=x0,
                          start_time=t0, max_events=max_events)


def test_record_with_reslip_matches_exact_simulator():
    """A stiff spring from rest: several cycles, each with a re-slip, to 1e-9 mm."""
    W, k = 36.0, 200.0
    v = 0.3 * float(ss.critical_speed(RESLIP, W, k))
    ts = np.arange(0.0, 2.0, 1e-3)
    tr = _exact(RESLIP, W, k, v, ts, 0.0, 0.0)
    assert tr.result == SimulationResult.successful
    assert int(np.sum(np.asarray(tr.cycles.restick_failed))) >= 2  # re-slips happen
    x = scipy_record(RESLIP, W, k, v, ts)
    assert np.max(np.abs(x - np.asarray(tr.deflection))) < 1e-9
    # started mid-record at rest, above mu_d W / k: breaks away at once
    t0, x0 = 0.5, 1.05 * RESLIP.mu_d * W / k
    xw, ydw = simulate_window(friction_values(RESLIP), W, k, v, ts[ts >= t0], t0=t0, x0=x0)
    tr = _exact(RESLIP, W, k, v, ts[ts >= t0], x0, t0)
    assert np.max(np.abs(xw - np.asarray(tr.deflection))) < 1e-9
    assert np.max(np.abs(ydw - np.asarray(tr.slider_velocity))) < 1e-6
    assert float(tr.cycles.stick_time[0]) == 0.0 and float(tr.cycles.breakaway_time[0]) == t0


def test_event_budget_is_rendered_like_the_exact_simulator():
    """With `max_slips` the last slip runs on past its end, as simulate_exact renders a record
    whose events ran out (max_events 4: two slips, here the first slip and its re-slip)."""
    W, k = 36.0, 200.0
    v = 0.3 * float(ss.critical_speed(RESLIP, W, k))
    ts = np.arange(0.0, 2.0, 1e-3)
    tr = _exact(RESLIP, W, k, v, ts, 0.0, 0.0, max_events=4)
    assert tr.result == SimulationResult.max_events_reached
    x, _ = simulate_window(friction_values(RESLIP), W, k, v, ts, max_slips=2)
    assert np.max(np.abs(x - np.asarray(tr.deflection))) < 1e-9
    assert np.max(np.abs(x - scipy_record(RESLIP, W, k, v, ts))) > 1e-3  # it did run out


@pytest.fixture(scope="module")
def campaign():
    # simulated on test_trace_objective's padded length: the exact simulator's campaign
    # program of the synthetic campaigns, compiled once
    recs = synthetic_campaign(RESLIP, speed_fractions=(0.05, 0.3), cycles=4, seed=525,
                              pad_to=40_000)
    feats = [record_features(r) for r in recs]
    tdata = trace_data(recs, feats)
    truth = CampaignParams(EmpiricalFriction.from_friction(RESLIP), jnp.zeros(len(recs)))
    return recs, tdata, truth


def test_values_from_free_follows_the_fit_flattening(campaign):
    _, _, truth = campaign
    p = eqx.tree_at(lambda q: q.friction.log_gamma, truth, jnp.log(0.7))
    flat = ravel_pytree(eqx.partition(p, free_spec(p))[0])[0]
    np.testing.assert_allclose(values_from_free(flat), np.asarray(p.friction.values()),
                               rtol=1e-14)


def test_trace_residuals_match_the_jax_objective(campaign):
    """Whitened residuals with the same frozen standard errors, at the truth and at a
    perturbed point with gauge offsets (some windows then start above mu_d W / k)."""
    recs, tdata, truth = campaign
    windows = reference_windows(tdata)
    jres = jax.jit(trace_residuals_and_flags)
    _, ok, vel = jres(truth, tdata)
    sd = trace_sd(truth, tdata, vel)
    sd_np = np.asarray(sd)
    m = np.asarray(tdata.mask)
    # the SciPy simulator's slider velocity gives the same weights (padding differs: 0 here)
    _, vel_np = scipy_trace_simulation(friction_values(RESLIP), windows)
    np.testing.assert_allclose(np.asarray(trace_sd(truth, tdata, vel_np))[m], sd_np[m],
                               rtol=1e-9)
    perturbed = CampaignParams(
        EmpiricalFriction.from_values(mu_s=0.58, mu_d=0.2109, gamma=0.38, m=0.48, delta=40.0,
                                      n=0.97),
        # mm; record 3 (k = 86.9) then restarts above mu_d W/k (its slips end 1.9 um
        # below); the k = 200 records re-slip, so they have no windows (trace_data)
        jnp.asarray([1e-3, -5e-4, 5e-4, -5e-3, 0.0, 0.0]))
    x0 = windows.start_level - np.asarray(perturbed.offset)[windows.window_record]
    at_once = windows.stiffness * x0 >= windows.weight * 0.2109
    assert at_once.any() and not at_once.all()
    m = m.ravel()
    for p in (truth, perturbed):
        r_jax, ok, _ = jres(p, tdata, weights_at=truth, slider_velocity=vel)
        assert bool(np.all(np.asarray(ok)))
        r_np = scipy_trace_residuals(np.asarray(p.friction.values()), windows, sd_np,
                                     offsets=np.asarray(p.offset))
        assert r_np.shape == r_jax.shape and np.all(r_np[~m] == 0)
        assert np.max(np.abs(r_np[m])) > 1.0  # real residuals, not zeros
        assert np.max(np.abs(r_np - np.asarray(r_jax))) < 1e-8  # measured: 2e-10


def test_closed_form_slip_matches_the_ode_and_the_exact_simulator():
    """`slip="closed_form"` (the NumPy baseline without an ODE solver): a record with
    re-slips, a window started above mu_d W / k, and the event budget, as the ODE version
    and simulate_exact (1e-9 mm; slider velocity 1e-6 mm/s)."""
    W, k = 36.0, 200.0
    v = 0.3 * float(ss.critical_speed(RESLIP, W, k))
    ts = np.arange(0.0, 2.0, 1e-3)
    vals = friction_values(RESLIP)
    for kw, max_events in (({}, 40), ({"max_slips": 2}, 4)):
        tr = _exact(RESLIP, W, k, v, ts, 0.0, 0.0, max_events=max_events)
        x, yd = simulate_window(vals, W, k, v, ts, slip="closed_form", **kw)
        if not kw:
            assert np.array_equal(scipy_record(RESLIP, W, k, v, ts, slip="closed_form"), x)
        x_ode, _ = simulate_window(vals, W, k, v, ts, **kw)
        assert np.max(np.abs(x - np.asarray(tr.deflection))) < 1e-9
        assert np.max(np.abs(yd - np.asarray(tr.slider_velocity))) < 1e-6
        assert np.max(np.abs(x - x_ode)) < 1e-9
    t0, x0 = 0.5, 1.05 * RESLIP.mu_d * W / k
    xw, _ = simulate_window(vals, W, k, v, ts[ts >= t0], t0=t0, x0=x0, slip="closed_form")
    tr = _exact(RESLIP, W, k, v, ts[ts >= t0], x0, t0)
    assert np.max(np.abs(xw - np.asarray(tr.deflection))) < 1e-9
    with pytest.raises(ValueError, match="slip must be"):
        simulate_window(vals, W, k, v, ts, slip="euler")


def test_closed_form_trace_residuals_match_the_jax_objective(campaign):
    recs, tdata, truth = campaign
    windows = reference_windows(tdata)
    r_jax, _, vel = jax.jit(trace_residuals_and_flags)(truth, tdata)
    sd = np.asarray(trace_sd(truth, tdata, vel))
    r_np = scipy_trace_residuals(friction_values(RESLIP), windows, sd, slip="closed_form")
    m = np.asarray(tdata.mask).ravel()
    assert np.max(np.abs(r_np[m])) > 1.0
    assert np.max(np.abs(r_np - np.asarray(r_jax))) < 1e-8
