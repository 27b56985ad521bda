"""A normal load N apart from the weight W: the friction force is mu N, the inertia W/g.

A slideway (W, N, k) is exactly the paper's slideway (W' = N, k' = k N/W) with every
length scaled by W/N (divide its equation of motion by N/W): the simulators and the steady
analysis are checked against that equivalence, the default N = W against the plain
slideway bit for bit, and a campaign with N != W is fitted back.
"""

import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from stickslip_fitting.data.features import record_features
from stickslip_fitting.data.synthetic import truth_values
from stickslip_fitting.modes import Objective, Padding
from stickslip_fitting.params import NAMES
from stickslip_fitting.solve.fit import fit_features
from stickslip_fitting.uncertainty.laplace import laplace

import stickslip_jax as ss
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.limit_cycle import limit_cycle
from stickslip_jax.records import Record, format_record, parse_record
from stickslip_jax.simulation import pad_times, simulate_exact, simulate_smooth

FR = ss.lubricant("A")
W, N, K, V = 36.0, 60.0, 86.9, 0.05  # kgf, kgf, kgf/mm, mm/s
SAMPLES = 6001
"""Samples of every exact simulation run operation by operation here: one length, so
the simulator's operations compile once for the module (measured cold in one process:
181 compilations in place of 247 with three lengths, 4 to 6 s less CPU time)."""


def test_default_load_is_the_weight_bit_for_bit():
    ts = jnp.linspace(0.0, 30.0, SAMPLES)
    plain = simulate_exact(ss.Slideway(FR, W, K), ConstantSpeed(V), ts)
    given = simulate_exact(ss.Slideway(FR, W, K, normal_load=W), ConstantSpeed(V), ts)
    assert ss.Slideway(FR, W, K).load is not None and ss.Slideway(FR, W, K).normal_load is None
    np.testing.assert_array_equal(plain.deflection, given.deflection)
    np.testing.assert_array_equal(plain.cycles.mu_m, given.cycles.mu_m)
    a, b = ss.steady_state(FR, W, K, V), ss.steady_state(FR, W, K, V, normal_load=W)
    for name in ("stick_time", "amplitude", "amplitude_ratio", "critical_speed"):
        assert float(getattr(a, name)) == float(getattr(b, name)), name
    assert float(ss.critical_speed(FR, W, K)) == float(ss.critical_speed(FR, W, K, W))


@pytest.mark.parametrize("load", [12.0, 60.0])
def test_exact_simulator_matches_the_scaled_slideway(load):
    s = W / load  # lengths of the equivalent slideway (W' = N, k' = k N / W) are s times
    ts = jnp.linspace(0.0, 30.0, SAMPLES)
    rig = simulate_exact(ss.Slideway(FR, W, K, normal_load=load), ConstantSpeed(V), ts)
    twin = simulate_exact(ss.Slideway(FR, load, K / s), ConstantSpeed(V * s), ts)
    assert int(jnp.sum(rig.cycles.valid)) >= 3
    np.testing.assert_allclose(np.asarray(rig.deflection) * s, twin.deflection,
                               rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(rig.cycles.stick_time, twin.cycles.stick_time, rtol=1e-9,
                               atol=1e-12)
    np.testing.assert_allclose(rig.cycles.mu_0, twin.cycles.mu_0, rtol=1e-12)
    # the friction drop scales with N, the slip time stays pi sqrt(W/(g k))
    assert float(rig.cycles.model_slip_time[0]) == pytest.approx(
        math.pi * math.sqrt(W / (ss.units.G_MM_S2 * K)), rel=1e-12)


def test_smooth_simulator_matches_the_scaled_slideway():
    s = W / N
    ts = jnp.linspace(0.0, 8.0, 801)
    a = jnp.asarray
    kw = dict(smoothing=a(1e-3), rtol=a(1e-9))
    # compiled whole, not op by op: one program, the twin's normal load given as its
    # weight (the paper's N = W, checked bit for bit above)
    smooth = eqx.filter_jit(simulate_smooth)
    rig = smooth(ss.Slideway(FR, W, K, normal_load=N), ConstantSpeed(a(V)), ts, **kw,
                 atol=a(1e-11))
    twin = smooth(ss.Slideway(FR, N, K / s, normal_load=N), ConstantSpeed(a(V * s)), ts,
                  **kw, atol=a(1e-11 * s))
    x, y = np.asarray(rig.deflection) * s, np.asarray(twin.deflection)
    assert np.ptp(x) > 0.05
    assert np.max(np.abs(x - y)) < 2e-4 * np.ptp(y)


def test_steady_state_with_a_normal_load():
    s = W / N
    rig = ss.steady_state(FR, W, K, V, normal_load=N)
    twin = ss.steady_state(FR, N, K / s, V * s)
    assert float(rig.stick_time) == pytest.approx(float(twin.stick_time), rel=1e-10)
    assert float(rig.amplitude) * s == pytest.approx(float(twin.amplitude), rel=1e-10)
    assert float(rig.critical_speed) * s == pytest.approx(float(twin.critical_speed),
                                                          rel=1e-10)
    assert float(rig.slip_time) == float(ss.steady_state(FR, W, K, V).slip_time)
    with pytest.raises(Exception, match="normal load"):
        ss.steady_state(FR, W, K, V, normal_load=-1.0)


def test_record_carries_the_normal_load():
    t = np.arange(5) * 1e-3
    rec = Record.from_arrays(t, np.zeros(5), stiffness=K, weight=W, normal_load="588.399 N",
                             drive_speed=V)
    assert rec.normal_load == pytest.approx(60.0, rel=1e-6) and rec.load == rec.normal_load
    back = parse_record(format_record(rec))
    assert back == rec and back.normal_load == rec.normal_load
    assert Record.from_arrays(t, np.zeros(5), stiffness=K, weight=W, drive_speed=V).load == W
    assert Record.from_dataframe(rec.to_dataframe()) == rec
    with pytest.raises(ValueError, match="normal_load"):
        rec.replace(normal_load=0.0)


@eqx.filter_jit
def _simulate(friction, loads, ks, vs, x0s, ts, mask):
    def one(n, k, v, x0, t, m):
        return simulate_exact(ss.Slideway(friction, W, k, normal_load=n), ConstantSpeed(v),
                              t, initial_deflection=x0, mask=m, max_events=48)

    return jax.vmap(one)(loads, ks, vs, x0s, ts, mask)


@functools.cache
def _campaign_at_n():
    """`_campaign(FR, N)`, simulated once for the module's tests (records are not changed
    in place: `Record.replace` gives new ones)."""
    return tuple(_campaign(FR, N))


def _campaign(friction, load, seed=3, noise=5e-4, rate=1000.0):
    """Records of W = 36 kgf under the normal load `load` at three k and two speeds, each
    from its steady slip end (eq 5 with N), white noise `noise` mm."""
    plan = []
    for k in (40.0, 86.9, 200.0):
        for frac in (0.03, 0.3):
            v = frac * float(ss.critical_speed(friction, W, k, load))
            st = ss.steady_state(friction, W, k, v, normal_load=load)
            x1 = (2.0 * float(st.mu_m) - float(st.mu_0)) * load / k
            n = int(6 * (float(st.stick_time) + float(st.slip_time)) * rate) + 1
            plan.append((load, k, v, x1 - 1e-9, n))
    times = [np.arange(p[4]) / rate for p in plan]
    ts, mask = pad_times(times)
    f = lambda i: jnp.asarray([p[i] for p in plan])  # noqa: E731
    x = _simulate(friction, f(0), f(1), f(2), f(3), ts, mask).deflection
    rng = np.random.default_rng(seed)
    return [Record(time=times[i], deflection=np.asarray(x[i, :n]) + rng.normal(0, noise, n),
                   stiffness=k, weight=W, normal_load=nl, drive_speed=v, lubricant="A",
                   source=f"n{nl:g}_k{k:g}_{i}.csv")
            for i, (nl, k, v, _, n) in enumerate(plan)]


def test_campaign_with_a_normal_load_is_fitted_back():
    records = list(_campaign_at_n())
    feats = [record_features(r) for r in records]
    assert all(f.stick_slip for f in feats) and all(f.load == N for f in feats)
    fit = fit_features(feats, padding=Padding(cycles=8))
    unc = laplace(fit)
    truth = truth_values(FR)
    assert fit.converged
    for i, name in enumerate(NAMES):
        lo, hi = unc.ci95[i]
        assert lo <= truth[name] <= hi, (name, unc.value[i], (lo, hi), truth[name])
    for name in ("mu_s", "mu_d"):
        assert fit.values[name] == pytest.approx(truth[name], rel=0.02)
    # the same records read as N = W would put mu wrong by the factor N / W
    wrong = [record_features(r.replace(normal_load=None)) for r in records]
    assert np.median(wrong[0].mu_m) == pytest.approx(np.median(feats[0].mu_m) * N / W,
                                                     rel=1e-12)
    # the trace objective simulates with N too: its misfit at the features optimum is noise
    both = fit_features(feats, records=records, objective=Objective.TRACE,
                        padding=Padding(cycles=8))
    assert 0.5 < both.reduced_chi2 < 2.0
    assert both.values["mu_d"] == pytest.approx(truth["mu_d"], rel=0.01)


def test_discovery_model_takes_the_normal_load():
    """The per-cycle discovery model (`discovery.cycle_model`) with every effect at zero
    on records of W = 36 kgf under N = 60 kgf, at the truth: the exact simulator restarted
    per window (friction N mu, inertia W/g) to 1e-3 of a sample's standard error, and the
    residuals are the noise; the same model under N = W misses by many standard errors."""
    from stickslip_fitting.discovery.cycle_model import CycleModel, drift_origins
    from stickslip_fitting.objectives.trace import trace_data, trace_sd, trace_simulation
    from stickslip_fitting.params import CampaignParams, EmpiricalFriction

    @eqx.filter_jit  # one program: outside jit they compile operation by operation
    def _simulation_and_sd(params, data):
        sim = trace_simulation(params, data)
        return sim, trace_sd(params, data, sim.slider_velocity)

    records = list(_campaign_at_n()[::2])
    feats = [record_features(r) for r in records]
    params = CampaignParams(EmpiricalFriction.from_friction(FR), jnp.zeros(len(records)))
    rms = []
    plain = [r.replace(normal_load=None) for r in records]
    for data in (trace_data(records, feats, drive_fix=False),
                 trace_data(plain, [record_features(r) for r in plain], drive_fix=False)):
        sim, sd = _simulation_and_sd(params, data)
        model = CycleModel(data, drift_origins(records), sd, len(records))
        r, _, ok = model.residuals(model.z0(params.friction, np.zeros(len(records))))
        rms.append(float(np.sqrt(np.mean(r**2))))
        if len(rms) == 1:
            exact = ((np.asarray(data.deflection) - np.asarray(sim.deflection))
                     / np.asarray(sd)).ravel()[model.mask]
            assert ok[np.asarray(data.mask).any(1)].all()
            assert np.max(np.abs(r - exact)) < 1e-3
    assert 0.9 < rms[0] < 1.1 and rms[1] > 10.0, rms


@pytest.mark.slow  # 264-465 s at load 13 on 2 cores
def test_discover_with_a_normal_load(tmp_path):
    """`stickslip discover` on three records of W = 36 kgf under N = 60 kgf (the exact
    simulator's, the header's normal_load): the paper's model with N describes them, so
    nothing is named (measured: none, high; gap 0.519 um against 0.500 um noise)."""
    import json

    from stickslip_jax.cli import main
    from stickslip_jax.records import write_record

    paths = [str(write_record(r, tmp_path / r.source)) for r in _campaign_at_n()[::2]]
    out = tmp_path / "d.json"
    assert main(["discover", *paths, "--json", str(out), "--quiet"]) == 0
    rep = json.loads(out.read_text())
    assert rep["effect"] == "none" and rep["confidence"] == "high", rep["explanation"]
    assert rep["gap_before"] < 1.1 * rep["noise"]


def test_limit_cycle_with_a_normal_load():
    """The time-domain limit cycle with N: the exact simulator's last cycle, damped or not."""
    cyc = limit_cycle(FR, W, K, V, normal_load=N)
    assert float(cyc.stick_time) == pytest.approx(
        float(ss.steady_state(FR, W, K, V, normal_load=N).stick_time), rel=1e-9)
    ts = jnp.linspace(0.0, 60.0, SAMPLES)
    tr = simulate_exact(ss.Slideway(FR, W, K, normal_load=N), ConstantSpeed(V), ts,
                        initial_deflection=float(cyc.trough))
    c = tr.cycles
    last = int(jnp.sum(c.valid)) - 1
    assert float(c.peak[last]) == pytest.approx(float(cyc.peak), rel=1e-9)
    assert float(c.stick_time[last]) == pytest.approx(float(cyc.stick_time), rel=1e-9)
    damped = limit_cycle(FR, W, K, V, damping_ratio=0.05, normal_load=N)
    twin = limit_cycle(FR, N, K * N / W, V * W / N, damping_ratio=0.05)
    assert float(damped.amplitude) == pytest.approx(float(twin.amplitude) * N / W, rel=1e-12)
    assert float(limit_cycle(FR, W, K, V, normal_load=W).amplitude) == float(
        limit_cycle(FR, W, K, V).amplitude)


def test_simulate_command_takes_a_normal_load(tmp_path):
    """`stickslip simulate --normal-load` writes a record whose load is N and whose truth
    carries it; W stays the moving weight."""
    from stickslip_jax.cli import main
    from stickslip_jax.records import read_record

    out = tmp_path / "n.csv"
    assert main(["simulate", "--weight", "36", "--normal-load", "588.4 N", "--stiffness",
                 "86.9", "--speed", "5", "--duration", "1", "--out", str(out)]) == 0
    rec = read_record(out)
    assert rec.weight == 36.0 and abs(rec.normal_load - 60.0) < 1e-3
    assert abs(rec.truth["friction"]["normal_load_kgf"] - 60.0) < 1e-3


def test_steady_command_takes_a_normal_load(tmp_path, capsys):
    """`stickslip steady --normal-load`: eq (6), the limit cycle and the tolerance speed of
    the slideway whose friction is mu N (W the moving weight); N = W changes nothing."""
    import json

    from stickslip_jax.cli import main
    from stickslip_jax.units import mm_per_min

    def steady(*extra):
        out = tmp_path / "s.json"
        assert main(["steady", "--weight", "36", "--stiffness", "86.9", "--speed", "3",
                     "--tolerance", "5 um", "--json", str(out), *extra]) == 0
        return json.loads(out.read_text())

    plain, same, rig = steady(), steady("--normal-load", "36"), steady("--normal-load", "588.4 N")
    assert same["results"] == plain["results"]
    n = rig["normal_load_kgf"]
    assert n == pytest.approx(60.0, rel=1e-4) and rig["weight_kgf"] == W
    row, v = rig["results"][0], 3.0 / 60.0
    ref = ss.steady_state(FR, W, K, v, normal_load=n)
    assert row["stick_time_s"] == pytest.approx(float(ref.stick_time), rel=1e-9)
    assert row["amplitude_mm"] == pytest.approx(float(ref.amplitude), rel=1e-9)
    assert row["critical_speed_mm_per_min"] == pytest.approx(
        float(mm_per_min(ref.critical_speed)), rel=1e-9)
    assert row["cycle_amplitude_mm"] == pytest.approx(
        float(limit_cycle(FR, W, K, v, normal_load=n).amplitude), rel=1e-9)
    v_tol = rig["tolerance"]["drive_speed_mm_per_min"] / 60.0
    assert float(limit_cycle(FR, W, K, v_tol, normal_load=n).amplitude) == pytest.approx(
        5e-3, rel=1e-6)
    assert "N = 60" in capsys.readouterr().out
    with pytest.raises(SystemExit) as refused:
        main(["steady", "--weight", "36", "--stiffness", "86.9", "--speed", "3",
              "--normal-load", "-2"])
    assert refused.value.code == 2 and "--normal-load" in capsys.readouterr().err


def test_design_map_takes_a_normal_load(capsys):
    """`design --normal-load` (and `sf.design_map(normal_load=)`): every point the steady
    analysis of the slideway under N; refused with --max-amplitude, which holds N = W."""
    import stickslip_fitting as sf

    from stickslip_jax.cli import main

    study = sf.design_map("20:60:3", "86.9", "1:30:4", normal_load="588.4 N")
    n = study.report["normal_load_kgf"]
    for i, w in enumerate((20.0, 40.0, 60.0)):
        for j, v in enumerate(np.linspace(1.0, 30.0, 4) / 60.0):
            ref = ss.steady_state(FR, w, K, v, normal_load=n)
            assert study.maps["amplitude"][i, 0, j] == pytest.approx(float(ref.amplitude),
                                                                     rel=1e-9, abs=1e-15)
            assert study.maps["critical_speed"][i, 0, j] == pytest.approx(
                float(ref.critical_speed), rel=1e-9)
    assert main(["design", "--weight", "36", "--stiffness", "86.9", "--speed", "5",
                 "--normal-load", "60", "--max-amplitude", "1um"]) == 2
    assert "--normal-load" in capsys.readouterr().err


def test_law_starts_read_the_normal_load():
    """The starting points of the other friction laws (`solve.laws.law_starts`) take mu
    from k x / N: records of W = 36 kgf under N = 60 kgf give the starts of the same
    records with W = N (the weight only sets the inertia)."""
    import dataclasses

    from stickslip_fitting.modes import FrictionLaw
    from stickslip_fitting.solve.laws import law_starts

    feats = [record_features(r) for r in _campaign_at_n()[::2]]
    same = [dataclasses.replace(f, weight=N, normal_load=None) for f in feats]
    for law in (FrictionLaw.LOG_AGING, FrictionLaw.RATE_STATE_AGING):
        assert law_starts(law, feats) == law_starts(law, same)
