"""emcee posterior (stickslip_fitting.uncertainty.mcmc): agrees with the Laplace intervals, diagnostics, CLI, plots."""

import json

import jax.numpy as jnp
import numpy as np
import pytest

import stickslip_jax as ss
from stickslip_fitting.data.features import record_features
from stickslip_fitting.solve.fit import fit_features
from stickslip_fitting.uncertainty.mcmc import log_posterior, run_mcmc
from stickslip_fitting.modes import Covariance
from stickslip_fitting.data.synthetic import synthetic_campaign, truth_values
from stickslip_fitting.uncertainty.laplace import laplace
from record_files import record_files


@pytest.fixture(scope="module")
def fitted():
    recs = synthetic_campaign(ss.lubricant("A"), speed_fractions=(0.05, 0.3), cycles=4, seed=2,
                              pad_to=40_000)
    fit = fit_features([record_features(r) for r in recs])
    return recs, fit


def test_vectorised_log_posterior(fitted):
    _, fit = fitted
    logp, theta0, names, n_off = log_posterior(fit)
    assert names == ["mu_s", "mu_d", "gamma", "m", "delta", "n"] and n_off == 0
    batch = jnp.stack([jnp.asarray(theta0), jnp.asarray(theta0) + 0.01])
    lp = np.asarray(logp(batch))
    assert lp.shape == (2,) and lp[0] > lp[1]
    assert lp[0] == pytest.approx(-0.5 * fit.chi2 / max(1.0, fit.reduced_chi2))
    outside = jnp.asarray(theta0).at[3].set(jnp.log(50.0))[None]  # m = 50: outside the prior
    assert np.asarray(logp(outside))[0] == -np.inf


def test_posterior_matches_laplace_and_contains_truth(fitted):
    _, fit = fitted
    res = run_mcmc(fit, walkers=24, steps=800, seed=1)
    unc = laplace(fit)
    truth = truth_values(ss.lubricant("A"))
    summ = res.summary()
    for i, n in enumerate(res.names):
        s = summ[n]
        assert s["ci95"][0] <= truth[n] <= s["ci95"][1], n
        # posterior sd within a factor 2 of the Laplace standard error
        assert 0.5 < s["sd"] / unc.stderr[i] < 2.0, (n, s["sd"], unc.stderr[i])
        assert s["ess"] > 0 and s["tau_steps"] > 0
    assert 0.1 < res.acceptance < 0.9
    assert "log-uniform" in res.prior


def test_short_chain_warns(fitted):
    _, fit = fitted
    res = run_mcmc(fit, walkers=16, steps=40, seed=0)
    assert any("too short" in w for w in res.warnings)
    with pytest.raises(ValueError, match="--walkers"):
        run_mcmc(fit, walkers=4, steps=40)


def test_cli_mcmc_and_plots(fitted, tmp_path, capsys):
    from stickslip_fitting.report.plots import fit_figure
    from stickslip_jax.cli import main

    recs, fit = fitted
    paths = record_files(recs, tmp_path)
    out, corner = tmp_path / "m.json", tmp_path / "corner.png"
    rc = main(["mcmc", *paths, "--walkers", "16", "--steps", "60", "--no-progress",
               "--json", str(out), "--corner", str(corner)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "prior:" in text and "ESS" in text and "too short" in text
    rep = json.loads(out.read_text())
    assert set(rep["parameters"]) == {"mu_s", "mu_d", "gamma", "m", "delta", "n"}
    # the posterior draws travel in the JSON: `stickslip design --posterior` reads them
    draws = np.asarray(rep["samples"])
    assert rep["names"] == list(rep["parameters"]) and draws.shape == (16 * 45, 6)
    assert rep["fixed"] == {}
    for i, n in enumerate(rep["names"]):
        assert np.median(draws[:, i]) == pytest.approx(rep["parameters"][n]["median"], rel=0.02)
    assert main(["design", "--posterior", str(out), "--weight", "36", "--stiffness", "86.9",
                 "--speed", "1:100:6:log", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    prob = np.asarray(doc["probability_stick_slip"]).ravel()
    assert prob[0] == 1.0 and prob[-1] == 0.0  # 1 mm/min sticks; 100 mm/min > v_c = 49
    band = np.asarray(doc["critical_speed_band_mm_min"]).ravel()
    assert 40 < band[1] < 60
    # a fixed parameter goes into "fixed"; --draws thins the matrix
    out2 = tmp_path / "m2.json"
    assert main(["mcmc", *paths, "--walkers", "16", "--steps", "20", "--no-progress",
                 "--fix", "n=1", "--draws", "50", "--json", str(out2)]) == 0
    rep2 = json.loads(out2.read_text())
    assert rep2["fixed"] == {"n": 1.0} and "n" not in rep2["names"]
    assert 25 <= len(rep2["samples"]) <= 50 and len(rep2["samples"][0]) == 5
    from stickslip_fitting.design.posterior import load_samples

    sample = load_samples(out2)
    assert np.all(np.asarray(sample.kinetic.n) == 1.0)
    capsys.readouterr()
    assert corner.stat().st_size > 10_000
    png = tmp_path / "fit.png"
    fit_figure(fit, laplace(fit), recs, png)
    assert png.stat().st_size > 10_000


def test_fitted_traces_follow_the_records(fitted):
    # the figure's overlay: the restarted simulation at the fitted parameters lies on
    # the record within its noise inside every window, NaN separates the windows
    from stickslip_fitting.report.plots import fitted_traces, friction_curves

    recs, fit = fitted
    sims = fitted_traces(fit, recs)  # every record: the program of the figure's traces
    assert sims is not None and len(sims) == len(recs)
    for rec, f, (t, x) in zip(recs, fit.features, sims):
        gaps = np.isnan(t)
        assert gaps.sum() == np.count_nonzero(f.complete[1:]) and np.isnan(x[gaps]).all()
        idx = np.searchsorted(rec.time, t[~gaps])
        np.testing.assert_array_equal(rec.time[idx], t[~gaps])
        resid = rec.deflection[idx] - x[~gaps]
        assert np.sqrt(np.mean(resid**2)) < 3 * f.noise
    grid, best, lo, hi = friction_curves(fit, laplace(fit), n_draws=50)
    assert np.all(lo <= best + 1e-12) and np.all(best <= hi + 1e-12) and np.all(hi > lo)
    assert np.allclose(best, np.asarray(fit.params.friction.friction().static(grid)))


def test_trace_likelihood_tempered_to_the_robust_intervals(fitted, tmp_path, capsys,
                                                          monkeypatch):
    """`stickslip mcmc --objective trace`: the sampler draws from the trace objective the
    fit minimised, tempered so that no parameter's posterior is narrower than its
    cluster-robust Laplace interval (module doc of stickslip_fitting.uncertainty.mcmc).
    The checks of the tempering read the command's own trace fit."""
    from stickslip_fitting.commands import mcmc as mcmc_command
    from stickslip_fitting.uncertainty.mcmc import likelihood_scale
    from stickslip_jax.cli import main

    recs, _ = fitted
    paths = record_files(recs, tmp_path)
    out = tmp_path / "t.json"
    posteriors = []
    sample = mcmc_command.posterior

    def kept(*args, **kwargs):
        posteriors.append(sample(*args, **kwargs))
        return posteriors[-1]

    monkeypatch.setattr(mcmc_command, "posterior", kept)
    # 250 steps: the walkers start in a small ball and spread, so a shorter chain gives
    # narrower posteriors and the check below is the harder to pass (measured, seed 0:
    # sd / robust stderr at least 0.69 after 250 steps, 0.86 after 400; each truth between
    # 0.29 and 0.69 of its interval); each step evaluates the trace objective on 16 walkers
    assert main(["mcmc", *paths, "--objective", "trace", "--walkers", "16", "--steps", "250",
                 "--no-progress", "--json", str(out)]) == 0
    assert "likelihood: trace objective" in capsys.readouterr().out
    tfit = posteriors[0].campaign_fit.fit
    scale = likelihood_scale(tfit)
    robust, fisher = laplace(tfit), laplace(tfit, covariance=Covariance.FISHER)
    assert robust.covariance == "sandwich"
    ratio = np.nanmax(np.diag(robust.cov_log) / np.diag(fisher.cov_log))
    assert scale == pytest.approx(max(1.0, tfit.reduced_chi2) * max(1.0, ratio), rel=1e-9)
    logp, theta0, _, _ = log_posterior(tfit, scale)
    # 8 rows, as the command's sampler evaluates its 16 walkers (two halves of 8 a step):
    # its compiled program
    lp = np.asarray(logp(jnp.tile(jnp.asarray(theta0), (8, 1))))
    assert lp.shape == (8,) and np.all(lp == lp[0])
    assert float(lp[0]) == pytest.approx(-0.5 * tfit.chi2 / scale, rel=1e-6)
    # the objective and the tempering travel in the JSON
    rep = json.loads(out.read_text())
    assert rep["objective"] == "trace" and rep["likelihood_scale"] == pytest.approx(scale,
                                                                                    rel=1e-6)
    truth = truth_values(ss.lubricant("A"))
    for i, n in enumerate(rep["names"]):
        s = rep["parameters"][n]
        assert s["ci95"][0] <= truth[n] <= s["ci95"][1], n
        # no narrower than the robust interval (a short chain: a loose factor)
        assert s["sd"] > 0.5 * robust.stderr[i], (n, s["sd"], robust.stderr[i])
