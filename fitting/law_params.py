r"""Fit parameters of the other base friction laws (`stickslip_jax.friction.rate_state`,
`.log_aging`), final subclasses of `stickslip_fitting.params.AbstractFrictionParams`.

| law | parameter | unit | stored as |
|---|---|---|---|
| rate-and-state | mu_ref ($\mu_*$, steady state at `v_0`) | - | `log_mu_ref` |
| | a, b | - | `log_a`, `log_b` |
| | d_c | mm | `log_d_c` |
| log aging | mu_d | - | `log_mu_d` |
| | beta | - | `log_beta` |
| | t_c | s | `log_t_c` |
| | c | - | `log_c` |
| | v_c | mm/s | `log_v_c` |

The rate-and-state law's reference velocity `v_0` (mm/s, default 1e-3) is given
($\mu_*$ and $v_0$ trade off exactly). These laws are fitted through whole records
(`objectives.smooth`).
"""

from __future__ import annotations

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from stickslip_jax.friction import (AbstractStateEvolution, AgingLaw, Friction, LogAgingStatic,
                                    LogVelocityKinetic, SlipLaw, rate_state_friction)
from stickslip_jax.numerics import as_float

from .params import AbstractFrictionParams

__all__ = ["LogAgingFriction", "RateStateAgingFriction", "RateStateSlipFriction"]


class _LogParams(AbstractFrictionParams):
    """Shared conversions of laws whose every leaf is `log_<name>` of a positive value."""

    def values(self):
        return jnp.exp(jnp.stack([getattr(self, self.LEAVES[n]) for n in self.NAMES]))

    def from_log_values(self, logs):
        return eqx.tree_at(lambda p: p.leaves(), self, [logs[i] for i in range(len(self.NAMES))])

    def with_values(self, **values):
        v = self.merged_values(values)
        bad = [n for n in self.NAMES if not v[n] > 0]
        if bad:
            raise ValueError(f"parameters must be positive: {', '.join(bad)}")
        return self.from_log_values(jnp.log(jnp.asarray([v[n] for n in self.NAMES])))

    def with_fixed(self, fixed: dict):
        return self.with_values(**fixed)

    def physical(self):
        return jnp.asarray(True)

    @classmethod
    def from_values(cls, **values):
        """From natural values ({name: value}, all positive); ValueError otherwise."""
        missing = sorted(set(cls.NAMES) - set(values))
        if missing:
            raise ValueError(f"{cls.__name__}: missing {', '.join(missing)}")
        template = cls(*([0.0] * len(cls.NAMES)))
        return template.with_values(**values)


RS_NAMES = ("mu_ref", "a", "b", "d_c")
RS_UNITS = {"mu_ref": "-", "a": "-", "b": "-", "d_c": "mm"}
RS_BOUNDS = {"mu_ref": (1e-3, 2.0), "a": (2e-3, 0.2), "b": (1e-4, 0.5), "d_c": (1e-6, 1.0)}


class _RateStateParams(_LogParams):
    log_mu_ref: Float[Array, ""] = eqx.field(converter=as_float)
    log_a: Float[Array, ""] = eqx.field(converter=as_float)
    log_b: Float[Array, ""] = eqx.field(converter=as_float)
    log_d_c: Float[Array, ""] = eqx.field(converter=as_float)
    v_0: float = eqx.field(static=True, default=1e-3)

    EVOLUTION: ClassVar[AbstractStateEvolution]
    NAMES: ClassVar[tuple[str, ...]] = RS_NAMES
    UNITS: ClassVar[dict[str, str]] = RS_UNITS
    LEAVES: ClassVar[dict[str, str]] = {n: f"log_{n}" for n in RS_NAMES}
    SHAPE_NAMES: ClassVar[tuple[str, ...]] = ("b", "d_c")
    PRIOR_BOUNDS: ClassVar[dict[str, tuple[float, float]]] = RS_BOUNDS
    REGION: ClassVar[str] = ""

    def friction(self) -> Friction:
        mu, a, b, d_c = (jnp.exp(x) for x in (self.log_mu_ref, self.log_a, self.log_b,
                                              self.log_d_c))
        return rate_state_friction(mu, a, b, d_c, self.v_0, self.EVOLUTION)


class RateStateAgingFriction(_RateStateParams):
    """Rate-and-state law with Dieterich's aging law (`stickslip_jax.friction.AgingLaw`)."""

    MODEL: ClassVar[str] = "rate_state_aging"
    EVOLUTION: ClassVar[AbstractStateEvolution] = AgingLaw()


class RateStateSlipFriction(_RateStateParams):
    """Rate-and-state law with Ruina's slip law (`stickslip_jax.friction.SlipLaw`)."""

    MODEL: ClassVar[str] = "rate_state_slip"
    EVOLUTION: ClassVar[AbstractStateEvolution] = SlipLaw()


LOG_NAMES = ("mu_d", "beta", "t_c", "c", "v_c")


class LogAgingFriction(_LogParams):
    r"""Logarithmic aging $\mu_0 = \mu_d + \beta\ln(1 + T_1/t_c)$ with the kinetic friction
    $\mu_d - c\ln(1 + v/v_c)$ (`stickslip_jax.friction.log_aging`)."""

    log_mu_d: Float[Array, ""] = eqx.field(converter=as_float)
    log_beta: Float[Array, ""] = eqx.field(converter=as_float)
    log_t_c: Float[Array, ""] = eqx.field(converter=as_float)
    log_c: Float[Array, ""] = eqx.field(converter=as_float)
    log_v_c: Float[Array, ""] = eqx.field(converter=as_float)

    MODEL: ClassVar[str] = "log_aging"
    NAMES: ClassVar[tuple[str, ...]] = LOG_NAMES
    UNITS: ClassVar[dict[str, str]] = {"mu_d": "-", "beta": "-", "t_c": "s", "c": "-",
                                       "v_c": "mm/s"}
    LEAVES: ClassVar[dict[str, str]] = {n: f"log_{n}" for n in LOG_NAMES}
    SHAPE_NAMES: ClassVar[tuple[str, ...]] = ("beta", "t_c")
    PRIOR_BOUNDS: ClassVar[dict[str, tuple[float, float]]] = {
        "mu_d": (1e-3, 2.0), "beta": (1e-4, 1.0), "t_c": (1e-6, 1e3), "c": (1e-5, 1.0),
        "v_c": (1e-4, 1e3)}
    REGION: ClassVar[str] = ""

    def friction(self) -> Friction:
        mu_d, beta, t_c, c, v_c = self.values()
        return Friction(LogAgingStatic(mu_d, beta, t_c), LogVelocityKinetic(c, v_c))
