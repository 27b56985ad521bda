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

`CampaignParams` adds one gauge offset per record (mm, a nuisance). The fitted leaves
are chosen with a boolean filter spec (`free_spec`); the parameters held at given values
are a `Hold`, whose `where` selects their leaves like `eqx.tree_at`'s. Names appear only
at the edges: `--fix` and `fit(fix=...)` (`Hold.named`) and reports (`NAMES`, `UNITS`).

Every fittable friction law is a final subclass of `AbstractFrictionParams`
(`EmpiricalFriction`, `microsqueeze_params.MicrosqueezeFriction`, `law_params`): generic
code reads its class variables and methods and never probes a class for what it
offers. A new law: subclass, fill the class variables, implement the abstract methods.
"""

from __future__ import annotations

import abc
import dataclasses
import math
from collections.abc import Callable, Mapping
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from stickslip_jax.friction import Friction, KatoKinetic, KatoStatic
from stickslip_jax.lsq import free_filter
from stickslip_jax.numerics import as_float

__all__ = ["AbstractFrictionParams", "NAMES", "UNITS", "CampaignParams", "EmpiricalFriction",
           "Hold", "free_spec", "parse_fix"]

NAMES = ("mu_s", "mu_d", "gamma", "m", "delta", "n")
"""Friction parameters of the empirical model (eqs 1 and 3), in reporting order."""

UNITS = {"mu_s": "-", "mu_d": "-", "gamma": "s^-m", "m": "-", "delta": "s^-n", "n": "-"}
"""Unit of each parameter (internal units; dimensionless shown as -)."""

PRIOR_BOUNDS = {"mu_s": (1e-3, 2.0), "mu_d": (1e-3, 2.0), "gamma": (1e-4, 1e3), "m": (0.02, 5.0),
                "delta": (1e-3, 1e5), "n": (0.02, 5.0)}
"""Support of the log-uniform MCMC prior of each parameter of eqs (1), (3) (natural
units: gamma s^-m, delta s^-n)."""


class AbstractFrictionParams(eqx.Module):
    """A fittable friction law in unconstrained coordinates (abstract). Class variables:
    `MODEL` (its name in reports), `NAMES` (natural parameters, `values()` order), `UNITS`,
    `LEAVES` ({name: the field that stores it}), `SHAPE_NAMES` (the parameters of the rise
    of mu_0 with stick time: undetermined with one drive speed), `PRIOR_BOUNDS` (support
    of the log-uniform MCMC prior), `REGION` (the physical region beyond those, in words).
    """

    MODEL: ClassVar[str]
    NAMES: ClassVar[tuple[str, ...]]
    UNITS: ClassVar[dict[str, str]]
    LEAVES: ClassVar[dict[str, str]]
    SHAPE_NAMES: ClassVar[tuple[str, ...]]
    PRIOR_BOUNDS: ClassVar[dict[str, tuple[float, float]]]
    REGION: ClassVar[str]

    # Every subclass stores mu_d as the field `log_mu_d`, mu_s - mu_d as `log_gap`, and has
    # the static field `fixed_mu_s: float | None = None` last (`static_levels`). (Not
    # declared here: an abstract field would come before the subclass's own fields.)

    @abc.abstractmethod
    def friction(self) -> Friction:
        """The `stickslip_jax.Friction` (static and kinetic law) these parameters give."""

    @abc.abstractmethod
    def values(self) -> Float[Array, " P"]:
        """Natural parameters in `NAMES` order."""

    @abc.abstractmethod
    def from_log_values(self, logs) -> AbstractFrictionParams:
        """The same law (and given constants) at log natural values in `NAMES` order
        (traceable; near an optimum no constraint is active)."""

    @abc.abstractmethod
    def with_values(self, **values) -> AbstractFrictionParams:
        """The same law with some natural values replaced; ValueError (naming the
        parameter and its domain) unless the result is a valid parameter set."""

    @abc.abstractmethod
    def physical(self):
        """True (a traced bool) where no coordinate had to be clipped onto the law's
        physical region: the support of the MCMC prior besides `PRIOR_BOUNDS`."""

    @staticmethod
    def check_values(**values) -> None:
        """ValueError naming the natural `values` that are not positive, or when mu_s does
        not exceed mu_d (traced values are not checked)."""
        try:
            fv = {k: float(v) for k, v in values.items()}
        except (TypeError, jax.errors.ConcretizationTypeError):
            return
        bad = [k for k, v in fv.items() if not v > 0]
        if bad:
            raise ValueError(f"parameters must be positive: {', '.join(bad)}")
        if not fv["mu_s"] > fv["mu_d"]:
            raise ValueError(f"need mu_s > mu_d, got mu_s={fv['mu_s']}, mu_d={fv['mu_d']}")

    def kinetic(self) -> KatoKinetic:
        """Eq (3)'s kinetic law (`log_delta`, `log_n`), shared by every law here."""
        return KatoKinetic(delta=jnp.exp(self.log_delta), n=jnp.exp(self.log_n))

    def log_values(self) -> Float[Array, " P"]:
        """log of the natural parameters: the coordinates of relative uncertainty."""
        return jnp.log(self.values())

    def static_levels(self):
        r"""($\mu_s$, $\mu_d$): $\mu_d = e^{\text{log\_mu\_d}}$,
        $\mu_s = \mu_d + e^{\text{log\_gap}}$; when `fixed_mu_s` is set (mu_s held fixed
        with mu_d free, `with_fixed`) $\mu_s$ is that value and $\mu_d$ stays below it (a
        trial point above is clipped: no gradient, so the fit rejects it)."""
        mu_d = jnp.exp(self.log_mu_d)
        if self.fixed_mu_s is None:
            return mu_d + jnp.exp(self.log_gap), mu_d
        mu_s = jnp.asarray(self.fixed_mu_s, dtype=float)
        return mu_s, jnp.minimum(mu_d, mu_s * (1.0 - 1e-9))

    def with_fixed(self, fixed: dict) -> AbstractFrictionParams:
        """These parameters with the `fixed` ({name: value}) values, to be held there by
        the fit (`free_spec`). A free mu_s or mu_d that a fixed one would put on the wrong
        side of the other moves (mu_s = 1.5 mu_d). With mu_s fixed and mu_d free the law
        is anchored at that mu_s (`fixed_mu_s`: the stored gap would otherwise move mu_s
        with mu_d), so the fit honours every fixed value exactly. ValueError when the
        fixed values are outside the law's domain (naming the parameter)."""
        v = self.merged_values(fixed)
        if v["mu_s"] <= v["mu_d"]:
            if "mu_d" not in fixed:
                v["mu_d"] = v["mu_s"] / 1.5
            elif "mu_s" not in fixed:
                v["mu_s"] = v["mu_d"] * 1.5
        p = self.with_values(**v)
        if "mu_s" in fixed and "mu_d" not in fixed:
            p = dataclasses.replace(p, fixed_mu_s=float(v["mu_s"]))
        return p

    def leaves(self, names=None) -> list:
        """The stored leaves of `names` (default all of `NAMES`), for `eqx.tree_at`; on
        a filter spec of this class, its booleans."""
        return [getattr(self, self.LEAVES[n]) for n in (self.NAMES if names is None else names)]

    def named_values(self) -> dict[str, float]:
        """{name: natural value} (reporting edge only)."""
        return {n: float(x) for n, x in zip(self.NAMES, np.asarray(self.values()))}

    def merged_values(self, values: dict) -> dict[str, float]:
        """`named_values()` with `values` replacing some; ValueError naming any unknown
        parameter (for `with_values`)."""
        unknown = sorted(set(values) - set(self.NAMES))
        if unknown:
            raise ValueError(f"unknown parameter(s) {', '.join(unknown)}; choose from "
                             f"{', '.join(self.NAMES)}")
        v = self.named_values()
        v.update({k: float(x) for k, x in values.items()})
        return v


class EmpiricalFriction(AbstractFrictionParams):
    r"""Eq (1) + eq (3) friction in unconstrained coordinates (all logs, module doc)."""

    log_mu_d: Float[Array, ""] = eqx.field(converter=as_float)
    log_gap: Float[Array, ""] = eqx.field(converter=as_float)
    log_gamma: Float[Array, ""] = eqx.field(converter=as_float)
    log_m: Float[Array, ""] = eqx.field(converter=as_float)
    log_delta: Float[Array, ""] = eqx.field(converter=as_float)
    log_n: Float[Array, ""] = eqx.field(converter=as_float)
    fixed_mu_s: float | None = eqx.field(static=True, default=None)

    MODEL: ClassVar[str] = "empirical"
    NAMES: ClassVar[tuple[str, ...]] = NAMES
    UNITS: ClassVar[dict[str, str]] = UNITS
    LEAVES: ClassVar[dict[str, str]] = {"mu_s": "log_gap", "mu_d": "log_mu_d", "gamma": "log_gamma",
                                        "m": "log_m", "delta": "log_delta", "n": "log_n"}
    SHAPE_NAMES: ClassVar[tuple[str, ...]] = ("mu_s", "gamma", "m")
    PRIOR_BOUNDS: ClassVar[dict[str, tuple[float, float]]] = PRIOR_BOUNDS
    REGION: ClassVar[str] = ""

    @classmethod
    def from_values(cls, mu_s, mu_d, gamma, m, delta, n) -> EmpiricalFriction:
        """From natural values; raises ValueError unless 0 < mu_d < mu_s and the rest > 0."""
        cls.check_values(mu_s=mu_s, mu_d=mu_d, gamma=gamma, m=m, delta=delta, n=n)
        mu_s, mu_d, gamma, m, delta, n = map(as_float, (mu_s, mu_d, gamma, m, delta, n))
        return cls(log_mu_d=jnp.log(mu_d), log_gap=jnp.log(mu_s - mu_d), log_gamma=jnp.log(gamma),
                   log_m=jnp.log(m), log_delta=jnp.log(delta), log_n=jnp.log(n))

    @classmethod
    def from_friction(cls, friction: Friction) -> EmpiricalFriction:
        s, k = friction.static, friction.kinetic
        if not isinstance(s, KatoStatic) or not isinstance(k, KatoKinetic):
            raise ValueError("the empirical model needs KatoStatic (eq 1) and KatoKinetic (eq 3)")
        return cls.from_values(s.mu_s, s.mu_d, s.gamma, s.m, k.delta, k.n)

    def friction(self) -> Friction:
        mu_s, mu_d = self.static_levels()
        static = KatoStatic(mu_s=mu_s, mu_d=mu_d, gamma=jnp.exp(self.log_gamma),
                            m=jnp.exp(self.log_m))
        return Friction(static, self.kinetic())

    def values(self) -> Float[Array, "6"]:
        """Natural parameters (mu_s, mu_d, gamma, m, delta, n)."""
        mu_s, mu_d = self.static_levels()
        return jnp.stack([mu_s, mu_d, jnp.exp(self.log_gamma), jnp.exp(self.log_m),
                          jnp.exp(self.log_delta), jnp.exp(self.log_n)])

    def from_log_values(self, logs) -> EmpiricalFriction:
        """From log natural values (mu_s > mu_d assumed: the gap is floored at 1e-300)."""
        l_mus, l_mud, l_g, l_m, l_d, l_n = (logs[i] for i in range(6))
        gap = jnp.maximum(jnp.exp(l_mus) - jnp.exp(l_mud), 1e-300)
        return EmpiricalFriction(l_mud, jnp.log(gap), l_g, l_m, l_d, l_n,
                                 fixed_mu_s=self.fixed_mu_s)

    def with_values(self, **values) -> EmpiricalFriction:
        """Natural values replaced (the others kept); ValueError outside the domain."""
        return EmpiricalFriction.from_values(**self.merged_values(values))

    def physical(self):
        return jnp.asarray(True)


class CampaignParams(eqx.Module):
    """Everything a campaign fit estimates: friction + one gauge offset (mm) per record."""

    friction: AbstractFrictionParams
    offset: Float[Array, " R"] = eqx.field(converter=as_float)


def _floats(values) -> tuple[float, ...]:
    return tuple(float(v) for v in np.atleast_1d(np.asarray(values, dtype=float)))


class Hold(eqx.Module):
    """Friction parameters a fit holds at given natural values: `where` selects their
    stored leaves (like `eqx.tree_at`'s), `values` in the same order (mu_s held means mu_s
    itself, `with_fixed`)::

        Hold(lambda f: f.log_n, 1.0)                       # n = 1, the paper's value
        Hold(lambda f: (f.log_m, f.log_n), (0.5, 1.0))
        Hold.named({"n": 1.0})                             # from names (the edges)
    """

    where: Callable = eqx.field(static=True)
    values: tuple[float, ...] = eqx.field(static=True, converter=_floats)

    @classmethod
    def named(cls, values: Mapping[str, float]) -> Hold:
        """From {name: natural value} (`--fix NAME=VALUE`, `api.fit(fix=...)`); names
        the law lacks raise ValueError when the hold is used (`natural`)."""
        names = tuple(values)

        def where(f):
            unknown = [n for n in names if n not in f.LEAVES]
            if unknown:
                raise ValueError(f"unknown parameter(s) {', '.join(unknown)}; choose from "
                                 f"{', '.join(f.NAMES)}")
            return tuple(getattr(f, f.LEAVES[n]) for n in names)

        return cls(where, tuple(values.values()))

    def natural(self, friction: AbstractFrictionParams) -> dict[str, float]:
        """{name: value} of the held parameters of `friction`'s law; ValueError when
        `where` selects a leaf that stores none of them or the values do not match."""
        names = friction.NAMES
        tags = eqx.tree_at(lambda f: f.leaves(), friction,
                           [jnp.asarray(float(i)) for i in range(len(names))])
        picked = jax.tree_util.tree_leaves(self.where(tags))
        known = free_filter(friction, lambda f: f.leaves())
        chosen = free_filter(friction, self.where)
        if any(c and not k for c, k in zip(jax.tree_util.tree_leaves(chosen),
                                           jax.tree_util.tree_leaves(known))):
            raise ValueError(f"Hold: select leaves of the parameters {', '.join(names)}")
        if len(picked) != len(self.values):
            raise ValueError(f"Hold: {len(picked)} parameters selected, {len(self.values)} "
                             "values given")
        return {names[int(t)]: v for t, v in zip(picked, self.values)}

    def apply(self, friction: AbstractFrictionParams) -> AbstractFrictionParams:
        """`friction` with the held values (`AbstractFrictionParams.with_fixed`)."""
        return friction.with_fixed(self.natural(friction))


def free_spec(params: CampaignParams, *, hold: Hold | None = None,
              offsets: bool = False) -> CampaignParams:
    """Boolean filter spec: True on the leaves to fit.

    Every friction leaf but those `hold` selects (held at their current value: mu_s
    held means the gap mu_s - mu_d is); `offsets`: the per-record gauge offsets too.
    """
    if hold is not None:
        hold.natural(params.friction)  # ValueError naming an unknown parameter
    spec = jax.tree_util.tree_map(lambda _: False, params)
    leaves = lambda p: p.friction.leaves() + [p.offset]  # noqa: E731
    spec = eqx.tree_at(leaves, spec, [True] * len(params.friction.NAMES) + [bool(offsets)])
    if hold is None:
        return spec
    return eqx.tree_at(lambda p: hold.where(p.friction), spec, replace_fn=lambda _: False)


def free_mask(spec: CampaignParams) -> np.ndarray:
    """Which friction parameters (`NAMES` order) a filter spec frees."""
    return np.array([bool(b) for b in spec.friction.leaves()])


def parse_fix(items, law=None) -> dict[str, float]:
    """{name: value} from `--fix NAME=VALUE` options, checked against the friction law
    `law` (an `AbstractFrictionParams` subclass, default the empirical law): known names,
    each at most once, values inside the law's physical range (its MCMC prior support),
    mu_s > mu_d when both are given, and at least one parameter left to fit."""
    law = EmpiricalFriction if law is None else law
    names, bounds, units = law.NAMES, law.PRIOR_BOUNDS, law.UNITS
    out = {}
    for item in items:
        name, _, value = item.partition("=")
        name = name.strip()
        if name not in names or not value:
            raise ValueError(f"--fix: expected NAME=VALUE with NAME in {', '.join(names)}, "
                             f"got {item!r}")
        try:
            v = float(value)
        except ValueError:
            raise ValueError(f"--fix {name}: {value!r} is not a number") from None
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"--fix {name}: the value must be positive and finite, got {v}")
        if name in out and out[name] != v:
            raise ValueError(f"--fix {name}: given twice ({out[name]:g} and {v:g}); give it "
                             "once")
        lo, hi = bounds[name]
        if not lo <= v <= hi:
            unit = "" if units[name] == "-" else f" {units[name]}"
            raise ValueError(f"--fix {name}={v:g} lies outside the physical range "
                             f"{lo:g}-{hi:g}{unit} of {name}")
        out[name] = v
    if "mu_s" in out and "mu_d" in out and not out["mu_s"] > out["mu_d"]:
        raise ValueError(f"--fix: mu_s ({out['mu_s']:g}) must exceed mu_d ({out['mu_d']:g})")
    if len(out) == len(names):
        raise ValueError("--fix: every parameter is fixed, nothing is left to fit; leave at "
                         "least one free")
    return out
