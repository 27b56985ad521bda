"""The problems discovery fits over flat coordinates: `AbstractProblem` (its `solve` is
the one place discovery calls the solver), `SubProblem`, `SharedScrewProblem`; the
smoothed base's is `model.Problem`."""

from __future__ import annotations

import abc
import dataclasses

import numpy as np
import optimistix as optx

from stickslip_jax.lsq import (HostResiduals, LeastSquaresSolution, Stall,
                               gauss_newton_decrease, least_squares)

from .cycle_effects import Shape
from .cycle_model import CycleModel

__all__ = ["HOPE", "SHAPE_FIELDS", "AbstractProblem", "SharedScrewProblem", "SubProblem",
           "with_shape"]

HOPE = 4.0
"""A fit with a `target` stops once its best point, lowered by this many times the
Gauss-Newton decrease predicted there, stays above the target (from the `HOPE_AFTER`-th
evaluation: the first steps from a bent start gain more than the linear model says)."""
HOPE_AFTER = 4
PACE = 2.0
"""A fit with a `target` also stops once its best point, lowered by this many times its
recent pace (its best chi-square's drop per evaluation over the last `PACE_WINDOW`)
over every evaluation its budget leaves, stays above the target (from the
`PACE_AFTER`-th evaluation): far from the data the Gauss-Newton decrease keeps promising
more than the fit gains, and a fit that gains at a slowing pace cannot reach a target
that even twice its pace misses."""
PACE_WINDOW = 4
PACE_AFTER = 8

SHAPE_FIELDS = {"viscous_damping": ("damping",), "stribeck": ("vs", "p", "form"),
                "rate_state": ("length",), "drive_periodic_error": ("pitch",),
                "sensor_lowpass": ("order", "zeta")}
"""The `Shape` settings each family owns: one `Shape` holds every family's, so the
effects named keep theirs while another family's are scanned (`with_shape`)."""


def with_shape(held: Shape, fam, shape: Shape) -> Shape:
    """`held` with the settings of family `fam` taken from `shape` (`SHAPE_FIELDS`)."""
    fields = SHAPE_FIELDS.get(fam.name, ())
    return dataclasses.replace(held, **{k: getattr(shape, k) for k in fields})


class AbstractProblem(abc.ABC):
    """A model over flat coordinates z: `evaluate(z)` -> (whitened residuals, Jacobian
    [N, P], whether the model ran), `active()` the coordinates the fit moves (None: all)."""

    @abc.abstractmethod
    def evaluate(self, z) -> tuple[np.ndarray, np.ndarray, bool]:
        """Residuals, Jacobian and success at z."""

    def active(self) -> np.ndarray | None:
        return None

    def solve(self, z0, *, max_evals: int = 25, chi2_tol: float = 0.05, first=None,
              lam0: float = 1e-3, stall_evals: int = 4, stall_tol: float = 0.5,
              target: float | None = None) -> LeastSquaresSolution:
        """The fit from z0 over `active()` (`lsq.least_squares`): converged when the
        Gauss-Newton step would lower the cost by less than `chi2_tol`, when the last
        `stall_evals` accepted steps lowered it by < `stall_tol` together, or where no
        step can; else after `max_evals` evaluations. `first`: (r, J, ok) at z0; a small
        `lam0` suits a start where the quadratic model is trusted (a score step).
        `target`: a chi-square worth reaching; the fit stops at its best point once it
        cannot (`HOPE`, `PACE`; `stats["hopeless"]` True)."""
        watch = _Watch(self.evaluate, target, first, z0, max_evals)
        try:
            return least_squares(HostResiduals(watch if target is not None else self.evaluate,
                                               first), z0, self.active(), rtol=0.0,
                                 atol=chi2_tol, max_steps=max_evals, lam0=lam0,
                                 stall=Stall(stall_evals, stall_tol))
        except _Hopeless:
            return LeastSquaresSolution(
                watch.z, optx.RESULTS.nonlinear_max_steps_reached,
                dict(num_steps=watch.n, lam=lam0, history=[], ok=watch.ok, cost=watch.cost,
                     hopeless=True), residuals=watch.r, jacobian=watch.J)


class _Hopeless(Exception):
    """A watched fit cannot reach its target (`_Watch`)."""


class _Watch:
    """An `evaluate` that keeps the fit's best point and raises `_Hopeless` (`HOPE`,
    `PACE`; `budget`: the fit's evaluations)."""

    def __init__(self, evaluate, target, first, z0, budget):
        self.evaluate, self.target, self.n, self.budget = evaluate, target, 0, budget
        self.cost, self.floor = np.inf, -np.inf
        self.z = self.r = self.J = None
        self.ok = False
        self.costs = []  # the best chi-square after each evaluation (the start's first)
        if first is not None:
            self._keep(np.array(z0, float), *first)
            self.costs.append(self.cost)

    def _keep(self, z, r, J, ok):
        usable = ok and np.all(np.isfinite(r)) and np.all(np.isfinite(J))
        cost = float(r @ r) if usable else np.inf  # a point the solver itself would accept
        if cost < self.cost:
            self.z, self.r, self.J, self.ok, self.cost = z, r, J, ok, cost
            J = np.asarray(J)
            with np.errstate(over="ignore", invalid="ignore"):  # judged finite below
                A, g = J.T @ J, J.T @ np.asarray(r)
            self.floor = -np.inf  # no judgement where the linear model is not finite
            if np.all(np.isfinite(A)) and np.all(np.isfinite(g)):
                try:
                    self.floor = cost - HOPE * float(gauss_newton_decrease(A, g, xp=np))
                except np.linalg.LinAlgError:
                    pass

    def __call__(self, z):
        r, J, ok = self.evaluate(z)
        self.n += 1
        self._keep(np.array(z, float), r, J, ok)
        self.costs.append(self.cost)
        if (self.n >= HOPE_AFTER and self.z is not None and np.isfinite(self.cost)
                and (self.floor > self.target or self._slow())):
            raise _Hopeless
        return r, J, ok

    def _slow(self) -> bool:
        """`PACE`: at twice its recent pace the fit's budget cannot reach the target."""
        if self.n < PACE_AFTER or self.n >= self.budget or len(self.costs) <= PACE_WINDOW:
            return False  # the budget's last evaluation ends the fit as it is
        pace = (self.costs[-1 - PACE_WINDOW] - self.cost) / PACE_WINDOW  # inf: no judgement
        return bool(self.cost - PACE * pace * (self.budget - self.n) > self.target)


@dataclasses.dataclass
class SubProblem(AbstractProblem):
    """The per-cycle model with only `cols` of the full coordinates free."""

    model: CycleModel
    z_full: np.ndarray
    cols: np.ndarray
    shape: Shape = Shape()
    sensor: bool = False
    prior: np.ndarray | None = None  # per free coordinate: prior sd (z units), inf: none

    def full(self, z):
        out = self.z_full.copy()
        out[self.cols] = z
        return out

    def evaluate(self, z):
        r, J, ok = self.model.evaluate(self.full(z), self.cols, self.shape, self.sensor)
        if self.prior is None:
            return r, J, ok
        on = np.isfinite(self.prior)  # a Gaussian prior as extra residual rows
        rows = np.zeros((int(on.sum()), J.shape[1]))
        rows[np.arange(rows.shape[0]), np.flatnonzero(on)] = 1.0 / self.prior[on]
        return np.concatenate([r, np.asarray(z)[on] / self.prior[on]]), np.vstack([J, rows]), ok

    def without_effect(self, z, k) -> np.ndarray:
        """The free coordinates `z` with the family's effect taken out (its `k`
        coordinates, the last, at 0)."""
        w = np.array(z, float)
        w[w.size - k:] = 0.0
        return w

    def family_columns(self, J, k) -> np.ndarray:
        """The family's columns (the last `k` free coordinates) of a Jacobian `J`."""
        return np.asarray(J)[:, J.shape[1] - k:]

    def family_part(self, z, cov, k):
        """The last `k` model coordinates (the family's) at the free coordinates `z`, and
        their covariance from the free coordinates' `cov` (None: not computed)."""
        return np.asarray(z)[-k:], (None if cov is None else cov[-k:, -k:])


@dataclasses.dataclass
class SharedScrewProblem(SubProblem):
    """The screw error with one amplitude per harmonic and a phase per record (one lead
    screw, records starting at different places on it): free coordinates are the base's
    `n_base`, then A1, A2 (scale units) and the G first- then G second-harmonic phases
    (rad); `cols`: base, then the family's 4 per record (a1_sin = A1 cos phi1, ...)."""

    n_base: int = 0

    def _coef(self, w):
        w = np.asarray(w, float)
        G = (w.size - 2) // 2
        a1, a2, p1, p2 = w[0], w[1], w[2:2 + G], w[2 + G:]
        coef = np.stack([a1 * np.cos(p1), a1 * np.sin(p1), a2 * np.cos(p2),
                         a2 * np.sin(p2)], axis=1).ravel()
        D = np.zeros((4 * G, w.size))
        for g in range(G):
            D[4 * g + 0, 0], D[4 * g + 0, 2 + g] = np.cos(p1[g]), -a1 * np.sin(p1[g])
            D[4 * g + 1, 0], D[4 * g + 1, 2 + g] = np.sin(p1[g]), a1 * np.cos(p1[g])
            D[4 * g + 2, 1], D[4 * g + 2, 2 + G + g] = np.cos(p2[g]), -a2 * np.sin(p2[g])
            D[4 * g + 3, 1], D[4 * g + 3, 2 + G + g] = np.sin(p2[g]), a2 * np.cos(p2[g])
        return coef, D

    def _model_z(self, z):
        z = np.asarray(z, float)
        return np.concatenate([z[:self.n_base], self._coef(z[self.n_base:])[0]])

    def full(self, z):
        return super().full(self._model_z(z))

    def evaluate(self, z):
        r, J, ok = self.model.evaluate(self.full(z), self.cols, self.shape, self.sensor)
        _, D = self._coef(np.asarray(z)[self.n_base:])
        return r, np.hstack([J[:, :self.n_base], J[:, self.n_base:] @ D]), ok

    def family_columns(self, J, k) -> np.ndarray:
        return np.asarray(J)[:, self.n_base:]

    def without_effect(self, z, k) -> np.ndarray:
        """Amplitudes at 0, the records' phases kept."""
        w = np.array(z, float)
        w[self.n_base:self.n_base + 2] = 0.0
        return w

    def family_part(self, z, cov, k):
        _, D = self._coef(np.asarray(z)[self.n_base:])
        vals = self._model_z(z)[-k:]
        if cov is None:
            return vals, None
        return vals, D @ cov[self.n_base:, self.n_base:] @ D.T

    @staticmethod
    def start(coef, G):
        """Free screw coordinates from per-record coefficients (z units, 4 per record):
        the median amplitudes of the records that have any, and each record's phases."""
        c = np.asarray(coef, float).reshape(G, 4)
        amp1, amp2 = np.hypot(c[:, 0], c[:, 1]), np.hypot(c[:, 2], c[:, 3])
        a1 = float(np.median(amp1[amp1 > 0])) if np.any(amp1 > 0) else 1.0
        a2 = float(np.median(amp2[amp2 > 0])) if np.any(amp2 > 0) else 0.1 * a1
        return np.concatenate([[a1, a2], np.arctan2(c[:, 1], c[:, 0]),
                               np.arctan2(c[:, 3], c[:, 2])])
