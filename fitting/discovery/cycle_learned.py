r"""Beyond the library, on the per-cycle base: a learned correction over the cycle phase.

When no effect family explains the residual (`cycle_workflow`: "unexplained"), the
per-cycle model gets an additive correction of the gauge reading learned from the data,
a smooth function of where in its cycle each sample lies:

$$x_\mathrm{model}(t) + A_w\,g_\mathrm{stick}(\phi) + g_\mathrm{stick}^0(\phi)
  + A_w\,g_\mathrm{slip}(\psi),$$

with the stick phase $\phi = (t - t_e)/T_1 \in [0, 1]$ (measured slip end $t_e$, stick
time $T_1$), the slip phase $\psi = (t - t_e - T_1)\omega_0/\pi$ (0 at the measured
breakaway, 1 a single slip later) and the window's climb $A_w = v T_1$ (mm): a pattern
that scales with the cycle (a spring law, a slip shape) and one that does not (a creep,
a gauge artefact). Each $g$ is a cubic B-spline, so the correction is linear: fitted
with the base parameters by one Gauss-Newton step from the base optimum.

Nothing here is a physical law: the answer is **where** the gap lies (`signature`) and
**how much of it** a smooth phase-locked term closes (`closes`: the share of the gap's
excess over the noise); what it cannot close is not locked to the cycle (coloured noise,
irregular slips, a drift between cycles). Units: mm and s.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from stickslip_jax.units import G_MM_S2

from .cycle_model import per_sample

__all__ = ["CycleLearned", "SLIP_KNOTS", "STICK_KNOTS", "fit_cycle_correction",
           "phase_coordinates"]

STICK_KNOTS = 8
"""Coefficients of each stick-phase spline (cubic, equally spaced on [0, 1])."""

SLIP_KNOTS = 6
"""Coefficients of the slip-phase spline (cubic, equally spaced on [0, `SLIP_SPAN`])."""

SLIP_SPAN = 1.5
"""The slip phase the slip spline covers (single slips end at 1; a longer slip is a
damped or lengthened one); samples beyond it get no slip correction."""

SMOOTHING = 1.0
"""Weight of the P-spline penalty (module doc of `fit_cycle_correction`): a second
difference of one noise unit costs like this many samples."""


def phase_coordinates(data) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per masked sample of `data`: the stick phase phi, the slip phase psi and the
    window's climb A_w = v T1 (mm)."""
    start, T1, speed, k, w = per_sample(data, "start_time", "stick_time", "speed",
                                        "stiffness", "weight")
    since = np.asarray(data.time)[np.asarray(data.mask)] - start
    stick = np.maximum(T1, 1e-12)
    psi = (since - stick) * np.sqrt(k * G_MM_S2 / w) / np.pi
    return since / stick, psi, speed * stick


def _bspline_columns(x: np.ndarray, n_coef: int, lo: float, hi: float) -> np.ndarray:
    """Cubic B-spline basis (clamped, equally spaced knots) on [lo, hi] at x; zero outside."""
    from scipy.interpolate import BSpline

    degree = 3
    inner = np.linspace(lo, hi, n_coef - degree + 1)
    knots = np.r_[[lo] * degree, inner, [hi] * degree]
    inside = (x >= lo) & (x <= hi)
    out = np.zeros((x.size, n_coef))
    if inside.any():
        out[inside] = BSpline.design_matrix(np.clip(x[inside], lo, hi), knots,
                                            degree).toarray()
    return out


def correction_columns(phi, psi, climb) -> tuple[np.ndarray, list[str]]:
    """The correction's columns in mm per unit coefficient (module doc) and their labels."""
    stick = (phi >= 0) & (psi < 0)
    b_stick = _bspline_columns(np.where(stick, phi, -1.0), STICK_KNOTS, 0.0, 1.0)
    b_slip = _bspline_columns(np.where(psi >= 0, psi, -1.0), SLIP_KNOTS, 0.0, SLIP_SPAN)
    cols = np.hstack([b_stick * climb[:, None], b_stick * 1e-3, b_slip * climb[:, None]])
    labels = ([f"stick_scaled[{i}]" for i in range(STICK_KNOTS)]
              + [f"stick_fixed[{i}]" for i in range(STICK_KNOTS)]
              + [f"slip_scaled[{i}]" for i in range(SLIP_KNOTS)])
    return cols, labels


@dataclasses.dataclass(frozen=True)
class CycleLearned:
    """The learned phase correction of the per-cycle base (module doc); gaps in mm."""

    gap_before: float
    gap_after: float
    noise: float
    n_parameters: int
    signature: str
    profile: dict
    median_climb: float = 0.0
    """The campaign's median window climb v T1 (mm), at which `correction_at` evaluates
    the scaled parts."""

    def correction_at(self) -> tuple[np.ndarray, np.ndarray]:
        """The correction (mm) at the median climb over the cycle: x = stick phase on
        [0, 1], then 1 + slip phase."""
        p = self.profile
        stick = (np.asarray(p["stick_fixed_mm"])
                 + self.median_climb * np.asarray(p["stick_per_mm_of_climb"]))
        slip = self.median_climb * np.asarray(p["slip_per_mm_of_climb"])
        return (np.r_[p["stick_phase"], 1.0 + np.asarray(p["slip_phase"])],
                np.r_[stick, slip])

    @property
    def closes(self) -> float:
        excess = self.gap_before - self.noise
        return float((self.gap_before - self.gap_after) / excess) if excess > 0 else 0.0

    def to_json(self) -> dict:
        return {"gap_before": self.gap_before, "gap_after": self.gap_after, "gap_unit": "mm",
                "closes": self.closes, "n_parameters": self.n_parameters,
                "signature": self.signature, "basis": "cubic B-splines over the stick phase "
                "(scaled by the window's climb, and fixed) and the slip phase (scaled)",
                "profile_mm": self.profile}


def _profile(coef, n_grid: int = 31) -> dict:
    """The fitted correction on a phase grid (scaled parts in mm per mm of climb)."""
    grid = np.linspace(0.0, 1.0, n_grid)
    slip_grid = np.linspace(0.0, SLIP_SPAN, n_grid)
    bs = _bspline_columns(grid, STICK_KNOTS, 0.0, 1.0)
    bl = _bspline_columns(slip_grid, SLIP_KNOTS, 0.0, SLIP_SPAN)
    s_scaled = bs @ coef[:STICK_KNOTS]
    s_fixed = bs @ coef[STICK_KNOTS:2 * STICK_KNOTS] * 1e-3
    slip = bl @ coef[2 * STICK_KNOTS:]
    return {"stick_phase": grid.tolist(), "stick_per_mm_of_climb": s_scaled.tolist(),
            "stick_fixed_mm": s_fixed.tolist(), "slip_phase": slip_grid.tolist(),
            "slip_per_mm_of_climb": slip.tolist()}


def fit_cycle_correction(data, r0: np.ndarray, Jb: np.ndarray, sd: np.ndarray,
                         noise: float, use: np.ndarray | None = None,
                         samples=None) -> CycleLearned:
    """Fit the phase correction with the base parameters (module doc) from the base
    fit's whitened residuals `r0` and Jacobian `Jb` (standard errors `sd`, mm); `noise`
    (mm); `use`: the residuals the gaps are over (default all); `samples`: what each
    residual stands for (`thinning.Samples`)."""
    from scipy.linalg import block_diag

    from .decision import rms_gap

    phi, psi, climb = phase_coordinates(data)
    if phi.size != r0.size:
        raise ValueError(f"fit_cycle_correction: {phi.size} masked samples in the data, "
                         f"{r0.size} residuals")
    cols, _ = correction_columns(phi, psi, climb)
    a_med = float(np.median(climb))
    A = np.hstack([Jb, cols / sd[:, None]])
    # P-spline smoothness: second differences of each spline's coefficients, in units of
    # the noise at the median climb, cost like `SMOOTHING` samples (a sparsely sampled end
    # of the slip phase otherwise takes wild values)
    scaled_unit = noise / max(a_med, 1e-12)  # mm per mm of climb; the fixed part in um
    blocks = [np.diff(np.eye(size), 2, axis=0) / unit for size, unit in
              ((STICK_KNOTS, scaled_unit), (STICK_KNOTS, noise / 1e-3), (SLIP_KNOTS, scaled_unit))]
    pen = np.hstack([np.zeros((sum(b.shape[0] for b in blocks), Jb.shape[1])),
                     np.sqrt(SMOOTHING) * block_diag(*blocks)])
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    beta = np.linalg.lstsq(np.vstack([A, pen]) / scale, np.r_[r0, np.zeros(len(pen))],
                           rcond=1e-10)[0] / scale
    r1 = r0 - A @ beta
    coef = beta[Jb.shape[1]:]
    used = np.any(cols != 0, axis=0)
    use = np.ones(r0.size, bool) if use is None else np.asarray(use, bool)
    part = None if samples is None else samples[use]
    gap_before = rms_gap(r0[use], sd[use], part)
    gap_after = rms_gap(r1[use], sd[use], part)
    profile = _profile(coef)
    # where the correction (in mm, at the campaign's median climb) is largest
    corr = cols @ coef
    parts = {"in the stick, early (phase 0-0.5)": (phi >= 0) & (phi < 0.5) & (psi < 0),
             "in the stick, late (phase 0.5-1, before breakaway)": (phi >= 0.5) & (psi < 0),
             "in the slip": (psi >= 0) & (psi <= 1.0),
             "after the slip (phase 1-1.5: settling)": (psi > 1.0)}
    rms = {k: float(np.sqrt(np.mean(corr[s] ** 2))) if s.any() else 0.0
           for k, s in parts.items()}
    where = max(rms, key=rms.get)
    signature = (f"the correction is largest {where} (RMS {rms[where] * 1e3:.3g} um; "
                 f"median climb {a_med * 1e3:.3g} um)")
    return CycleLearned(gap_before=gap_before, gap_after=gap_after, noise=float(noise),
                        n_parameters=int(used.sum()), signature=signature, profile=profile,
                        median_climb=a_med)
