"""Trace objective (stickslip_fitting.objectives.trace, stickslip_fitting.objectives.combined): the exact simulator restarted per
cycle against every sample; recovery, gradients, the combined objective, bad input."""

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stickslip_jax as ss
from stickslip_fitting.data.features import record_features
from stickslip_fitting.solve.fit import MAX_ROUNDS, fit_features
from stickslip_fitting.modes import Objective, Padding
from stickslip_fitting.params import NAMES, CampaignParams, EmpiricalFriction
from stickslip_fitting.data.synthetic import synthetic_campaign, truth_values
from stickslip_fitting.objectives.trace import (CHUNK, cycle_windows, reslip_windows,
                                               trace_data, trace_residuals, trace_simulation)
from stickslip_fitting.uncertainty.laplace import laplace
from record_files import record_files


@pytest.fixture(scope="module")
def campaign():
    fr = ss.lubricant("A")
    recs = synthetic_campaign(fr, speed_fractions=(0.05, 0.3), cycles=4, seed=11, pad_to=40_000)
    feats = [record_features(r) for r in recs]
    return fr, recs, feats


SOLVE_COMPILES = []


def _count_solve_compiles(event, duration, fun_name="", **kwargs):
    if event == "/jax/core/compile/backend_compile_duration" and "_solve_starts" in fun_name:
        SOLVE_COMPILES.append(fun_name)


jax.monitoring.register_event_duration_secs_listener(_count_solve_compiles)


@pytest.fixture(scope="module")
def trace_fit_and_compiles(campaign):
    """The trace fit and how many programs of the solve XLA compiled for it."""
    _, recs, feats = campaign
    before = len(SOLVE_COMPILES)
    fit = fit_features(feats, objective=Objective.TRACE, records=recs,
                       padding=Padding(cycles=8))
    return fit, len(SOLVE_COMPILES) - before


@pytest.fixture(scope="module")
def trace_fit(trace_fit_and_compiles):
    return trace_fit_and_compiles[0]


def test_trace_fit_compiles_two_programs(trace_fit_and_compiles):
    # one program for the features solve and one for the trace solve, each compiled once
    # for all its rounds: had the arguments' structure differed between rounds, XLA
    # would compile them again (4 programs or more)
    _, compiled = trace_fit_and_compiles
    assert compiled <= 2  # fewer where this process compiled the layout before


def test_residuals_at_truth_are_unit_normal(campaign):
    fr, recs, feats = campaign
    data = trace_data(recs, feats)
    assert reslip_windows(feats) == 0  # no re-slips here: every complete cycle is a window
    assert data.time.shape[1] == CHUNK and data.time.shape[0] % 8 == 0
    params = CampaignParams(EmpiricalFriction.from_friction(fr), jnp.zeros(len(recs)))
    res = jax.jit(trace_residuals)
    r = np.asarray(res(params, data))
    m = np.asarray(data.mask).ravel()
    assert np.all(r[~m] == 0)
    # one window per complete cycle, most of the samples used
    assert data.n_residuals() > 0.6 * sum(rec.n_samples for rec in recs)
    assert 0.9 < np.std(r[m]) < 1.1 and abs(np.mean(r[m])) < 0.1
    assert np.max(np.abs(r[m])) < 6.0  # no phase drift: restarted every cycle
    # rows of CHUNK samples: stick times differ by ~10x here, yet little padding
    assert data.mask.size < 1.5 * data.n_residuals()
    # the same windows unchunked (one row each, padded to the longest): same residuals
    longest = int(np.bincount(np.asarray(data.window), weights=np.asarray(data.mask).sum(1)).max())
    whole = trace_data(recs, feats, chunk=longest)
    assert whole.mask.shape[0] < data.mask.shape[0] and whole.mask.shape[1] >= longest
    assert whole.mask.size > 2 * data.mask.size  # what padding to the longest cost
    r_whole = np.asarray(res(params, whole))
    np.testing.assert_allclose(np.sort(r_whole[np.asarray(whole.mask).ravel()]), np.sort(r[m]),
                               rtol=1e-9, atol=1e-9)


def test_windows_after_a_reslip_are_left_out():
    """A prior draw whose stiff-spring (k = 200 kgf/mm) slips end above mu_d W/k and slip
    on: their measured slip ends are not where the slider rests (residuals up to 29
    standard errors at the truth when those windows were kept). They are left out and
    counted; every other window stays, and the residuals at the truth are unit normal."""
    fr = ss.Friction(ss.KatoStatic(mu_s=0.5698, mu_d=0.2174, gamma=0.3446, m=0.5057),
                     ss.KatoKinetic(delta=33.84, n=0.9216))
    recs = synthetic_campaign(fr, speed_fractions=(0.05, 0.3), cycles=4, seed=525,
                              pad_to=40_000)  # `campaign`'s simulation program
    feats = [record_features(r) for r in recs]
    stiff = [f.stiffness == 200.0 for f in feats]
    assert all(f.slipped_on.all() for f, s in zip(feats, stiff) if s)
    assert not any(f.slipped_on.any() for f, s in zip(feats, stiff) if not s)
    dropped = sum(f.n_complete for f, s in zip(feats, stiff) if s)
    assert reslip_windows(feats) == dropped > 0
    data = trace_data(recs, feats)
    rows = np.asarray(data.mask).any(axis=1)
    assert np.unique(np.asarray(data.window)[rows]).size == sum(
        f.n_complete for f, s in zip(feats, stiff) if not s)
    r = np.asarray(eqx.filter_jit(trace_residuals)(  # one program, not op by op
        CampaignParams(EmpiricalFriction.from_friction(fr), jnp.zeros(len(recs))), data))
    m = np.asarray(data.mask).ravel()
    assert 0.9 < np.std(r[m]) < 1.1 and np.max(np.abs(r[m])) < 6.0
    with pytest.raises(ValueError, match="re-slip"):  # only re-slipping records: said so
        trace_data([rec for rec, s in zip(recs, stiff) if s],
                   [f for f, s in zip(feats, stiff) if s])
    # keep_reslips (discovery, where a slow gauge lengthens every slip): every window
    kept = trace_data(recs, feats, keep_reslips=True)
    rows = np.asarray(kept.mask).any(axis=1)
    assert np.unique(np.asarray(kept.window)[rows]).size == cycle_windows(feats) == sum(
        f.n_complete - int(f.complete[0]) for f in feats)


def test_trace_fit_recovers_truth_within_intervals(campaign, trace_fit):
    fr, _, _ = campaign
    fit = trace_fit
    unc = laplace(fit)
    truth = truth_values(fr)
    assert fit.converged and fit.trace_failures == 0 and fit.objective.kind == "trace"
    assert 0.8 < fit.reduced_chi2 < 1.3
    # reweighting rounds reached their fixed point: the reported chi2 is the objective's
    # (weights at the optimum), and each round's LM stopped in a few steps
    assert fit.n_rounds < MAX_ROUNDS and fit.n_steps <= 6 * fit.n_rounds
    chi2 = float(np.sum(np.asarray(eqx.filter_jit(fit.objective.residuals)(fit.params)) ** 2))
    assert chi2 == pytest.approx(fit.chi2, rel=1e-6)
    for i, n in enumerate(NAMES):
        lo, hi = unc.ci95[i]
        assert lo <= truth[n] <= hi, (n, unc.value[i], (lo, hi), truth[n])
    for n in ("mu_s", "mu_d"):
        assert fit.values[n] == pytest.approx(truth[n], rel=0.02)


def test_trace_jacobian_matches_finite_differences(trace_fit):
    """Forward-mode derivatives of the restarted simulations (what LM uses) vs central FD."""
    fit = trace_fit
    data = fit.objective.trace
    free, static = eqx.partition(fit.params, fit.spec)
    flat, unravel = jax.flatten_util.ravel_pytree(free)
    mask = np.asarray(data.mask).ravel()

    @jax.jit
    def push(v, t, data):  # one compilation: values and directional derivatives
        def sim(v):
            return trace_simulation(eqx.combine(unravel(v), static), data).deflection.ravel()

        return jax.jvp(sim, (v,), (t,))

    h = 1e-6
    for j in range(flat.size):
        e = jnp.zeros_like(flat).at[j].set(1.0)
        J_j = np.asarray(push(flat, e, data)[1])[mask]
        fd = ((np.asarray(push(flat + h * e, e, data)[0])
               - np.asarray(push(flat - h * e, e, data)[0])) / (2 * h))[mask]
        # on the bulk of the samples (a sample within h of a phase boundary sees the kink)
        err = np.abs(J_j - fd)
        assert np.quantile(err, 0.999) < 1e-5 * np.abs(fd).max() + 1e-10, j
        assert np.abs(fd).max() > 0


@pytest.mark.slow  # ~60 s of compilation on 2 cores; the trace fit itself is checked above
def test_combined_objective_from_the_cli(campaign, tmp_path, capsys):
    """`stickslip fit --objective both`: features and trace residuals weighted 1/2 each."""
    import json

    from stickslip_jax.cli import main

    fr, recs, feats = campaign
    paths = record_files(recs, tmp_path)
    out = tmp_path / "both.json"
    assert main(["fit", *paths, "--objective", "both", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "full trace" in text and "trace residual rms" in text
    rep = json.loads(out.read_text())
    truth = truth_values(fr)
    assert rep["converged"] and rep["trace_window_failures"] == 0
    n_f = sum(2 * r["complete_cycles"] - 1 for r in rep["records"])  # about: levels + sticks
    assert rep["dof"] == pytest.approx(0.5 * n_f + 0.5 * rep["trace_samples"], rel=0.05)
    assert 0.8 < rep["reduced_chi2"] < 1.3
    assert 0.4e-3 < rep["trace_residual_rms_mm"] < 0.6e-3  # the 0.5 um noise
    for n in ("mu_s", "mu_d", "delta"):
        assert rep["parameters"][n]["value"] == pytest.approx(truth[n], rel=0.02)
    # the two objectives read the same samples: intervals come from the cluster-robust
    # (sandwich) covariance, not the Fisher information, and no narrow-interval warning
    assert rep["covariance"] == "sandwich"
    assert not any("objective 'both'" in w for w in rep["identifiability"]["warnings"])


def test_fit_residuals_are_the_objectives(trace_fit):
    """The fit's residuals with the weights frozen at the point itself (and its simulated slider
    velocity) are the objective's `residuals`, for the trace and the combined objective."""
    from stickslip_fitting.objectives.combined import make_objective

    fit = trace_fit
    both = make_objective(Objective.BOTH, fit.data, fit.objective.trace, weights=(0.3, 0.7))
    assert both.kind == "both" and both.weight_of(Objective.TRACE) == 0.7
    assert list(both.blocks()) == ["levels", "stick_times", "start_levels", "trace"]

    @eqx.filter_jit  # one program: outside jit the residuals compile operation by operation
    def pair(obj, params):
        vel = trace_simulation(params, obj.trace_data()).slider_velocity
        r, (ok, _) = obj.residuals_and_aux(params, params, vel)
        return r, obj.residuals(params), ok

    r, expected, ok = pair(both, fit.params)
    assert sum(both.blocks().values()) == expected.size
    parts = both.split(expected)
    assert parts["trace"].size == int(np.prod(fit.objective.trace.mask.shape))
    assert np.asarray(ok).all() and r.shape == expected.shape
    np.testing.assert_allclose(np.asarray(r), np.asarray(expected), rtol=1e-12, atol=1e-12)


def test_bad_inputs(campaign):
    _, recs, feats = campaign
    with pytest.raises(ValueError, match="needs the records"):
        fit_features(feats, objective=Objective.TRACE)
    with pytest.raises(TypeError, match="objective: a member of Objective"):
        fit_features(feats, objective="samples")


def test_a_drive_program_drives_the_windows(campaign):
    """A record driven by a program is simulated through its windows' drive knots; a
    program of one constant speed gives the residuals of that drive speed."""
    fr, recs, feats = campaign
    prog = dataclasses.replace(recs[0], drive_program=((0.0, recs[0].drive_speed),))
    params = CampaignParams(EmpiricalFriction.from_friction(fr), jnp.zeros(len(recs)))
    # the whole campaign, its first record driven by the program: the plain windows are
    # `test_residuals_at_truth_are_unit_normal`'s, so their residuals' program is shared
    res = jax.jit(trace_residuals)
    plain, knotted = trace_data(recs, feats), trace_data([prog, *recs[1:]], feats)
    assert plain.drive_knots is None and knotted.drive_knots is not None
    np.testing.assert_allclose(np.asarray(res(params, knotted)), np.asarray(res(params, plain)),
                               rtol=0, atol=1e-6)


def test_fit_objective_moves_only_the_leaves_chosen(trace_fit):
    """The one fitting verb over an objective and a parameter pytree: the free leaves are
    chosen by a function, as `eqx.tree_at`'s `where`."""
    from stickslip_fitting.solve.fit import fit_objective

    fit = trace_fit
    start = eqx.tree_at(lambda p: p.friction.log_mu_d, fit.params,
                        fit.params.friction.log_mu_d + 0.01)
    out = fit_objective(fit.objective, start, lambda p: p.friction.log_mu_d)
    assert out.converged and out.dof == fit.dof + sum(np.asarray(fit.spec.friction.leaves())) - 1
    for name in ("log_gap", "log_gamma", "log_m", "log_delta", "log_n"):
        assert float(getattr(out.params.friction, name)) == float(getattr(start.friction, name))
    assert abs(float(out.params.friction.log_mu_d) - float(fit.params.friction.log_mu_d)) < 1e-3
