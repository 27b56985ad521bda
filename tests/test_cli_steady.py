"""`stickslip steady` (stickslip_jax.commands.steady) in-process and as the console script."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import stickslip_jax as ss
from stickslip_jax.cli import main
from stickslip_jax.units import from_mm_per_min

BASE = ["steady", "--lubricant", "A", "--weight", "36", "--stiffness", "86.9"]


def test_table_with_units(capsys):
    assert main(BASE + ["--speed", "0.1", "1", "10"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert "W = 36 kgf" in out[0] and "k = 86.9 kgf/mm" in out[0] and "Hz" in out[0]
    for unit in ("v [mm/min]", "T1 [s]", "a [mm]", "ak/W [-]", "f [Hz]", "v_c [mm/min]"):
        assert unit in out[1]
    assert len(out) == 6 and "limit cycle" in out[5]
    row = out[3].split()  # 1 mm/min
    assert row[0] == "1" and row[1] == "yes"
    r = ss.steady_state(ss.lubricant("A"), 36.0, 86.9, from_mm_per_min(1.0))
    assert float(row[2]) == pytest.approx(float(r.stick_time), rel=1e-4)
    assert float(row[4]) == pytest.approx(float(r.amplitude), rel=1e-4)
    assert float(row[8]) == pytest.approx(48.911, abs=1e-3)
    assert float(row[9]) == pytest.approx(float(r.amplitude), rel=1e-4)  # = eq (6) below v_c


def test_limit_cycle_columns_above_v_c_and_tolerance(capsys):
    argv = BASE + ["--speed", "52", "90", "--tolerance", "1 um", "--json", "-"]
    assert main(argv) == 0
    cap = capsys.readouterr()
    doc = json.loads(cap.out)
    r52, r90 = doc["results"]
    assert not r52["stick_slip"] and r52["amplitude_mm"] == 0.0  # eq (12): none above v_c
    # the time-domain limit cycle goes on (the exact simulator's 8.0 and 5.7 um)
    assert r52["cycle_amplitude_mm"] == pytest.approx(8.010e-3, rel=1e-3)
    assert r90["cycle_amplitude_mm"] == pytest.approx(5.664e-3, rel=1e-3)
    assert r52["cycle_stick_time_s"] > r90["cycle_stick_time_s"] > 0
    tol = doc["tolerance"]
    assert tol["amplitude_mm"] == pytest.approx(1e-3)
    assert tol["speed_mm_min"] == pytest.approx(1282.2, rel=1e-3)
    assert "below 1 um above v = 1282.2 mm/min" in cap.err


def test_damping_ratio_boundary_beside_v_c(capsys):
    """--damping-ratio: the damped limit cycle and the sharp boundary speed, printed and in
    the JSON, equal `limit_cycle(..., damping_ratio)` and `boundary_speed` called directly."""
    from stickslip_jax.limit_cycle import boundary_speed, limit_cycle

    argv = BASE + ["--speed", "30", "90", "--damping-ratio", "0.05", "--json", "-"]
    assert main(argv) == 0
    cap = capsys.readouterr()
    doc = json.loads(cap.out)
    friction = ss.lubricant("A")
    v_b = 60.0 * float(boundary_speed(friction, 36.0, 86.9, 0.05))
    assert doc["damping_ratio"] == 0.05
    assert doc["boundary_speed_mm_per_min"] == pytest.approx(v_b, rel=1e-12)
    assert v_b == pytest.approx(54.735, abs=1e-3)  # the README's 54.7 mm/min
    line = next(s for s in cap.err.splitlines() if s.startswith("damping ratio zeta = 0.05"))
    assert f"above v = {v_b:.5g} mm/min" in line and "v_c = 48.911 mm/min" in line
    r30, r90 = doc["results"]
    c30 = limit_cycle(friction, 36.0, 86.9, 0.5, damping_ratio=0.05)
    f0 = doc["natural_frequency_hz"]
    assert r30["damped_regime"] == "stick-slip"
    assert r30["damped_cycle_amplitude_mm"] == pytest.approx(float(c30.amplitude), rel=1e-9)
    assert r30["damped_cycle_stick_time_s"] == pytest.approx(float(c30.stick_time), rel=1e-9)
    assert r30["damped_cycle_frequency_ratio"] == pytest.approx(float(c30.frequency) / f0,
                                                                rel=1e-9)
    # the damped cycle is smaller than the undamped one, and gone above the boundary
    assert 0 < r30["damped_cycle_amplitude_mm"] < r30["cycle_amplitude_mm"]
    assert r90["damped_regime"] == "steady sliding" and r90["damped_cycle_amplitude_mm"] == 0
    assert r90["cycle_amplitude_mm"] > 0  # the undamped model's cycle goes on
    header = cap.err.splitlines()[1]
    assert "a_damped [mm]" in header and "f/f0_damped [-]" in header
    row = cap.err.splitlines()[2].split()
    assert float(row[-3]) == pytest.approx(float(c30.amplitude), rel=1e-4)
    assert float(row[-1]) == pytest.approx(float(c30.frequency) / f0, rel=1e-4)


def test_damping_ratio_zero_has_no_boundary(capsys):
    """zeta = 0: boundary_speed is inf, so the JSON has null with its reason, the table
    says there is none, and the damped cycle is the undamped one."""
    assert main(BASE + ["--speed", "90", "--damping-ratio", "0", "--json", "-"]) == 0
    cap = capsys.readouterr()
    doc = json.loads(cap.out)
    assert doc["boundary_speed_mm_per_min"] is None
    assert "infinite" in doc["null_reasons"]["boundary_speed_mm_per_min"]
    (r90,) = doc["results"]
    assert r90["damped_cycle_amplitude_mm"] == pytest.approx(r90["cycle_amplitude_mm"],
                                                             rel=1e-9)
    assert "no boundary speed" in cap.err


def test_json_and_units_on_arguments(capsys):
    argv = ["steady", "--lubricant", "C", "--weight", "353.04 N", "--stiffness", "852.2 N/mm",
            "--speed", "1", "100 um/s", "--json"]
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["lubricant"] == "C" and doc["table"] == 6
    assert doc["weight_kgf"] == pytest.approx(36.0, rel=1e-4)
    assert doc["stiffness_kgf_mm"] == pytest.approx(86.9, rel=1e-4)
    speeds = [r["speed_mm_min"] for r in doc["results"]]
    assert speeds == pytest.approx([1.0, 6.0])
    assert [r["stick_slip"] for r in doc["results"]] == [True, False]  # v_c(C) ~ 4.3 mm/min
    assert doc["results"][1]["amplitude_mm"] == 0.0
    ref = ss.steady_state(ss.lubricant("C"), doc["weight_kgf"], doc["stiffness_kgf_mm"], 1 / 60)
    assert doc["results"][0]["stick_time_s"] == pytest.approx(float(ref.stick_time), rel=1e-12)


def test_help(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["steady", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for flag in ("--lubricant", "--weight", "--stiffness", "--speed", "--json", "mm/min",
                 "--damping-ratio", "boundary"):
        assert flag in out


@pytest.mark.parametrize(
    "args, names",
    [
        (["--lubricant", "Z", "--weight", "36", "--stiffness", "86.9", "--speed", "1"],
         "--lubricant"),
        (["--weight", "0", "--stiffness", "86.9", "--speed", "1"], "--weight"),
        (["--weight", "36", "--stiffness", "-2", "--speed", "1"], "--stiffness"),
        (["--weight", "36", "--stiffness", "86.9", "--speed", "1", "-5"], "--speed"),
        (["--weight", "36", "--stiffness", "86.9", "--speed", "1.2.3"], "--speed"),
        (["--weight", "thirty", "--stiffness", "86.9", "--speed", "1"], "--weight"),
        (["--weight", "36 kgf/mm", "--stiffness", "86.9", "--speed", "1"], "--weight"),
        (["--weight", "36", "--stiffness", "86.9", "--speed", "1", "--damping-ratio", "1"],
         "--damping-ratio"),
    ],
)
def test_user_errors_one_line_exit_2(capsys, args, names):
    try:
        code = main(["steady"] + args)
    except SystemExit as exc:  # argparse type errors exit from parse_args
        code = exc.code
    assert code == 2
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and names in err[0] and "error" in err[0], captured.err
    assert captured.out == ""


def test_console_script_subprocess():
    """The README's main command, through the installed console script (one process)."""
    exe = Path(sys.executable).with_name("stickslip")
    cmd = [str(exe)] if exe.exists() else [shutil.which("stickslip")]
    ok = subprocess.run(cmd + BASE + ["--speed", "0.1", "1", "10", "--json"],
                        capture_output=True, text=True, timeout=300)
    assert ok.returncode == 0, ok.stderr
    assert [r["stick_slip"] for r in json.loads(ok.stdout)["results"]] == [True, True, True]
