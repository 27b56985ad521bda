"""The one-call posterior and discovery, `stickslip_fitting.sample(records, ...)` ->
`CampaignPosterior` and `stickslip_fitting.discover(records, ...)` -> `CampaignDiscovery`:
the shape of `CampaignFit` (a summary DataFrame, the command's figure, the command's JSON
document), checked against `stickslip mcmc --json` and `stickslip discover --json` run in
this process on the same records; the smoothed whole-record base chosen as an object
(`base=SmoothBase(...)`) on a two-record campaign."""

import json
import pathlib

import pytest
import stickslip_fitting as sf
from stickslip_fitting.api.discovery import FAMILY_COLUMNS, SMOOTH_COLUMNS, CampaignDiscovery
from stickslip_fitting.api.posterior import POSTERIOR_COLUMNS, CampaignPosterior

from stickslip_jax.cli import main

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "data" / "examples"
NAMES = ["mu_s", "mu_d", "gamma", "m", "delta", "n"]
SAMPLER = dict(steps=20, walkers=12, seed=3)
PNG = b"\x89PNG\r\n\x1a\n"
# three records of the shipped campaign: the options' checks, which answer before any fit
DISCOVERY_FILES = sorted(str(p) for p in EXAMPLES.glob("*.csv"))[:3]


@pytest.fixture(scope="module")
def posterior():
    return sf.sample(str(EXAMPLES / "*.csv"), **SAMPLER)


@pytest.fixture(scope="module")
def mcmc_document(tmp_path_factory):
    """`stickslip mcmc data/examples --json OUT` with the same sampler settings."""
    out = tmp_path_factory.mktemp("mcmc") / "mcmc.json"
    assert main(["mcmc", str(EXAMPLES), "--steps", str(SAMPLER["steps"]), "--walkers",
                 str(SAMPLER["walkers"]), "--seed", str(SAMPLER["seed"]), "--json", str(out),
                 "--quiet"]) == 0
    return json.loads(out.read_text())


def test_sample_is_the_package_attribute(posterior):
    assert isinstance(posterior, CampaignPosterior)
    assert "sample" in sf.__all__ and "CampaignPosterior" in sf.__all__
    assert posterior.names == NAMES and posterior.fixed == {}
    assert 0.0 < posterior.acceptance <= 1.0


def test_posterior_summary_columns_and_rows(posterior):
    frame = posterior.summary()
    assert tuple(frame.columns) == POSTERIOR_COLUMNS
    assert list(frame.index) == NAMES and frame.index.name == "parameter"
    assert (frame["low"] <= frame["median"]).all() and (frame["median"] <= frame["high"]).all()
    assert (frame["sd"] > 0).all() and (frame["ess"] > 0).all()
    assert frame.loc["gamma", "unit"] == "s^-m" and frame.loc["mu_s", "unit"] == "-"
    assert frame.attrs["acceptance"] == posterior.acceptance
    # the shipped campaign was made with these values: the posterior sits on them
    assert frame.loc["mu_d", "median"] == pytest.approx(0.21, rel=1e-3)
    assert frame.loc["n", "median"] == pytest.approx(1.0, rel=1e-2)


def saved_document(result, path) -> dict:
    """`result.to_json(path)`'s document, checked to be the text it returned and
    `to_dict()`."""
    text = result.to_json(path)
    doc = json.loads(path.read_text())
    assert json.loads(text) == doc == result.to_dict()
    return doc


def test_posterior_json_is_the_command_document(posterior, mcmc_document, tmp_path):
    doc = saved_document(posterior, tmp_path / "post.json")
    assert list(doc) == list(mcmc_document)
    assert list(doc["parameters"]["mu_s"]) == list(mcmc_document["parameters"]["mu_s"])
    assert doc["names"] == mcmc_document["names"] == NAMES
    for key in ("model", "objective", "loss", "walkers", "steps", "burn", "record_names",
                "records", "deprecated_keys", "fixed", "prior"):
        assert doc[key] == mcmc_document[key], key
    # the same fit and the same seed: the same chain
    assert doc["acceptance"] == pytest.approx(mcmc_document["acceptance"], rel=1e-9)
    for name in NAMES:
        assert doc["parameters"][name]["median"] == pytest.approx(
            mcmc_document["parameters"][name]["median"], rel=1e-9)
    assert len(doc["samples"]) == len(mcmc_document["samples"])


def test_posterior_plot_writes_the_corner_png(posterior, tmp_path):
    path = tmp_path / "corner.png"
    fig = posterior.plot(path)
    assert fig is not None
    assert path.read_bytes()[:8] == PNG


def test_posterior_text(posterior):
    text = str(posterior)
    assert text.splitlines()[0].split()[:2] == ["parameter", "median"]
    assert "prior: " in text and "acceptance" in text
    assert "CampaignPosterior(" in repr(posterior)


def test_sample_around_a_given_fit_and_its_options():
    # a fit given: sampled around without fitting again; the fit's options are its own
    fit = sf.fit(str(EXAMPLES / "*.csv"))
    post = sf.sample(fit, steps=20, walkers=12, seed=1, draws=5)
    assert post.campaign_fit is fit
    assert post.report["objective"] == "features" and len(post.report["samples"]) <= 5
    with pytest.raises(ValueError, match="fix"):
        sf.sample(fit, fix={"n": 1.0}, steps=12, walkers=12)


@pytest.mark.parametrize("kw, word", [
    (dict(steps=5), "steps"), (dict(seed=-1), "seed"), (dict(draws=0), "draws"),
    (dict(walkers=4), "walkers"), (dict(burn=30, steps=20), "burn"),
])
def test_sample_errors_name_the_keyword_before_fitting(kw, word):
    with pytest.raises(ValueError, match=word):
        sf.sample(str(EXAMPLES / "*.csv"), **kw)


@pytest.fixture(scope="module")
def found(clean_discovery_paths, clean_discovery_run):
    """`stickslip_fitting.discover(FILES, learn=True)` on the files of conftest's
    `clean_discovery_run` (`stickslip discover FILES --json OUT --learn`): its call of the
    discovery engine checked to be the command's (the same records, in order, and the
    same base), answered with the command's result (one discovery for both)."""
    import dataclasses

    import numpy as np
    import stickslip_fitting.discovery.engine as engine

    records, base, result = clean_discovery_run["call"]

    def command_result(recs, given, progress=None):
        assert [r.source for r in recs] == [r.source for r in records]
        for a, b in zip(recs, records):
            np.testing.assert_array_equal(a.deflection, b.deflection)
        assert [e.path for e in given.unreadable] == [e.path for e in base.unreadable]
        assert dataclasses.replace(given, unreadable=()) == dataclasses.replace(
            base, unreadable=())
        return result

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(engine, "discover", command_result)
        return sf.discover(clean_discovery_paths, learn=True)


@pytest.fixture(scope="module")
def discover_document(clean_discovery):
    return clean_discovery[1]


def test_discover_is_the_package_attribute(found):
    assert isinstance(found, CampaignDiscovery)
    assert "discover" in sf.__all__ and "CampaignDiscovery" in sf.__all__
    # the clean campaign has no effect beyond the paper's model
    assert found.effect == "none" and found.named == []


def test_discovery_summary_lists_every_family(found):
    from stickslip_fitting.discovery.cycle_effects import FAMILIES

    frame = found.summary()
    assert tuple(frame.columns) == FAMILY_COLUMNS and frame.index.name == "family"
    assert sorted(frame.index) == sorted(f.name for f in FAMILIES)
    assert ((frame["p_value"] >= 0) & (frame["p_value"] <= 1)).all()
    assert frame["named"].sum() == len(found.named)
    assert list(frame.index[frame["named"]]) == [n for n in frame.index if n in found.named]
    assert frame["significant"].dtype == bool


def test_discovery_parameters_are_a_frame_with_unknowns_as_nan(found):
    """`parameters()`: the fit summary's columns; a value the windows do not determine
    (the friction level, which the per-record gauge offsets follow) is NaN with its
    reason, never a number."""
    import math

    from stickslip_fitting.api.campaign import SUMMARY_COLUMNS

    after, before = found.parameters(), found.parameters("before")
    assert tuple(after.columns) == SUMMARY_COLUMNS and after.index.name == "parameter"
    assert list(before.index) == ["mu_s", "mu_d", "gamma", "m", "delta", "n"]
    for name, row in after.iterrows():
        entry = found.to_dict()["estimates_after"][name]
        if entry["value"] is None:
            assert math.isnan(row["value"]) and row["reason"].startswith("not identifiable")
        else:
            assert row["value"] == entry["value"]
    with pytest.raises(ValueError, match="when"):
        found.parameters("later")


def test_discovery_json_is_the_command_document(found, discover_document, tmp_path):
    doc = saved_document(found, tmp_path / "found.json")
    assert list(doc) == list(discover_document)
    for key in ("effect", "confidence", "base", "loss", "deprecated_keys", "records"):
        assert doc[key] == discover_document[key], key
    assert [c["name"] for c in doc["candidates"]] == [
        c["name"] for c in discover_document["candidates"]]
    assert doc["gap_before_mm"] == pytest.approx(discover_document["gap_before_mm"], rel=1e-6)


def test_discovery_plot_writes_a_png(found, tmp_path):
    path = tmp_path / "found.png"
    found.plot(path)
    assert path.read_bytes()[:8] == PNG
    text = str(found)
    assert text.startswith(f"effect: {found.effect}") and "family" in text


@pytest.mark.parametrize("kw, word", [
    (dict(only=["no_such_family"]), "only"), (dict(top=0), "top"),
    (dict(alpha=1.5), "alpha"), (dict(max_evals=1), "max_evals"),
    (dict(loss="cauchy"), "loss"),
])
def test_discover_errors_name_the_keyword(kw, word):
    with pytest.raises(ValueError, match=word):
        sf.discover(DISCOVERY_FILES, **kw)


def test_discover_needs_two_records():
    with pytest.raises(ValueError, match="two records"):
        sf.discover(DISCOVERY_FILES[:1])


@pytest.mark.parametrize("kw, word", [
    (dict(base="smooth"), "base"), (dict(base=sf.SmoothBase(), top=2), "top"),
    (dict(base=sf.CycleBase(), only=["stribeck"], strict=True), "only, strict"),
])
def test_discover_base_is_an_object_that_carries_its_options(kw, word):
    with pytest.raises(ValueError, match=word):
        sf.discover(DISCOVERY_FILES, **kw)


def test_discover_hands_a_smooth_base_to_the_engine_and_reads_its_result(tmp_path):
    """`base=SmoothBase(...)` goes to the discovery engine as given (its options its own
    fields), and a smoothed base's answer reads as its table (`SMOOTH_COLUMNS`, by effect),
    its document (base "smooth", no loss) and its text: here an answer built by hand (the
    whole run on a campaign is `test_discover_on_the_smooth_base`, slow: its smoothed
    base's programs, with host callbacks, compile in no other test of the default run)."""
    from types import SimpleNamespace as NS

    import stickslip_fitting.discovery.engine as engine
    from stickslip_fitting.discovery.result import SmoothDiscovery

    fit = NS(converged=True, n_evals=8)
    analysis = NS(phases={}, test={"p_value": 1e-20})
    cands = [dict(name="gauge_drift", score=120.0, score_p_value=1e-20, dof=2,
                  delta_criterion=-194.6, lr_p_value=1e-40, unphysical=None),
             dict(name="viscous_damping", score=3.0, score_p_value=0.2, dof=1,
                  delta_criterion=None, lr_p_value=None, unphysical=None)]
    answer = SmoothDiscovery(
        effect="gauge_drift", explanation="a drifting gauge zero", confidence="high",
        gap_before=6.3e-4, gap_after=4.8e-4, noise=5e-4, criterion="BIC", candidates=cands,
        estimates_before=[], estimates_after=[], effect_estimates=[], timings={},
        base_fit=fit, final_fit=fit, residuals_before=analysis, residuals_after=analysis,
        test_before=analysis.test, test_after={"p_value": 0.3}, base_problem=None,
        final_problem=None, campaign=NS(screening=[]))
    base = sf.SmoothBase(candidates=("gauge_drift", "viscous_damping"), top=1, max_evals=8,
                         refit_evals=4, crop=sf.Crop.SLIP_END)
    given = []
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(engine, "discover",
                   lambda recs, b, progress=None: given.append((recs, b)) or answer)
        found = sf.discover(DISCOVERY_FILES, base=base)
    (recs, b), = given
    assert len(recs) == 3 and b == base and found.result is answer
    assert found.effect == "gauge_drift" and found.named == ["gauge_drift"]
    frame = found.summary()
    assert tuple(frame.columns) == SMOOTH_COLUMNS and frame.index.name == "effect"
    assert list(frame.index) == ["gauge_drift", "viscous_damping"]
    assert frame.loc["gauge_drift", "delta_bic"] == -194.6 and frame["delta_bic"].isna().sum() == 1
    assert frame.loc["viscous_damping", "dof"] == 1 and list(frame["named"]) == [True, False]
    doc = saved_document(found, tmp_path / "smooth.json")
    assert doc["base"] == "smooth" and "loss" not in doc
    assert doc["misspecification_after"] == {"p_value": 0.3}
    assert str(found).startswith("effect: gauge_drift") and "dBIC" in str(found)


@pytest.mark.slow  # 46 s of CPU in one process: the smoothed base's programs compiled
def test_discover_on_the_smooth_base(tmp_path):
    """`base=SmoothBase(...)` runs `stickslip discover --base smooth` through the same
    result: two short records of the exact simulator with a drifting gauge zero added (no
    smoothed simulation of its own to compile), one candidate beside it."""
    from stickslip_fitting.data.synthetic import synthetic_campaign

    from stickslip_jax.lubricants import lubricant

    recs = [r.replace(deflection=r.deflection + 4e-3 * r.time)  # mm/s of gauge drift
            for r in synthetic_campaign(lubricant("A"), conditions=((36.0, 86.9),),
                                        speed_fractions=(0.26, 0.36), cycles=3,
                                        sample_rate=500.0, seed=3)]
    base = sf.SmoothBase(candidates=("gauge_drift", "viscous_damping"), top=1, max_evals=8,
                         refit_evals=4, crop=sf.Crop.SLIP_END)
    found = sf.discover(recs, base=base)
    assert found.result.BASE == "smooth" and found.effect == "gauge_drift"
    assert found.named == ["gauge_drift"] and found.result.gap_after < found.result.gap_before
    frame = found.summary()
    assert tuple(frame.columns) == SMOOTH_COLUMNS and frame.index.name == "effect"
    assert list(frame.index) == ["gauge_drift", "viscous_damping"]
    assert frame.loc["gauge_drift", "delta_bic"] < -10 and frame["delta_bic"].isna().sum() == 1
    assert not frame.loc["gauge_drift", "unphysical"] and list(frame["named"]) == [True, False]
    doc = saved_document(found, tmp_path / "smooth.json")
    assert doc["base"] == "smooth" and "loss" not in doc and "misspecification_after" in doc
    found.plot(tmp_path / "smooth.png")
    assert (tmp_path / "smooth.png").read_bytes()[:8] == PNG
    assert str(found).startswith("effect: gauge_drift") and "dBIC" in str(found)
