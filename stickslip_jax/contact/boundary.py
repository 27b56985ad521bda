r"""Boundary-lubricated contact: load shares and static friction against the approach.

Paper section 7.2.1 and 7.2.4, eqs (13)-(15) and (33)-(35). The normal load $W$ is
carried by metallic junctions (pressure $p_m$ on $A_m$), by the adsorbed film (yield
pressure $p_b$ on $A_b$) and by the microsqueeze film $W_s$:

$$W = p_m A_m + p_b A_b + W_s \quad (13), \qquad F = S_m A_m + S_b A_b \quad (14),$$
$$\mu_0 = F / W \quad (15).$$

Ratios (eq 35): $C_1 = S_m/p_m$, $C_2 = p_b/p_m$, $C_3 = S_b/p_b$; the paper's values
1, 1, 0.075 with $p_m$ = 200 kgf/mm$^2$ and $W$ = 12.4 kgf are the defaults of
`BoundaryContact`. Lengths in mm, loads in kgf, pressures in kgf/mm$^2$, areas mm$^2$.
"""

from __future__ import annotations

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .surfaces import MODEL_SLIDER_WEIGHT, SurfacePair
from ..numerics import as_float, is_concrete, check_positive

Scalar = Float[Array, ""]


class BoundaryContact(eqx.Module):
    r"""Load and material constants of the boundary-lubrication model (eqs 13-15, 35).

    `W` normal load (kgf, default 12.4, the chapter 7 slider), `p_m` flow pressure of
    the metal (kgf/mm$^2$, default 200), `C1` = $S_m/p_m$ (default 1), `C2` = $p_b/p_m$
    (default 1), `C3` = $S_b/p_b$ (default 0.075). All may be changed by the user.
    """

    W: Scalar = eqx.field(converter=as_float, default=MODEL_SLIDER_WEIGHT)
    p_m: Scalar = eqx.field(converter=as_float, default=200.0)
    C1: Scalar = eqx.field(converter=as_float, default=1.0)
    C2: Scalar = eqx.field(converter=as_float, default=1.0)
    C3: Scalar = eqx.field(converter=as_float, default=0.075)

    def __check_init__(self):
        check_positive("BoundaryContact", W=self.W, p_m=self.p_m, C1=self.C1, C2=self.C2, C3=self.C3)
        if is_concrete(self.C1, self.C3) and np.any(np.asarray(self.C2 * self.C3) >= np.asarray(self.C1)):
            raise ValueError(
                "BoundaryContact: the film must be weaker in shear than the metal, "
                f"C2*C3 = S_b/p_m < C1 = S_m/p_m; got C2*C3 = {self.C2 * self.C3}, C1 = {self.C1}")


def load_shares(pair: SurfacePair, contact: BoundaryContact, a, t_b):
    r"""Load shares $(W_m, W_b, W_s)$ in kgf at approach `a` (mm) with film thickness
    `t_b` (mm): $W_m = p_m A_m$, $W_b = p_b A_b$ and $W_s = W - W_m - W_b$ (eq 13)."""
    W_m = contact.p_m * pair.metallic_area(a)
    W_b = contact.C2 * contact.p_m * pair.film_area(a, t_b)
    return W_m, W_b, contact.W - W_m - W_b


def static_coefficient(pair: SurfacePair, contact: BoundaryContact, a, t_b) -> Float[Array, "..."]:
    r"""Static friction $\mu_0(a) = (S_m A_m + S_b A_b)/W$ (eqs 14, 15 with $W_s$ from eq 13),
    dimensionless; `a`, `t_b` in mm."""
    p_m = contact.p_m
    F = contact.C1 * p_m * pair.metallic_area(a) + contact.C3 * contact.C2 * p_m * pair.film_area(a, t_b)
    return F / contact.W


def _cubic(a, alpha, beta, t, target):
    return alpha * a**3 + beta * (a + t) ** 3 - target


def _cubic_slope(a, alpha, beta, t):
    return 3.0 * alpha * a**2 + 3.0 * beta * (a + t) ** 2


@functools.partial(jax.jit, static_argnames="iterations")
def _newton_cubic(alpha, beta, t, target, iterations: int):
    """Newton's iterations for `_cubic_root` from the upper bound, as one compiled program
    (a loop traced on every eager call would compile again on every call)."""
    def body(_, a):
        return jnp.maximum(a - _cubic(a, alpha, beta, t, target)
                           / _cubic_slope(a, alpha, beta, t), 0.0)

    a0 = jnp.cbrt(jnp.maximum(target, 0.0) / (alpha + beta))
    return jax.lax.fori_loop(0, iterations, body, a0)


def _cubic_root(alpha, beta, t, target, iterations: int = 60):
    r"""Root $a \ge 0$ of $\alpha a^3 + \beta (a + t)^3 = $ `target` (increasing in a for
    $\beta \ge 0$, $\alpha + \beta > 0$). Newton from the upper bound
    $(\mathrm{target}/(\alpha+\beta))^{1/3}$ under `stop_gradient`, then one
    differentiable Newton step, which gives exact first-order (implicit) gradients."""
    sg = jax.lax.stop_gradient
    a = _newton_cubic(*(sg(jnp.asarray(x, dtype=float)) for x in (alpha, beta, t, target)),
                      iterations)
    return a - _cubic(a, alpha, beta, t, target) / _cubic_slope(a, alpha, beta, t)


def final_approach(pair: SurfacePair, contact: BoundaryContact, t_b) -> Scalar:
    r"""Approach $a_s$ (mm) at which $W_s = 0$: $W = p_m A_m(a_s) + p_b A_b(a_s)$ (eq 33)."""
    K = pair.area_factor
    C2 = contact.C2
    target = contact.W / (contact.p_m * K)
    # p_m K [(1 - C2) a^3 + C2 (a + t)^3] = W
    return _cubic_root(1.0 - C2, C2, jnp.asarray(t_b, dtype=float), target)


def approach_for(pair: SurfacePair, contact: BoundaryContact, mu, t_b) -> Scalar:
    r"""Approach $a$ (mm) at which $\mu_0(a)$ = `mu` (eq 15 inverted), e.g. $a_d$ for
    $\mu_0 = \mu_d$. Negative when `mu` is below $\mu_0(0) = C_2 C_3 p_m K t_b^3/W$."""
    K = pair.area_factor
    c = contact.C2 * contact.C3
    target = jnp.asarray(mu, dtype=float) * contact.W / (contact.p_m * K)
    t_b = jnp.asarray(t_b, dtype=float)
    below = target < c * t_b**3
    a = _cubic_root(contact.C1 - c, c, t_b, jnp.maximum(target, c * t_b**3))
    # report how far below a = 0 the request lies (film-only branch); double-where keeps
    # the gradient of cbrt finite when the deficit is 0
    deficit = jnp.where(below, c * t_b**3 - target, 1.0)
    return jnp.where(below, -jnp.cbrt(deficit / c), a)


class FilmEstimate(eqx.Module):
    """Result of `film_from_mu_s`: film thickness `t_b` and final approach `a_s` (mm),
    with the areas `A_ms`, `A_bs` (mm^2) of eq (35)."""

    t_b: Scalar
    a_s: Scalar
    A_ms: Scalar
    A_bs: Scalar


def film_from_mu_s(pair: SurfacePair, contact: BoundaryContact, mu_s, *,
                   check: bool = True) -> FilmEstimate:
    r"""Adsorbed film thickness $t_b$ and final approach $a_s$ from $\mu_s$ (eqs 31-35).

    With $W_s = 0$ (eq 33, 34): $A_{ms} = (W/p_m)(C_3 - \mu_s)/(C_3 - C_1)$ and
    $A_{bs} = (W/p_m)(\mu_s - C_1)/(C_2 (C_3 - C_1))$ (eq 35); then $a_s = (A_{ms}/K)^{1/3}$
    (eq 31) and $t_b = (A_{bs}/K + a_s^3)^{1/3} - a_s$ (eq 32). Needs $C_3 < \mu_s < C_1$.
    Lengths in mm; Table 11 lists the result for lubricants A-G on S1G1. `check=False`
    leaves out the check of a traced `mu_s` (`eqx.error_if`, a host callback: the program
    stays out of the compilation cache) for callers that keep it inside.
    """
    mu_s = jnp.asarray(mu_s, dtype=float)
    if check and is_concrete(mu_s, contact.C1, contact.C3):
        bad = (np.asarray(mu_s) <= np.asarray(contact.C3)) | (np.asarray(mu_s) >= np.asarray(contact.C1))
        if np.any(bad):
            raise ValueError(
                f"film_from_mu_s: mu_s must lie between C3 = S_b/p_b = {float(contact.C3)} and "
                f"C1 = S_m/p_m = {float(contact.C1)}; got {np.asarray(mu_s)}")
    elif check:
        mu_s = eqx.error_if(mu_s, (mu_s <= contact.C3) | (mu_s >= contact.C1),
                            "film_from_mu_s: mu_s outside (C3, C1)")
    K = pair.area_factor
    C1, C2, C3 = contact.C1, contact.C2, contact.C3
    scale = contact.W / contact.p_m
    A_ms = scale * (C3 - mu_s) / (C3 - C1)
    A_bs = scale * (mu_s - C1) / (C2 * (C3 - C1))
    a_s = jnp.cbrt(A_ms / K)
    t_b = jnp.cbrt(A_bs / K + a_s**3) - a_s
    return FilmEstimate(t_b=t_b, a_s=a_s, A_ms=A_ms, A_bs=A_bs)


def static_limit(pair: SurfacePair, contact: BoundaryContact, t_b) -> Scalar:
    r"""$\mu_s = \mu_0(a_s)$ for a given film thickness `t_b` (mm): the curves of
    Figs 85-88 (eqs 31-33 and 35 solved for $\mu_s$)."""
    return static_coefficient(pair, contact, final_approach(pair, contact, t_b), t_b)
