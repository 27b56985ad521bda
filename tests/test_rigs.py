"""Rotational rigs read into the equivalent linear slideway (stickslip_jax.rigs): a record
written in the rig's units (angle in rad or deg or torque in N*m, torsional stiffness,
inertia, normal load, friction radius) reads to the same record as its linear twin."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stickslip_jax.records import Record, RecordError, format_record, parse_record
from stickslip_jax.rigs import RotationalRig, rig_quantities, rotational_record
from stickslip_jax.units import KGF_N

T = np.arange(6) * 2e-3  # s
X = np.array([0.01, 0.02, 0.035, 0.03, 0.012, 0.011])  # mm
U = np.array([0.0, 0.004, 0.008, 0.012, 0.016, 0.02])  # mm


def _lines(rows):
    return "\n".join(",".join(repr(float(v)) for v in row) for row in rows) + "\n"


def _linear_twin(k, w, n, v, drive=False):
    head = (f"# stickslip-record: 1\n# stiffness: {k!r} kgf/mm\n# slider_weight: {w!r} kgf\n"
            f"# normal_load: {n!r} kgf\n# drive_speed: {v!r} mm/s\n")
    cols = "time [s],deflection [mm]" + (",drive [mm]" if drive else "")
    return parse_record(head + cols + "\n" + _lines(zip(T, X, U) if drive else zip(T, X)))


def _same(a: Record, b: Record, rtol=1e-12):
    for name in ("stiffness", "weight", "normal_load", "drive_speed"):
        assert getattr(a, name) == pytest.approx(getattr(b, name), rel=rtol), name
    np.testing.assert_allclose(a.time, b.time, rtol=0, atol=0)
    np.testing.assert_allclose(a.deflection, b.deflection, rtol=rtol, atol=1e-15)
    if b.drive is not None:
        np.testing.assert_allclose(a.drive, b.drive, rtol=rtol, atol=1e-15)


@settings(max_examples=40, deadline=None)
@given(radius=st.floats(1.0, 500.0), k=st.floats(0.01, 500.0), w=st.floats(0.01, 100.0),
       n=st.floats(0.01, 500.0), v=st.floats(1e-4, 10.0),
       angle_unit=st.sampled_from(["rad", "deg"]),
       torque=st.booleans(), drive=st.booleans())
def test_rotational_record_reads_as_its_linear_twin(radius, k, w, n, v, angle_unit, torque,
                                                    drive):
    """Rig units -> the linear record: x = R theta, k = k_t/R^2, W = g J/R^2, N, v = R w."""
    twin = _linear_twin(k, w, n, v, drive)
    per = 180.0 / math.pi if angle_unit == "deg" else 1.0
    k_t = k * radius ** 2 * KGF_N / 1e3                 # N*m/rad
    inertia = w * (radius / 1e3) ** 2                   # kg*m^2: J = M R^2, M = W/g (kg)
    rpm = v / radius * 30.0 / math.pi
    head = (f"# stickslip-record: 1\n# friction_radius: {radius!r} mm\n"
            f"# torsional_stiffness: {k_t!r} N*m/rad\n# inertia: {inertia!r} kg*m^2\n"
            f"# normal_load: {n * KGF_N!r} N\n# drive_speed: {rpm!r} rpm\n")
    if torque:
        cols, values = ["time [s]", "torque [N*m]"], [T, k * X * radius * KGF_N / 1e3]
    else:
        cols, values = ["time [s]", f"angle [{angle_unit}]"], [T, X / radius * per]
    if drive:
        cols.append(f"drive [{angle_unit}]")
        values.append(U / radius * per)
    rec = parse_record(head + ",".join(cols) + "\n" + _lines(zip(*values)))
    assert rec.friction_radius == radius and rec.rig == RotationalRig(radius)
    _same(rec, twin, rtol=1e-11)
    # written back (internal linear units and the radius) it reads exactly
    assert parse_record(format_record(rec)) == rec
    q = rig_quantities(rec)
    assert q["torsional_stiffness_n_m_per_rad"] == pytest.approx(k_t, rel=1e-11)
    assert q["inertia_kg_m2"] == pytest.approx(inertia, rel=1e-11)
    assert q["drive_speed_rad_per_s"] == pytest.approx(rpm * math.pi / 30.0, rel=1e-11)
    assert rec.load == pytest.approx(n, rel=1e-12)


def test_python_constructor_matches_the_file():
    text = ("# stickslip-record: 1\n# friction_radius: 20 mm\n"
            "# torsional_stiffness: 0.5 N*m/rad\n# inertia: 2e-4 kg*m^2\n# normal_load: 40 N\n"
            "# drive_speed: 3 rpm\ntime [s],angle [deg],drive [rad]\n"
            + _lines(zip(T, X * 10, U)))
    rec = parse_record(text)
    built = rotational_record(T, X * 10, angle_unit="deg", drive=U, drive_unit="rad",
                              torsional_stiffness="0.5 N*m/rad", inertia="2e-4 kg*m^2",
                              normal_load="40 N", friction_radius="20 mm", drive_speed="3 rpm")
    assert built == rec
    assert rec.stiffness == pytest.approx(0.5e3 / KGF_N / 400.0, rel=1e-14)  # k_t / R^2
    assert rec.weight == pytest.approx(2e-4 * 1e6 / 400.0, rel=1e-12)       # J / R^2 * g
    assert rec.drive_speed == pytest.approx(20.0 * 3.0 * math.pi / 30.0, rel=1e-14)
    assert RotationalRig(20.0).to_rig(rec.deflection, "length", "deg") == pytest.approx(X * 10)
    with pytest.raises(RecordError, match="exactly one"):
        rotational_record(T, X, torque=X, torsional_stiffness=1.0, inertia=1.0,
                          normal_load=1.0, friction_radius=1.0)


@pytest.mark.parametrize("header, match", [
    ("# stiffness: 1 kgf/mm\n# torsional_stiffness: 1 N*m/rad\n# slider_weight: 1 kgf",
     "friction radius"),
    ("# friction_radius: 10 mm\n# stiffness: 1 kgf/mm\n# torsional_stiffness: 1 N*m/rad\n"
     "# slider_weight: 1 kgf", "both torsional_stiffness and stiffness"),
    ("# friction_radius: 10 mm\n# torsional_stiffness: 1 N*m/s\n# slider_weight: 1 kgf",
     "torsional stiffness unit"),
    ("# friction_radius: -1 mm\n# stiffness: 1 kgf/mm\n# slider_weight: 1 kgf",
     "positive"),
    ("# stiffness: 1 kgf/mm\n# slider_weight: 1 kgf\n# normal_load: 3 mm", "force unit"),
])
def test_bad_rig_headers_name_the_fix(header, match):
    text = (f"# stickslip-record: 1\n{header}\n# drive_speed: 1 mm/s\n"
            "time [s],deflection [mm]\n0,0\n0.1,0\n")
    with pytest.raises(RecordError, match=match):
        parse_record(text)


def test_screening_reports_the_rig_in_its_units():
    from stickslip_fitting.data.campaign import screen_records
    from stickslip_fitting.data.features import record_features

    rec = rotational_record(np.arange(400) * 1e-3, np.zeros(400), torsional_stiffness=
                            "0.5 N*m/rad", inertia="2e-4 kg*m^2", normal_load="40 N",
                            friction_radius="20 mm", drive_speed="3 rpm")
    f = record_features(rec)
    assert f.load == rec.normal_load
    row = screen_records([rec, rec], min_records=0).screening[0].to_json()
    assert row["torsional_stiffness_n_m_per_rad"] == pytest.approx(0.5)
    assert row["inertia_kg_m2"] == pytest.approx(2e-4)
    assert row["normal_load_kgf"] == pytest.approx(40.0 / KGF_N)
    assert row["friction_radius_mm"] == 20.0 and row["drive_speed_rad_per_s"] == pytest.approx(
        math.pi / 10.0)


def test_fit_of_a_rotational_campaign_reports_in_rig_units(tmp_path):
    """`stickslip fit` on records written in a torsional rig's units gives the fit of their
    linear twins, and its JSON carries each record's rig quantities and angles."""
    import json

    import stickslip_jax as ss
    from stickslip_fitting.data.synthetic import synthetic_campaign
    from stickslip_jax.cli import main
    from stickslip_jax.records import write_record

    radius = 50.0  # mm
    recs = synthetic_campaign(ss.lubricant("A"), conditions=((36.0, 86.9), (36.0, 200.0)),
                              speed_fractions=(0.05, 0.3), cycles=4, pad_to=40_000, seed=2)
    lin, rot = [], []
    for i, r in enumerate(recs):
        lin.append(write_record(r, tmp_path / f"lin{i}.csv"))
        head = (f"# stickslip-record: 1\n# friction_radius: {radius} mm\n"
                f"# torsional_stiffness: {r.stiffness * radius ** 2 * KGF_N / 1e3!r} N*m/rad\n"
                f"# inertia: {r.weight * (radius / 1e3) ** 2!r} kg*m^2\n"
                f"# normal_load: {r.weight * KGF_N!r} N\n"
                f"# drive_speed: {r.drive_speed / radius * 30 / math.pi!r} rpm\n"
                "# lubricant: A\ntime [s],angle [deg]\n")
        rot.append(tmp_path / f"rot{i}.csv")
        rot[-1].write_text(head + _lines(zip(r.time, np.degrees(r.deflection / radius))))
    docs = []
    for paths, name in ((lin, "lin"), (rot, "rot")):
        out = tmp_path / f"{name}.json"
        assert main(["fit", *map(str, paths), "--json", str(out), "--quiet"]) == 0
        docs.append(json.loads(out.read_text()))
    for a, b in zip(docs[0]["parameters"].values(), docs[1]["parameters"].values()):
        assert b["value"] == pytest.approx(a["value"], rel=1e-7)
        assert b["ci95"] == pytest.approx(a["ci95"], rel=1e-5)
    row = docs[1]["records"][0]
    assert row["friction_radius_mm"] == radius
    assert row["torsional_stiffness_n_m_per_rad"] == pytest.approx(
        86.9 * radius ** 2 * KGF_N / 1e3, rel=1e-12)
    assert row["gauge_offset_rad"] == pytest.approx(row["gauge_offset_mm"] / radius)
    assert row["noise_rad"] == pytest.approx(docs[0]["records"][0]["noise_mm"] / radius,
                                             rel=1e-6)
    assert "friction_radius_mm" not in docs[0]["records"][0]
