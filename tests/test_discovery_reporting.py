"""What `stickslip discover` (cycle base) says about its own numbers: the significance
count agrees with the candidate table, a parameter on an end of its range says "at
bound" and a standard error of zero is never printed as "+- 0", a refit whose traces do
not change with the family's parameters is no result, a friction table the refit left
as it was says so, a phase left above the noise is named in the explanation, and the
friction parameters before and after carry the one covariance path's standard errors
and identifiability: a value the records do not determine is "-" in the table and the
figure and null with a reason in the JSON."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from stickslip_fitting.discovery.cycle_effects import family
from stickslip_fitting.discovery.decision import rms_by_phase
from stickslip_fitting.discovery.result import (CycleDiscovery, effect_estimate, estimate_text,
                                                phase_misfit, phase_text)
from stickslip_fitting.discovery.stages.rank import significance_line
from stickslip_fitting.discovery.stages.refit import dead
from stickslip_fitting.report.discovery_text import candidate_table, parameter_table
from stickslip_fitting.report.rows import DiscoveryEstimates


def _candidate(name, p, p_fw, by):
    return {"name": name, "shape": "", "score": 1.0, "score_p_value": p,
            "family_wise_p_value": p_fw, "per_sample_p_value": 1e-9,
            "significant": by is not None, "significant_by": by, "chi2_drop": None,
            "unphysical": None}


def test_significance_count_agrees_with_the_table():
    # every robust p >= 0.03 (as on the real campaign) and still significant by the
    # per-sample route: the table says which test, and its count is the rows marked
    cands = [_candidate("viscous_damping", 0.42, 0.9, "per-sample"),
             _candidate("stribeck", 0.42, 0.9, "per-sample"),
             _candidate("gauge_drift", 0.001, 0.004, "family-wise"),
             _candidate("friction_drift", 0.64, 1.0, None)]
    cands[0]["per_sample_p_value"] = 0.0  # underflowed: printed as a bound, never as 0
    text = candidate_table(cands)
    lines = text.splitlines()
    assert "<1e-300" in lines[2] and "<1e-300" not in lines[3]
    rows = [ln for ln in lines[2:] if ln.split() and ln.split()[0] in
            {c["name"] for c in cands}]
    marked = [ln for ln in rows if ln.split()[-2] in ("per-sample", "family-wise")]
    n = int(re.search(r"^(\d+) of 4 families significant", text, re.M).group(1))
    assert n == len(marked) == 3
    assert "p family-wise" in lines[0] and "significant" in lines[0]
    # the ranking's progress line counts the same and names both tests
    Sc = dataclasses.make_dataclass("Sc", ["significant_by"])
    line = significance_line([Sc("per-sample"), Sc("per-sample"), Sc("family-wise")], 4,
                             0.01, 0.0002, 51)
    assert line.startswith("3 of 4 families significant: 1 by the robust window test")
    assert "2 by a relevant predicted drop with per-sample p < 0.0002" in line


def test_a_value_at_its_bound_says_so_never_plus_minus_zero():
    f = family("viscous_damping")
    (lo, hi), = f.support()
    at = effect_estimate("c", "kgf*s/mm", hi, 0.0, (lo, hi))
    text = estimate_text(at)
    assert text == "c = 1 kgf*s/mm (at bound)" and "+-" not in text
    assert at.to_json()["at_bound"] and "bound" in at.to_json()["reason"]
    # inside the range but no variance from the Gauss-Newton covariance: no "+- 0"
    flat = effect_estimate("c", "kgf*s/mm", 0.1, 0.0, (lo, hi))
    assert estimate_text(flat) == "c = - (no standard error)"
    assert flat.to_json()["value"] is None and flat.to_json()["reason"]
    ok = effect_estimate("c", "kgf*s/mm", 0.02, 0.003, (lo, hi))
    assert estimate_text(ok) == "c = 0.02 +- 0.003 kgf*s/mm"
    assert ok.to_json()["reason"] is None and not ok.to_json()["at_bound"]


def test_a_step_of_the_staircase_gives_no_value_it_does_not_determine():
    """The JSON's "steps": a value without a standard error is null with its reason."""
    from stickslip_fitting.discovery.cycle_effects import Shape
    from stickslip_fitting.discovery.stages.state import Step

    f = family("viscous_damping")
    step = Step(family=f, shape=Shape(), values=np.array([0.1]), stderr=np.array([0.0]),
                gap_after=1e-3, p_family=0.01, confidence="low", drop=50.0, rivals=[])
    doc = step.to_json(G=2)
    assert doc["values"] == {"c": None} and doc["stderr"] == {"c": None}
    assert doc["units"] == {"c": "kgf*s/mm"}
    assert doc["estimates"]["c"]["reason"].startswith("not identifiable: no standard error")
    sized = dataclasses.replace(step, stderr=np.array([0.02])).to_json(G=2)
    assert sized["values"] == {"c": 0.1} and sized["stderr"] == {"c": 0.02}


def _result(before, after, effect_rows):
    rows = DiscoveryEstimates.value_rows
    units = {k: "-" for k in before}
    fields = {f.name: None for f in dataclasses.fields(CycleDiscovery)}
    fields.update(estimates_before=rows(before, units), estimates_after=rows(after, units),
                  effect_estimates=effect_rows, effect_of="viscous_damping",
                  effect="viscous_damping")
    return CycleDiscovery(**fields)


def test_parameter_table_and_json_of_the_effect():
    before = {"mu_s": 0.34668, "mu_d": 0.32452}
    bound = effect_estimate("c", "kgf*s/mm", 1.0, 0.0, (0.0, 1.0))
    res = _result(before, dict(before), [bound])
    text = parameter_table(res)
    assert "friction parameters unchanged by the refit" in text
    (row,) = [ln for ln in text.splitlines() if ln.startswith("viscous_damping.c")]
    assert "at upper bound 1" in row and "+-" not in row
    size = res.effect_size["c"]
    assert {"value", "stderr", "unit"} <= set(size) and size["at_bound"] is True
    assert "upper bound" in size["reason"]
    moved = _result(before, {"mu_s": 0.35, "mu_d": 0.31},
                    [effect_estimate("c", "kgf*s/mm", 0.02, 0.003, (0.0, 1.0))])
    assert "unchanged" not in parameter_table(moved)
    undetermined = _result(before, {"mu_s": 0.35, "mu_d": 0.31},
                           [effect_estimate("c", "kgf*s/mm", 0.1, 0.0, (0.0, 1.0))])
    (row,) = [ln for ln in parameter_table(undetermined).splitlines()
              if ln.startswith("viscous_damping.c")]
    assert row.split()[2] == "-" and "no standard error" in row


def test_a_refit_whose_traces_do_not_move_is_no_result():
    assert dead(np.zeros((50, 1)))
    assert not dead(np.r_[np.zeros(49), 1e-12][:, None])
    assert not dead(np.zeros((50, 0)))


def test_a_phase_above_the_noise_is_named():
    rng = np.random.default_rng(0)
    slipping = np.zeros(2000, bool)
    slipping[:100] = True
    sd = np.where(slipping, 1.1e-3, 0.5e-3)  # a slip's own errors are larger
    r = rng.normal(size=2000) * sd * np.where(slipping, 0.92, 1.0)
    phases = rms_by_phase(r, slipping, sd)
    assert {"rms", "samples", "expected_rms", "chi2_per_sample"} <= set(phases["slip"])
    noise = 0.5e-3
    text = phase_text(phases, noise)
    assert "slip phases" in text and "within their own standard errors" in text
    assert "stick phases" not in text  # at the noise
    assert phase_misfit(phases) == []
    # a slip residual beyond its own errors: not explained by any family
    r2 = np.where(slipping, 3.0 * r, r)
    phases2 = rms_by_phase(r2, slipping, sd)
    assert "not explained by any family" in phase_text(phases2, noise)
    assert phase_misfit(phases2) == ["slip"]
    assert phase_text(rms_by_phase(r * 0.5, slipping, sd), 1e-3) == ""


def test_both_bases_answer_with_one_document():
    """`CycleDiscovery` and `SmoothDiscovery` are one `Discovery`: the keys every base
    writes, "base" saying which, then each base's own."""
    from types import SimpleNamespace as NS

    from stickslip_fitting.discovery.result import Discovery, SmoothDiscovery

    fit = NS(converged=True, n_evals=3)
    common = dict(effect="none", explanation="", confidence="high", gap_before=1e-3,
                  gap_after=1e-3, noise=1e-3, criterion="", candidates=[],
                  estimates_before=[], estimates_after=[], effect_estimates=[], timings={},
                  base_fit=fit, final_fit=fit)
    analysis = NS(phases={}, test={"p_value": 0.5})
    smooth = SmoothDiscovery(**common, residuals_before=analysis, residuals_after=analysis,
                             test_before=analysis.test, test_after=analysis.test,
                             base_problem=None, final_problem=None,
                             campaign=NS(screening=[]))
    cycle = CycleDiscovery(**common, phases_before={}, phases_after={},
                           campaign=NS(screening=[]), model=None, z_before=None,
                           z_after=None, shape=None, sensor=False)
    assert isinstance(smooth, Discovery) and isinstance(cycle, Discovery)
    s, c = smooth.to_json(), cycle.to_json()
    shared = {"effect", "explanation", "confidence", "indistinguishable_from", "base",
              "base_fit", "final_fit", "gap_before", "gap_after", "gap_unit", "noise",
              "criterion", "candidates", "parameters_before", "parameters_after",
              "estimates_before", "estimates_after", "effect_size",
              "residuals_by_phase_before", "residuals_by_phase_after",
              "timings_s"}
    assert set(s) & set(c) == shared and (c["base"], s["base"]) == ("cycle", "smooth")
    assert set(c) - shared == {"gap_all_records_before_mm", "gap_all_records_after_mm",
                               "records", "records_scaled", "windows_set_aside",
                               "learned_correction", "sparse_form", "misfit_left",
                               "steps"}
    assert set(s) - shared == {"misspecification_before", "misspecification_after",
                               "records_screened"}
    assert s["misspecification_after"] == {"p_value": 0.5} and c["learned_correction"] is None
    from stickslip_fitting.report.discovery_text import answer_text

    # each base prints its own candidate table
    assert "dBIC" in answer_text(smooth) and "p family-wise" in answer_text(cycle)


def _cycle_fit(values, offsets=(0.01, -0.02), seed=0):
    """A per-cycle fit's solution at the friction `values` (mu_s, mu_d, gamma, m, delta,
    n): coordinates the six `EmpiricalFriction` logs, the offsets and one effect, a
    well-conditioned Jacobian of 400 rows, residuals at chi2/n about 1."""
    from types import SimpleNamespace as NS

    mu_s, mu_d, gamma, m, delta, n = values
    z = np.r_[np.log([mu_d, mu_s - mu_d, gamma, m, delta, n]), offsets, 0.3]
    rng = np.random.default_rng(seed)
    r = rng.normal(size=400)
    return NS(z=z, J=rng.normal(size=(400, z.size)) * 30.0, r=r, rss=float(r @ r),
              result=None, converged=True, n_evals=5)


CLUSTERS = (np.repeat([0, 1], 200), np.arange(400) // 20)
"""(record, cycle window) of every residual of `_cycle_fit`: two records of 10 windows."""


def _features(omega0=(40.0, 90.0), sticks=((0.5, 0.8), (5.0, 9.0))):
    from types import SimpleNamespace as NS

    return [NS(omega0=w, stick_time=np.asarray(t), complete=np.ones(len(t), bool))
            for w, t in zip(omega0, sticks)]


def test_unidentified_friction_after_the_refit_prints_dashes_and_null():
    """The final fit's friction goes through the one covariance path (`laplace`): delta
    and n far outside their physical range (as the real records' refit leaves them)
    have no value in the table ("-" and the reason) nor in the JSON (null with a
    reason); the others keep value, standard error and unit."""
    from types import SimpleNamespace as NS

    from stickslip_fitting.discovery.cycle_workflow import with_uncertainty
    from stickslip_fitting.discovery.result import friction_rows

    wild = (0.35, 0.3, 2.0, 0.5, 1.8e7, 1.1e-5)
    good = (0.35, 0.3, 2.0, 0.5, 60.0, 1.0)
    rows = {e.name: e for e in friction_rows(_cycle_fit(wild), _features(), CLUSTERS,
                                             chi2=400.0, dof=391)}
    assert not rows["delta"].identifiable and not rows["n"].identifiable
    assert "physical range" in rows["delta"].reason
    assert rows["mu_d"].identifiable and 0 < rows["mu_d"].stderr < 0.01
    assert rows["mu_d"].value == pytest.approx(0.3) and rows["mu_s"].value == pytest.approx(0.35)
    prior = _cycle_fit(good)  # a prior's rows after the data's: in no cluster
    prior.J, prior.r = np.vstack([prior.J, 10.0 * np.eye(9)[-2:]]), np.r_[prior.r, 0.1, 0.1]
    assert all(e.identifiable and e.stderr > 0
               for e in friction_rows(prior, _features(), CLUSTERS, chi2=400.0, dof=391))
    broken = _cycle_fit(good)
    broken.J[3, 2] = np.nan  # a model that did not run somewhere: no covariance, no value
    assert all(e.to_json()["value"] is None and "not finite" in e.reason
               for e in friction_rows(broken, _features(), CLUSTERS, chi2=400.0, dof=391))
    base, final = _cycle_fit(good, seed=1), _cycle_fit(wild)
    res = _result({}, {}, [effect_estimate("c", "kgf*s/mm", 0.02, 0.003, (0.0, 1.0))])
    data = NS(mask=np.ones((20, 20), bool), record=np.repeat([0, 1], 10), window=np.arange(20))
    res = dataclasses.replace(res, base_fit=base, final_fit=final, model=NS(data=data),
                              campaign=NS(features=_features(), screening=[]))
    res = with_uncertainty(res, NS(within=0.0, n_used=400))
    text = parameter_table(res)
    lines = text.splitlines()
    assert re.split(r"\s{2,}", lines[0]) == ["parameter", "unit", "before", "after",
                                              "std err", "note"]
    table = {ln.split()[0]: re.split(r"\s{2,}", ln) for ln in lines[2:]}
    for name in ("delta", "n"):
        assert table[name][3] == "-" and table[name][4] == "-", table[name]
        assert table[name][5].startswith("not identifiable: the fit left the physical range")
    assert table["delta"][1] == "s^-n" and table["delta"][2] == "60"  # before: determined
    assert table["mu_d"][3] == "0.3" and float(table["mu_d"][4]) > 0
    assert table["viscous_damping.c"][3:5] == ["0.02", "0.003"]
    assert "1.8e+07" not in text and "1.1e-05" not in text and "unchanged" not in text
    doc = res.to_json()
    assert doc["parameters_after"]["delta"] is None and doc["parameters_after"]["n"] is None
    assert doc["parameters_before"]["delta"] == pytest.approx(60.0)
    entry = doc["estimates_after"]["n"]
    assert entry["value"] is None and entry["reason"].startswith("not identifiable")
    assert doc["estimates_after"]["mu_d"]["stderr"] > 0
    assert doc["estimates_after"]["viscous_damping.c"]["unit"] == "kgf*s/mm"
    assert set(doc["estimates_before"]) == set(doc["parameters_before"])


def test_the_figure_gives_the_parameters_with_dashes_for_unknowns(tmp_path):
    """The figure's parameter box: value +- standard error with the unit, "at bound", and
    "-" with the reason for a value the data do not determine; never the placeholder."""
    from types import SimpleNamespace as NS

    from stickslip_fitting.discovery.plots import plot_cycle_discovery
    from stickslip_fitting.discovery.result import friction_rows

    rows = friction_rows(_cycle_fit((0.35, 0.3, 2.0, 0.5, 1.8e7, 1.1e-5)), _features(),
                         CLUSTERS, chi2=400.0, dof=391)
    res = _result({}, {}, [effect_estimate("c", "kgf*s/mm", 1.0, 0.0, (0.0, 1.0))])
    mask = np.ones((2, 50), bool)
    time = np.linspace(0, 1, 100).reshape(2, 50)
    data = NS(mask=mask, time=time, deflection=np.sin(time), record=np.array([0, 1]),
              window=np.array([0, 0]))
    model = NS(data=data, sd=np.full((2, 50), 1e-3), n_records=2,
               residuals=lambda z, *a: (np.zeros(100),))
    phases = {"stick": {"rms": 2e-3}, "slip": {"rms": 1e-3}}
    res = dataclasses.replace(
        res, estimates_after=rows, model=model, phases_before=phases,
        phases_after=phases, noise=1e-3, gap_before=2e-3, gap_after=1e-3, confidence="low",
        campaign=NS(records=[NS(name=f"r{g}") for g in range(2)], screening=[]), learned=None,
        steps=[], misfit_left=None, candidates=[], indistinguishable_from=[])
    fig = plot_cycle_discovery(res)
    (box,) = [t for a in fig.axes for t in a.texts if t.get_gid() == "parameters"]
    text = box.get_text().replace("\n  ", " ")  # wrapped lines joined
    assert "delta = - (the fit left the physical range 0.001-100000)" in text
    assert "n = - (the fit left" in text and "e+07" not in text and "e-05" not in text
    assert re.search(r"mu_d = 0\.3 \+- [0-9.e-]+\n", text)
    assert "viscous_damping.c = 1 kgf*s/mm (at bound)" in text
    fig.savefig(tmp_path / "d.png")
    panel = box.axes.get_window_extent()  # inside its panel
    assert panel.x0 < box.get_window_extent().x0 and box.get_window_extent().x1 <= panel.x1
    assert box.get_window_extent().y0 >= panel.y0
