"""Sparse forms of the residual (`discovery.sparse`): the regression recovers planted
terms exactly, the slip terms are the slider's response to a force, and (slow) on
campaigns with effects outside the library, from the independent generator, discovery
answers with the form, in words naming the right phase and variable.

`python tests/test_sparse_forms.py [SEEDS]` prints the campaign table.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import types

import numpy as np
import pytest

from stickslip_fitting.discovery import sparse

sys.path.insert(0, os.path.dirname(__file__))
import independent_records as ir  # noqa: E402


def _planted(seed: int, j: int, size: float):
    """Whitened residuals: unit noise + a base combination + `size` x the column j of a
    correlated library (every column a smooth function plus a shared part)."""
    rng = np.random.default_rng(seed)
    n, p, K = 3000, 7, len(sparse.TERMS)
    t = np.linspace(0.0, 1.0, n)
    base = np.stack([np.cos(np.pi * i * t) for i in range(p)], axis=1)
    shared = rng.standard_normal(n)
    C = np.stack([np.sin((3 + 1.7 * k) * np.pi * t + k) ** (1 + k % 3) + 0.3 * shared
                  for k in range(K)], axis=1)
    b = rng.standard_normal(n) + base @ rng.standard_normal(p) + size * C[:, j]
    return base, b, C


@pytest.mark.parametrize("seed", range(8))
def test_select_terms_recovers_a_planted_term_exactly(seed):
    j = seed * 3 % len(sparse.TERMS)
    base, b, C = _planted(seed, j, size=0.8)
    S, rss = sparse.select_terms(base, b, C)
    assert list(S) == [j]
    beta = np.linalg.lstsq(np.hstack([base, C[:, S]]), b, rcond=None)[0]
    assert beta[-1] == pytest.approx(0.8, abs=0.1)
    assert rss < 1.1 * b.size


def test_select_terms_keeps_nothing_in_noise():
    rng = np.random.default_rng(5)
    base, _, C = _planted(5, 0, 0.0)
    hits = sum(sparse.select_terms(base, rng.standard_normal(base.shape[0]), C)[0].size > 0
               for _ in range(20))
    assert hits <= 1


def test_terms_refitted_to_zero_are_not_reported():
    """A term whose refitted coefficient is within `MIN_T` standard errors of zero is left
    out of the form (its words would name a phase the records do not show); the others
    keep their order by significance, and a term without a standard error stays."""
    coef = {3: -2.69, 10: -4.1e-10, 7: 0.5, 12: 1.0}
    se = {3: 0.03, 10: 1e-3, 7: 0.2, 12: 0.0}
    assert sparse.significant_terms([10, 7, 3, 12, 20], coef, se) == [12, 3, 7]
    assert sparse.significant_terms([10], coef, se) == []


def test_select_terms_keeps_no_pair_of_one_creep_with_opposite_signs():
    """Two collinear columns that cancel (a creep's two parts with opposite signs, whose
    difference no creep makes) are not both kept where `same_sign` pairs them; the pair
    is kept where it is not paired."""
    base, _, C = _planted(11, 0, 0.0)
    rng = np.random.default_rng(11)
    # their difference is no column of the library (0.2 C[:, 2] would let {0, 2} stand in)
    C[:, 1] = C[:, 0] + 0.2 * np.cos(40.0 * np.linspace(0.0, 1.0, base.shape[0]))
    b = rng.standard_normal(base.shape[0]) + 3.0 * C[:, 0] - 2.5 * C[:, 1]
    free, _ = sparse.select_terms(base, b, C)
    paired, _ = sparse.select_terms(base, b, C, same_sign=((0, 1),))
    assert {0, 1} <= set(free)
    assert not {0, 1} <= set(paired)


def _one_slip_model(W=36.0, k=86.9, rate=20000.0):
    """A stand-in for the per-cycle model: one window, the slider slipping from 50 ms for
    half a period pi/omega_0, then at rest."""
    w0 = np.sqrt(k * 9806.65 / W)
    t = np.arange(0.0, 0.2, 1.0 / rate)[None, :]
    slip = (t >= 0.05) & (t < 0.05 + np.pi / w0)
    yd = np.where(slip, np.sin(w0 * (t - 0.05)), 0.0)
    row = lambda v: np.array([v])  # noqa: E731
    data = types.SimpleNamespace(
        mask=np.ones_like(t, bool), record=row(0), window=row(0), start_time=row(0.0),
        stick_time=row(0.05), speed=row(0.1), stiffness=row(k), weight=row(W),
        time=t, deflection=np.zeros_like(t))
    return types.SimpleNamespace(data=data, scales=np.ones(7), n_base=7,
                                 residuals=lambda z: (None, yd, None)), w0, t.ravel()


def test_slip_terms_are_the_response_to_a_force():
    """A constant force W c during a half-period slip moves the slider by
    (g c / omega_0^2)(1 - cos omega_0 tau), and it stays there once the slider stops."""
    model, w0, t = _one_slip_model()
    C = sparse.library(model, np.zeros(7), np.zeros(t.size), np.ones(t.size))
    col = C[:, [term.name for term in sparse.TERMS].index("slip_sign")]
    tau = np.clip(t - 0.05, 0.0, np.pi / w0)
    expected = -9806.65 / w0 ** 2 * (1.0 - np.cos(w0 * tau))
    assert np.max(np.abs(col - expected)) < 0.01 * np.max(np.abs(expected))
    stick = [term.name for term in sparse.TERMS].index("stick_level")
    assert np.all(C[t <= 0.05, stick] == 1.0) and np.all(C[t > 0.05, stick] == 0.0)


def _first_cycle(creep_mm: float):
    """The independent generator's first cycle (W 36, k 86.9, 5 mm/min, noise-free) as the
    sparse form's coordinates: the slider's velocity from the record without creep."""
    kw = dict(weight=36.0, stiffness=86.9, speed_mm_min=5.0, duration=4.0, rate_hz=1000.0,
              seed=3)
    plain = ir.simulate(ir.LUBRICANT_A, imp=ir.Imperfections(noise_mm=0.0), **kw)
    crept = ir.simulate(ir.LUBRICANT_A, imp=ir.Imperfections(noise_mm=0.0, creep_mm=creep_mm),
                        **kw)
    t = plain.time
    keep = t < plain.slip_ends[0] + 0.05
    t, tb, te = t[keep], plain.breakaways[0], plain.slip_ends[0]
    yd = np.gradient(plain.drive[keep] - plain.clean[keep], t)
    slip = (t >= tb) & (t < te)
    one = np.ones_like(t)
    c = dict(t=t, window=0 * one, start_time=0 * one, stick_time=(tb + 0.002) * one,
             stiffness=86.9 * one, weight=36.0 * one, yd=np.where(slip, yd, 0.0), slip=slip,
             stick=t < tb, after=t >= te)
    return c, tb, (crept.clean - plain.clean)[keep]


def test_breakaways_are_the_models_half_sine():
    """The model's breakaway is read from its slider velocity (a half sine), not from the
    measured stick time (here 2 ms late)."""
    c, tb, _ = _first_cycle(0.0)
    assert np.all(np.abs(sparse._breakaways(c) - tb) < 2e-4)


def test_preslide_term_is_the_generators_creep():
    """A creep of c before the breakaway that leaves the breakaway where it was: the
    reading falls by c exp(-(t_b - t)/tau) in the stick, and the slip, starting c lower,
    swings c cos(omega_0 (t - t_b)) from it and ends c higher (the independent
    generator's creep against the same record without it)."""
    c, _, diff = _first_cycle(0.003)
    t_b = sparse._breakaways(c)
    col = np.where(c["stick"], np.exp(-np.maximum(t_b - c["t"], 0.0) / 0.05),
                   sparse._start_response(c, t_b))
    assert np.max(np.abs(-0.003 * col - diff)) < 0.2e-3
    assert np.sqrt(np.mean((-0.003 * col - diff) ** 2)) < 0.05e-3


def test_backlash_holds_the_spring_for_the_play_after_every_slip():
    """The independent generator's backlash: after each slip the deflection stays flat
    while the drive takes up its play b (b/v), then climbs at the drive speed."""
    b, v = 0.005, 5.0 / 60.0
    tr = ir.simulate(ir.LUBRICANT_A, weight=36.0, stiffness=86.9, speed_mm_min=5.0,
                     duration=6.0, rate_hz=1000.0, physics=ir.Physics(backlash_mm=b))
    for te in tr.slip_ends[1:3]:
        i = int(np.ceil(te * 1000.0)) + 1
        flat = tr.clean[i:i + int(0.9 * b / v * 1000.0)]
        assert np.ptp(flat) < 1e-9
        climb = tr.clean[i + int(1.2 * b / v * 1000.0):][:100]
        assert np.diff(climb).mean() == pytest.approx(v / 1000.0, rel=1e-3)


def test_scattered_breakaways_are_fitted_window_by_window():
    """`sparse._scattered` gives every window the residuals of its own best static
    friction among `SCATTER_SHIFTS` (mu_s (1 + e), mu_d held), whatever the others'; a
    form that closes less than `FOUND_SHARE` of what they leave is not found."""
    win = np.repeat([[3], [3], [7], [9]], 5, axis=1)  # 4 rows of 5 samples, 3 windows
    wid = np.repeat([0, 0, 1, 2], 5)
    mu_d, rise = 0.1, 0.02
    truth = rise + np.array([0.01, -0.03, 0.0025])[wid] * (mu_d + rise)  # per sample

    def evaluate(z, cols):  # each window's rows: its friction's miss, and a breakaway lost
        miss = np.exp(z[sparse.MU_S]) - truth
        return 1e3 * miss * np.linspace(1.0, 2.0, wid.size), None, z[sparse.MU_S] < -3.0
    data = types.SimpleNamespace(mask=np.ones(win.shape, bool), record=np.zeros(4),
                                 window=win[:, 0])
    model = types.SimpleNamespace(data=data, scales=np.ones(8), evaluate=evaluate)
    z = np.r_[np.log(mu_d), np.log(rise), np.zeros(6)]
    r_s = sparse._scattered(model, z, np.ones(wid.size, bool))
    assert np.allclose(r_s, 0.0, atol=1e-12)
    form = sparse.SparseForm(terms=({"name": "stick_creep10ms"},), gap_before=3.0,
                             gap_after=1.9, noise=1.0, found=True, z=np.zeros(1),
                             r=np.zeros(1), gap_scatter=1.87)
    assert form.closes > sparse.FOUND_SHARE and not sparse._beyond_scatter(form)
    assert sparse._beyond_scatter(dataclasses.replace(form, gap_scatter=2.5, gap_after=1.2))


def test_a_family_is_not_certain_where_the_gap_is_within_the_weights():
    """A family named where the base's excess chi-square is within `small_excess` x n
    (the weights' approximations) rests on its score test alone: low confidence; the same
    family removing most of a real excess and leaving the noise: high."""
    from stickslip_fitting.discovery.options import DiscoveryOptions
    from stickslip_fitting.discovery.stages.learn import _verdict

    n, ns = 100_000, types.SimpleNamespace

    def verdict(chi2_per_sample):
        excess = (chi2_per_sample - 1.0) * n
        fx = ns(opts=DiscoveryOptions(), base=ns(fit=ns(rss=chi2_per_sample * n), within=0.0,
                                                 n_used=n, noise=1e-3))
        choice = ns(decided_drop=0.9 * excess, decision=ns(clear=True))
        return _verdict(fx, choice, ns(family=ns(name="rate_state")), 1.0e-3)

    assert verdict(1.03) == ("rate_state", "low")
    assert verdict(1.5) == ("rate_state", "high")


# ---- campaigns with effects outside the library (slow) --------------------------------

OUTSIDE = {
    # (generator arguments, the phase and the variable the words must name)
    "creep": (dict(imp=ir.Imperfections(creep_mm=0.003)), "stick", "breakaway"),
    "hardening": (dict(physics=ir.Physics(hardening=0.5)), "slip", "deflection"),
    "backlash": (dict(physics=ir.Physics(backlash_mm=0.005)), "stick", "since the last slip"),
}


def run_one(kind: str, seed: int) -> dict:
    from stickslip_fitting.discovery.cycle_workflow import discover_cycles

    kw, phase, variable = OUTSIDE[kind]
    res = discover_cycles(ir.campaign(ir.LUBRICANT_A, seed=seed, cycles=4.0, **kw))
    form = res.sparse_form
    # the leading (most significant) term in the right phase, a term naming the variable
    words_ok = bool(form is not None and form.terms
                    and form.terms[0]["phase"] == phase
                    and any(variable in t["variable"] + t["words"] for t in form.terms))
    return dict(kind=kind, seed=seed, effect=res.effect, confidence=res.confidence,
                gap_before=res.gap_before / res.noise, gap_after=res.gap_after / res.noise,
                closes=form.closes if form is not None else None,
                formula=form.formula if form is not None else "", words_ok=words_ok)


@pytest.mark.slow
def test_outside_effects_are_answered_by_their_form():
    """Measured (2-core machine): creep 86 % and 90 % of the excess by its form, the 0.5
    stiffening load coupling (low) on seed 0 and its form on seed 1 (103 %), backlash
    94 % and 93 %: 5 of 6 by their form."""
    rows = [run_one(kind, seed) for kind in OUTSIDE for seed in range(2)]
    for r in rows:
        print(r)
    assert not [r for r in rows if r["confidence"] == "high"
                and r["effect"] not in ("none", "unexplained", "sparse_form")]
    for kind in OUTSIDE:
        mine = [r for r in rows if r["kind"] == kind]
        assert all(r["effect"] != "none" for r in mine), kind
    by_form = [r for r in rows if r["effect"] == "sparse_form"]
    assert len(by_form) >= 2 / 3 * len(rows)
    assert all(r["closes"] >= 0.7 and r["words_ok"] for r in by_form)


def test_library_forms_name_terms_and_families():
    """Every term that `sparse.LIBRARY_FORMS` gives a family to is a term of the library,
    and the family is one of the effect families (a form holding it confirms that family
    rather than replacing it, `stages.form`)."""
    from stickslip_fitting.discovery.cycle_effects import FAMILIES
    from stickslip_fitting.discovery.sparse import LIBRARY_FORMS, TERMS

    names = {f.name for f in FAMILIES}
    assert set(LIBRARY_FORMS) <= {t.name for t in TERMS}
    assert set().union(*LIBRARY_FORMS.values()) <= names


if __name__ == "__main__":
    for kind in OUTSIDE:
        for seed in range(int(sys.argv[1]) if len(sys.argv) > 1 else 2):
            print(run_one(kind, seed), flush=True)

