"""One JSON key per quantity across commands: every command's `--json`
on small inputs (the shipped campaign, small grids, a small synthetic campaign) carries
`schema_version` first, names each quantity by one key in every command (`SYNONYMS`),
writes units as key suffixes (`stickslip_jax.output.UNIT_SUFFIXES`), and keeps each
renamed key under its old name for one release, listed under `deprecated_keys`.
"""

from __future__ import annotations

import importlib
import json
import pathlib
import re
import sys

import pytest

from stickslip_jax.cli import main
from stickslip_jax.output import SCHEMA_VERSION, versioned

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLES = sorted(str(p) for p in (ROOT / "data" / "examples").glob("*.csv"))

JSON_COMMANDS = ("steady", "design", "plan", "fit", "mcmc", "discover", "pitch", "fit-batch")

SYNONYMS = {
    "stiffness_kgf_per_mm": {"stiffness_kgf_mm", "stiffness", "k_kgf_per_mm", "k_kgf_mm",
                             "stiffness_n_per_mm"},
    "drive_speed_mm_per_min": {"speed_mm_min", "speed_mm_per_min", "drive_speed_mm_min",
                               "drive_speed", "speed", "v_mm_per_min", "drive_speed_mm_s",
                               "speed_mm_s"},
    "weight_kgf": {"weight", "w_kgf", "weight_n"},
    "critical_speed_mm_per_min": {"critical_speed_mm_min", "critical_speed", "v_c_mm_per_min",
                                  "v_c_mm_min", "critical_speed_mm_s"},
    "critical_speed_band_mm_per_min": {"critical_speed_band_mm_min"},
    "amplitude_ratio": {"ak_over_W", "ak_over_w", "ak_w"},
    "frequency_ratio": {"f_over_f0", "f_f0"},
    "frequency_hz": {"frequency", "f_hz"},
    "natural_frequency_hz": {"f0_hz", "natural_frequency"},
    "stick_time_s": {"stick_time", "t1_s", "T1_s"},
    "slip_time_s": {"t2_s", "T2_s"},
    "amplitude_mm": {"a_mm", "amplitude_um"},
    "max_amplitude_mm": {"tolerance_mm", "amplitude_tolerance_mm", "max_amplitude"},
    "noise_mm": {"noise", "noise_um", "noise_sd_mm"},
    "gap_before_mm": {"gap_before"},
    "gap_after_mm": {"gap_after"},
    "drive_height_mm": {"height_mm", "height", "drive_height"},
    "drive_offset_mm": {"offset_mm", "drive_offset"},
    "viscosity_pa_s": {"viscosity", "eta_pa_s", "eta"},
    "eps_prime_um": {"eps_prime", "eps_prime_mm"},
    "d_eps_um": {"d_eps", "d_eps_mm"},
    "mean_um": {"mean_mm"},
    "measured_eps_prime_um": {"measured_eps_prime"},
    "measured_d_eps_um": {"measured_d_eps"},
    "residual_rms_mm": {"residual_rms", "rms_residual_mm"},
}
"""The canonical key of a quantity -> other names it has had or could plausibly get. A
document may use only the canonical one (others only as deprecated aliases)."""

UNSUFFIXED_COMPOUND = re.compile(r"_(kgf|mm|um|n)_(mm|min|s|um)$")
"""A compound unit written without `_per_` (`_kgf_mm`, `_mm_min`): ambiguous, not the
convention (`_kgf_per_mm`, `_mm_per_min`)."""

ROWS = ("records",)
"""Keys that hold one object per item in every command (`fit`, `discover`: the screening
of every record; `plan`: the proposed records; `pitch`: per record file), never a list of
names (mcmc's names are `record_names`)."""

SKIP = {"units"}
"""Subtrees whose keys name kinds of quantity, not values (pitch's `units` map)."""


def _pitch_records(folder: pathlib.Path) -> list[str]:
    """The docs figures' two tilt records (`docs/make_figures.py`: `pitch_records`)."""
    sys.path.insert(0, str(pathlib.Path(__file__).parents[1] / "docs"))
    try:
        from make_figures import pitch_records
    finally:
        sys.path.pop(0)
    return pitch_records(folder, stem="p")


@pytest.fixture(scope="module")
def documents(tmp_path_factory, clean_discovery):
    """{command: its --json document} on small inputs, every option that adds keys on
    (mcmc: the fit's records and test_api_results's walkers, their compiled programs;
    fit-batch: the fit's campaign, whose programs it reuses: 0.8 s of CPU time after the
    fit against 3.2 s for a part of it);
    discover's: test_cycle_discovery's clean campaign with its options (`--learn`; conftest
    `clean_discovery`: the learned correction and the null reasons, run once)."""
    d = tmp_path_factory.mktemp("json_keys")
    runs = {
        "steady": ["steady", "--weight", "36", "--stiffness", "86.9", "--speed", "1", "60",
                   "--tolerance", "1um", "--damping-ratio", "0.05"],
        "design": ["design", "--weight", "36", "--stiffness", "100:1000:3", "--speed", "5",
                   "--max-amplitude", "1um", "--quiet"],
        "plan": ["plan", "A", "--budget", "2", "--quiet"],
        "fit": ["fit", *EXAMPLES, "--quiet"],
        "mcmc": ["mcmc", *EXAMPLES, "--steps", "20", "--walkers", "12", "--quiet"],
        "pitch": ["pitch", *_pitch_records(d), "--fit"],
        "fit-batch": ["fit-batch", str(ROOT / "data" / "examples" / "*.csv"),
                      str(d / "no_such_folder"), "--quiet"],
    }
    rc, discovered, _, _ = clean_discovery
    assert set(runs) | {"discover"} == set(JSON_COMMANDS) and rc == 0
    docs = {"discover": discovered}
    for name, argv in runs.items():
        out = d / f"{name}.json"
        rc = main([*argv, "--json", str(out)])
        assert rc in (0, 3), (name, rc)  # 3: ran, answer flagged unreliable (still JSON)
        docs[name] = json.loads(out.read_text())
    return docs


def _dicts(obj, path=""):
    """Every dict in `obj` with its path (lists walked through; `SKIP` subtrees left out)."""
    if isinstance(obj, dict):
        yield path, obj
        for k, v in obj.items():
            if k not in SKIP and k != "deprecated_keys":
                yield from _dicts(v, f"{path}.{k}")
    elif isinstance(obj, list):
        for v in obj:
            yield from _dicts(v, f"{path}[]")


def current_keys(doc) -> dict[str, set[str]]:
    """{key: paths} of `doc`, leaving out each deprecated alias written beside its new
    key in the same dict with the same value (checked here)."""
    deprecated = doc.get("deprecated_keys", {})
    keys: dict[str, set[str]] = {}
    for path, d in _dicts(doc):
        for k, v in d.items():
            new = deprecated.get(k)
            if new is not None and new in d:
                assert d[new] == v, f"{path}.{k}: alias differs from {new}"
                continue
            keys.setdefault(k, set()).add(path or ".")
    return keys


def problems(docs: dict[str, dict]) -> list[str]:
    """What breaks the convention in `docs` {command: document} (empty: none)."""
    canonical = {alt: name for name, alts in SYNONYMS.items() for alt in alts}
    out = []
    for command, doc in docs.items():
        if next(iter(doc), None) != "schema_version" or doc["schema_version"] != SCHEMA_VERSION:
            out.append(f"{command}: schema_version is not the first key")
        for key, paths in current_keys(doc).items():
            if key in canonical:
                out.append(f"{command}: {key} at {sorted(paths)} is {canonical[key]} elsewhere")
            if UNSUFFIXED_COMPOUND.search(key):
                out.append(f"{command}: {key}: compound unit without _per_")
        deprecated = doc.get("deprecated_keys", {})
        for path, d in _dicts(doc):
            for key in ROWS:
                if key in d and not (key in deprecated and deprecated[key] in d):
                    value = d[key]
                    if not (isinstance(value, list) and all(isinstance(v, dict) for v in value)):
                        out.append(f"{command}: {path}.{key} is not a list of objects")
        for old, new in doc.get("deprecated_keys", {}).items():
            used = [p for p, d in _dicts(doc) if old in d and new in d]
            if not used:
                out.append(f"{command}: deprecated {old} -> {new} never written beside {new}")
    return out


def test_every_json_document_follows_the_key_convention(documents):
    assert set(documents) == set(JSON_COMMANDS)
    assert problems(documents) == []


def test_one_key_per_quantity_across_commands(documents):
    """The quantities several commands report are under one key in all of them."""
    where = {name: [c for c, doc in documents.items() if name in current_keys(doc)]
             for name in ("stiffness_kgf_per_mm", "drive_speed_mm_per_min", "weight_kgf",
                          "critical_speed_mm_per_min", "amplitude_ratio", "noise_mm")}
    assert set(where["stiffness_kgf_per_mm"]) >= {"steady", "design", "plan", "fit", "mcmc",
                                                  "discover"}
    assert set(where["drive_speed_mm_per_min"]) >= {"steady", "design", "plan", "fit",
                                                    "discover"}
    assert set(where["critical_speed_mm_per_min"]) >= {"steady", "design"}
    assert set(where["amplitude_ratio"]) >= {"steady"}
    assert set(where["noise_mm"]) >= {"fit", "discover"}


def test_old_keys_are_kept_for_one_release(documents):
    """Readers of the old keys still find them, with the same values, for one release."""
    steady = documents["steady"]
    assert steady["deprecated_keys"]["stiffness_kgf_mm"] == "stiffness_kgf_per_mm"
    assert steady["stiffness_kgf_mm"] == steady["stiffness_kgf_per_mm"]
    row = steady["results"][0]
    assert row["speed_mm_min"] == row["drive_speed_mm_per_min"] == pytest.approx(1.0)
    assert row["ak_over_W"] == row["amplitude_ratio"]
    assert steady["tolerance"]["amplitude_mm"] == steady["tolerance"]["max_amplitude_mm"]
    assert row["amplitude_mm"] != steady["tolerance"]["max_amplitude_mm"]  # not renamed
    design = documents["design"]
    assert design["axes"]["speed_mm_min"] == design["axes"]["drive_speed_mm_per_min"]
    req = design["tolerance"]["required_stiffness"][0]
    assert req["stiffness_kgf_mm"] == req["stiffness_kgf_per_mm"]
    assert documents["discover"]["noise"] == documents["discover"]["noise_mm"]
    rec = documents["pitch"]["records"][0]
    assert rec["offset_mm"] == rec["drive_offset_mm"] == pytest.approx(30.0)
    mcmc = documents["mcmc"]  # its list of names was "records", objects elsewhere
    assert mcmc["deprecated_keys"] == {"records": "record_names"}
    assert mcmc["records"] == mcmc["record_names"]
    assert "deprecated_keys" not in documents["fit"]  # nothing renamed: no aliases


@pytest.mark.parametrize("name", JSON_COMMANDS)
def test_aliases_are_declared_by_the_command(documents, name):
    """The deprecated keys a document lists are the JSON_ALIASES its command declares (in
    the command module, or in the module that writes the document: for design the map's
    contract, stickslip_fitting.api.design; for mcmc stickslip_fitting.report.mcmc_document;
    for discover stickslip_fitting.report.discovery_text)."""
    from stickslip_jax.cli import registered

    module = next(importlib.import_module(m) for m in registered()
                  if importlib.import_module(m).NAME == name)
    writer = {"design": "stickslip_fitting.api.design",
              "mcmc": "stickslip_fitting.report.mcmc_document",
              "discover": "stickslip_fitting.report.discovery_text"}.get(name)
    if writer:
        module = importlib.import_module(writer)
    aliases = getattr(module, "JSON_ALIASES", {})
    listed = documents[name].get("deprecated_keys", {})
    assert listed == {aliases[new]: new for new in listed.values()}
    for new, old in aliases.items():
        assert new not in SYNONYMS.get(old, ()), (new, old)
        # record_names: a change of meaning (records holds objects), not a synonym
        assert old in SYNONYMS.get(new, ()) or new in ("max_amplitude_mm", "mean_um",
                                                       "record_names"), \
            f"{name}: {old} -> {new} missing from SYNONYMS"


def test_records_is_one_structure_in_every_command(documents):
    """`records`: a non-empty list of objects wherever a command writes it under that name
    (mcmc's list of names is `record_names`, `records` only as its deprecated alias)."""
    has = {c for c, doc in documents.items() if "records" in current_keys(doc)}
    assert has == {"fit", "discover", "plan", "pitch", "fit-batch"}  # fit-batch: in `fit`'s
    assert "records" in documents["fit-batch"]["campaigns"][0]["result"]  # reports
    for command in has - {"fit-batch"}:
        rows = documents[command]["records"]
        assert rows and all(isinstance(r, dict) for r in rows), command
    for command in ("fit", "discover"):  # the screening of every record, by name
        assert {"name", "status"} <= set(documents[command]["records"][0]), command
    mcmc = documents["mcmc"]
    assert all(isinstance(n, str) for n in mcmc["record_names"])
    assert mcmc["record_names"] == [r["name"] for r in mcmc["records_screened"]
                                    if r["status"] == "used"]


def test_the_check_catches_synonyms_and_missing_versions():
    """The checker is not vacuous: the pre-convention keys fail it."""
    old_steady = {"schema_version": SCHEMA_VERSION, "stiffness_kgf_mm": 86.9,
                  "results": [{"speed_mm_min": 1.0, "ak_over_W": 0.1}]}
    found = problems({"steady": old_steady, "fit": {"records": [{"noise": 1e-3}]}})
    assert any("stiffness_kgf_mm" in p for p in found)
    assert any("speed_mm_min" in p for p in found)
    assert any("ak_over_W" in p for p in found)
    assert any("fit: schema_version" in p for p in found)
    assert any("noise" in p for p in found)
    names = {"schema_version": SCHEMA_VERSION, "records": ["r1.csv", "r2.csv"]}
    assert problems({"mcmc": names}) == ["mcmc: .records is not a list of objects"]
    assert problems({"mcmc": versioned({"record_names": ["r1.csv"]}, {"record_names": "records"})}
                    ) == []  # the deprecated alias beside its new key is fine
    # an alias is fine only beside its new key with the same value
    doc = versioned({"a": [{"stiffness_kgf_per_mm": 2.0}]}, {"stiffness_kgf_per_mm": "k_kgf_mm"})
    assert doc["deprecated_keys"] == {"k_kgf_mm": "stiffness_kgf_per_mm"}
    assert doc["a"][0]["k_kgf_mm"] == 2.0 and problems({"x": doc}) == []
    doc["a"][0]["k_kgf_mm"] = 3.0
    with pytest.raises(AssertionError, match="alias differs"):
        problems({"x": doc})
    assert problems({"x": {"schema_version": SCHEMA_VERSION, "speed_mm_s": 1.0}})  # synonym
    assert problems({"x": {"schema_version": SCHEMA_VERSION, "load_kgf_mm": 1.0}})  # no _per_


def test_discovery_parameters_follow_the_fit_convention(documents):
    """`discover`'s friction and effect parameters before and after: one entry each in
    `estimates_before` / `estimates_after` with the keys of `fit`'s `parameters` entries
    (a value the records do not determine is null with a "reason"); `parameters_before`
    and `parameters_after` give the same values, null where the entry's is."""
    truth = {"truth", "relative_error", "truth_in_ci95"}  # fit's, with records made from one
    fit_keys = set(next(iter(documents["fit"]["parameters"].values()))) - truth
    doc = documents["discover"]
    for when in ("before", "after"):
        entries, values = doc[f"estimates_{when}"], doc[f"parameters_{when}"]
        assert set(entries) == set(values) and {"mu_s", "mu_d", "delta", "n"} <= set(entries)
        for name, e in entries.items():
            assert set(e) == fit_keys, name
            assert values[name] == e["value"], name
            assert (e["value"] is None) == (e["reason"] or "").startswith("not identifiable")
            assert e["value"] is None or e["stderr"] is None or e["stderr"] >= 0
