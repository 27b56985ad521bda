r"""Logarithmic aging of static friction with a velocity-weakening kinetic friction.

Static friction grows with the logarithm of the stick time (Dieterich 1972, J. Geophys.
Res. 77, 3690; Rabinowicz, "Friction and wear of materials", 1965):
$\mu_0(T_1) = \mu_d + \beta\ln(1 + T_1/t_c)$, unbounded but slow for $T_1 \gg t_c$.
The kinetic friction falls with the logarithm of the sliding speed (the same sources):
$\mu_k(v) = \mu_d - c\ln(1 + |v|/v_c)$, equal to $\mu_d$ (the static level at
$T_1 = 0$) at rest. Units: $T_1$, $t_c$ in s; $v$, $v_c$ in mm/s; $\mu$, $\beta$, $c$
dimensionless.

The smoothed simulator (`stickslip_jax.simulation.simulate_smooth`) applies $\mu_k$ at the
slider's velocity through `AbstractVelocityKinetic.at_velocity`; the mean-kinetic interface
(`__call__`, used by the per-cycle tables and the exact simulator) returns its level at
$v = v_c$, a constant stand-in for the slip-averaged friction.
"""

from __future__ import annotations

import abc

import equinox as eqx
import jax.numpy as jnp

from ..numerics import as_float
from .kinetic import AbstractKineticFriction
from .static import AbstractStaticFriction, Scalar


class LogAgingStatic(AbstractStaticFriction):
    r"""$\mu_0(T_1) = \mu_d + \beta\ln(1 + T_1/t_c)$ (module docstring); `beta`
    dimensionless, `t_c` in s. `asymptote()` is $\mu_0$ at $T_1 = 10^{12}$ s."""

    mu_d: Scalar = eqx.field(converter=as_float)
    beta: Scalar = eqx.field(converter=as_float)
    t_c: Scalar = eqx.field(converter=as_float)

    def __call__(self, stick_time):
        t = jnp.maximum(jnp.asarray(stick_time, dtype=float), 0.0)
        return self.mu_d + self.beta * jnp.log1p(t / self.t_c)


class AbstractVelocityKinetic(AbstractKineticFriction):
    """A kinetic-friction law of the slider velocity, applied at every instant by the
    smoothed simulator (`at_velocity`)."""

    @abc.abstractmethod
    def at_velocity(self, velocity, mu_0, mu_d):
        """Kinetic friction coefficient at the slider velocity `velocity` (mm/s) of a slip
        that began at `mu_0`."""


class LogVelocityKinetic(AbstractVelocityKinetic):
    r"""$\mu_k(v) = \mu_d - c\ln(1 + |v|/v_c)$ (module docstring); `c` dimensionless,
    `v_c` in mm/s. The mean-kinetic interface gives $\mu_k(v_c)$."""

    c: Scalar = eqx.field(converter=as_float)
    v_c: Scalar = eqx.field(converter=as_float)

    def at_velocity(self, velocity, mu_0, mu_d):
        return mu_d - self.c * jnp.log1p(jnp.abs(velocity) / self.v_c)

    def __call__(self, mu_0, mu_d, slip_time):
        shape = jnp.broadcast_shapes(jnp.shape(mu_0), jnp.shape(slip_time))
        return jnp.broadcast_to(self.at_velocity(self.v_c, mu_0, mu_d), shape)
