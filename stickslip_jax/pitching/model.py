r"""The pitching/yawing model of chapter 6: moments, compliance, squeeze-film lag, geometry.

Coordinates and units (internal: kgf, mm, s, rad):

- `s` runs along the slideway in the drive direction (mm). Measuring points and the
  pivot of each tilt plane are given by their `s` position.
- The drive point is `DrivePoint(height, offset)`: `height` h (mm) above the slide
  surface, `offset` l (mm) sideways from the slider's centre of gravity (positive
  towards the inverted-V way).
- Pitch (vertical plane) angle $\varepsilon_v$ and yaw (horizontal plane) angle
  $\varepsilon_h$ in rad. A measuring point at `s` moves by
  $\delta = \varepsilon\,(s - s_{pivot})$ in mm: vertically for pitch points (the
  paper's points 1-3), sideways for yaw points (points 4-5).

Physics (sections 6.2-6.4): the moments $M_v = F (h - h_{Mv})$, $M_h = F (l - l_{Mh})$
(kgf mm) of the spring force $F = k x$ tilt the slider by $c M$ (`TiltPlane`; the line
$\varepsilon_s$, Figs 54-55), followed through a squeeze-film lag (`LinearLag`) whose time
constants scale with the viscosity $\eta$ (`PitchingModel`, Figs 55-56).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..numerics import as_float

ETA_A = 2.2e-8
"""Viscosity of the paper's lubricant A in kgf*s/mm^2 (NOTES.md: 0.216 Pa*s, ~195 cSt)."""


def _as_vector(x):
    return jnp.atleast_1d(jnp.asarray(x, dtype=float))


class LinearLag(eqx.Module):
    r"""Squeeze-film lag of the tilt: a sum of first-order modes (section 6.3).

    The tilt follows the static tilt $u(t) = c M(t)$ through
    $\varepsilon = w_0 u + \sum_j \theta_j$, $\tau_j \dot\theta_j = w_j u - \theta_j$,
    with $w_0 = 1 - \sum_j w_j$ the instantaneous (elastic) share. The static gain is 1,
    so a slowly varying moment gives the paper's $\varepsilon_s$; a ramp of the force
    gives the lagging rise $\varepsilon_u$ (Figs 54-55) and a sudden drop of the force
    the recovery $\varepsilon_d$ (Fig 56), from one linear model, so the superposition
    of section 6.3 holds exactly.

    `time_constants` $\tau_j$ in s at the model's reference viscosity, `weights`
    $w_j$ (dimensionless, $0 \le w_j$, $\sum w_j \le 1$). One mode with weight 1 is the
    plain first-order squeeze lag.
    """

    time_constants: Float[Array, " modes"] = eqx.field(converter=_as_vector)
    weights: Float[Array, " modes"] = eqx.field(converter=_as_vector)

    def __check_init__(self):
        if self.time_constants.ndim != 1 or self.time_constants.shape != self.weights.shape:
            raise ValueError(
                "LinearLag: time_constants and weights must be 1-D of the same length, got "
                f"{self.time_constants.shape} and {self.weights.shape}")

    @property
    def instantaneous_weight(self) -> Float[Array, ""]:
        """Share $w_0 = 1 - \\sum w_j$ of the tilt that follows the moment without lag."""
        return 1.0 - jnp.sum(self.weights)


def first_order(time_constant) -> LinearLag:
    """A single first-order squeeze lag with time constant `time_constant` (s)."""
    return LinearLag(time_constants=time_constant, weights=1.0)


class TiltPlane(eqx.Module):
    r"""One tilt plane (pitch: vertical, yaw: horizontal).

    - `compliance` $c$: static tilt per unit moment, rad/(kgf mm) (line $\varepsilon_s$);
    - `neutral`: position of the friction resultant's point, mm; the height $h_{Mv}$ for
      pitch, the offset $l_{Mh}$ for yaw (Figs 52-53, 62);
    - `lag`: the squeeze-film `LinearLag`, time constants at the reference viscosity;
    - `pivot`: `s` position (mm) of the axis the slider turns about.
    """

    compliance: Float[Array, ""] = eqx.field(converter=as_float)
    neutral: Float[Array, ""] = eqx.field(converter=as_float)
    lag: LinearLag
    pivot: Float[Array, ""] = eqx.field(converter=as_float, default=0.0)

    def __check_init__(self):
        if not isinstance(self.lag, LinearLag):
            raise ValueError(f"TiltPlane.lag must be a LinearLag, got {type(self.lag)}")

    def arm(self, position) -> Float[Array, "..."]:
        """Moment arm in mm: drive height minus $h_{Mv}$ (pitch) or offset minus $l_{Mh}$ (yaw)."""
        return jnp.asarray(position, dtype=float) - self.neutral


class DrivePoint(eqx.Module):
    """Where the spring force acts: `height` h above the slide surface and `offset` l
    sideways from the centre of gravity, both in mm (Fig 42: C1, C2, C3, V, F, C1*)."""

    height: Float[Array, "..."] = eqx.field(converter=as_float)
    offset: Float[Array, "..."] = eqx.field(converter=as_float, default=0.0)


PITCH = "pitch"
YAW = "yaw"


class MeasuringPoints(eqx.Module):
    """Positions `s` (mm, along the slideway) of the measuring points and the plane each
    belongs to (`planes`: "pitch" for vertical points, "yaw" for horizontal points).
    `names` are the record channel names, e.g. ("pitch_1", ..., "yaw_5")."""

    positions: Float[Array, " points"] = eqx.field(converter=_as_vector)
    planes: tuple[str, ...] = eqx.field(static=True)
    names: tuple[str, ...] = eqx.field(static=True)

    def __check_init__(self):
        n = self.positions.shape[0]
        if len(self.planes) != n or len(self.names) != n:
            raise ValueError(f"MeasuringPoints: {n} positions but {len(self.planes)} planes and "
                             f"{len(self.names)} names")
        bad = [p for p in self.planes if p not in (PITCH, YAW)]
        if bad:
            raise ValueError(f"MeasuringPoints: planes must be 'pitch' or 'yaw', got {bad}")

    @property
    def is_pitch(self) -> tuple[bool, ...]:
        return tuple(p == PITCH for p in self.planes)

    def index(self, point: str) -> int:
        """The index of the point named `point`; ValueError naming the points otherwise."""
        if point not in self.names:
            raise ValueError(f"point must be one of {self.names}, got {point!r}")
        return self.names.index(point)


def paper_points(length: float = 240.0, point2: float = 10.0) -> MeasuringPoints:
    """Five points laid out like Fig 42: 1-3 vertical (front, near the pivot, rear),
    4-5 horizontal (front, rear); `length` is the front-to-rear spacing in mm and
    `point2` the distance of point 2 from the pitch pivot (mm; the paper's point 2 sits
    near the intimate-contact point d and moves little). Positions are illustrative:
    the paper's drawing is lost."""
    half = 0.5 * length
    return MeasuringPoints(positions=(half, point2, -half, half, -half),
                           planes=(PITCH, PITCH, PITCH, YAW, YAW),
                           names=("pitch_1", "pitch_2", "pitch_3", "yaw_4", "yaw_5"))


class PitchingModel(eqx.Module):
    r"""Pitching and yawing of the slider driven by the spring force (chapter 6).

    `pitch`, `yaw`: the two `TiltPlane`s; `points`: the `MeasuringPoints`;
    `viscosity` $\eta$ of the lubricant in use and `reference_viscosity` $\eta_{ref}$ at
    which the lags' time constants are given (kgf s/mm^2). The squeeze-film time
    constants scale as $\tau = \tau_{ref}\,\eta/\eta_{ref}$ (squeeze damping is
    proportional to the viscosity, the restoring stiffness is not, Fig 55: the line
    $\varepsilon_s$ does not depend on the lubricant).
    """

    pitch: TiltPlane
    yaw: TiltPlane
    points: MeasuringPoints
    viscosity: Float[Array, ""] = eqx.field(converter=as_float, default=ETA_A)
    reference_viscosity: Float[Array, ""] = eqx.field(converter=as_float, default=ETA_A)

    def __check_init__(self):
        for name in ("pitch", "yaw"):
            if not isinstance(getattr(self, name), TiltPlane):
                raise ValueError(f"PitchingModel.{name} must be a TiltPlane")
        if not isinstance(self.points, MeasuringPoints):
            raise ValueError("PitchingModel.points must be MeasuringPoints")

    def plane(self, name: str) -> TiltPlane:
        if name not in (PITCH, YAW):
            raise ValueError(f"plane must be 'pitch' or 'yaw', got {name!r}")
        return self.pitch if name == PITCH else self.yaw

    @property
    def viscosity_ratio(self) -> Float[Array, ""]:
        return self.viscosity / self.reference_viscosity

    def with_viscosity(self, viscosity) -> PitchingModel:
        """The same slider with another lubricant viscosity (kgf s/mm^2)."""
        return eqx.tree_at(lambda m: m.viscosity, self, as_float(viscosity))


def default_model(viscosity: float = ETA_A) -> PitchingModel:
    r"""An illustrative slider shaped like the paper's (Fig 42), not a fit to its figures
    (they were lost in the text): $h_{Mv}$ = 30 mm (between the drive points C1 and C2 of
    `PAPER_DRIVE_POINTS`), $l_{Mh}$ = 5 mm towards the V way, pitch compliance
    8e-8 rad/(kgf mm) with a 1 s squeeze lag at lubricant A's viscosity, yaw compliance
    1e-7 rad/(kgf mm) with a 10 s lag (only a slight restoring moment sideways, section
    6.4, so the yaw recovers slowly and its per-cycle variation is small, Fig 61).
    """
    return PitchingModel(pitch=TiltPlane(compliance=8e-8, neutral=30.0, lag=first_order(1.0)),
                         yaw=TiltPlane(compliance=1e-7, neutral=5.0, lag=first_order(10.0)),
                         points=paper_points(), viscosity=viscosity, reference_viscosity=ETA_A)


PAPER_DRIVE_POINTS = {"C1": DrivePoint(height=20.0, offset=0.0),
                      "C2": DrivePoint(height=45.0, offset=0.0),
                      "C3": DrivePoint(height=70.0, offset=0.0),
                      "V": DrivePoint(height=45.0, offset=40.0),
                      "F": DrivePoint(height=45.0, offset=-40.0)}
"""Illustrative drive points with the layout of Fig 42 (heights/offsets in mm): C1-C3 one
above the other through the centre of gravity (C2 at it), V and F sideways."""
