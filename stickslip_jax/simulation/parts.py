r"""Parts of the smoothed simulator: the interfaces a new physical effect implements.

The smoothed simulator (smooth.py) integrates the slider of Fig 5,
$M\ddot y = k x - F_{fric} + \sum_i F_i$, $\dot x = \dot u - \dot y$, together with its
friction memory and any states the parts declare. Every part is an `eqx.Module`
whose parameters are ordinary fields (so `eqx.tree_at` / `eqx.partition` select them
for fitting) and which is *neutral when its parameters are zero*.

Each part may carry its own ODE states: a class variable `num_states` (default 0),
`init_state(ctx)` (default zeros) and `state_derivative(t, core, own, ctx)` (default
zeros); `own` is the part's state vector (shape `(num_states,)`).

- `AbstractForceTerm.force(t, core, own, ctx) -> kgf`: extra force on the slider,
  positive forward (e.g. viscous damping $-c\dot y$, a Stribeck excess, a periodic
  drive error expressed as a force). It may use `ctx.normal_load` and
  `ctx.sign(ydot)`, the smoothed sign function of the simulator.
- `AbstractLoadCoupling.normal_load(t, core, own, ctx) -> kgf`: the normal load $N$
  that multiplies every friction coefficient (`ConstantLoad`: the slideway's N, the
  paper's N = W).
- `AbstractMeasurement.observe(t, core, own, ctx) -> mm`: what the strain gauge
  reports for the deflection (offset, drift, sensor dynamics via its own states);
  `noise_std` (mm) is the white-noise level used by synthetic records and likelihoods.
"""

from __future__ import annotations

import abc
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..numerics import as_float

Scalar = Float[Array, ""]


class Core(eqx.Module):
    """Simulator state at one time: deflection x (mm), slider velocity ydot (mm/s),
    stick-time state tau (s), breakaway-friction memory mu_0_memory (-)."""

    x: Scalar
    ydot: Scalar
    tau: Scalar
    mu_0_memory: Scalar


class Context(eqx.Module):
    """Constants and derived values handed to the parts (units kgf, mm, s).

    `sign(v)` is the simulator's smoothed sign of a velocity, `tanh(8 v / eps)`, with
    `eps` the smoothing velocity (mm/s) of the stick/slip switch.
    `normal_load` is filled in after the load coupling part has been evaluated
    (the slideway's static load `Slideway.load`, N or W, while the load part itself runs).
    """

    weight: Scalar
    stiffness: Scalar
    mass: Scalar
    omega0: Scalar
    drive_position: Scalar
    drive_speed: Scalar
    eps: Scalar
    normal_load: Scalar

    def sign(self, v):
        return jnp.tanh(8.0 * v / self.eps)


class AbstractPart(eqx.Module):
    """Common base: optional own ODE states (`num_states`, `init_state`, `state_derivative`)."""

    num_states: ClassVar[int] = 0

    def init_state(self, ctx: Context) -> Float[Array, " s"]:
        """Initial value of the part's states (default zeros)."""
        return jnp.zeros((self.num_states,))

    def state_derivative(self, t, core: Core, own, ctx: Context) -> Float[Array, " s"]:
        """Time derivative of the part's states (default zeros)."""
        return jnp.zeros((self.num_states,))


class AbstractForceTerm(AbstractPart):
    """An extra force on the slider (kgf, positive in the drive direction)."""

    @abc.abstractmethod
    def force(self, t, core: Core, own, ctx: Context) -> Scalar:
        """Force in kgf at time t (s)."""


class AbstractLoadCoupling(AbstractPart):
    """The normal load N (kgf) that multiplies the friction coefficients."""

    @abc.abstractmethod
    def normal_load(self, t, core: Core, own, ctx: Context) -> Scalar:
        """Normal load in kgf at time t (s)."""


class AbstractMeasurement(AbstractPart):
    """Map the true spring deflection to what the gauge records (mm)."""

    noise_std: eqx.AbstractVar[Scalar]

    @abc.abstractmethod
    def observe(self, t, core: Core, own, ctx: Context) -> Scalar:
        """Recorded deflection in mm at time t (s), without noise."""


class ConstantLoad(AbstractLoadCoupling):
    """A constant normal load: the slideway's `normal_load` N, or the paper's N = W."""

    def normal_load(self, t, core, own, ctx):
        return ctx.normal_load


class ViscousDamping(AbstractForceTerm):
    r"""Linear viscous force $-c\,\dot y$; `c` in kgf*s/mm (0 = absent)."""

    c: Scalar = eqx.field(converter=as_float, default=0.0)

    def force(self, t, core, own, ctx):
        return -self.c * core.ydot


class IdealGauge(AbstractMeasurement):
    """The gauge reads the deflection plus a constant `offset` (mm); white noise
    `noise_std` (mm) is added only by synthetic records, not by the simulator."""

    offset: Scalar = eqx.field(converter=as_float, default=0.0)
    noise_std: Scalar = eqx.field(converter=as_float, default=0.0)

    def observe(self, t, core, own, ctx):
        return core.x + self.offset
