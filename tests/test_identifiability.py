"""Identifiability report (stickslip_fitting.uncertainty.laplace): one speed, one k/W, and a well-designed campaign."""

import numpy as np
import pytest

import stickslip_jax as ss
from stickslip_fitting.data.features import record_features
from stickslip_fitting.solve.fit import fit_features
from stickslip_fitting.modes import Padding
from stickslip_fitting.uncertainty.laplace import laplace
from stickslip_fitting.data.synthetic import synthetic_campaign


@pytest.fixture(scope="module")
def one_speed():
    """Table 1's three (W, k) pairs (all k/W = 2.41/mm: one slip time) at one speed fraction."""
    recs = synthetic_campaign(ss.lubricant("A"), conditions=ss.experimental_conditions(),
                              speed_fractions=(0.1,), cycles=4, seed=5, pad_to=40_000)
    fit = fit_features([record_features(r) for r in recs], padding=Padding(cycles=8))
    return fit, laplace(fit)


def test_one_speed_flags_mu_s_gamma_m_and_n(one_speed):
    fit, unc = one_speed
    assert np.isfinite(fit.chi2)  # the fit finishes
    assert not unc.identifiable["gamma"] and not unc.identifiable["m"]
    assert not unc.identifiable["n"]
    text = " ".join(unc.warnings)
    assert "gamma, m" in text and "one drive speed" in text and "delta*T2^n" in text
    rows = {r["name"]: r for r in unc.table()}
    assert rows["gamma"]["stderr"] is None and rows["gamma"]["ci95"] is None
    # one stick time cannot fix the asymptote either; nothing is printed with a small error
    assert not unc.identifiable["mu_s"]
    assert all(r["stderr"] is None for r in rows.values() if not r["identifiable"])


def test_fisher_spectrum_shows_the_degeneracy(one_speed):
    _, unc = one_speed
    eig = unc.fisher_eigenvalues
    assert eig[0] < 1e-6 * eig[-1]
    weak = unc.weakest_direction
    assert max(weak, key=lambda k: abs(weak[k])) in ("mu_s", "gamma", "m", "delta", "n")
