r"""Heavy-tailed likelihoods: robust losses as transformed residuals.

The project's one least-squares solver minimises $\sum_i \tilde r_i^2$. A loss $\rho$
(the negative log density of one whitened residual $r$, up to a constant) enters as the
transformed residual

$$\tilde r = \operatorname{sign}(r)\,\sqrt{2\rho(r)}, \qquad
  \sum_i \tilde r_i^2 = 2\sum_i \rho(r_i) = -2\log L + \text{const},$$

so the same Levenberg-Marquardt, Jacobian, cluster-robust covariance and emcee
log-posterior serve every loss (the "square-rooted" robust cost of Triggs et al.,
*Bundle adjustment: a modern synthesis*, 2000, sec. 4.3). The residuals are already
whitened, so the losses are in units of the noise.

Final losses: `Gaussian()` ($\rho = r^2/2$, the default); `Huber(c=1.345)` ($r^2/2$ for
$|r| \le c$, $c|r| - c^2/2$ beyond: 95 % efficiency on Gaussian noise, a residual beyond
$c$ pulls with a constant force); `StudentT(nu=4)`
($\frac{\nu+1}{2}\log(1 + r^2/\nu)$: a far outlier pulls with a force that falls as
$1/r$, for sporadic irregular slips and spikes the filter missed).

`HeavyTailed(objective, loss)` is another objective's residuals transformed; its
intervals come from the cluster-robust (sandwich) covariance, which does not assume the
loss is the true density. `parse_loss("student-t:4")` reads `--loss`.
"""

from __future__ import annotations

import abc
import math
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .combined import AbstractObjective

__all__ = ["AbstractLoss", "Gaussian", "HeavyTailed", "Huber", "LOSSES", "StudentT",
           "loss_of", "parse_loss", "with_loss"]


class AbstractLoss(eqx.Module):
    """A loss $\\rho(r)$ of whitened residuals, used through `transform` (module doc)."""

    name: ClassVar[str]

    @abc.abstractmethod
    def rho(self, r):
        """Negative log density of a whitened residual, up to a constant (rho(0) = 0)."""

    @abc.abstractmethod
    def transform(self, r):
        """sign(r) sqrt(2 rho(r)), smooth at r = 0."""

    @abc.abstractmethod
    def spec(self) -> str:
        """The loss as written on the command line (`parse_loss` reads it back)."""

    def describe(self) -> str:
        return f"{self.spec()} loss"

    def psi(self, r):
        """rho'(r), elementwise: the force a residual exerts on the fit."""
        r = jnp.asarray(r, float)
        return jax.vmap(jax.grad(self.rho))(r.ravel()).reshape(r.shape)

    def curvature(self, r):
        """rho''(r), elementwise: the residual's share of the loss's Hessian (negative
        for Student-t beyond sqrt(nu), zero for Huber beyond c)."""
        r = jnp.asarray(r, float)
        return jax.vmap(jax.grad(jax.grad(self.rho)))(r.ravel()).reshape(r.shape)

    def weights(self, r):
        """psi(r) / r, elementwise (rho''(0) at r = 0): a residual's weight in iteratively
        reweighted least squares, where a weighted Gaussian fit with these weights held
        fixed has the loss's estimating equation (Huber: min(1, c/|r|); Student-t:
        (nu + 1) / (nu + r^2))."""
        r = np.asarray(r, float)
        small = np.abs(r) < 1e-6
        safe = np.where(small, 1.0, r)
        return np.where(small, float(self.curvature(0.0)), np.asarray(self.psi(safe)) / safe)

    def score_form(self, J, r):
        """(J', r') of the M-estimator from the Jacobian `J` and residuals `r` of the
        *untransformed* objective: J'^T r' = sum_i psi(r_i) J_i (the score) and J'^T J' =
        sum_i max(rho''(r_i), 0) J_i J_i^T (the loss's Hessian), which a least-squares
        covariance turns into Huber's sandwich. The transformed residuals' Gauss-Newton
        matrix weights residual i by psi^2 / (2 rho) > rho'' (0.90 against 0.60 at one
        sd for Student-t, nu 4): too narrow (90 % coverage 0.74 / 0.79 for mu_s / mu_d on
        24 independent campaigns, tests/test_real_world_coverage.py)."""
        J, r = np.asarray(J), np.asarray(r)
        psi = np.asarray(self.psi(r))
        w = np.maximum(np.asarray(self.curvature(r)), 1e-9 * float(self.curvature(0.0)))
        root = np.sqrt(w)
        return J * root[:, None], psi / root


class Gaussian(AbstractLoss):
    """rho = r^2/2: ordinary least squares."""

    name: ClassVar[str] = "gaussian"

    def rho(self, r):
        return 0.5 * r * r

    def transform(self, r):
        return r

    def spec(self) -> str:
        return "gaussian"


class Huber(AbstractLoss):
    """rho = r^2/2 for |r| <= c, c|r| - c^2/2 beyond."""

    c: float = 1.345
    name: ClassVar[str] = "huber"

    def __check_init__(self):
        if not (self.c > 0 and math.isfinite(self.c)):
            raise ValueError(f"--loss huber: the threshold c must be positive, got {self.c}")

    def rho(self, r):
        a = jnp.abs(r)
        return jnp.where(a <= self.c, 0.5 * r * r, self.c * a - 0.5 * self.c**2)

    def transform(self, r):
        a = jnp.abs(r)
        inner = a <= self.c
        # the outer branch's argument kept off zero inside, so its gradient is finite
        outer = jnp.sqrt(jnp.where(inner, self.c**2, 2.0 * self.c * a - self.c**2))
        return jnp.where(inner, r, jnp.sign(r) * outer)

    def spec(self) -> str:
        return f"huber:{self.c:g}"


class StudentT(AbstractLoss):
    """rho = (nu+1)/2 log(1 + r^2/nu)."""

    nu: float = 4.0
    name: ClassVar[str] = "student-t"

    def __check_init__(self):
        if not (self.nu > 0 and math.isfinite(self.nu)):
            raise ValueError(f"--loss student-t: the degrees of freedom nu must be positive, "
                             f"got {self.nu}")

    def rho(self, r):
        return 0.5 * (self.nu + 1.0) * jnp.log1p(r * r / self.nu)

    def transform(self, r):
        # r * sqrt((nu+1)/nu * log1p(x)/x), x = r^2/nu; log1p(x)/x -> 1 - x/2 at x -> 0
        x = r * r / self.nu
        small = x < 1e-6
        ratio = jnp.where(small, 1.0 - 0.5 * x, jnp.log1p(x) / jnp.where(small, 1.0, x))
        return r * jnp.sqrt((self.nu + 1.0) / self.nu * ratio)

    def spec(self) -> str:
        return f"student-t:{self.nu:g}"


LOSSES: dict[str, type[AbstractLoss]] = {"gaussian": Gaussian, "huber": Huber,
                                         "student-t": StudentT}
"""Loss names of the command line (`--loss NAME[:PARAMETER]`)."""


def parse_loss(text: str) -> AbstractLoss:
    """The loss written as NAME or NAME:PARAMETER (`huber:1.345`, `student-t:4`)."""
    name, _, value = str(text).strip().partition(":")
    name = name.strip().lower().replace("_", "-")
    if name in ("t", "student", "studentt"):
        name = "student-t"
    if name not in LOSSES:
        raise ValueError(f"--loss: expected one of {', '.join(LOSSES)} (optionally "
                         f"NAME:PARAMETER, e.g. student-t:4 or huber:1.345), got {text!r}")
    if not value:
        return LOSSES[name]()
    if name == "gaussian":
        raise ValueError(f"--loss gaussian takes no parameter, got {text!r}")
    try:
        number = float(value)
    except ValueError:
        raise ValueError(f"--loss {name}: {value!r} is not a number") from None
    return LOSSES[name](number)


class HeavyTailed(AbstractObjective):
    """The residuals of `inner` through `loss.transform` (module doc); everything else
    (blocks, clusters, data, failures) is the inner objective's."""

    inner: AbstractObjective
    loss: AbstractLoss
    robust: ClassVar[bool] = True

    def __check_init__(self):
        if isinstance(self.inner, HeavyTailed):
            raise ValueError("HeavyTailed: the objective already has a loss")

    @property
    def kind(self):
        """The inner objective's (`stickslip_fitting.modes.Objective`)."""
        return self.inner.kind

    @property
    def slip_time(self):
        return self.inner.slip_time

    def residuals_and_aux(self, params, weights_at=None, slider_velocity=None):
        r, aux = self.inner.residuals_and_aux(params, weights_at, slider_velocity)
        return self.loss.transform(r), aux

    def velocity_shape(self):
        return self.inner.velocity_shape()

    def dof(self) -> float:
        return self.inner.dof()

    def blocks(self) -> dict[str, int]:
        return self.inner.blocks()

    def clusters(self, features):
        return self.inner.clusters(features)

    def describe(self) -> str:
        return f"{self.inner.describe()}, {self.loss.describe()}"

    def trace_data(self):
        return self.inner.trace_data()

    def failures(self, ok) -> int:
        return self.inner.failures(ok)


def with_loss(objective: AbstractObjective, loss: AbstractLoss | None) -> AbstractObjective:
    """`objective` under `loss` (itself for None or the Gaussian loss)."""
    if loss is None or isinstance(loss, Gaussian):
        return objective
    return HeavyTailed(objective, loss)


def loss_of(objective: AbstractObjective) -> AbstractLoss:
    """The loss `objective` is fitted under (`Gaussian()` unless it is `HeavyTailed`)."""
    return objective.loss if isinstance(objective, HeavyTailed) else Gaussian()
