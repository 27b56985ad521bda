"""Tests of stickslip_jax.record_plots (stick/slip detection, phase plane) and `stickslip plot`."""

from __future__ import annotations

import numpy as np
import pytest

from stickslip_jax.cli import main
from stickslip_jax.record_plots import (
    SLIP,
    STICK,
    classify_phases,
    default_window,
    plot_record,
)
from stickslip_jax.records import Record, write_record
from stickslip_jax.units import G_MM_S2

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def sawtooth(W=36.0, k=86.9, v_mm_min=10.0, a=0.02, c=0.1, duration=2.0, rate=1000.0,
             noise=0.5e-3, seed=0):
    """Stick-slip written independently of the package's simulators.

    Stick: x rises at the drive speed v from c - a to c + a (T1 = 2a/v). Slip: the
    v -> 0 limit, eq (11), x = c + a cos(omega0 tau) for tau in [0, pi/omega0].
    Returns (record, true stick mask, number of slips).
    """
    v = v_mm_min / 60
    w0 = np.sqrt(G_MM_S2 * k / W)
    T1, T2 = 2 * a / v, np.pi / w0
    t = np.arange(int(round(duration * rate))) / rate
    phase = np.mod(t, T1 + T2)
    stick = phase < T1
    x = np.where(stick, c - a + v * phase, c + a * np.cos(w0 * (phase - T1)))
    x = x + np.random.default_rng(seed).normal(0.0, noise, t.shape)
    record = Record(time=t, deflection=x, stiffness=k, weight=W, drive_speed=v, lubricant="A")
    return record, stick, int(np.sum(np.diff(stick.astype(int)) == -1))


@pytest.fixture(scope="module")
def noisy():
    return sawtooth()


def test_phases_of_a_noisy_sawtooth(noisy):
    record, stick, n_slips = noisy
    phases = classify_phases(record)
    assert n_slips == 7
    assert phases.n_slips == n_slips
    # labels agree with the truth except a couple of samples at each slip's ends
    agree = np.mean((phases.labels == STICK) == stick)
    assert agree > 0.985, agree
    # every true slip holds a detected slip run
    for a, b in phases.runs(SLIP):
        assert not stick[a:b].any()
    # noise of the slider speed: 0.5 um through a 5-point slope fit at 1 kHz
    w = phases.window
    assert w == default_window(record) == 5  # quarter of T2 = 20 ms at 1 kHz
    sigma = 0.5e-3 * np.sqrt(12 / (w * (w**2 - 1))) / 1e-3
    assert phases.noise == pytest.approx(sigma, rel=0.15)
    assert phases.threshold == pytest.approx(5 * phases.noise)


def test_phase_plane_slip_is_a_half_circle():
    record, stick, _ = sawtooth(noise=0.0, rate=5000.0, duration=0.6)
    phases = classify_phases(record, window=5)
    rate = phases.rate
    slip = np.zeros_like(stick)
    for a, b in phases.runs(SLIP):  # away from the turning points
        slip[a + 2:b - 2] = True
    assert phases.n_slips == 2 and slip.sum() > 150
    # (x - c)^2 + (xdot/omega0)^2 = a^2 on the slip (eq 11): checks the omega0 scaling
    radius = np.hypot(record.deflection[slip] - 0.1, rate[slip] / record.omega0)
    np.testing.assert_allclose(radius, 0.02, rtol=1e-3)
    # stick: xdot = v
    inner = stick & (np.convolve(stick, np.ones(9), "same") == 9)
    np.testing.assert_allclose(rate[inner], 10 / 60, rtol=1e-9)


def test_steady_sliding_has_no_slips():
    t = np.arange(3000) * 1e-3
    rng = np.random.default_rng(3)
    r = Record(time=t, deflection=0.1 + rng.normal(0, 0.5e-3, t.shape), stiffness=86.9,
               weight=36.0, drive_speed=3.0)
    # x constant while the drive moves at 3 mm/s: neither stick nor slip
    p = classify_phases(r)
    assert p.n_slips == 0 and p.stick_fraction < 0.01
    # the same drift as a stick (x rises with the drive): all stick
    stuck = classify_phases(r.replace(deflection=r.deflection + 3.0 * t))
    assert stuck.n_slips == 0 and stuck.stick_fraction > 0.999


def test_hold_of_a_drive_program_is_stick():
    # slide (x rises at v) - hold (x constant) - slide: all stick, no slip
    v = 0.05
    t = np.arange(3000) * 1e-3
    program = ((0.0, v), (1.0, 0.0), (2.0, v))
    r = Record(time=t, deflection=np.zeros_like(t), stiffness=86.9, weight=36.0,
               drive_program=program)
    r = r.replace(deflection=0.05 + r.drive_position())
    p = classify_phases(r)
    assert p.n_slips == 0 and p.stick_fraction == 1.0 and p.threshold < 1e-9
    # with a constant drive_speed instead the hold is not stick: the drive matters
    assert classify_phases(r.replace(drive_program=None, drive_speed=v)).stick_fraction < 0.7


def test_even_window_is_refused(noisy):
    with pytest.raises(ValueError, match="odd"):
        classify_phases(noisy[0], window=4)


def test_figure_has_trace_and_phase_plane(noisy):
    fig = plot_record(noisy[0])
    trace, plane = fig.axes
    assert trace.get_xlabel() == "time t [s]" and "deflection" in trace.get_ylabel()
    assert "omega_0" in plane.get_xlabel() and plane.get_ylabel() == "x [mm]"
    assert "7 slips" in trace.get_legend().get_title().get_text()


def test_cli_plot_writes_png_in_the_current_folder_not_beside_the_data(tmp_path, noisy,
                                                                        capsys, monkeypatch):
    """Without --plot the figure is NAME.png in the current folder; the record's data
    folder gets nothing. --plot OUT.png (and its hidden alias --out) write OUT.png."""
    data, work = tmp_path / "data", tmp_path / "work"
    data.mkdir()
    work.mkdir()
    monkeypatch.chdir(work)
    p = write_record(noisy[0], data / "run.csv")
    assert main(["plot", str(p)]) == 0
    png = work / "run.png"
    assert png.read_bytes()[:8] == PNG_MAGIC and png.stat().st_size > 20_000
    assert sorted(f.name for f in data.iterdir()) == ["run.csv"]
    out = capsys.readouterr().out
    assert out.startswith("run.png: ") and "7 slips" in out
    import matplotlib.image

    for option in ("--plot", "--out"):
        custom = tmp_path / f"fig{option.strip('-')}.png"
        assert main(["plot", str(p), option, str(custom)]) == 0
        assert str(custom) in capsys.readouterr().out
        h, w = matplotlib.image.imread(custom).shape[:2]
        assert w > 1000 and h > 400
    assert sorted(f.name for f in data.iterdir()) == ["run.csv"]


@pytest.mark.parametrize(
    "content, extra, words",
    [
        ("# stickslip-record: 1\n# stiffness: 86.9\ntime [s],deflection [mm]\n0,0\n", [],
         ["bad.csv: line 2", "no unit"]),
        (None, [], ["no such file"]),
        ("ok", ["--out", "fig.jpg"], ["--out", ".png"]),
        ("ok", ["--out", "nodir/fig.png"], ["--out", "does not exist"]),
    ],
)
def test_cli_plot_errors(tmp_path, noisy, capsys, content, extra, words):
    p = tmp_path / "bad.csv"
    if content == "ok":
        write_record(noisy[0], p)
    elif content is not None:
        p.write_text(content)
    extra = [e if not e.endswith("png") and not e.endswith("jpg") else str(tmp_path / e)
             for e in extra]
    assert main(["plot", str(p), *extra]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("stickslip plot: error: ")
    for w in words:
        assert w in err, err


def _stick_in_slides(labels, time, slides, margin):
    """Samples labelled stick within the slides (start, end) (s), `margin` s in from their
    ends, and the samples there."""
    inside = np.zeros(time.size, bool)
    for a, b in slides:
        inside |= (time > a + margin) & (time < b - margin)
    return int(np.sum(inside & (labels == STICK))), int(np.sum(inside))


def test_a_pause_within_a_torsional_slide_is_no_stick():
    """Records of the independent torsional generator (`tests/torsional_rig.py`) whose
    rotor stops for a moment in a long slide and slips on (a stop and a breakaway at the
    same instant): those moments are labelled pauses, never stick, while every true
    stick of 5 % of a natural period or more keeps its stick label. Measured on 20
    records (seeds 100-119): stick samples within the slides 3000 -> 99 (one rest of 26
    samples whose y cannot be told from a stick's), no true stick lost."""
    import torsional_rig as tr

    from stickslip_jax.record_plots import PAUSE

    for seed in (101, 103, 106):
        rig = tr.random_rig(seed)
        run = tr.simulate(rig)
        m = tr.measured(rig, run)
        rec = Record(time=m["time"], deflection=m["deflection"], drive=m["drive"],
                     stiffness=rig.stiffness, weight=rig.weight)
        ph = classify_phases(rec)
        breaks, stops = run["breaks"], run["stops"]
        # a stop followed by a breakaway within 1 ms (the shortest rest is 5 ms or more)
        paused = [s for j, s in enumerate(stops) if j + 1 < len(breaks)
                  and breaks[j + 1] - s < 1e-3]
        assert paused, seed  # the run has stops within its slides
        # one slide from each breakaway after a stick to the stop before the next stick
        starts = [b for j, b in enumerate(breaks) if j == 0 or b - stops[j - 1] >= 1e-3]
        ends = [s for j, s in enumerate(stops) if j + 1 >= len(breaks)
                or breaks[j + 1] - s >= 1e-3]
        stuck, total = _stick_in_slides(ph.labels, m["time"], zip(starts, ends),
                                        ph.window * (m["time"][1] - m["time"][0]))
        assert total > 1000 and stuck == 0, (seed, stuck, total)
        at = [np.argmin(np.abs(m["time"] - s)) for s in paused]
        assert np.mean(ph.labels[at] == PAUSE) > 0.5, (seed, ph.labels[at])
        period = 2.0 * np.pi / rig.omega0
        for j, s in enumerate(stops[:-1]):
            if breaks[j + 1] - s >= 0.05 * period:  # a true stick keeps its label
                rest = (m["time"] > s) & (m["time"] < breaks[j + 1])
                assert np.any(ph.labels[rest] == STICK), (seed, s)


def test_a_pause_of_a_paper_rig_is_no_stick(tmp_path, capsys):
    """A paper-rig record of the independent generator (`tests/independent_records.py`,
    lubricant A with a slow kinetic decay, delta 25: every slip stops above mu_d W/k
    and slips on from rest, eq (1) at T1 = 0): the stop within each slip is a pause.
    Measured: stick samples within the slips 62 -> 2; `stickslip plot` says the share."""
    import dataclasses

    import independent_records as ir

    from stickslip_jax.record_plots import PAUSE

    truth = ir.simulate(dataclasses.replace(ir.LUBRICANT_A, delta=25.0), weight=36.0,
                        stiffness=86.9, speed_mm_min=5.0, duration=6.0, rate_hz=1000.0,
                        seed=1)
    rec = Record(time=truth.time, deflection=truth.deflection, stiffness=86.9, weight=36.0,
                 drive_speed=5.0 / 60.0, lubricant="A")
    ph = classify_phases(rec)
    stuck, total = _stick_in_slides(ph.labels, truth.time,
                                    zip(truth.breakaways, truth.slip_ends), ph.window * 1e-3)
    assert ph.n_slips == len(truth.breakaways) == 8
    assert total > 200 and stuck <= 5 and np.sum(ph.labels == PAUSE) > 20, (stuck, total)
    assert ph.stick_fraction > 0.9
    assert main(["plot", str(write_record(rec, tmp_path / "reslip.csv")),
                 "--plot", str(tmp_path / "reslip.png")]) == 0
    assert "% in pauses within slips" in capsys.readouterr().out
