"""Surface factors from 1-D profiles (section 7.4): synthetic rod-model profiles, bad input."""

import numpy as np
import pytest

from stickslip_jax.contact import estimate_surface, synthetic_profile

CASES = [  # H_max, R (mm), z (1/mm), D
    (20e-3, 5e-3, 20.0, 1.5),
    (10e-3, 8e-3, 25.0, 1.2),
    (5e-3, 3e-3, 40.0, 2.0),
]


@pytest.mark.parametrize("H,R,z,D", CASES)
@pytest.mark.parametrize("seed", [0, 1])
def test_synthetic_profile_factors_come_back(H, R, z, D, seed):
    x, h = synthetic_profile(H, R, z, D, length=6.0, spacing=0.2e-3, seed=seed)
    est = estimate_surface(h * 1e3, 0.2e-3, height_unit="um", length_unit="mm")  # heights in um
    for got, want in [(est.H_max, H), (est.R, R), (est.z, z), (est.D, D)]:
        assert got == pytest.approx(want, rel=0.10)
    assert est.xi == pytest.approx(D * R / H * z, rel=0.15)
    assert est.surface().xi() == pytest.approx(est.xi, rel=1e-12)


def test_noisy_profile_within_ten_percent():
    H, R, z, D = 20e-3, 5e-3, 20.0, 1.5
    x, h = synthetic_profile(H, R, z, D, length=6.0, spacing=0.2e-3, seed=3)
    noisy = h + np.random.default_rng(0).normal(0.0, 0.002 * H, h.size)
    est = estimate_surface(noisy, 0.2, height_unit="mm", length_unit="um")  # spacing in um
    assert est.R == pytest.approx(R, rel=0.10)
    assert est.z == pytest.approx(z, rel=0.10)
    assert est.D == pytest.approx(D, rel=0.10)
    assert est.H_max == pytest.approx(H, rel=0.10)


def test_units_are_respected():
    x, h = synthetic_profile(10e-3, 4e-3, 25.0, 1.2, length=4.0, spacing=0.2e-3)
    a = estimate_surface(h, 0.2e-3, height_unit="mm")
    b = estimate_surface(h * 1e3, 0.2, height_unit="um", length_unit="um")
    assert a.R == pytest.approx(b.R, rel=1e-9) and a.z == pytest.approx(b.z, rel=1e-9)


def test_bad_profiles_raise_clear_errors():
    with pytest.raises(ValueError, match="too short"):
        estimate_surface(np.arange(5.0), 1e-3)
    with pytest.raises(ValueError, match="constant"):
        estimate_surface(np.ones(1000), 1e-3)
    h = np.sin(np.linspace(0, 40, 1000))
    h[10] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        estimate_surface(h, 1e-3)
    with pytest.raises(ValueError, match="1-D"):
        estimate_surface(np.ones((10, 10)), 1e-3)
    with pytest.raises(ValueError, match="unknown unit"):
        estimate_surface(np.ones(100), 1e-3, height_unit="inch")
    with pytest.raises(ValueError, match="spacing"):
        estimate_surface(np.sin(np.arange(100.0)), -1.0)
    with pytest.raises(ValueError, match="too coarse"):
        x, hh = synthetic_profile(20e-3, 5e-3, 20.0, 1.5, length=4.0, spacing=2e-3)
        estimate_surface(hh, 2e-3, height_unit="mm")
    with pytest.raises(ValueError, match="asperities"):
        estimate_surface(np.r_[np.zeros(50), 1.0, np.zeros(50)], 1e-3)


def test_synthetic_profile_rejects_impossible_geometry():
    with pytest.raises(ValueError, match="overlap"):
        synthetic_profile(20e-3, 30e-3, 20.0, 1.5, length=1.0, spacing=1e-3)
    with pytest.raises(ValueError, match="D >= 1"):
        synthetic_profile(20e-3, 5e-3, 20.0, 0.5, length=1.0, spacing=1e-3)
