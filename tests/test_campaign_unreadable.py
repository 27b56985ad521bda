"""A campaign with a file that cannot be read as a record (a summary table left in the
folder, a logger's long gap): the other records are fitted, the file is listed as
`unreadable` with the reason, and `--strict` refuses as before (`fitting.campaign`,
`stickslip_jax.records.read_campaign_files`)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_safety import EXAMPLES, copy_records, run_checked
from stickslip_fitting.data.campaign import UNREADABLE, load_campaign

from stickslip_jax.records import RecordError, read_campaign, read_campaign_files


def _folder(tmp_path):
    """The shipped campaign plus two files that are not records: a summary table and a
    record whose logger lost 200 samples in a row (a gap to split at)."""
    recs = copy_records(tmp_path / "camp")
    (tmp_path / "camp" / "summary.csv").write_text("run,speed,amplitude\n1,5,0.02\n")
    src = recs[0].read_text().splitlines()
    head = [ln for ln in src if ln.startswith("#") or ln.startswith("time")]
    body = [ln for ln in src if ln and ln[0].isdigit()]
    gap = tmp_path / "camp" / "A_gap.csv"
    gap.write_text("\n".join(head + body[:1000] + body[1200:]) + "\n")
    return tmp_path / "camp"


def test_unreadable_files_are_listed_and_the_rest_read(tmp_path):
    d = _folder(tmp_path)
    got = read_campaign_files(d)
    assert len(got.records) == len(EXAMPLES)
    assert sorted(e.path.rsplit("/", 1)[-1] for e in got.unreadable) == ["A_gap.csv",
                                                                        "summary.csv"]
    assert any("uneven" in e.reason for e in got.unreadable)
    with pytest.raises(RecordError, match="A_gap.csv"):  # the strict reader, as before
        read_campaign(d)
    c = load_campaign([d])
    bad = [s for s in c.screening if s.status == UNREADABLE]
    assert [s.name for s in bad] == ["A_gap.csv", "summary.csv"]
    assert len(c.records) == len(EXAMPLES)
    said = [w for w in c.warnings if "A_gap.csv" in w or "summary.csv" in w]
    assert len(said) == 2 and all("unreadable (line" in w for w in said)
    row = bad[0].to_json()
    assert row["status"] == "unreadable" and np.isnan(row["weight_kgf"])
    with pytest.raises(RecordError, match="A_gap.csv"):
        load_campaign([d], strict=True)


def test_one_unreadable_file_alone_is_its_error(tmp_path):
    d = _folder(tmp_path)
    with pytest.raises(RecordError, match="summary.csv"):
        load_campaign([d / "summary.csv"], min_records=1)


def test_fit_sets_the_unreadable_file_aside_and_says_so(tmp_path, capsys):
    d = _folder(tmp_path)
    out, _ = run_checked(["fit", d, "--json", tmp_path / "fit.json"], capsys,
                           tmp_path, 0, new=["fit.json"])
    assert "mu_s" in out
    assert "warning: summary.csv: unreadable, not fitted (line 1:" in out
    assert "warning: A_gap.csv: unreadable, not fitted (line" in out and "uneven" in out
    doc = json.loads((tmp_path / "fit.json").read_text())
    rows = {r["name"]: r for r in doc["records"]}
    assert rows["summary.csv"]["status"] == "unreadable"
    assert rows["summary.csv"]["weight_kgf"] is None
    assert doc["records_not_used"] == 2
    assert sum(r["status"] == "used" for r in doc["records"]) == len(EXAMPLES)
