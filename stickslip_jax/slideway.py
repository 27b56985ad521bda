r"""The mechanical system of Fig 5: a slider of weight W on a spring of stiffness k, with friction."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from .friction import Friction
from .units import G_MM_S2
from .numerics import as_float


class Slideway(eqx.Module):
    r"""Slider (weight `weight` W in kgf) driven through a spring (`stiffness` k in kgf/mm).

    `mass` is $M = W/g$ in kgf*s^2/mm; `omega0` $=\sqrt{gk/W}$ in rad/s; `slip_time`
    is eq (7), $T_2 = \pi/\omega_0$ in s.
    """

    friction: Friction
    weight: Float[Array, ""] = eqx.field(converter=as_float)
    stiffness: Float[Array, ""] = eqx.field(converter=as_float)

    def __check_init__(self):
        if not isinstance(self.friction, Friction):
            raise ValueError(f"friction must be a Friction, got {type(self.friction)}")

    @property
    def mass(self):
        return self.weight / G_MM_S2

    @property
    def omega0(self):
        return jnp.sqrt(G_MM_S2 * self.stiffness / self.weight)

    @property
    def natural_frequency(self):
        return self.omega0 / (2 * jnp.pi)

    @property
    def slip_time(self):
        return jnp.pi / self.omega0
