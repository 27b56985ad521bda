r"""Rough surfaces and surface pairs of the model slideway (paper section 7.2.2, Table 10).

A `Surface` (Table 10) is the linear-distribution asperity model of eq (29); a
`SurfacePair` (slider, slideway) in contact over the apparent area $A_0$ (mm$^2$) gives the
equivalent radius $R_e$, the asperity count $I_0$, the contact-point count (eq 30), the
metallic and film-carrying areas (eqs 31, 32) against the approach $a$ (mm), and the
coefficient of surface topography $\xi_1\xi_2$ (section 7.4, Tables 10 and 12).

```python
>>> from stickslip_jax.contact import surface_pair
>>> pair = surface_pair("S1G1")
>>> float(pair.xi_product)        # Table 12 prints 1140
1138.4...
```
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ..numerics import as_float, check_positive
from ..tables import load_table

Scalar = Float[Array, ""]

#: Load of the chapter 7 model slider (kgf) and its apparent contact pressure
#: (0.344 kgf/cm^2 = 0.344e-2 kgf/mm^2), section 7.1.1.
MODEL_SLIDER_WEIGHT = 12.4
MODEL_CONTACT_PRESSURE = 0.344e-2
#: Apparent contact area of the model slideway, A_0 = W / pressure = 3604.7 mm^2.
MODEL_APPARENT_AREA = MODEL_SLIDER_WEIGHT / MODEL_CONTACT_PRESSURE
#: Unit length of the coefficient of surface topography (mm).
UNIT_LENGTH = 1.0


class Surface(eqx.Module):
    r"""One rough surface (Table 10): the linear-distribution asperity model of eq (29).

    Fields: `H_max` maximum asperity height (mm), `R` asperity radius (mm), `z`
    asperities per unit length (1/mm), `D` distribution factor (dimensionless).
    Every field may be a JAX array (batched surfaces under `vmap`).
    """

    H_max: Scalar = eqx.field(converter=as_float)
    R: Scalar = eqx.field(converter=as_float)
    z: Scalar = eqx.field(converter=as_float)
    D: Scalar = eqx.field(converter=as_float)

    def __check_init__(self):
        check_positive("Surface", H_max=self.H_max, R=self.R, z=self.z, D=self.D)

    def xi(self, unit_length: float = UNIT_LENGTH) -> Scalar:
        r"""Coefficient of surface topography $\xi = D (R/H_{max}) z L_u$ (section 7.4),
        dimensionless; `unit_length` $L_u$ in mm (1 mm in the paper)."""
        return self.D * (self.R / self.H_max) * self.z * unit_length

    @classmethod
    def from_table(cls, name: str) -> Surface:
        """A surface of Table 10 by name (S1-S5 sliders, G1-G5 slideways)."""
        r = load_table(10).row(name)
        return cls(H_max=r.H_max, R=r.R, z=r.z, D=r.D)


class SurfacePair(eqx.Module):
    r"""Two rough surfaces in contact over the apparent area `A_0` (mm$^2$), eqs (25)-(32).

    `slider`, `slideway`: `Surface`; `A_0` defaults to the chapter 7 model slideway,
    12.4 kgf / 0.344 kgf/cm$^2$ = 3604.7 mm$^2$.
    """

    slider: Surface
    slideway: Surface
    A_0: Scalar = eqx.field(converter=as_float, default=MODEL_APPARENT_AREA)

    def __check_init__(self):
        check_positive("SurfacePair", A_0=self.A_0)

    @property
    def R_e(self) -> Scalar:
        r"""Equivalent radius $R_e = R_1 R_2/(R_1 + R_2)$ (mm), section 7.2.2."""
        r1, r2 = self.slider.R, self.slideway.R
        return r1 * r2 / (r1 + r2)

    @property
    def I_0(self) -> Scalar:
        r"""Total number of asperities $I_0 = z_1 z_2 A_0$ (dimensionless; NOTES.md: the
        reading that reproduces Table 11)."""
        return self.slider.z * self.slideway.z * self.A_0

    @property
    def xi_product(self) -> Scalar:
        r"""$\xi_1 \xi_2$ (Table 12), dimensionless."""
        return self.slider.xi() * self.slideway.xi()

    @property
    def area_factor(self) -> Scalar:
        r"""$K = \pi R_e I_0 D_1 D_2 / (3 H_{max1} H_{max2})$ (mm$^{-1}$), so that
        $A_m = K a^3$ (eq 31) and $A_b = K[(a + t_b)^3 - a^3]$ (eq 32)."""
        s1, s2 = self.slider, self.slideway
        return jnp.pi * self.R_e * self.I_0 * s1.D * s2.D / (3.0 * s1.H_max * s2.H_max)

    def contact_count(self, a: Float[ArrayLike, "..."]) -> Float[Array, "..."]:
        r"""Number of contact points $I = I_0 D_1 D_2 a^2 / (2 H_{max1} H_{max2})$, eq (30);
        `a` is the approach in mm."""
        a = jnp.asarray(a, dtype=float)
        s1, s2 = self.slider, self.slideway
        return self.I_0 * s1.D * s2.D * a**2 / (2.0 * s1.H_max * s2.H_max)

    def metallic_area(self, a: Float[ArrayLike, "..."]) -> Float[Array, "..."]:
        r"""Metallic contact area $A_m = K a^3$ (mm$^2$), eq (31); `a` in mm."""
        a = jnp.asarray(a, dtype=float)
        return self.area_factor * a**3

    def film_area(self, a: Float[ArrayLike, "..."], t_b: Float[ArrayLike, ""]) -> Float[Array, "..."]:
        r"""Area carried by the adsorbed film, $A_b = K[(a + t_b)^3 - a^3]$ (mm$^2$), eq (32);
        `a` and the film thickness `t_b` in mm."""
        a = jnp.asarray(a, dtype=float)
        t_b = jnp.asarray(t_b, dtype=float)
        # (a + t)^3 - a^3 written without cancellation
        return self.area_factor * t_b * (3.0 * a**2 + 3.0 * a * t_b + t_b**2)


def surface_pair(name: str, A_0: float = MODEL_APPARENT_AREA) -> SurfacePair:
    """A surface combination of Table 12 by name, e.g. "S1G1" (slider S1 on slideway G1)."""
    name = name.upper()
    if len(name) != 4 or name[0] != "S" or name[2] != "G":
        raise ValueError(f"surface pair {name!r}: expected a name like 'S1G1' (slider S_, slideway G_)")
    return SurfacePair(Surface.from_table(name[:2]), Surface.from_table(name[2:]), A_0)


def symmetric_pair(H_max, R, z, D, A_0: float = MODEL_APPARENT_AREA) -> SurfacePair:
    """Two identical surfaces (the section 7.4 calculations assume equal factors)."""
    s = Surface(H_max=H_max, R=R, z=z, D=D)
    return SurfacePair(s, s, A_0)
