r"""Effect families of the per-cycle discovery model (`cycle_model`).

Every family has parameters that are **zero when the effect is absent** and, where the
physics has a shape the data must choose, a small grid of **shapes** (scanned by the
score test, `cycle_workflow`): the effect forms of a real slideway will not be ours
exactly, so a family is a set of forms, not one formula. Units are internal (kgf, mm, s).

| name | enters the per-cycle model as | parameters | shapes scanned |
|---|---|---|---|
| `viscous_damping` | slip force $-c\,\dot y$ | c kgf s/mm (dashpot) or damping ratio $\zeta$, $c = 2\zeta\sqrt{k m}$ per record | dashpot; ratio |
| `stribeck` | slip friction $+b\,s(\dot y/v_s)$, falling with slip speed from 0 at rest ($\mu_m$ is the friction the slip starts against): $s(w) = e^{-w^p} - 1$, $1/(1 + w^p) - 1$, $-w$, $-\ln(1 + w)$ (no floor, rate-and-state's steady state) | b (-) | exponential: $v_s$ 3, 10, 30 mm/s, p 1, 2; logarithmic: $v_s$ 1, 10 mm/s |
| `rate_state` | slip friction $+a\ln(1 + \dot y/V_\mathrm{ref}) + b\ln(\theta/\theta_b)$, Dieterich-Ruina with the aging law $\dot\theta = 1 - \dot y\theta/D_c$ | a, b (-) | $D_c$ 0.01, 0.03, 0.1 mm |
| `drive_periodic_error` | drive $u + \sum_{h=1,2} a_h \sin(2\pi h u/\lambda) + b_h\cos(\dots)$, per record | 4 per record, mm | $\lambda$ 1-10 mm |
| `drive_speed_drift` | drive speed $v(1 + s\,(t - t_\mathrm{mid}))$ | s 1/s | - |
| `sensor_lowpass` | gauge reads $x$ through a low-pass of mean delay $\tau$ | $\tau$ s | order 1; order 2 with damping ratio 0.4-1 |
| `friction_drift` | $\mu_s$, $\mu_d$ shift by $r_s t$, $r_d t$ (t from the record's start) | $r_s$, $r_d$ 1/s | - |
| `gauge_drift` | gauge zero drifts: reads $x + r t$ | r mm/s | - |
| `load_coupling` | normal load $N = W + \kappa k x$ (drive moment, ch. 6) | $\kappa$ (-) | - |

`scales`: a typical detectable size (fit coordinate = value / scale); `signs`: +1 where
physics requires >= 0 (a passive damper dissipates; a sensor is causal; a Stribeck curve
lowers friction as the slip goes on; rate-and-state's a and b are Dieterich and Ruina's
positive constants, the evolution effect b a friction that falls as the contact state
renews, as the base law `law_params.RateStateAgingFriction` and the whole-record base's
`effects.RateState` hold them), 0 for either sign; `bound`: the largest physical magnitude
(a fit beyond it is unphysical, never named; why in `bound_note`). The drive error is
bounded on the error itself (`drive_error_range` <= `DRIVE_ERROR_MAX`), not its
coefficients: a record shorter than a pitch sees a piece of the sine, which large
coefficients of opposite sign draw.

The **stick terms** (`STICK_TERMS`, `stick_terms`) are no family (never scanned or
named): a displacement $q(s) = \sum_j c_j\phi_j(s)$ (mm) of the deflection during the
stick ($s$ the time since the last slip) added to the stick line before the breakaway
condition, so it moves the breakaway (a pre-slide creep, a drive's lost motion); the
sparse form of the residual (`discovery.sparse`) chooses and refits them.
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np

from stickslip_jax.modes import AbstractMode

__all__ = ["DAMPING_FORMS", "DRIVE_ERROR_MAX", "FAMILIES", "PITCH_STEP", "SHAPE_STEP",
           "STICK_SCALE", "STICK_TAUS", "STICK_TERMS", "STICK_TRAVELS", "STRIBECK_FORMS",
           "DampingForm", "Family", "Shape", "StribeckForm", "drive_error",
           "drive_error_range", "family", "neighbour_shapes", "stick_terms"]


class StribeckForm(AbstractMode):
    r"""Form of the Stribeck curve $s(w)$, $w = v/v_s$ (`Shape.form`): `EXP`
    $e^{-w^p} - 1$, `LOG` $-\ln(1 + w)$, `LINEAR` $-w$, `RATIONAL` $1/(1 + w^p) - 1$ (Hess
    and Soom's with p = 2). The value names the form in labels and JSON; the member's
    position is the per-cycle model's switch index (`cycle_model`). The linear form is
    not scanned: with a negative coefficient it is viscous damping's own (measured: on the
    damping benchmark campaign its refit outran the damping refit and made the answer
    uncertain)."""

    EXP = "exp"
    LOG = "log"
    LINEAR = "linear"
    RATIONAL = "rational"

    @property
    def has_exponent(self) -> bool:
        """Whether the curve has the exponent p (`EXP`, `RATIONAL`)."""
        return self in (StribeckForm.EXP, StribeckForm.RATIONAL)


class DampingForm(AbstractMode):
    """Viscous damping's form (`Shape.damping`): one dashpot c (kgf s/mm) for every record
    (`DASHPOT`), or one damping ratio zeta, c = 2 zeta sqrt(k m) in each record (`RATIO`,
    as a machine's modal damping is quoted). The value names the form in labels and JSON."""

    DASHPOT = "dashpot"
    RATIO = "ratio"


STRIBECK_FORMS = tuple(StribeckForm)
"""The Stribeck forms in the per-cycle model's switch order."""
DAMPING_FORMS = tuple(DampingForm)
"""Viscous damping's forms in the per-cycle model's index order."""
SENSOR_ZETAS = (0.4, 0.55, 0.7, 0.85, 1.0)
"""Damping ratios of the second-order sensor kernels scanned: under-damped amplifiers,
the Butterworth response of most anti-aliasing filters, critically damped."""
DRIVE_ERROR_MAX = 0.1
"""mm: a drive error larger than 100 um over a record is a broken drive, not an effect (a
worn lead screw's periodic error reaches tens of um: the independent generator's largest,
20 um with a 30 % second harmonic, spans about 50 um peak to peak)."""


STICK_TAUS = (0.01, 0.03, 0.1)
"""s: time constants of the approach-to-breakaway (creep) stick terms."""
STICK_TRAVELS = (0.002, 0.004, 0.008, 0.016)
"""mm: drive travels over which the lost-motion stick terms are taken up."""
STICK_TERMS = (("stick_level", "stick_x1", "stick_x2", "stick_x3", "stick_s1", "stick_s2")
               + tuple(f"stick_phase{p}" for p in (1, 2, 4, 8))
               + tuple(f"stick_creep{int(t * 1e3)}ms" for t in STICK_TAUS)
               + tuple(f"stick_lost{int(L * 1e3)}um" for L in STICK_TRAVELS))
"""The stick terms' names, in the order of `stick_terms`' columns (module doc)."""
STICK_SCALE = 1e-3
"""Model coordinate of a stick term = its coefficient / this (1 um for the mm terms)."""


def stick_terms(s, T1, x, v):
    """[..., len(STICK_TERMS)] the stick terms at the time since the last slip s (s,
    clipped at 0), the measured stick time T1 (s), the stick line's deflection x (mm) and
    the drive speed v (mm/s): 1; x, x^2, x^3; s, s^2; (s/T1)^p, p = 1, 2, 4, 8 (s/T1
    clipped to [0, 1.5]); exp(-(T1 - s)/tau) (s <= T1), tau `STICK_TAUS`; min(v s, L)/L,
    L `STICK_TRAVELS`. JAX or NumPy input."""
    s = jnp.maximum(s, 0.0)
    ph = jnp.clip(s / T1, 0.0, 1.5)
    cols = [jnp.ones_like(s), x, x * x, x ** 3, s, s * s, ph, ph ** 2, ph ** 4, ph ** 8]
    cols += [jnp.exp(-jnp.maximum(T1 - s, 0.0) / tau) for tau in STICK_TAUS]
    cols += [jnp.minimum(v * s, L) / L for L in STICK_TRAVELS]
    return jnp.stack(jnp.broadcast_arrays(*cols), axis=-1)


def drive_error(coef, t, speed, pitch, xp=jnp):
    """The drive error (mm) of `drive_periodic_error` at times t (s) of a record driven
    at `speed` (mm/s): coef = (a1_sin, a1_cos, a2_sin, a2_cos) mm, `pitch` mm; `xp`:
    `numpy` on the host (eager JAX would compile a program per record length)."""
    ph = 2.0 * xp.pi * speed * t / pitch
    s, c = xp.sin(ph), xp.cos(ph)  # the second harmonic by the double-angle formulas
    return coef[0] * s + coef[1] * c + coef[2] * (2.0 * s * c) + coef[3] * (c * c - s * s)


def drive_error_range(coef, t, speed, pitch) -> float:
    """Peak-to-peak of `drive_error` over the times t (mm)."""
    e = drive_error(np.asarray(coef, float), np.asarray(t, float), speed, pitch, np)
    return float(e.max() - e.min())


@dataclasses.dataclass(frozen=True)
class Shape:
    """Shape settings of the model (traced, so one compilation serves every shape):
    Stribeck speed scale `vs` (mm/s), exponent `p` and curve `form` (`StribeckForm`),
    rate-and-state D_c `length` (mm), screw `pitch` (mm), sensor kernel `order` (1 or 2)
    and its damping ratio `zeta`, viscous `damping` form (`DampingForm`). A form given by
    its value ("rational", "ratio") is taken as that member."""

    vs: float = 10.0
    p: float = 1.0
    length: float = 0.03
    pitch: float = 5.0
    order: int = 1
    zeta: float = 1.0
    form: StribeckForm = StribeckForm.EXP
    damping: DampingForm = DampingForm.DASHPOT

    def __post_init__(self):
        object.__setattr__(self, "form", StribeckForm.parse(self.form, "form"))
        object.__setattr__(self, "damping", DampingForm.parse(self.damping, "damping"))

    def label(self, fam: "Family") -> str:
        keys = {"stribeck": {StribeckForm.EXP: ("vs", "p"),
                             StribeckForm.RATIONAL: ("form", "vs", "p")}.get(
                    self.form, ("form", "vs")),
                "rate_state": ("D_c",),
                "viscous_damping": ("damping",),
                "drive_periodic_error": ("pitch",),
                "sensor_lowpass": ("order",) if self.order == 1 else ("order", "zeta")}
        value = {"vs": self.vs, "p": self.p, "D_c": self.length, "pitch": self.pitch,
                 "order": self.order, "zeta": self.zeta, "form": self.form.value,
                 "damping": self.damping.value}
        return ", ".join(f"{k} = {value[k]:g}" if k not in ("form", "damping")
                         else f"{value[k]}"
                         for k in keys.get(fam.name, ()))


@dataclasses.dataclass(frozen=True)
class Family:
    name: str
    explanation: str
    params: tuple[str, ...]
    units: tuple[str, ...]
    scales: tuple[float, ...]
    signs: tuple[int, ...]
    bound: tuple[float, ...]
    bound_note: str
    shapes: tuple[Shape, ...] = (Shape(),)
    per_record: bool = False

    def named(self, shape: Shape) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """The parameters' names and units in this shape (viscous damping's ratio form
        fits the damping ratio zeta, dimensionless, instead of c)."""
        if self.name == "viscous_damping" and shape.damping is DampingForm.RATIO:
            return ("zeta",), ("-",)
        return self.params, self.units

    def support(self) -> tuple[tuple[float, float], ...]:
        """Each parameter's physical range (natural units): [0, bound] where physics
        requires >= 0 (`signs` +1), [-bound, bound] otherwise (a fit beyond it is
        unphysical, `unphysical`)."""
        return tuple((0.0 if sign > 0 else -b, b) for sign, b in zip(self.signs, self.bound))

    def n_params(self, n_records: int) -> int:
        return len(self.params) * (n_records if self.per_record else 1)

    def unphysical(self, values: np.ndarray) -> str | None:
        """Why fitted natural `values` (flat, per record repeated) are not physical, or None."""
        k = len(self.params)
        v = np.asarray(values, float).reshape(-1, k)
        bad = []
        for j, p in enumerate(self.params):
            if self.signs[j] > 0 and np.any(v[:, j] < 0):
                bad.append(f"{p} = {v[:, j].min():.3g} < 0")
            if np.any(np.abs(v[:, j]) > self.bound[j]):
                bad.append(f"|{p}| = {np.abs(v[:, j]).max():.3g} > {self.bound[j]:g} "
                           f"({self.bound_note})")
        return "; ".join(bad) or None


FAMILIES: tuple[Family, ...] = (
    Family("viscous_damping",
           "A force proportional to the slider velocity (a viscous oil film or a damper) "
           "resists the slip, so slips are slower and smaller than dry friction predicts.",
           ("c",), ("kgf*s/mm",), (0.01,), (1,), (1.0,),
           "a damping ratio above about 1 would stop stick-slip altogether",
           shapes=(Shape(), Shape(damping=DampingForm.RATIO))),
    Family("stribeck",
           "Kinetic friction falls with slip speed (a Stribeck curve): the slip starts "
           "against higher friction than it ends with.",
           ("b",), ("-",), (0.01,), (1,), (0.5,), "a friction step larger than mu itself",
           shapes=tuple(Shape(vs=vs, p=p) for vs in (3.0, 10.0, 30.0) for p in (1.0, 2.0))
           + tuple(Shape(vs=vs, form=StribeckForm.LOG) for vs in (1.0, 10.0))),
    Family("rate_state",
           "Rate-and-state friction (Dieterich-Ruina): friction rises with the slip speed "
           "(direct effect a) and falls as the contact state renews over a slip distance "
           "D_c (evolution effect b), so each slip starts against the friction the stick "
           "has aged to and ends against less.",
           ("a", "b"), ("-", "-"), (0.001, 0.001), (1, 1), (0.1, 0.1),
           "rate-and-state coefficients above 0.1 (lubricated metals: 0.001-0.02)",
           shapes=tuple(Shape(length=L) for L in (0.01, 0.03, 0.1))),
    Family("drive_periodic_error",
           "The drive is not u = v t: a periodic error of the lead screw (first and second "
           "harmonic of its pitch) moves the spring's far end back and forth.",
           ("a1_sin", "a1_cos", "a2_sin", "a2_cos"), ("mm",) * 4, (1e-3,) * 4, (0,) * 4,
           (DRIVE_ERROR_MAX,) * 4,
           "a screw error above 100 um is a broken drive, not an effect",
           shapes=tuple(Shape(pitch=p) for p in (1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0,
                                                 8.0, 10.0)),
           per_record=True),
    Family("drive_speed_drift",
           "The drive speed drifts slowly during a record (a motor or belt warming up).",
           ("s",), ("1/s",), (1e-4,), (0,), (0.01,), "more than 1 % speed change per second"),
    Family("sensor_lowpass",
           "The gauge or its amplifier is a low-pass filter: the record lags and rounds the "
           "fast slips.",
           ("tau",), ("s",), (1e-3,), (1,), (0.05,),
           "a gauge slower than 50 ms cannot show slips at all",
           shapes=(Shape(order=1),) + tuple(Shape(order=2, zeta=z) for z in SENSOR_ZETAS)),
    Family("friction_drift",
           "The friction level drifts with time (temperature, wear, lubricant spreading).",
           ("r_s", "r_d"), ("1/s", "1/s"), (1e-4, 1e-4), (0, 0), (0.01, 0.01),
           "friction changing by more than 0.01 per second"),
    Family("gauge_drift",
           "The gauge zero drifts (thermal drift of the sensor or amplifier).",
           ("r",), ("mm/s",), (1e-5,), (0,), (1e-3,), "more than 1 um/s of zero drift"),
    Family("load_coupling",
           "The normal load changes with the spring force (a drive moment pitching the "
           "slider, ch. 6): friction grows with the deflection where the moment presses "
           "the slider down (kappa > 0) and falls where it lifts it (kappa < 0).",
           ("kappa",), ("-",), (0.01,), (0,), (1.0,), "kappa mu above 1 lifts the slider"),
)


SHAPE_STEP = 1.6
"""Factor between neighbouring speed scales, slip distances and pitches in the shape
refinement (`neighbour_shapes`)."""


PITCH_STEP = 1.1
"""Factor between neighbouring screw pitches in the shape refinement (the scanned
pitches are 1.2-1.5x apart)."""


def neighbour_shapes(fam: Family, shape: Shape) -> list[Shape]:
    """The shapes next to `shape` (the shape refinement's local search): speed scales and
    slip distances x or / `SHAPE_STEP`, pitches x or / `PITCH_STEP`, the Stribeck exponent
    +-1 (0.5 at least) and other forms, the sensor's damping ratio +-0.15 (0.3-1) and
    other order. Empty for families without shapes."""
    rep = dataclasses.replace
    out: list[Shape] = []
    if fam.name == "stribeck":
        out += [rep(shape, vs=shape.vs * SHAPE_STEP), rep(shape, vs=shape.vs / SHAPE_STEP)]
        if shape.form.has_exponent:
            out += [rep(shape, p=shape.p + 1.0), rep(shape, p=max(shape.p - 1.0, 0.5))]
        out += [rep(shape, form=f, p=shape.p if f.has_exponent else 1.0)
                for f in (StribeckForm.EXP, StribeckForm.RATIONAL, StribeckForm.LOG)
                if f is not shape.form]
    elif fam.name == "viscous_damping":
        out += [rep(shape, damping=d) for d in DampingForm if d is not shape.damping]
    elif fam.name == "rate_state":
        out += [rep(shape, length=shape.length * SHAPE_STEP),
                rep(shape, length=shape.length / SHAPE_STEP)]
    elif fam.name == "drive_periodic_error":
        out += [rep(shape, pitch=shape.pitch * PITCH_STEP),
                rep(shape, pitch=shape.pitch / PITCH_STEP)]
    elif fam.name == "sensor_lowpass":
        if shape.order == 2:
            out += [rep(shape, zeta=min(shape.zeta + 0.15, 1.0)),
                    rep(shape, zeta=max(shape.zeta - 0.15, 0.3)), rep(shape, order=1)]
        else:
            out += [rep(shape, order=2, zeta=0.7)]
    return [s for s in dict.fromkeys(out) if s != shape]


def family(name: str) -> Family:
    for f in FAMILIES:
        if f.name == name:
            return f
    raise ValueError(f"unknown effect {name!r}; choose from "
                     f"{', '.join(f.name for f in FAMILIES)}")
