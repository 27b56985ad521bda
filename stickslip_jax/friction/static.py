r"""Static friction against stick time: the paper's eq (1) and the laws of Table 3.

Every law maps the stick time $T_1$ (s) to the static friction coefficient
$\mu_0$ (dimensionless) and exposes `mu_d`, the value of $\mu_0$ as $T_1 \to 0$, which
the kinetic law of eq (3) shares. All laws are NaN-free (value and gradient) at
$T_1 = 0$.
"""

from __future__ import annotations

import abc

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ..numerics import as_float, one_minus_exp_neg, safe_power

Scalar = Float[Array, ""]


class AbstractStaticFriction(eqx.Module):
    r"""Base class of static-friction laws $\mu_0(T_1)$.

    Subclasses define `mu_d` (dimensionless, $\mu_0$ at $T_1 = 0$) and `__call__`
    mapping stick time in s to $\mu_0$.
    """

    mu_d: eqx.AbstractVar[Scalar]

    @abc.abstractmethod
    def __call__(self, stick_time: Float[ArrayLike, "..."]) -> Float[Array, "..."]:
        """Static friction coefficient after a stick of `stick_time` seconds."""

    def asymptote(self) -> Scalar:
        r"""$\mu_0$ for a very long stick ($T_1 = 10^{12}$ s); `mu_s` where the law has one."""
        return self(jnp.asarray(1e12))


class KatoStatic(AbstractStaticFriction):
    r"""The paper's empirical law, eq (1):
    $\mu_0(T_1) = \mu_s - (\mu_s - \mu_d)\exp(-\gamma T_1^m)$.

    `mu_s`, `mu_d` dimensionless; `gamma` in s$^{-m}$; `m` dimensionless; $T_1$ in s.
    Parameter sets: Table 4, Table 6 (chapters 2-5) and Table 9 (chapter 7).
    """

    mu_s: Scalar = eqx.field(converter=as_float)
    mu_d: Scalar = eqx.field(converter=as_float)
    gamma: Scalar = eqx.field(converter=as_float)
    m: Scalar = eqx.field(converter=as_float)

    def __init__(self, mu_s, mu_d, gamma, m):
        # Explicit so that positional order is (mu_s, mu_d, gamma, m) as in eq (1); the
        # inherited abstract `mu_d` would otherwise come first in the dataclass order.
        self.mu_s, self.mu_d, self.gamma, self.m = mu_s, mu_d, gamma, m

    def __call__(self, stick_time):
        t = jnp.asarray(stick_time, dtype=float)
        rise = one_minus_exp_neg(self.gamma * safe_power(t, self.m))
        return self.mu_d + (self.mu_s - self.mu_d) * rise

    def asymptote(self):
        return self.mu_s


class _RateStatic(AbstractStaticFriction):
    """A Table 3 law of `mu_s`, `mu_d` (dimensionless) and a rate `C` (1/s), in that
    positional order as in the table; `mu_s` is its long-stick value."""

    mu_s: Scalar = eqx.field(converter=as_float)
    mu_d: Scalar = eqx.field(converter=as_float)
    C: Scalar = eqx.field(converter=as_float)

    def __init__(self, mu_s, mu_d, C):
        self.mu_s, self.mu_d, self.C = mu_s, mu_d, C

    def asymptote(self):
        return self.mu_s


class HoweStatic(_RateStatic):
    r"""Howe et al. (Table 3): $\mu_0 = \mu_d + (\mu_s - \mu_d)(1 - e^{-C T})$; `C` in 1/s."""

    def __call__(self, stick_time):
        t = jnp.maximum(jnp.asarray(stick_time, dtype=float), 0.0)
        return self.mu_d + (self.mu_s - self.mu_d) * one_minus_exp_neg(self.C * t)


class DerjaguinStatic(AbstractStaticFriction):
    r"""Derjaguin (Table 3): $\mu_0 = \mu_d + C_1 T / (C_2 + T)$; `C1` dimensionless, `C2` in s."""

    mu_d: Scalar = eqx.field(converter=as_float)
    C1: Scalar = eqx.field(converter=as_float)
    C2: Scalar = eqx.field(converter=as_float)

    def __call__(self, stick_time):
        t = jnp.maximum(jnp.asarray(stick_time, dtype=float), 0.0)
        return self.mu_d + self.C1 * t / (self.C2 + t)

    def asymptote(self):
        return self.mu_d + self.C1


class PowerLawStatic(AbstractStaticFriction):
    r"""Rabinowicz / Brockley (Table 3, NOTES.md item 10): $\mu_0 = \mu_d + C_1 T^{C_2}$.

    `C1` in s$^{-C_2}$, `C2` dimensionless. Unbounded as $T \to \infty$.
    """

    mu_d: Scalar = eqx.field(converter=as_float)
    C1: Scalar = eqx.field(converter=as_float)
    C2: Scalar = eqx.field(converter=as_float)

    def __call__(self, stick_time):
        t = jnp.asarray(stick_time, dtype=float)
        return self.mu_d + self.C1 * safe_power(t, self.C2)


class OkamuraStatic(_RateStatic):
    r"""Okamura's squeeze law (Table 3):
    $\mu_0 = \mu_s / \{(\mu_s/\mu_d - 1)/\sqrt{C T + 1} + 1\}$; `C` in 1/s.
    """

    def __call__(self, stick_time):
        t = jnp.maximum(jnp.asarray(stick_time, dtype=float), 0.0)
        return self.mu_s / ((self.mu_s / self.mu_d - 1.0) / jnp.sqrt(self.C * t + 1.0) + 1.0)
