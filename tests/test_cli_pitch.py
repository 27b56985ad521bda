"""`stickslip pitch`: prediction and fit from record files; one-line errors with exit code 2."""

import json

import numpy as np
import pytest

from stickslip_jax import pitching as pt
from stickslip_jax.cli import main
from stickslip_jax.records import Record, write_record


def _sawtooth(n=601, period=2.0, dt=0.02):
    """A stick ramp from 5 to 12 kgf then a fast drop, repeated (k = 86.9 kgf/mm)."""
    t = np.arange(n) * dt
    phase = (t % period) / period
    force = np.where(phase < 0.95, 5.0 + 7.0 * phase / 0.95, 12.0 - 7.0 * (phase - 0.95) / 0.05)
    return t, force


@pytest.fixture(scope="module")
def record_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("pitch")
    t, force = _sawtooth()
    model = pt.default_model()
    paths = []
    for i, (h, o) in enumerate([(20.0, 30.0), (60.0, -30.0)]):
        disp = np.asarray(pt.tilt_history(model, t, force, pt.DrivePoint(h, o)).displacement)
        disp = disp + 2e-5 * np.random.default_rng(i).standard_normal(disp.shape)
        rec = Record(time=t, deflection=force / 86.9, stiffness=86.9, weight=36.0, drive_speed=0.05,
                     channels={"pitch_1": disp[:, 0], "pitch_3": disp[:, 2]},
                     channel_units={"pitch_1": "um", "pitch_3": "um"},
                     extra_header={"drive_height": f"{h} mm", "drive_offset": f"{o} mm"})
        paths.append(write_record(rec, d / f"r{i}.csv", channel_units="original"))
    return paths


def test_predicts_tilt_at_the_given_drive_point(record_files, capsys, tmp_path):
    out_json = tmp_path / "p.json"
    rc = main(["pitch", str(record_files[0]), "--height", "45", "--offset", "5 mm",
               "--json", str(out_json)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "h = 45 mm, l = 5 mm" in text and "pitch_1" in text and "yaw_5" in text
    data = json.loads(out_json.read_text())
    rows = {r["point"]: r for r in data["records"][0]["points"]}
    assert rows["yaw_4"]["eps_prime"] == pytest.approx(0.0, abs=1e-12)  # l = l_Mh: no yaw
    assert rows["pitch_1"]["eps_prime"] > 0 > rows["pitch_3"]["eps_prime"]
    assert "measured_eps_prime" in rows["pitch_1"] and "measured_eps_prime" not in rows["yaw_4"]


def test_fit_from_headers_and_plot(record_files, capsys, tmp_path):
    png, js = tmp_path / "p.png", tmp_path / "p.json"
    rc = main(["pitch", *map(str, record_files), "--fit", "--plot", str(png), "--json", str(js)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "neutral_height" in text and "converged" in text
    params = json.loads(js.read_text())["parameters"]
    for name, true in (("neutral_height", 30.0), ("compliance_pitch", 8e-8), ("tau_pitch", 1.0)):
        # interval coverage is tested in test_pitch_fit.py
        assert params[name]["value"] == pytest.approx(true, rel=1e-2), name
    assert "no yaw channels" in text
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize(
    "argv, message",
    [
        (["pitch", "missing.csv", "--height", "45"], "no such file"),
        (["__REC__", "--height", "45", "50", "60"], "--height: give one value or one per record"),
        (["__REC__", "--height", "45", "--viscosity", "3 furlongs"], "usage"),
    ],
)
def test_errors_are_one_line_with_exit_code_2(record_files, capsys, argv, message):
    argv = ["pitch", str(record_files[0])] + argv[1:] if argv[0] == "__REC__" else argv
    with pytest.raises(SystemExit) if message == "usage" else _nullcontext() as exc:
        rc = main(argv)
    if message == "usage":
        assert exc.value.code == 2
        err = capsys.readouterr().err
    else:
        assert rc == 2
        err = capsys.readouterr().err
        assert message in err
    assert len(err.strip().splitlines()) in (1, 2)  # argparse adds a usage line


def test_missing_drive_height_is_a_one_line_error(tmp_path, capsys):
    t, force = _sawtooth(n=50)
    rec = Record(time=t, deflection=force / 86.9, stiffness=86.9, weight=36.0, drive_speed=0.05)
    path = write_record(rec, tmp_path / "bare.csv")
    assert main(["pitch", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "drive height unknown" in err[0]


class _nullcontext:
    def __enter__(self):
        return None

    def __exit__(self, *a):
        return False
