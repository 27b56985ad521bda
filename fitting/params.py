r"""Fit parameters as typed pytrees, stored in unconstrained coordinates.

The empirical model of the paper has six friction parameters: eq (1)
$\mu_0 = \mu_s - (\mu_s - \mu_d) e^{-\gamma T_1^m}$ and eq (3)
$\mu_m = \mu_d + (\mu_0 - \mu_d) e^{-\delta T_2^n}$. They are constrained
($\mu_d > 0$, $\mu_s > \mu_d$, $\gamma, m, \delta, n > 0$), so the optimiser and the
sampler work in unconstrained coordinates:

| parameter | unit | stored as |
|---|---|---|
| mu_d | - | `log_mu_d` = log mu_d |
| mu_s | - | `log_gap` = log(mu_s - mu_d) |
| gamma | s^-m | `log_gamma` |
| m | - | `log_m` |
| delta | s^-n | `log_delta` |
| n | - | `log_n` |

`CampaignParams` adds one gauge offset per record (mm, a nuisance). Which leaves are
fitted is chosen with a boolean filter spec and `eqx.partition` (`free_spec`), never
with string-keyed dicts; names appear only at the reporting edge (`NAMES`, `UNITS`).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from stickslip_jax.friction import Friction, KatoKinetic, KatoStatic

__all__ = [
    "NAMES",
    "UNITS",
    "CampaignParams",
    "EmpiricalFriction",
    "free_spec",
    "natural_values",
]

NAMES = ("mu_s", "mu_d", "gamma", "m", "delta", "n")
"""Friction parameters of the empirical model (eqs 1 and 3), in reporting order."""

UNITS = {"mu_s": "-", "mu_d": "-", "gamma": "s^-m", "m": "-", "delta": "s^-n", "n": "-"}
"""Unit of each parameter (internal units; dimensionless shown as -)."""

_LEAF = {
    "mu_s": "log_gap", "mu_d": "log_mu_d", "gamma": "log_gamma",
    "m": "log_m", "delta": "log_delta", "n": "log_n",
}


def _f(x):
    return jnp.asarray(x, dtype=float)


class EmpiricalFriction(eqx.Module):
    r"""Eq (1) + eq (3) friction in unconstrained coordinates (all logs, see module doc).

    `friction()` builds the `stickslip_jax.Friction` (KatoStatic + KatoKinetic);
    `values()` returns the natural parameters in `NAMES` order (mu_s, mu_d
    dimensionless; gamma in s^-m; m; delta in s^-n; n).
    """

    log_mu_d: Float[Array, ""] = eqx.field(converter=_f)
    log_gap: Float[Array, ""] = eqx.field(converter=_f)
    log_gamma: Float[Array, ""] = eqx.field(converter=_f)
    log_m: Float[Array, ""] = eqx.field(converter=_f)
    log_delta: Float[Array, ""] = eqx.field(converter=_f)
    log_n: Float[Array, ""] = eqx.field(converter=_f)

    @classmethod
    def from_values(cls, mu_s, mu_d, gamma, m, delta, n) -> EmpiricalFriction:
        """From natural values; raises ValueError unless 0 < mu_d < mu_s and the rest > 0."""
        try:
            fv = dict(mu_s=float(mu_s), mu_d=float(mu_d), gamma=float(gamma), m=float(m),
                      delta=float(delta), n=float(n))
        except (TypeError, jax.errors.ConcretizationTypeError):
            fv = None  # traced values: no checks
        if fv is not None:
            bad = [k for k, v in fv.items() if not v > 0]
            if bad:
                raise ValueError(f"parameters must be positive: {', '.join(bad)}")
            if not fv["mu_s"] > fv["mu_d"]:
                raise ValueError(f"need mu_s > mu_d, got mu_s={fv['mu_s']}, mu_d={fv['mu_d']}")
        return cls(
            log_mu_d=jnp.log(_f(mu_d)), log_gap=jnp.log(_f(mu_s) - _f(mu_d)),
            log_gamma=jnp.log(_f(gamma)), log_m=jnp.log(_f(m)),
            log_delta=jnp.log(_f(delta)), log_n=jnp.log(_f(n)),
        )

    @classmethod
    def from_friction(cls, friction: Friction) -> EmpiricalFriction:
        s, k = friction.static, friction.kinetic
        if not isinstance(s, KatoStatic) or not isinstance(k, KatoKinetic):
            raise ValueError("the empirical model needs KatoStatic (eq 1) and KatoKinetic (eq 3)")
        return cls.from_values(s.mu_s, s.mu_d, s.gamma, s.m, k.delta, k.n)

    def friction(self) -> Friction:
        mu_d = jnp.exp(self.log_mu_d)
        static = KatoStatic(
            mu_s=mu_d + jnp.exp(self.log_gap), mu_d=mu_d,
            gamma=jnp.exp(self.log_gamma), m=jnp.exp(self.log_m),
        )
        return Friction(static, KatoKinetic(delta=jnp.exp(self.log_delta), n=jnp.exp(self.log_n)))

    def values(self) -> Float[Array, "6"]:
        """Natural parameters (mu_s, mu_d, gamma, m, delta, n)."""
        mu_d = jnp.exp(self.log_mu_d)
        return jnp.stack([
            mu_d + jnp.exp(self.log_gap), mu_d, jnp.exp(self.log_gamma), jnp.exp(self.log_m),
            jnp.exp(self.log_delta), jnp.exp(self.log_n),
        ])

    def log_values(self) -> Float[Array, "6"]:
        """log of the natural parameters: the coordinates of relative uncertainty."""
        return jnp.log(self.values())


class CampaignParams(eqx.Module):
    """Everything a campaign fit estimates: friction + one gauge offset (mm) per record."""

    friction: EmpiricalFriction  # or another friction-parameter module (names_of)
    offset: Float[Array, " R"] = eqx.field(converter=_f)


def natural_values(params: CampaignParams) -> Float[Array, "6"]:
    return params.friction.values()


def free_spec(params: CampaignParams, *, fixed=(), offsets: bool = False) -> CampaignParams:
    """Boolean filter spec: True on the leaves to fit.

    `fixed`: names from `NAMES` held at their current value (mu_s fixed means the gap
    mu_s - mu_d is fixed). `offsets`: fit the per-record gauge offsets.
    """
    names, leaf = names_of(params.friction), getattr(params.friction, "LEAVES", _LEAF)
    bad = [n for n in fixed if n not in names]
    if bad:
        raise ValueError(f"unknown parameter(s) {bad}; choose from {', '.join(names)}")
    spec = jax.tree_util.tree_map(lambda _: False, params)
    leaves = lambda p: [getattr(p.friction, leaf[n]) for n in names] + [p.offset]  # noqa: E731
    return eqx.tree_at(leaves, spec, [n not in fixed for n in names] + [bool(offsets)])


def names_of(friction) -> tuple[str, ...]:
    """Reporting names of a friction-parameter module (`NAMES` for `EmpiricalFriction`;
    other models, e.g. `fitting.microsqueeze_params.MicrosqueezeFriction`, carry their own)."""
    return tuple(getattr(friction, "NAMES", NAMES))


def units_of(friction) -> dict[str, str]:
    """Units of `names_of(friction)`."""
    return dict(getattr(friction, "UNITS", UNITS))


def leaf_name(name: str) -> str:
    """The `EmpiricalFriction` field that stores parameter `name`."""
    return _LEAF[name]


def as_numpy_values(params: CampaignParams) -> dict[str, float]:
    """Natural values as a {name: float} dict (reporting edge only)."""
    v = np.asarray(params.friction.values())
    return {n: float(x) for n, x in zip(NAMES, v)}
