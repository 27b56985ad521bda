"""No silently wrong answers: fixed values honoured exactly and checked, strict JSON,
posterior and prior draws checked against the model's domain, slips counted through a
glitch or a quantised logger, copies of a record refused, noise-free records floored.

Each case asserts the exit code, that no input changed and that no output but the
expected one exists (`cli_safety.run_checked`)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_safety import EXAMPLES, copy_records, one_line, run_checked

NAMES = ["mu_s", "mu_d", "gamma", "m", "delta", "n"]
TRUTH = [0.56, 0.21, 0.38, 0.4, 67.0, 1.0]


@pytest.fixture(scope="module")
def camp(tmp_path_factory):
    folder = tmp_path_factory.mktemp("camp")
    return folder, copy_records(folder, EXAMPLES)


@pytest.mark.parametrize("command", ["fit", "mcmc"])
@pytest.mark.parametrize("fix, message", [
    (["n=1", "n=2"], "given twice"),
    (["n=1e308"], "outside the physical range 0.02-5"),
    (["delta=1e-300"], "outside the physical range"),
    (["mu_s=0.2", "mu_d=0.3"], "must exceed mu_d"),
    (["mu_s=0.56", "mu_d=0.21", "gamma=0.38", "m=0.4", "delta=67", "n=1"], "nothing is left"),
    (["h_e=0.001"], "expected NAME=VALUE"),
    (["mu_s=nan"], "positive and finite"),
])
def test_fixed_values_are_checked_before_fitting(camp, command, fix, message, capsys):
    """Duplicate, out-of-range, contradictory or all-fixed --fix values are refused
    before the fit, never taken silently ("converged" with standard errors of 1e-70) nor
    a crash (IndexError)."""
    folder, records = camp
    args = [command, *records]
    for f in fix:
        args += ["--fix", f]
    _, err = run_checked(args, capsys, folder, 2)
    one_line(err, "--fix", message)


def test_fixed_mu_s_is_reported_exactly_and_a_misfit_is_said(camp, tmp_path, capsys):
    """`--fix mu_s=0.3` reports mu_s 0.3 exactly, and a fixed value that the records
    contradict is said, not hidden behind a quiet 'converged'."""
    folder, records = camp
    out = tmp_path / "f.json"
    stdout, _ = run_checked(["fit", *records, "--fix", "mu_s=0.3", "--json", out], capsys,
                            folder, 0)
    rep = json.loads(out.read_text())
    assert rep["parameters"]["mu_s"]["value"] == 0.3 and rep["parameters"]["mu_s"]["fixed"]
    assert any("incompatible" in w for w in rep["identifiability"]["warnings"])
    assert "incompatible" in stdout


def test_mcmc_keeps_a_fixed_value_exactly_and_design_uses_it(camp, tmp_path, capsys):
    """`mcmc --fix mu_s=0.3` writes that exact value into its JSON and into every draw
    `design --posterior` reads, and says the misfit of the fixed value."""
    from stickslip_fitting.design import friction_params, load_samples

    folder, records = camp
    out = tmp_path / "m.json"
    stdout, _ = run_checked(["mcmc", *records, "--fix", "mu_s=0.3", "--walkers", "12",
                             "--steps", "10", "-q", "--json", out], capsys, folder, 0)
    rep = json.loads(out.read_text())
    assert rep["fixed"] == {"mu_s": 0.3} and "mu_s" not in rep["names"]
    assert any("incompatible" in w for w in rep["warnings"]) and "incompatible" in stdout
    mu_s = np.asarray(friction_params(load_samples(out))["mu_s"])
    assert mu_s.size == len(rep["samples"]) and np.all(mu_s == 0.3)


def test_printed_json_is_strict_and_says_why_a_value_is_null(tmp_path, capsys):
    """`steady --stiffness 1e308 --json` prints strict JSON (no Infinity/NaN tokens): a
    value that is not finite is null, with the reason."""
    out, _ = run_checked(["steady", "--weight", "36", "--stiffness", "1e308", "--speed", "5",
                          "--json"], capsys, tmp_path, 0)

    def refuse(token):
        raise ValueError(token)

    doc = json.loads(out, parse_constant=refuse)
    # the critical speed's key, by its name or its deprecated alias
    key = next(k for k in doc["results"][0] if k.startswith("critical_speed_mm"))
    assert doc["results"][0][key] is None
    assert "NaN" in doc["null_reasons"][f"results[0].{key}"]
    assert "infinite" in doc["null_reasons"]["natural_frequency_hz"]


def test_posterior_draws_outside_the_domain_are_refused(tmp_path, capsys):
    """`design --posterior` refuses draws with mu_s < 0 or mu_s < mu_d (they would give
    v_c = -15.4 mm/min), and `plan` refuses such a prior (it would propose one record
    three times)."""
    draws = [TRUTH, [0.15, *TRUTH[1:]], [-0.3, *TRUTH[1:]]]
    post = tmp_path / "post.json"
    post.write_text(json.dumps({"names": NAMES, "samples": draws}))
    _, err = run_checked(["design", "--posterior", post, "--weight", "36", "--stiffness",
                          "86.9", "--speed", "1:100:4:log", "--json"], capsys, tmp_path, 2)
    one_line(err, "post.json", "2 of 3 draws", "mu_s <= mu_d in 2", "mu_s <= 0 in 1")
    prior = tmp_path / "prior.json"
    prior.write_text(json.dumps({"mean": dict(zip(NAMES, [0.2, 0.3, *TRUTH[2:]]))}))
    _, err = run_checked(["plan", prior], capsys, tmp_path, 2)
    one_line(err, "prior.json", "mu_s <= mu_d")
    _, err = run_checked(["plan", post], capsys, tmp_path, 2)
    one_line(err, "post.json", "mu_s <= mu_d")


def _rewrite(src, dst, change):
    """`src` with its (time, deflection) rows passed through `change`, written to `dst`."""
    lines = src.read_text().splitlines()
    head = [ln for ln in lines if not ln[:1].isdigit() and not ln.startswith("-")]
    rows = np.array([[float(c) for c in ln.split(",")] for ln in lines
                     if ln[:1].isdigit() or ln.startswith("-")])
    rows = change(rows.copy())
    dst.write_text("\n".join(head + [f"{float(t)!r},{float(x)!r}" for t, x in rows]) + "\n")


def _slips(out: str) -> int:
    return int(out.split(" samples, ")[1].split(" slip")[0])


@pytest.mark.parametrize("defect", ["glitch", "quantised"])
def test_plot_counts_slips_through_a_glitch_and_a_quantised_logger(tmp_path, defect, capsys):
    """`plot` counts the slips of the clean record, and says why, through one 10 mm
    glitch sample (which would leave 1 slip seen of 6) and a 5 um-quantised logger
    (which would give 81 slips)."""
    src = copy_records(tmp_path, [EXAMPLES[6]])[0]  # k 27.3 kgf/mm, 5 mm/min: 6 slips
    out, _ = run_checked(["plot", src, "--plot", tmp_path / "clean.png"], capsys, tmp_path, 0,
                         new=["clean.png"])
    clean = _slips(out)
    assert clean == 6

    def glitch(rows):
        rows[len(rows) // 2, 1] += 10.0
        return rows

    def quantised(rows):
        rows[:, 1] = np.round(rows[:, 1] / 0.005) * 0.005
        return rows

    bad = tmp_path / f"{defect}.csv"
    _rewrite(src, bad, glitch if defect == "glitch" else quantised)
    out, _ = run_checked(["plot", bad, "--plot", tmp_path / "bad.png"], capsys, tmp_path, 0,
                         new=["bad.png"])
    assert _slips(out) == clean
    assert ("1 single-sample spike" if defect == "glitch" else "quantised in steps of 0.005") in out


def test_the_same_data_under_another_name_counts_once(tmp_path, capsys):
    """A record re-saved by a spreadsheet (';', decimal commas, CRLF, another note) under
    another name is the same run: fitted once, with a note naming the copy."""
    copy_records(tmp_path, EXAMPLES[:3])
    text = EXAMPLES[0].read_text().replace("# note: ", "# note: re-saved; ")
    head, _, body = text.partition("time [s]")
    body = ("time [s]" + body).replace(",", ";").replace(".", ",")
    (tmp_path / "copy.csv").write_bytes((head + body).replace("\n", "\r\n").encode())
    out, err = run_checked(["fit", tmp_path], capsys, tmp_path, 0)
    assert "fitting 3 records" in err, err
    assert "copy.csv holds the same data: counted once" in out + err


def test_noise_free_record_gets_the_noise_floor():
    """A noise-free record's noise estimate is floored (10 nm), and said so: without the
    floor it gives delta 73.03 +- 1e-8 for a truth of 67."""
    import stickslip_jax as ss
    from stickslip_fitting.data.features import NOISE_FLOOR, record_features
    from stickslip_fitting.data.synthetic import synthetic_campaign

    rec = synthetic_campaign(ss.lubricant("A"), speed_fractions=(0.05,), cycles=3, seed=0,
                             noise=0.0)[0]
    f = record_features(rec)
    assert f.noise == NOISE_FLOOR and f.stick_slip
    assert "below the 10 nm floor" in f.noise_note
    # plateau levels average many samples: their errors are the floor over sqrt(samples)
    assert np.all(f.trough_sd[f.complete] > 1e-3 * NOISE_FLOOR)


@pytest.mark.slow  # about 1 min on 2 cores (12 records simulated, then fitted)
def test_noise_free_campaign_intervals_hold_the_truth(tmp_path, capsys):
    """End to end: the shipped campaign made again without noise
    (data/examples/make_campaign.py, noise 0) is fitted with 95 % intervals that hold
    the truth (without the noise floor: delta 73.03 +- 1e-8, truth 67), and the floor is
    said."""
    import importlib.util

    from cli_safety import ROOT

    spec = importlib.util.spec_from_file_location(
        "make_campaign", ROOT / "data" / "examples" / "make_campaign.py")
    make = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make)
    make.HERE, make.NOISE_MM = tmp_path, 0.0
    make.main()
    capsys.readouterr()
    out = tmp_path / "fit.json"
    stdout, _ = run_checked(["fit", *sorted(tmp_path.glob("*.csv")), "--json", out], capsys,
                            tmp_path, 0, new=["fit.json"])
    assert "below the 10 nm floor" in stdout
    rep = json.loads(out.read_text())["parameters"]
    for name, true in zip(NAMES, TRUTH):
        lo, hi = rep[name]["ci95"]
        assert lo <= true <= hi, (name, lo, hi)
        assert hi - lo > 1e-6 * true, (name, lo, hi)  # not collapsed
