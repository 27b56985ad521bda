"""The misfit a discovery's final model leaves, said by phase and form
(`discovery.misfit`): on residuals made of one known form in one phase, the phase and the
form are named with their sizes and units."""

from __future__ import annotations

import types

import numpy as np
import pytest

from stickslip_fitting.discovery.misfit import misfit_left

N, L, G = 12, 240, 2  # windows, samples per window, records
STICK, SLIP = 1.0, 0.1  # s


def _model(lag=0.0):
    """A stand-in for the per-cycle model: windows of a 1 s stick then a 0.1 s slip; the
    model breaks away `lag` s after the record."""
    tau = np.linspace(0.0, 1.2, L)
    start = 1.2 * np.arange(N)
    data = types.SimpleNamespace(
        mask=np.ones((N, L), bool), record=np.arange(N) % G, window=np.arange(N),
        start_time=start, stick_time=np.full(N, STICK), speed=np.full(N, 0.1),
        stiffness=np.full(N, 86.9), weight=np.full(N, 36.0), time=start[:, None] + tau,
        deflection=np.zeros((N, L)))
    yd = np.where((tau >= STICK + lag) & (tau < STICK + SLIP), 5.0, 0.0) * np.ones((N, 1))
    return types.SimpleNamespace(data=data, scales=np.ones(6 + G), n_base=6 + G,
                                 residuals=lambda z, *a: (None, yd, True)), tau


def _left(e_of, lag=0.0, upto=0.9 * STICK):
    model, tau = _model(lag)
    rng = np.random.default_rng(0)
    t = np.asarray(model.data.time)
    e = np.where(tau < upto, e_of(t, tau), 0.0) + 0.5e-3 * rng.standard_normal((N, L))
    sd = np.full(N * L, 0.5e-3)
    return misfit_left(model, np.zeros(6 + G), e.ravel() / sd, sd, 0.5e-3,
                       np.ones(N * L, bool))


def test_a_level_from_cycle_to_cycle_in_the_stick_is_named():
    level = np.random.default_rng(1).normal(0.0, 6e-3, N)[:, None]
    left = _left(lambda t, tau: level + 0 * tau)
    top = max(left.forms, key=lambda f: f["share"])
    assert left.phase == "stick" and top["name"] == "level" and top["share"] > 0.9
    assert top["rms_between_cycles_um"] == pytest.approx(1e3 * np.std(level), rel=0.05)
    assert "stick phases" in left.words and "level that differs from cycle to cycle" in left.words


def test_a_ramp_in_the_time_since_the_last_slip_is_named_with_its_slope():
    left = _left(lambda t, tau: 20e-3 * (tau - 0.45))  # 20 um/s
    ramp = next(f for f in left.forms if f["name"] == "ramp")
    assert left.phase == "stick" and ramp["share"] > 0.9
    assert ramp["slope_median_um_s"] == pytest.approx(20.0, rel=0.05)
    assert ramp["same_sign"] == 1.0
    assert "linear in the time since the last slip" in left.words and "um/s" in left.words


def test_an_oscillation_is_named_with_its_frequency():
    left = _left(lambda t, tau: 5e-3 * np.sin(2 * np.pi * 7.0 * t))
    wave = next(f for f in left.forms if f["name"] == "oscillation")
    assert wave == max(left.forms, key=lambda f: f["share"])
    assert wave["frequency_hz"] == pytest.approx(7.0, rel=0.03)
    assert wave["amplitude_um"] == pytest.approx(5.0, rel=0.15)
    assert "Hz" in left.words and set(left.to_json()) >= {"phase", "forms", "words"}


def test_a_late_breakaway_is_named_with_its_delay_and_the_friction_it_stands_for():
    """The model sticks 20 ms past the record's breakaway: the record has dropped by 30 um
    there, and the words give the delay, the climb v dt and mu_0 off by k v dt / W."""
    left = _left(lambda t, tau: np.where(tau >= 0.98 * STICK, -30e-3, 0.0), lag=0.02,
                 upto=STICK + 0.02)
    assert left.phase == "breakaway"
    assert left.delay["quartiles_ms"][1] == pytest.approx(20.0, abs=5.0)
    assert left.delay["late"] == 1.0 and left.delay["cycles"] == N
    assert left.delay["deflection_um"] == pytest.approx(2.0, abs=0.5)  # 0.1 mm/s x 20 ms
    assert left.delay["mu_0"] == pytest.approx(86.9 * 0.002 / 36.0, rel=0.3)
    assert "breaks away later than the record in 100 % of the 12 cycles, 0 of them" in left.words
    # a model that does not slip within its windows: their ends count, a lower bound
    left = _left(lambda t, tau: np.where(tau >= 0.98 * STICK, -30e-3, 0.0), lag=0.5,
                 upto=np.inf)
    assert left.delay["no_slip"] == N and left.delay["late"] == 1.0
    assert left.delay["quartiles_ms"][1] == pytest.approx(200.0, abs=5.0)
