"""Microsqueeze-model fit (h_e, Q in place of gamma, m): recovery on a synthetic campaign
made with the microsqueeze law, impossible trial points, and `stickslip fit --model
microsqueeze` end to end."""

import json

import jax.numpy as jnp
import numpy as np
import pytest

from fitting.features import record_features
from fitting.microsqueeze_fit import default_eta, fit_microsqueeze
from fitting.microsqueeze_params import MICROSQUEEZE_NAMES, MicrosqueezeFriction
from fitting.synthetic import synthetic_campaign
from fitting.uncertainty import laplace
from stickslip_jax.cli import main
from stickslip_jax.contact import MicrosqueezeStatic
from stickslip_jax.friction import Friction, KatoKinetic
from stickslip_jax.records import write_record

ETA_A = 2.2e-8  # kgf s/mm^2, Table 11 lubricant A


@pytest.fixture(scope="module")
def truth_friction():
    return Friction(MicrosqueezeStatic.from_table11("A"), KatoKinetic(delta=40.0, n=1.0))


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


def test_cli_microsqueeze(records, tmp_path, capsys):
    paths = []
    for r in records:
        p = tmp_path / f"{r.name}.csv"
        write_record(r, p)
        paths.append(str(p))
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


def test_default_eta():
    assert default_eta("C") == pytest.approx(9.79e-8)
    assert default_eta(None) == default_eta("unknown") == pytest.approx(ETA_A)
