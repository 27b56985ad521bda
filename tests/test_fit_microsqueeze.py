"""Microsqueeze-model fit (h_e, Q in place of gamma, m): recovery on a synthetic campaign
made with the microsqueeze law, impossible trial points, and `stickslip fit --model
microsqueeze` end to end."""

import json

import jax.numpy as jnp
import numpy as np
import pytest

from stickslip_fitting.data.features import record_features
from stickslip_fitting.modes import Objective
from stickslip_fitting.uncertainty.mcmc import PRIOR_BOUNDS, log_posterior, run_mcmc
from stickslip_fitting.solve.microsqueeze import default_eta, fit_microsqueeze
from stickslip_fitting.microsqueeze_params import MICROSQUEEZE_NAMES, MicrosqueezeFriction
from stickslip_fitting.data.synthetic import synthetic_campaign
from stickslip_fitting.uncertainty.laplace import laplace
from stickslip_jax.cli import main
from stickslip_jax.contact import MicrosqueezeStatic
from stickslip_jax.friction import Friction, KatoKinetic
from stickslip_jax.records import write_record

ETA_A = 2.2e-8  # kgf s/mm^2, Table 11 lubricant A


@pytest.fixture(scope="module")
def truth_friction():
    # checked at construction: no run-time check of its values in the simulator's program
    # (a host callback, which would keep the program out of the compilation cache)
    law = MicrosqueezeStatic.from_table11("A", check_traced=False)
    return Friction(law, KatoKinetic(delta=40.0, n=1.0))


@pytest.fixture(scope="module")
def records(truth_friction):
    # two k/W (slip times) x two speeds a factor 4 apart; 4 cycles each at 1 kHz
    return synthetic_campaign(truth_friction, conditions=((36.0, 40.0), (36.0, 86.9)),
                              speed_fractions=(0.1, 0.4), cycles=4, seed=3)


@pytest.fixture(scope="module")
def fitted(records):
    fit = fit_microsqueeze([record_features(r) for r in records], eta=ETA_A, pair="S1G1")
    return fit, laplace(fit)


def test_params_round_trip_and_law(truth_friction):
    p = MicrosqueezeFriction.from_friction(truth_friction)
    v = np.asarray(p.values())
    np.testing.assert_allclose(v, [0.450, 0.156, 0.851e-3, 28.4, 40.0, 1.0], rtol=1e-9)
    np.testing.assert_allclose(np.asarray(p.from_log_values(p.log_values()).values()), v, rtol=1e-9)
    T = jnp.array([0.1, 1.0, 10.0, 100.0])
    np.testing.assert_allclose(np.asarray(p.friction().static(T)),
                               np.asarray(truth_friction.static(T)), rtol=1e-12)


def test_impossible_trial_points_do_not_raise(truth_friction):
    p = MicrosqueezeFriction.from_friction(truth_friction)
    # margin h_e - t_b - a_d underflowing to 0, Q -> 0, mu_s above C1, mu_d below film friction
    for field, value in (("log_margin", -800.0), ("log_Q", -900.0), ("log_gap", 1.0),
                         ("log_mu_d", -30.0)):
        bad = eqx_set(p, field, value)
        mu = np.asarray(bad.friction().static(jnp.array([0.5, 5.0])))
        assert np.all(np.isfinite(mu)), field
    with pytest.raises(ValueError, match="h_e"):
        MicrosqueezeFriction.from_values(0.45, 0.156, 0.5e-3, 28.4, 40.0, 1.0, eta=ETA_A)


def eqx_set(p, field, value):
    import equinox as eqx

    return eqx.tree_at(lambda q: getattr(q, field), p, jnp.asarray(value))


def test_recovery_within_intervals(fitted, records):
    fit, unc = fitted
    truth = records[0].truth["friction"]
    assert set(truth) == set(MICROSQUEEZE_NAMES)
    assert fit.converged and fit.reduced_chi2 < 2.0
    rows = {r["name"]: r for r in unc.table()}
    assert rows["h_e"]["unit"] == "mm" and rows["Q"]["unit"] == "mm^4"
    for name in ("h_e", "Q", "mu_s", "mu_d", "delta", "n"):
        lo, hi = rows[name]["ci95"]
        assert lo <= truth[name] <= hi, (name, rows[name], truth[name])
    for name in ("mu_s", "mu_d"):
        assert abs(rows[name]["value"] / truth[name] - 1) < 0.02, name
    # the fit is not the start: the best start was moved
    assert fit.n_steps > 0


@pytest.fixture(scope="module")
def paths(records, tmp_path_factory):
    d = tmp_path_factory.mktemp("ms_records")
    out = []
    for r in records:
        write_record(r, d / f"{r.name}.csv")
        out.append(str(d / f"{r.name}.csv"))
    return out


def test_cli_microsqueeze(paths, tmp_path, capsys):
    out = tmp_path / "ms.json"
    assert main(["fit", *paths, "--model", "microsqueeze", "--eta", "0.216 Pa*s",
                 "--surface", "S1G1", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "h_e" in text and "mm^4" in text and "truth" in text
    rep = json.loads(out.read_text())
    assert rep["model"] == "microsqueeze"
    assert list(rep["parameters"]) == list(MICROSQUEEZE_NAMES)
    assert rep["parameters"]["Q"]["unit"] == "mm^4" and rep["parameters"]["h_e"]["unit"] == "mm"
    assert rep["given"]["eta"]["value"] == pytest.approx(ETA_A, rel=2e-3)  # 0.216 Pa*s
    assert rep["parameters"]["h_e"]["truth_in_ci95"] and rep["parameters"]["Q"]["truth_in_ci95"]
    # a bad surface name and --eta with the empirical model: one line, exit 2
    assert main(["fit", *paths, "--model", "microsqueeze", "--surface", "XX"]) == 2
    assert main(["fit", *paths, "--eta", "0.2 Pa*s"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all("Traceback" not in e for e in err)


@pytest.mark.slow  # 45 s: run in CI's slow phase (the default suite stays under 10 min)
def test_trace_objective_with_the_microsqueeze_law(records, paths, tmp_path, truth_friction):
    """Every objective works with both friction laws: the trace fit of the microsqueeze law
    (from the features fit's optimum) recovers every parameter within its robust 95 %
    interval, through the library and `stickslip fit --objective trace`."""
    from stickslip_fitting.data.synthetic import truth_values

    truth = truth_values(truth_friction)
    fit = fit_microsqueeze([record_features(r) for r in records], eta=ETA_A, pair="S1G1",
                           objective=Objective.TRACE, records=records)
    unc = laplace(fit)
    assert fit.converged and fit.objective.kind == "trace" and unc.covariance == "sandwich"
    assert 0.8 < fit.reduced_chi2 < 1.3
    for i, n in enumerate(MICROSQUEEZE_NAMES):
        assert unc.ci95[i, 0] <= truth[n] <= unc.ci95[i, 1], n
    out = tmp_path / "mst.json"
    assert main(["fit", *paths, "--model", "microsqueeze", "--eta", "0.216 Pa*s",
                 "--objective", "trace", "--json", str(out)]) == 0
    rep = json.loads(out.read_text())
    assert rep["model"] == "microsqueeze" and "trace" in rep["objective"]
    assert rep["trace_window_failures"] == 0


def test_default_eta():
    assert default_eta("C") == pytest.approx(9.79e-8)
    assert default_eta(None) == default_eta("unknown") == pytest.approx(ETA_A)


def test_mcmc_log_posterior_support(fitted):
    """Vectorised log-posterior of the microsqueeze model: the fit's chi2 at the optimum,
    zero density outside the prior or the law's physical region."""
    fit, _ = fitted
    logp, theta0, names, n_off = log_posterior(fit)
    assert tuple(names) == MICROSQUEEZE_NAMES and n_off == 0
    t0 = jnp.asarray(theta0)
    rows = [t0, t0 + 1e-3,
            t0.at[2].set(np.log(1e-4)),     # h_e = 0.1 um < t_b + a_d (about 0.8 um)
            t0.at[0].set(np.log(1.5)),      # mu_s above C1 = 1: no film thickness solves eq (35)
            t0.at[3].set(np.log(1e12))]     # Q outside the stated prior
    lp = np.asarray(logp(jnp.stack(rows)))
    scale = max(1.0, fit.reduced_chi2)
    assert lp[0] == pytest.approx(-0.5 * fit.chi2 / scale, rel=1e-9)
    assert np.isfinite(lp[1]) and lp[1] < lp[0]
    assert np.all(lp[2:] == -np.inf), lp
    assert PRIOR_BOUNDS["Q"][1] < 1e12


def test_mcmc_microsqueeze(fitted, records):
    fit, unc = fitted
    res = run_mcmc(fit, walkers=12, steps=20, seed=1)
    assert tuple(res.names) == MICROSQUEEZE_NAMES and res.samples.shape == (12 * 15, 6)
    assert res.units["h_e"] == "mm" and res.units["Q"] == "mm^4"
    assert "h_e in [1e-05, 0.1] mm" in res.prior and "Q in" in res.prior and "mm^4" in res.prior
    assert any("too short" in w for w in res.warnings)
    assert np.all(np.isfinite(res.tau)) and np.all(res.ess > 0)
    # the walkers start in a ball around the optimum and stay in its neighbourhood
    med = np.median(res.samples, axis=0)
    np.testing.assert_allclose(med, unc.value, rtol=0.05)


def test_cli_mcmc_microsqueeze(paths, tmp_path, capsys):
    out, corner = tmp_path / "ms_mcmc.json", tmp_path / "corner.png"
    assert main(["mcmc", *paths, "--model", "microsqueeze", "--eta", "0.216 Pa*s",
                 "--walkers", "12", "--steps", "12", "--no-progress",
                 "--json", str(out), "--corner", str(corner)]) == 0
    text = capsys.readouterr().out
    assert "h_e" in text and "mm^4" in text and "prior:" in text and "ESS" in text
    assert "given: eta = 2.203e-08 kgf*s/mm^2, surface S1G1" in text  # 0.216 Pa*s
    assert "too short" in text
    rep = json.loads(out.read_text())
    assert rep["model"] == "microsqueeze" and rep["names"] == list(MICROSQUEEZE_NAMES)
    assert rep["fixed"] == {}
    assert rep["parameters"]["Q"]["unit"] == "mm^4" and "truth" in rep["parameters"]["h_e"]
    assert rep["given"]["surface"] == "S1G1" and "microsqueeze physical region" in rep["prior"]
    assert np.asarray(rep["samples"]).shape == (12 * 9, 6)
    assert corner.stat().st_size > 10_000
