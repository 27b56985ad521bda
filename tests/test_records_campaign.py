"""What belongs in one campaign: the same run under two names counts once (compared by its
data, not its bytes), and records of another surface, lubricant or rig are refused naming
the record that differs (fit, discover and the Python calls read campaigns through these)."""

from __future__ import annotations

import gzip

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stickslip_jax.records import (
    RecordError,
    check_campaign,
    read_campaign,
    read_campaign_files,
)

RUN = """\
# stickslip-record: 1
# drive_speed: {speed} mm/min
# stiffness: {k} kgf/mm
# slider_weight: {w}
# lubricant: {lub}
# surface: {surface}
# note: {note}
time [s],deflection [mm]
""" + "".join(f"{0.001 * i!r},{0.12 + 0.0001 * (i * i % 13)!r}\n" for i in range(40))


def run(speed=1.0, k="86.9", w="36.0 kgf", lub="A", surface="S1G1", note="run"):
    return RUN.format(speed=speed, k=k, w=w, lub=lub, surface=surface, note=note)


def _folder(tmp_path, texts: dict[str, str]):
    for name, text in texts.items():
        (tmp_path / name).write_text(text)
    return tmp_path


@settings(max_examples=30, deadline=None, suppress_health_check=[
    HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(sep=st.sampled_from([";", "\t"]), crlf=st.booleans(), note=st.text(
    st.characters(min_codepoint=65, max_codepoint=122), min_size=1, max_size=20),
    zipped=st.booleans())
def test_a_resaved_copy_counts_once_with_a_note(tmp_path_factory, sep, crlf, note, zipped):
    d = tmp_path_factory.mktemp("copies")
    _folder(d, {"a.csv": run(1.0), "b.csv": run(2.0)})
    head, _, body = run(1.0, note=note).partition("time [s]")
    text = head + ("time [s]" + body).replace(",", sep).replace(".", ",")
    data = (text.replace("\n", "\r\n") if crlf else text).encode()
    (d / "resaved.csv").write_bytes(gzip.compress(data) if zipped else data)
    got = read_campaign_files(d)
    assert [r.name for r in got.records] == ["a", "b"]
    assert any("resaved.csv holds the same data: counted once" in n
               for n in got.records[0].notes)


def test_different_runs_are_all_kept(tmp_path):
    d = _folder(tmp_path, {"a.csv": run(1.0), "b.csv": run(1.0, k="27.3"),
                           "c.csv": run(2.0)})
    assert len(read_campaign_files(d).records) == 3


@pytest.mark.parametrize("odd, words", [
    (run(4.0, surface="S2G2"), ["mixes surfaces", "'S2G2' in odd"]),
    (run(4.0, lub="C"), ["mixes lubricants", "'C' in odd"]),
    (run(4.0, w="0.0307 kgf", k="0.017"), ["odd (0.0307 kgf)", "another rig"]),
    (run(4.0, k="86880"), ["odd (8.688e+04 kgf/mm)", "another rig"]),
])
def test_a_record_of_another_rig_or_material_is_refused_by_name(tmp_path, odd, words):
    d = _folder(tmp_path, {"a.csv": run(1.0), "b.csv": run(2.0), "c.csv": run(3.0),
                           "odd.csv": odd})
    with pytest.raises(RecordError) as info:
        read_campaign_files(d)
    msg = str(info.value)
    for w in words:
        assert w in msg, msg
    assert "\n" not in msg
    records = read_campaign(d)  # reading alone does not judge; check_campaign does
    with pytest.raises(RecordError):
        check_campaign(records, same=("lubricant", "surface"))


def test_a_record_without_a_surface_joins_any(tmp_path):
    d = _folder(tmp_path, {"a.csv": run(1.0), "b.csv": run(2.0).replace(
        "# surface: S1G1\n", "")})
    assert len(read_campaign_files(d).records) == 2


def test_the_paper_rigs_are_one_campaign(tmp_path):
    """11.3-53.2 kgf sliders on 27.3-128.5 kgf/mm springs (Table 1) are one rig."""
    d = _folder(tmp_path, {"a.csv": run(1.0, k="27.3", w="11.3 kgf"),
                           "b.csv": run(2.0, k="128.5", w="53.2 kgf"),
                           "c.csv": run(3.0)})
    assert check_campaign(read_campaign_files(d).records) == []
