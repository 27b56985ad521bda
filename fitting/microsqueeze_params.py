r"""Microsqueeze-model fit parameters: h_e and Q in place of gamma and m.

The static friction is the microsqueeze law of chapter 7 (`MicrosqueezeStatic`, eqs
(13)-(15), (28)-(35)); the kinetic friction is eq (3) as in the empirical model. The
viscosity $\eta$ (kgf s/mm$^2$), the surface pair and the contact constants are given
(not fitted); the film thickness $t_b$ follows from $\mu_s$ (eqs 33-35). The fitted
parameters and their unconstrained coordinates:

| parameter | unit | stored as |
|---|---|---|
| mu_d | - | `log_mu_d` = log mu_d |
| mu_s | - | `log_gap` = log(mu_s - mu_d) |
| h_e | mm | `log_margin` = log(h_e - t_b - a_d), $a_d$: approach where $\mu_0 = \mu_d$ |
| Q | mm^4 | `log_Q` |
| delta | s^-n | `log_delta` |
| n | - | `log_n` |

The margin coordinate makes $h_e > t_b + a_d$ (a squeeze film is left at the start of
the stick) hold at every trial point. Trial points outside the law's other physical
limits ($C_3 < \mu_s < C_1$, $\mu_d > \mu_0(a=0)$, a margin below $10^{-9}(t_b + a_d)$,
$|\log Q| > 200$) are clipped onto them inside `friction()` (zero gradient there, so
Levenberg-Marquardt rejects such steps) instead of raising; `physical()` says whether a
point needs none (the support of the MCMC prior).
"""

from __future__ import annotations

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from stickslip_jax.contact import BoundaryContact, MicrosqueezeStatic, SurfacePair, surface_pair
from stickslip_jax.contact.boundary import approach_for, film_from_mu_s
from stickslip_jax.friction import Friction, KatoKinetic
from stickslip_jax.numerics import as_float

from .params import PRIOR_BOUNDS, AbstractFrictionParams

__all__ = ["MICROSQUEEZE_NAMES", "MICROSQUEEZE_UNITS", "MicrosqueezeFriction"]

MICROSQUEEZE_NAMES = ("mu_s", "mu_d", "h_e", "Q", "delta", "n")
MICROSQUEEZE_UNITS = {"mu_s": "-", "mu_d": "-", "h_e": "mm", "Q": "mm^4", "delta": "s^-n",
                      "n": "-"}
_TINY = 1e-300


class MicrosqueezeFriction(AbstractFrictionParams):
    r"""Microsqueeze static law + eq (3) kinetic law in unconstrained coordinates.

    Fitted leaves: `log_mu_d`, `log_gap`, `log_margin` (mm), `log_Q` (mm^4),
    `log_delta`, `log_n`. Given leaves (never fitted): `eta` (kgf s/mm$^2$), `pair`
    (`SurfacePair`), `contact` (`BoundaryContact`).
    """

    log_mu_d: Float[Array, ""] = eqx.field(converter=as_float)
    log_gap: Float[Array, ""] = eqx.field(converter=as_float)
    log_margin: Float[Array, ""] = eqx.field(converter=as_float)
    log_Q: Float[Array, ""] = eqx.field(converter=as_float)
    log_delta: Float[Array, ""] = eqx.field(converter=as_float)
    log_n: Float[Array, ""] = eqx.field(converter=as_float)
    eta: Float[Array, ""] = eqx.field(converter=as_float)
    pair: SurfacePair
    contact: BoundaryContact
    fixed_mu_s: float | None = eqx.field(static=True, default=None)

    MODEL: ClassVar[str] = "microsqueeze"
    NAMES: ClassVar[tuple[str, ...]] = MICROSQUEEZE_NAMES
    UNITS: ClassVar[dict[str, str]] = MICROSQUEEZE_UNITS
    LEAVES: ClassVar[dict[str, str]] = {"mu_s": "log_gap", "mu_d": "log_mu_d", "h_e": "log_margin",
                                        "Q": "log_Q", "delta": "log_delta", "n": "log_n"}
    SHAPE_NAMES: ClassVar[tuple[str, ...]] = ("mu_s", "h_e", "Q")
    PRIOR_BOUNDS: ClassVar[dict[str, tuple[float, float]]] = {
        **{k: PRIOR_BOUNDS[k] for k in ("mu_s", "mu_d", "delta", "n")},
        "h_e": (1e-5, 1e-1), "Q": (1e-8, 1e10)}
    REGION: ClassVar[str] = "C3 < mu_s < C1, h_e > t_b + a_d"

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_values(cls, mu_s, mu_d, h_e, Q, delta, n, *, eta,
                    pair: SurfacePair | str = "S1G1", contact=None) -> MicrosqueezeFriction:
        """From natural values (h_e mm, Q mm^4, eta kgf s/mm^2); ValueError if impossible."""
        pair = surface_pair(pair) if isinstance(pair, str) else pair
        contact = BoundaryContact() if contact is None else contact
        cls.check_values(mu_s=mu_s, mu_d=mu_d, h_e=h_e, Q=Q, delta=delta, n=n, eta=eta)
        t_b = film_from_mu_s(pair, contact, mu_s).t_b  # raises unless C3 < mu_s < C1
        a_d = approach_for(pair, contact, mu_d, t_b)
        if float(a_d) < 0:
            raise ValueError(f"mu_d = {mu_d} is below the film-only friction mu_0(a=0) for "
                             f"mu_s = {mu_s}")
        margin = float(h_e) - float(t_b) - float(a_d)
        if not margin > 0:
            raise ValueError(f"h_e = {h_e} mm must exceed t_b + a_d = {float(t_b + a_d):.4g} mm")
        return cls(log_mu_d=np.log(float(mu_d)), log_gap=np.log(float(mu_s) - float(mu_d)),
                   log_margin=np.log(margin), log_Q=np.log(float(Q)),
                   log_delta=np.log(float(delta)), log_n=np.log(float(n)), eta=eta, pair=pair,
                   contact=contact)

    @classmethod
    def from_friction(cls, friction: Friction) -> MicrosqueezeFriction:
        s, k = friction.static, friction.kinetic
        if not isinstance(s, MicrosqueezeStatic) or not isinstance(k, KatoKinetic):
            raise ValueError("the microsqueeze model needs MicrosqueezeStatic and KatoKinetic (eq 3)")
        return cls.from_values(float(s.static_limit()), float(s.mu_d), float(s.h_e), float(s.Q),
                               float(k.delta), float(k.n), eta=float(s.eta), pair=s.pair,
                               contact=s.contact)

    def with_values(self, **values) -> MicrosqueezeFriction:
        """Same eta, pair, contact; natural values updated (missing ones kept);
        ValueError outside the law's domain."""
        return MicrosqueezeFriction.from_values(**self.merged_values(values), eta=self.eta,
                                                pair=self.pair, contact=self.contact)

    # ------------------------------------------------------------------ law
    def _parts(self):
        """(mu_s, mu_d, t_b, a_d) with the trial point clipped onto the physical region."""
        c = self.contact
        mu_s, mu_d = self.static_levels()
        lo, hi = c.C3 * (1 + 1e-6), c.C1 * (1 - 1e-6)
        mu_s = jnp.clip(mu_s, lo, hi)
        t_b = film_from_mu_s(self.pair, c, mu_s, check=False).t_b  # clipped inside
        mu_0_contact = c.C2 * c.C3 * c.p_m * self.pair.area_factor * t_b**3 / c.W
        mu_d = jnp.clip(mu_d, mu_0_contact * (1 + 1e-6), mu_s * (1 - 1e-6))
        a_d = approach_for(self.pair, c, mu_d, t_b)
        return mu_s, mu_d, t_b, a_d

    def physical(self):
        r"""True (a traced bool) when the point needs no clipping: $C_3 < \mu_s < C_1$,
        $\mu_d$ above the film-only friction $\mu_0(a=0)$, a margin $h_e - t_b - a_d$ of at
        least $10^{-9}(t_b + a_d)$ and $|\log Q| \le 200$ (the support of the MCMC prior)."""
        c = self.contact
        mu_s, mu_d = self.static_levels()
        ok_s = (mu_s > c.C3 * (1 + 1e-6)) & (mu_s < c.C1 * (1 - 1e-6))
        _, mu_d_c, t_b, a_d = self._parts()
        ok_d = mu_d == mu_d_c
        ok_h = jnp.exp(self.log_margin) >= 1e-9 * (t_b + a_d)
        return ok_s & ok_d & ok_h & (jnp.abs(self.log_Q) <= 200.0)

    def static_law(self) -> MicrosqueezeStatic:
        mu_s, mu_d, t_b, a_d = self._parts()
        base = t_b + a_d
        h_e = base + jnp.maximum(jnp.exp(self.log_margin), 1e-9 * base)
        Q = jnp.exp(jnp.clip(self.log_Q, -200.0, 200.0))
        return MicrosqueezeStatic(pair=self.pair, contact=self.contact, t_b=t_b, eta=self.eta,
                                  h_e=h_e, Q=Q, mu_d=mu_d, check_traced=False)  # clipped inside

    def friction(self) -> Friction:
        return Friction(self.static_law(), self.kinetic())

    def values(self) -> Float[Array, "6"]:
        """Natural parameters (mu_s, mu_d, h_e mm, Q mm^4, delta s^-n, n)."""
        mu_s, mu_d = self.static_levels()
        _, _, t_b, a_d = self._parts()
        return jnp.stack([mu_s, mu_d, t_b + a_d + jnp.exp(self.log_margin), jnp.exp(self.log_Q),
                          jnp.exp(self.log_delta), jnp.exp(self.log_n)])

    def from_log_values(self, logs) -> MicrosqueezeFriction:
        """Same eta, pair, contact at log natural values (near the optimum: no clipping)."""
        mu_s, mu_d, h_e = jnp.exp(logs[0]), jnp.exp(logs[1]), jnp.exp(logs[2])
        c = self.contact
        mu_s = jnp.clip(mu_s, c.C3 * (1 + 1e-6), c.C1 * (1 - 1e-6))  # no raise off the region
        t_b = film_from_mu_s(self.pair, self.contact, mu_s, check=False).t_b
        a_d = approach_for(self.pair, self.contact, mu_d, t_b)
        gap = jnp.maximum(mu_s - mu_d, _TINY)
        margin = jnp.maximum(h_e - t_b - a_d, _TINY)
        return MicrosqueezeFriction(log_mu_d=logs[1], log_gap=jnp.log(gap),
                                    log_margin=jnp.log(margin), log_Q=logs[3], log_delta=logs[4],
                                    log_n=logs[5], eta=self.eta, pair=self.pair,
                                    contact=self.contact, fixed_mu_s=self.fixed_mu_s)

