r"""Mean kinetic friction during the slip, the paper's eq (3)."""

from __future__ import annotations

import abc

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ..numerics import as_float, safe_power
from .static import AbstractStaticFriction, Scalar


class AbstractKineticFriction(eqx.Module):
    r"""Base class of mean-kinetic-friction laws $\mu_m(\mu_0, \mu_d, T_2)$."""

    @abc.abstractmethod
    def __call__(self, mu_0: Float[ArrayLike, "..."], mu_d: Float[ArrayLike, "..."],
                 slip_time: Float[ArrayLike, "..."]) -> Float[Array, "..."]:
        """Mean kinetic friction coefficient of a slip of `slip_time` s that began at `mu_0`."""


class KatoKinetic(AbstractKineticFriction):
    r"""Eq (3): $\mu_m = \mu_d + (\mu_0 - \mu_d)\exp(-\delta T_2^n)$.

    `delta` in s$^{-n}$, `n` dimensionless, $T_2$ in s; $\mu_d$ is shared with the static
    law (the paper's assumption). Table 6 gives `delta`, `n` for lubricants A and C.
    """

    delta: Scalar = eqx.field(converter=as_float)
    n: Scalar = eqx.field(converter=as_float)

    def __call__(self, mu_0, mu_d, slip_time):
        t2 = jnp.asarray(slip_time, dtype=float)
        return mu_d + (mu_0 - mu_d) * jnp.exp(-self.delta * safe_power(t2, self.n))


class Friction(eqx.Module):
    r"""A slideway's friction: a static law $\mu_0(T_1)$ and a kinetic law $\mu_m$ (eq 3).

    `mean_kinetic(stick_time, slip_time)` is eq (4) for the Kato laws.
    """

    static: AbstractStaticFriction
    kinetic: AbstractKineticFriction

    def __check_init__(self):
        if not isinstance(self.static, AbstractStaticFriction):
            raise ValueError(f"static must be a static-friction law, got {type(self.static)}")
        if not isinstance(self.kinetic, AbstractKineticFriction):
            raise ValueError(f"kinetic must be a kinetic-friction law, got {type(self.kinetic)}")

    @property
    def mu_d(self) -> Scalar:
        return self.static.mu_d

    def mean_kinetic(self, stick_time, slip_time):
        r"""Eq (4): $\mu_m$ after a stick of $T_1$ s and a slip of $T_2$ s."""
        return self.kinetic(self.static(stick_time), self.static.mu_d, slip_time)

    def drop(self, stick_time, slip_time):
        r"""$\mu_0(T_1) - \mu_m$: the friction drop that sets the amplitude (eq 5)."""
        mu_0 = self.static(stick_time)
        return mu_0 - self.kinetic(mu_0, self.static.mu_d, slip_time)
