"""The friction-parameter family (stickslip_fitting.params, stickslip_fitting.microsqueeze_params)."""

from __future__ import annotations

import numpy as np
import pytest

from stickslip_fitting.microsqueeze_params import MicrosqueezeFriction
from stickslip_fitting.params import (CampaignParams, EmpiricalFriction, Hold, free_mask,
                                      free_spec)

A = dict(mu_s=0.56, mu_d=0.21, gamma=0.38, m=0.4, delta=67.0, n=1.0)


def _laws():
    emp = EmpiricalFriction.from_values(**A)
    micro = MicrosqueezeFriction.from_values(0.4, 0.2, 0.01, 1.0, 50.0, 1.0, eta=2.2e-8)
    return emp, micro


@pytest.mark.parametrize("i", [0, 1])
def test_log_values_round_trip(i):
    p = _laws()[i]
    back = p.from_log_values(p.log_values())
    np.testing.assert_allclose(np.asarray(back.values()), np.asarray(p.values()), rtol=1e-9)
    assert type(back) is type(p)
    assert list(p.named_values()) == list(p.NAMES)


@pytest.mark.parametrize("i", [0, 1])
def test_with_values_checks_the_domain(i):
    p = _laws()[i]
    q = p.with_values(delta=12.5)
    assert q.named_values()["delta"] == pytest.approx(12.5)
    assert q.named_values()["mu_s"] == pytest.approx(p.named_values()["mu_s"])
    with pytest.raises(ValueError, match="unknown parameter"):
        p.with_values(bogus=1.0)
    with pytest.raises(ValueError, match="mu_s > mu_d"):
        p.with_values(mu_d=0.9)
    with pytest.raises(ValueError, match="positive"):
        p.with_values(n=-1.0)


def test_free_spec_and_mask():
    emp, _ = _laws()
    params = CampaignParams(emp, np.zeros(3))
    spec = free_spec(params, hold=Hold(lambda f: (f.log_n, f.log_gap), (1.0, 0.4)),
                     offsets=True)
    assert free_mask(spec).tolist() == [False, True, True, True, True, False]
    assert bool(spec.offset)
    assert free_mask(free_spec(params)).all() and not bool(free_spec(params).offset)
    with pytest.raises(ValueError, match="unknown parameter"):
        free_spec(params, hold=Hold.named({"h_e": 1.0}))


@pytest.mark.parametrize("i", [0, 1])
def test_hold_selects_leaves_by_a_function(i):
    """A `Hold` names its parameters by a function over the friction module (like
    `eqx.tree_at`'s `where`), in its own order; `Hold.named` is the same from names."""
    law = _laws()[i]
    shape = "log_m" if i == 0 else "log_Q"
    hold = Hold(lambda f: (f.log_n, getattr(f, shape)), (1.1, 0.7))
    name = {"log_m": "m", "log_Q": "Q"}[shape]
    assert hold.natural(law) == {"n": 1.1, name: 0.7}
    assert Hold(lambda f: f.log_n, 1.1).natural(law) == {"n": 1.1}
    assert Hold.named({name: 0.7, "n": 1.1}).natural(law) == {name: 0.7, "n": 1.1}
    held = hold.apply(law).named_values()
    assert held["n"] == pytest.approx(1.1, rel=1e-14)
    assert held[name] == pytest.approx(0.7, rel=1e-14)
    with pytest.raises(ValueError, match="2 values given"):
        Hold(lambda f: f.log_n, (1.0, 2.0)).natural(law)
    with pytest.raises(ValueError, match="unknown parameter"):
        Hold.named({"nu": 1.0}).natural(law)


def test_physical_region():
    emp, micro = _laws()
    assert bool(emp.physical()) and bool(micro.physical())
    # a margin far below the floor: the microsqueeze law clips, outside its region
    import equinox as eqx

    off = eqx.tree_at(lambda f: f.log_margin, micro, micro.log_margin - 80.0)
    assert not bool(off.physical())


def test_parameter_estimate_row():
    from stickslip_fitting.report.rows import ParameterEstimate

    e = ParameterEstimate("mu_s", "-", 0.55, 0.01, (0.53, 0.57)).with_truth({"mu_s": 0.56})
    assert e.truth_in_ci95 and e.relative_error == pytest.approx(-1 / 56)
    j = e.to_json()
    assert j["ci95"] == [0.53, 0.57] and j["truth"] == 0.56 and j["truth_in_ci95"]
    fixed = ParameterEstimate("n", "-", 1.0, None, None, fixed=True)
    assert fixed.truth_in_ci95 is None and "truth" not in fixed.to_json()


@pytest.mark.parametrize("i", [0, 1])
def test_fixed_mu_s_is_held_exactly(i):
    """--fix mu_s with mu_d free: the law is anchored at mu_s (a stored gap mu_s - mu_d
    would move mu_s with mu_d, and a fit would print 'mu_s 0.31722 fixed' for --fix
    mu_s=0.3)."""
    import equinox as eqx

    p = _laws()[i].with_fixed({"mu_s": 0.35})
    assert p.fixed_mu_s == 0.35
    params = CampaignParams(p, np.zeros(2))
    spec = free_spec(params, hold=Hold.named({"mu_s": 0.35}))
    assert free_mask(spec)[1] and not free_mask(spec)[0]
    moved = eqx.tree_at(lambda q: q.friction.log_mu_d, params, params.friction.log_mu_d - 0.2)
    assert float(moved.friction.values()[0]) == pytest.approx(0.35, abs=1e-15)
    assert float(moved.friction.values()[1]) < float(params.friction.values()[1])
    back = p.from_log_values(p.log_values())
    assert back.fixed_mu_s == 0.35
    # a fixed mu_s below the start's mu_d moves mu_d, never the fixed value
    low = _laws()[i].with_fixed({"mu_s": 0.25})
    assert low.named_values()["mu_s"] == pytest.approx(0.25)
    assert low.named_values()["mu_d"] < 0.25
    with pytest.raises(ValueError, match="mu_s > mu_d"):
        _laws()[i].with_fixed({"mu_s": 0.2, "mu_d": 0.3})


def test_fit_honours_fixed_values():
    import stickslip_jax as ss
    from stickslip_fitting.data.features import record_features
    from stickslip_fitting.solve.fit import fit_features
    from stickslip_fitting.data.synthetic import synthetic_campaign

    # the synthetic campaigns' padded length: their simulation program, compiled once
    recs = synthetic_campaign(ss.lubricant("A"), speed_fractions=(0.05, 0.3), cycles=3,
                              seed=4, pad_to=40_000)
    feats = [record_features(r) for r in recs]
    fit = fit_features(feats, hold=Hold(lambda f: (f.log_gap, f.log_n), (0.3, 1.2)))
    assert fit.values["mu_s"] == 0.3 and fit.values["n"] == pytest.approx(1.2, rel=1e-15)
    assert fit.values["mu_d"] < 0.3
    # held by name: the same hold
    named = fit_features(feats, hold=Hold.named({"mu_s": 0.3, "n": 1.2}))
    assert named.values == fit.values


def test_mcmc_rows_are_the_fit_rows():
    """One typed parameter row for fit and mcmc reports."""
    import numpy as np

    from stickslip_fitting.uncertainty.mcmc import McmcResult
    from stickslip_fitting.report.rows import ParameterEstimate

    rng = np.random.default_rng(0)
    res = McmcResult(names=["mu_s", "n"], samples=rng.normal([0.5, 1.0], 0.01, (400, 2)),
                     tau=np.ones(2), ess=np.full(2, 400.0), acceptance=0.3, walkers=8,
                     steps=50, burn=0, prior="", warnings=[], units={"mu_s": "-", "n": "-"})
    rows = res.estimates({"mu_s": 0.5, "n": 1.0})
    assert all(isinstance(r, ParameterEstimate) for r in rows)
    assert rows[0].value == pytest.approx(np.median(res.samples[:, 0]))
    assert rows[0].truth_in_ci95 and set(rows[0].to_json()) >= {"value", "stderr", "ci95"}
