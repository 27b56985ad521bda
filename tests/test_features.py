"""Cycle features (stickslip_fitting.data.features) against the exact simulator's own cycle table."""

import numpy as np
import pytest

import stickslip_jax as ss
from stickslip_fitting.data.features import extract_cycles, record_features
from stickslip_fitting.data.synthetic import synthetic_campaign

W, K = 36.0, 86.9


@pytest.fixture(scope="module")
def clean_and_noisy():
    """One record of lubricant A (W 36 kgf, k 86.9 kgf/mm, 0.1 v_c), with and without noise.

    Started from rest so the first (partial) cycle and the record start can be checked.
    """
    fr = ss.lubricant("A")
    kw = dict(conditions=((W, K),), speed_fractions=(0.1,), cycles=6, from_rest=True)
    clean = synthetic_campaign(fr, noise=0.0, **kw)[0]
    noisy = synthetic_campaign(fr, noise=5e-4, seed=3, **kw)[0]
    # the simulator's own cycles, for reference
    from stickslip_jax.drives import ConstantSpeed
    from stickslip_jax.simulation import simulate_exact

    import equinox as eqx

    tr = eqx.filter_jit(simulate_exact)(ss.Slideway(fr, W, K), ConstantSpeed(clean.drive_speed),
                                        clean.time, max_events=64)
    valid = np.asarray(tr.cycles.valid)
    ref = {name: np.asarray(getattr(tr.cycles, name))[valid]
           for name in ("peak", "trough", "stick_time", "breakaway_time", "slip_time")}
    return clean, noisy, ref


def test_noise_free_features_are_exact(clean_and_noisy):
    clean, _, ref = clean_and_noisy
    f = record_features(clean)
    assert f.stick_slip and f.n_complete >= 4
    n = len(f.peak)
    np.testing.assert_allclose(f.peak, ref["peak"][:n], atol=1e-9)
    np.testing.assert_allclose(f.trough, ref["trough"][:n], atol=1e-9)
    np.testing.assert_allclose(f.breakaway_time, ref["breakaway_time"][:n], atol=1e-6)
    np.testing.assert_allclose(f.stick_time[1:], ref["stick_time"][1:n], atol=1e-6)
    # the first stick began before the record's first slip: partial, T1 unknown
    assert not f.complete[0] and np.isnan(f.stick_time[0]) and f.complete[1:].all()
    # mu_m from eq (5) equals mu_m of eq (3) used in the simulation
    fr = ss.lubricant("A")
    mu0 = fr.static(f.stick_time[1:])
    mum = fr.kinetic(mu0, fr.mu_d, np.pi / f.omega0)
    np.testing.assert_allclose(f.mu_m[1:], mum, atol=1e-8)
    np.testing.assert_allclose(f.mu_0[1:], mu0, atol=1e-8)
    assert f.start_level == pytest.approx(0.0, abs=1e-9)


def test_noisy_features_are_calibrated(clean_and_noisy):
    _, noisy, ref = clean_and_noisy
    f = record_features(noisy)
    n = len(f.peak)
    assert f.noise == pytest.approx(5e-4, rel=0.1)
    z = np.concatenate([
        (f.peak - ref["peak"][:n]) / f.peak_sd,
        (f.trough - ref["trough"][:n]) / f.trough_sd,
        ((f.stick_time - ref["stick_time"][:n]) / f.stick_time_sd)[1:],
    ])
    assert np.all(np.abs(z) < 5)
    assert 0.4 < np.std(z) < 1.8  # standard errors are neither far too small nor too large
    # a naive peak pick is biased by the noise; the plateau estimate is not
    assert abs(np.mean(f.peak - ref["peak"][:n])) < 3 * f.peak_sd.mean()


def test_gauge_offset_shifts_levels_only(clean_and_noisy):
    _, noisy, _ = clean_and_noisy
    base = record_features(noisy)
    shifted = record_features(noisy.replace(deflection=noisy.deflection + 0.05))
    np.testing.assert_allclose(shifted.peak - base.peak, 0.05, atol=1e-12)
    np.testing.assert_allclose(shifted.trough - base.trough, 0.05, atol=1e-12)
    np.testing.assert_allclose(shifted.stick_time, base.stick_time, equal_nan=True)
    assert shifted.start_level == pytest.approx(0.05, abs=5e-5)


def test_drive_array_equals_constant_speed(clean_and_noisy):
    _, noisy, _ = clean_and_noisy
    a = extract_cycles(noisy.time, noisy.deflection, weight=W, stiffness=K,
                       drive=noisy.drive_speed)
    b = extract_cycles(noisy.time, noisy.deflection, weight=W, stiffness=K,
                       drive=noisy.drive_speed * noisy.time)
    np.testing.assert_allclose(a.peak, b.peak, rtol=1e-12)
    np.testing.assert_allclose(a.stick_time, b.stick_time, rtol=1e-9)


def test_record_cut_inside_a_slip_drops_that_slip(clean_and_noisy):
    clean, _, ref = clean_and_noisy
    t_cut = ref["breakaway_time"][3] + 0.5 * np.pi / clean.omega0
    keep = clean.time < t_cut
    cut = clean.replace(time=clean.time[keep], deflection=clean.deflection[keep])
    f = record_features(cut)
    assert len(f.peak) == 3  # the slip in progress at the end is not a cycle
    np.testing.assert_allclose(f.peak, ref["peak"][:3], atol=1e-9)


def test_no_stick_slip_is_reported_not_raised():
    rng = np.random.default_rng(0)
    t = np.arange(5000) * 1e-3
    v = 1.0  # steady sliding: x constant + noise while the drive moves
    flat = extract_cycles(t, 0.07 + rng.normal(0, 5e-4, t.size), weight=W, stiffness=K, drive=v)
    assert not flat.stick_slip and "no stick-slip" in flat.message
    ramp = extract_cycles(t, 0.01 * t + rng.normal(0, 5e-4, t.size), weight=W, stiffness=K,
                          drive=0.01)
    assert not ramp.stick_slip
    with pytest.raises(ValueError, match="equal length"):
        extract_cycles(t, t[:-1], weight=W, stiffness=K, drive=v)


def test_too_few_cycles_is_reported(clean_and_noisy):
    clean, _, ref = clean_and_noisy
    keep = clean.time < ref["breakaway_time"][1] + 0.3
    short = clean.replace(time=clean.time[keep], deflection=clean.deflection[keep])
    f = record_features(short)
    assert not f.stick_slip and "complete stick-slip cycle" in f.message


def _sticks_with_drive_error(error):
    """Twelve sticks of 800 samples at their own levels under a drive of 0.02 mm/s whose
    nominal position is off by `error(u)` (mm); noise 0.1 um."""
    from types import SimpleNamespace

    t = np.linspace(0.0, 120.0, 12001)
    u = 0.02 * t
    sticks = [SimpleNamespace(lo=lo, hi=lo + 800) for lo in range(100, 12000, 1000)]
    y = np.random.default_rng(0).normal(0.0, 1e-4, t.size)
    for j, p in enumerate(sticks):
        y[p.lo:p.hi] += 0.01 * j
    return t, u, y - error(u), sticks


def test_drive_error_finds_a_lead_screw_error_and_leaves_an_exact_drive():
    from stickslip_fitting.data.sticks import drive_error

    screw = lambda u: 0.004 * np.sin(2.0 * np.pi * u / 0.5)  # noqa: E731
    t, u, y, sticks = _sticks_with_drive_error(screw)
    fix, note = drive_error(t, u, y, sticks, 1e-4, 0.1)
    assert "periodic error 4 um at pitch 0.4999 mm" in note
    at = np.array([p.lo for p in sticks])
    np.testing.assert_allclose(fix[at] - fix[0], screw(u[at]) - screw(u[0]), atol=1e-4)
    t, u, y, sticks = _sticks_with_drive_error(lambda u: 0.0 * u)
    assert drive_error(t, u, y, sticks, 1e-4, 0.1) == (None, None)
    t, u, y, sticks = _sticks_with_drive_error(lambda u: 0.01 * u)
    assert drive_error(t, u, y, sticks, 1e-4, 0.1)[1].endswith("speed off by 0.012 mm/min on "
                                                                 "average")
