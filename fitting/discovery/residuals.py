r"""Where does a fitted model disagree with the records? Residuals by phase and a
calibrated misspecification test.

`analyse_residuals(residuals, mask, sticking)` (data - model, mm, per record; the
model's sticking flags) returns a `ResidualReport`:

- **phases**: each sample is *stick*, *breakaway* (`edge` samples either side of a slip
  start), *slip* or *end of slip* (`edge` either side of a slip end); per phase the RMS,
  mean (mm) and count.
- **misspecification test**: in windows of `window` samples, white residuals give
  $F = \frac{w\sum_b \bar r_b^2 / B}{\sum (r - \bar r_b)^2/(N-B)} \sim F(B, N-B)$ (exactly
  for i.i.d. Gaussian noise; fitted parameters make it slightly conservative); smooth
  structure the model misses raises the window means. The noise need not be known; the
  p-value is calibrated on campaigns with no hidden effect (tests).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.stats

__all__ = ["PHASES", "ResidualReport", "analyse_residuals", "misspecification_test",
           "phase_labels"]

PHASES = ("stick", "breakaway", "slip", "end_of_slip")


def phase_labels(sticking: np.ndarray, edge: int = 2) -> np.ndarray:
    """Phase index (into `PHASES`) of every sample from the model's sticking flags."""
    s = np.asarray(sticking, bool)
    n = s.shape[0]
    lab = np.where(s, 0, 2)
    starts = np.flatnonzero(s[:-1] & ~s[1:]) + 1  # first slipping sample
    ends = np.flatnonzero(~s[:-1] & s[1:]) + 1  # first sticking sample after a slip
    for i in starts:
        lab[max(i - edge, 0): min(i + edge, n)] = 1
    for i in ends:
        lab[max(i - edge, 0): min(i + edge, n)] = 3
    return lab


def misspecification_test(residuals: list[np.ndarray], window: int = 5) -> dict:
    """Window-means F test (module docstring): {"F", "df1", "df2", "p_value", "window"}."""
    means, within, n_tot, n_win = [], 0.0, 0, 0
    for r in residuals:
        r = np.asarray(r, float)
        nb = r.shape[0] // window
        if nb < 1:
            continue
        blocks = r[: nb * window].reshape(nb, window)
        m = blocks.mean(axis=1)
        means.append(m)
        within += float(np.sum((blocks - m[:, None]) ** 2))
        n_tot += nb * window
        n_win += nb
    if n_win < 2:
        raise ValueError("too few samples for the misspecification test")
    between = window * float(np.sum(np.concatenate(means) ** 2))
    df1, df2 = n_win, n_tot - n_win
    F = (between / df1) / (within / df2)
    return {"F": F, "df1": df1, "df2": df2, "p_value": float(scipy.stats.f.sf(F, df1, df2)),
            "window": window}


@dataclasses.dataclass
class ResidualReport:
    """The residuals by phase and the misspecification `test` (module doc)."""

    phases: dict
    test: dict

    @property
    def p_value(self) -> float:
        return self.test["p_value"]

    def worst_phase(self) -> str:
        """The phase whose RMS exceeds the noise most (relative)."""
        return max(self.phases, key=lambda p: self.phases[p]["rms"] if self.phases[p]["n"] else 0)


def analyse_residuals(residuals, mask, sticking, *, window: int = 5, edge: int = 2
                      ) -> ResidualReport:
    """`ResidualReport` of per-record residuals (module doc)."""
    r = np.concatenate(residuals)
    ph = np.concatenate([phase_labels(np.asarray(s)[np.asarray(m)], edge)
                         for s, m in zip(sticking, mask)])
    phases = {}
    for k, name in enumerate(PHASES):
        sel = ph == k
        phases[name] = {"rms": float(np.sqrt(np.mean(r[sel] ** 2))) if sel.any() else 0.0,
                        "mean": float(np.mean(r[sel])) if sel.any() else 0.0, "n": int(sel.sum())}
    return ResidualReport(phases=phases, test=misspecification_test(residuals, window))
