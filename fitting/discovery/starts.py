"""Starts of the per-cycle discovery's fits (`cycle_workflow`): the features' friction
moved where the per-cycle model runs (`plausible_start`), and a restart's kinetic friction
lifted off zero (`lift_mu_d`)."""

from __future__ import annotations

import numpy as np

from .options import DEFAULTS

__all__ = ["lift_mu_d", "plausible_start"]


def plausible_start(logs, stick_times, slip_times) -> np.ndarray:
    """The features' six `EmpiricalFriction` logs moved where the per-cycle model runs:
    parameters the features cannot determine may wander far (real records: m -> 0, delta
    2e12, n 1e116, so no slip ends; a strong Stribeck campaign: mu_s - mu_d 9e5 with gamma
    5e-8). An exponent outside `DiscoveryOptions.exponents` starts at 1; gamma T1^m and
    delta T2^n keep what the records measure at the median stick and slip times (s), with
    exp(-gamma T1^m) in [0.02, 0.98] and exp(-delta T2^n) in [0.02, 0.9] (a kinetic
    friction within 10 % of the breakaway level leaves no slip that ends); mu_s - mu_d
    keeps eq (1)'s rise mu_0(T1) - mu_d at the median stick time."""
    z = np.asarray(logs, float).copy()
    lgap, lg, lm, ld, ln = (float(v) for v in z[1:6])
    T1 = float(np.nanmedian(stick_times[stick_times > 0])) if np.any(stick_times > 0) else 1.0
    T2 = float(np.median(slip_times))
    out = []
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for l_coef, l_exp, T, q_max in ((lg, lm, T1, 0.98), (ld, ln, T2, 0.9)):
            lo, hi = np.log(-np.log(q_max)), np.log(-np.log(0.02))
            e = float(np.exp(l_exp))
            e1 = e if DEFAULTS.exponents[0] <= e <= DEFAULTS.exponents[1] else 1.0
            a = l_coef + e * np.log(T)  # log(coefficient T^exponent)
            a1 = float(np.clip(np.nan_to_num(a, nan=0.0, posinf=hi, neginf=lo), lo, hi))
            out.append((a1 - e1 * np.log(T), np.log(e1), a, a1))
        (lg1, lm1, a, a1), (ld1, ln1, _, _) = out
        # the rise (mu_s - mu_d)(1 - exp(-gamma T1^m)) at the median stick time
        rise = float(np.exp(lgap) * -np.expm1(-np.exp(a)))
        if np.isfinite(rise) and rise > 0:
            lgap = float(np.log(rise / -np.expm1(-np.exp(a1))))
    z[1:6] = [lgap, lg1, lm1, ld1, ln1]
    return z


def lift_mu_d(logs) -> np.ndarray:
    """The six friction logs with mu_d lifted to `mu_d_lift` x mu_s (mu_s kept) when below
    `mu_d_floor` x mu_s: a fit that drove mu_d towards 0 (a Stribeck drop of 0.2 on A:
    mu_d 1e-13) has no gradient left in log mu_d to bring it back once the effect is added."""
    z = np.asarray(logs, float).copy()
    mu_d, gap = np.exp(z[0]), np.exp(z[1])
    mu_s = mu_d + gap
    floor, lift = DEFAULTS.mu_d_floor, DEFAULTS.mu_d_lift
    if mu_d < floor * mu_s:
        z[0], z[1] = np.log(lift * mu_s), np.log((1.0 - lift) * mu_s)
    return z
