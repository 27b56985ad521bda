r"""Design of the drive point: the point of least tilt (the paper's C1*) and maps of the tilt.

The moments $F(h - h_{Mv})$ and $F(l - l_{Mh})$ are linear in the drive height and offset
and every tilt measure (peak, mean, variation, at any point) is proportional to
$|h - h_{Mv}|$ in pitch and $|l - l_{Mh}|$ in yaw, at every speed. So the drive point
that minimises the tilt within a feasible box is the neutral point $(h_{Mv}, l_{Mh})$
projected onto the box, whatever the speed or lubricant (section 6.4, Fig 63: C1* has
the lowest feasible height, C1's, and the offset of $M_h$).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..friction import Friction
from .metrics import SteadyTilt, tilt_against_speed
from .model import DrivePoint, PitchingModel


class DesignPoint(eqx.Module):
    """`drive`: the drive point of least tilt (mm); `pitch_arm`, `yaw_arm`: its remaining
    moment arms $h - h_{Mv}$, $l - l_{Mh}$ (mm; zero when the neutral point is reachable)."""

    drive: DrivePoint
    pitch_arm: Float[Array, ""]
    yaw_arm: Float[Array, ""]


def best_drive_point(model: PitchingModel, height_range=(-jnp.inf, jnp.inf),
                     offset_range=(-jnp.inf, jnp.inf)) -> DesignPoint:
    r"""Drive point minimising pitching and yawing within the box `height_range` x
    `offset_range` (mm): $(\mathrm{clip}(h_{Mv}), \mathrm{clip}(l_{Mh}))$ (Fig 63's C1*)."""
    h = jnp.clip(model.pitch.neutral, height_range[0], height_range[1])
    l_ = jnp.clip(model.yaw.neutral, offset_range[0], offset_range[1])
    return DesignPoint(drive=DrivePoint(height=h, offset=l_), pitch_arm=model.pitch.arm(h),
                       yaw_arm=model.yaw.arm(l_))


class TiltMap(eqx.Module):
    """Tilt of one measuring point over drive positions (columns) and speeds (rows):
    `peak` $\\varepsilon'$ and `variation` $\\Delta\\varepsilon$ in mm, `positions` (mm,
    heights for pitch points, offsets for yaw points) and `speeds` (mm/s)."""

    peak: Float[Array, "speeds positions"]
    variation: Float[Array, "speeds positions"]
    positions: Float[Array, " positions"]
    speeds: Float[Array, " speeds"]


def variation_map(model: PitchingModel, friction: Friction, weight, stiffness, speeds, positions,
                  point: str = "pitch_1") -> TiltMap:
    r"""$\varepsilon'$ and $\Delta\varepsilon$ (mm) at `point` over drive `speeds` (mm/s) and
    drive `positions` (mm: heights $h$ for a pitch point, offsets $l$ for a yaw point; the
    other coordinate stays at its neutral value). Figs 52-53 and the design map of $\Delta
    \varepsilon$ over height and speed. Uses the linearity in the arm: one steady sweep at
    a unit arm, scaled."""
    idx = model.points.index(point)
    pitch = model.points.planes[idx] == "pitch"
    unit = DrivePoint(height=model.pitch.neutral + (1.0 if pitch else 0.0),
                      offset=model.yaw.neutral + (0.0 if pitch else 1.0))
    sweep: SteadyTilt = tilt_against_speed(model, friction, weight, stiffness, speeds, unit)
    positions = jnp.asarray(positions, dtype=float)
    neutral = model.pitch.neutral if pitch else model.yaw.neutral
    arm = positions - neutral
    peak = sweep.points.peak[:, idx, None] * arm[None, :]
    variation = sweep.points.variation[:, idx, None] * jnp.abs(arm)[None, :]
    return TiltMap(peak=peak, variation=variation, positions=positions,
                   speeds=jnp.asarray(speeds, dtype=float))
