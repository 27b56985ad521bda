r"""The mechanical system of Fig 5: a slider of weight W on a spring of stiffness k, with friction
under a normal load N (the paper's N = W)."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from .friction import Friction
from .numerics import as_float
from .units import G_MM_S2


class Slideway(eqx.Module):
    r"""Slider (weight `weight` W in kgf) driven through a spring (`stiffness` k in kgf/mm),
    pressed on the slideway by `normal_load` N in kgf (None: the paper's N = W).

    W sets the inertia and N the friction: `mass` is $M = W/g$ in kgf*s^2/mm, `omega0`
    $=\sqrt{gk/W}$ in rad/s, `slip_time` is eq (7), $T_2 = \pi/\omega_0$ in s, and the
    friction force is $\mu$ `load` with `load` = N (W when `normal_load` is None).
    """

    friction: Friction
    weight: Float[Array, ""] = eqx.field(converter=as_float)
    stiffness: Float[Array, ""] = eqx.field(converter=as_float)
    normal_load: Float[Array, ""] | None = eqx.field(
        default=None, converter=lambda n: None if n is None else as_float(n))

    def __check_init__(self):
        if not isinstance(self.friction, Friction):
            raise ValueError(f"friction must be a Friction, got {type(self.friction)}")

    @property
    def load(self):
        """The normal load N in kgf that multiplies the friction coefficients."""
        return self.weight if self.normal_load is None else self.normal_load

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
