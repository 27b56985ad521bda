r"""Surface factors from a measured 1-D profile (paper section 7.4, Figs 65, 68, 89, 90).

`estimate_surface(heights, spacing)` returns $H_{max}$, the mean asperity radius $R$,
the asperity density $z$ and the distribution factor $D$ of Table 10, hence
$\xi = D (R/H_{max}) z L_u$:

- $H_{max}$: highest tip minus lowest valley of the profile.
- asperities: local maxima whose prominence exceeds `min_prominence` (default 5 % of
  $H_{max}$); $z$ = their number per mm.
- $R$: each tip is cut at a small depth $x$ (`cut_depth`, default 2 % of $H_{max}$);
  from the width $y$ of the cross-section, $R = y^2/(8x) + x/2$ (the paper's
  $R \approx y^2/8x$ plus the exact-chord term $x/2$, negligible as $x \to 0$); mean over
  the tips whose cut stays inside the asperity.
- $D$: slope of the distribution function $\phi(x)$ = fraction of tips within depth x
  of the highest tip, near $x = 0$ (least-squares line over the upper `fit_fraction` of
  tips), times $H_{max}$ (eq 16, 29).

This is data preparation, done once in NumPy (not traced). Profiles in um or mm
(`height_unit`), spacing in mm or um (`length_unit`); results in mm and 1/mm.
`synthetic_profile` builds Kragelskii rod-model profiles (Fig 71: rods with
hemispherical caps, tips linearly distributed in depth, section 7.2.2) with known
factors, for tests and examples.
"""

from __future__ import annotations

import equinox as eqx
import numpy as np

from .surfaces import UNIT_LENGTH, Surface

_TO_MM = {"mm": 1.0, "um": 1e-3, "µm": 1e-3, "micron": 1e-3, "nm": 1e-6}


def _factor(unit: str, what: str) -> float:
    try:
        return _TO_MM[unit]
    except KeyError:
        raise ValueError(f"{what}: unknown unit {unit!r}; use one of {', '.join(_TO_MM)}") from None


class SurfaceEstimate(eqx.Module):
    """Estimated surface factors (mm, mm, 1/mm, -) and the number of asperities used."""

    H_max: float
    R: float
    z: float
    D: float
    n_asperities: int = eqx.field(static=True)
    n_radius: int = eqx.field(static=True)

    @property
    def xi(self) -> float:
        """Coefficient of surface topography xi = D (R/H_max) z L_u (L_u = 1 mm)."""
        return self.D * self.R / self.H_max * self.z * UNIT_LENGTH

    def surface(self) -> Surface:
        return Surface(H_max=self.H_max, R=self.R, z=self.z, D=self.D)


def _peaks(h: np.ndarray, min_prominence: float) -> np.ndarray:
    """Indices of local maxima with prominence >= min_prominence (plateau-safe)."""
    n = h.size
    cand = np.nonzero((h[1:-1] > h[:-2]) & (h[1:-1] >= h[2:]))[0] + 1
    keep = []
    for i in cand:
        higher_left = np.nonzero(h[:i] > h[i])[0]
        lo = higher_left[-1] if higher_left.size else 0
        higher_right = np.nonzero(h[i + 1 :] > h[i])[0]
        hi = i + 1 + higher_right[0] if higher_right.size else n - 1
        base = max(h[lo : i + 1].min(), h[i : hi + 1].min())
        if h[i] - base >= min_prominence:
            keep.append(i)
    return np.asarray(keep, dtype=int)


def _crossing(h: np.ndarray, i: int, level: float, step: int) -> float | None:
    """Fractional index where the profile first falls below `level` walking from tip i."""
    j = i
    n = h.size
    while 0 <= j + step < n:
        nxt = j + step
        if h[nxt] > h[i]:
            return None  # reached a higher asperity first
        if h[nxt] < level:
            frac = (h[j] - level) / (h[j] - h[nxt])
            return j + step * frac
        j = nxt
    return None


def estimate_surface(heights, spacing: float, *, height_unit: str = "um", length_unit: str = "mm",
                     cut_depth: float | None = None, min_prominence: float | None = None,
                     fit_fraction: float = 0.5) -> SurfaceEstimate:
    """Estimate H_max, R, z, D (Table 10) from a profile sampled every `spacing`.

    `heights` 1-D, in `height_unit`; `spacing` in `length_unit`; `cut_depth` and
    `min_prominence` in `height_unit` (defaults 2 % and 5 % of H_max). Raises
    `ValueError` for profiles that are not 1-D, too short, constant, non-finite, too
    coarse to resolve the tips, or with fewer than 3 asperities.
    """
    hu, lu = _factor(height_unit, "height_unit"), _factor(length_unit, "length_unit")
    h = np.asarray(heights, dtype=float)
    if h.ndim != 1:
        raise ValueError(f"estimate_surface: heights must be 1-D, got shape {h.shape}")
    if h.size < 16:
        raise ValueError(f"estimate_surface: profile too short ({h.size} samples; need at least 16)")
    if not np.all(np.isfinite(h)):
        bad = int(np.count_nonzero(~np.isfinite(h)))
        raise ValueError(f"estimate_surface: profile has {bad} NaN/inf samples; remove or interpolate them")
    if not (np.isfinite(spacing) and spacing > 0):
        raise ValueError(f"estimate_surface: spacing must be finite and > 0, got {spacing}")
    h = h * hu  # mm
    dx = spacing * lu  # mm
    H_max = float(h.max() - h.min())
    if H_max <= 0.0:
        raise ValueError("estimate_surface: profile is constant (H_max = 0); nothing to estimate")
    prom = 0.05 * H_max if min_prominence is None else min_prominence * hu
    cut = 0.02 * H_max if cut_depth is None else cut_depth * hu
    if not 0.0 < fit_fraction <= 1.0:
        raise ValueError(f"estimate_surface: fit_fraction must be in (0, 1], got {fit_fraction}")
    peaks = _peaks(h, prom)
    if peaks.size < 3:
        raise ValueError(
            f"estimate_surface: found {peaks.size} asperities (need >= 3); profile too short "
            "or min_prominence too large")
    length = dx * (h.size - 1)
    z = peaks.size / length

    radii, widths = [], []
    for i in peaks:
        lvl = h[i] - cut
        left = _crossing(h, i, lvl, -1)
        right = _crossing(h, i, lvl, +1)
        if left is None or right is None:
            continue
        y = (right - left) * dx
        widths.append((right - left))
        radii.append(y**2 / (8.0 * cut) + cut / 2.0)
    if len(radii) < 3:
        raise ValueError("estimate_surface: could not cut 3 asperity tips at cut_depth; lower cut_depth")
    if np.median(widths) < 4.0:
        raise ValueError(
            f"estimate_surface: tips are only {np.median(widths):.1f} samples wide at cut_depth; "
            "the profile is too coarse (reduce spacing) or raise cut_depth")
    R = float(np.mean(radii))

    tips = np.sort(h[peaks].max() - h[peaks])  # depth of each tip below the highest, ascending
    n = tips.size
    phi = np.arange(1, n + 1) / n
    k = max(3, int(np.ceil(fit_fraction * n)))
    slope = np.polyfit(tips[:k], phi[:k], 1)[0]
    D = float(slope * H_max)
    return SurfaceEstimate(H_max=H_max, R=R, z=float(z), D=D, n_asperities=int(n), n_radius=len(radii))


def synthetic_profile(H_max, R, z, D, length, spacing, *, seed: int = 0):
    """Rod-model profile (mm) of Fig 71: asperities at pitch 1/z, each a rod with a
    hemispherical cap of radius R, tip depths below the highest tip spread uniformly
    (stratified, random order) over [0, H_max/D] (phi = D x/H_max, section 7.2.2),
    standing on a floor H_max below the highest tip. Needs D >= 1 and 2R < 1/z.
    Returns (x, heights), both in mm.
    """
    if D < 1.0:
        raise ValueError("synthetic_profile: needs D >= 1 so every tip lies above the floor")
    pitch = 1.0 / z
    if 2.0 * R >= pitch:
        raise ValueError(f"synthetic_profile: caps overlap (2R = {2 * R} mm >= pitch 1/z = {pitch} mm)")
    rng = np.random.default_rng(seed)
    n = int(round(length * z))
    depth = (rng.permutation(n) + rng.uniform(0.0, 1.0, n)) / n * (H_max / D)
    depth[np.argmin(depth)] = 0.0
    x = np.arange(0.0, n * pitch, spacing)
    centres = (np.arange(n) + 0.5) * pitch
    h = np.full_like(x, -H_max)
    idx = np.clip(np.round(x / pitch - 0.5).astype(int), 0, n - 1)
    d = x - centres[idx]
    inside = np.abs(d) <= R
    cap = -depth[idx] - (R - np.sqrt(np.maximum(R**2 - d**2, 0.0)))
    h = np.where(inside, np.maximum(cap, -H_max), h)
    return x, h
