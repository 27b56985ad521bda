"""The design points of a map and the characteristics computed at each (the types every
map kernel shares: `maps` for eqs (5)-(7) and (12), `exact` for the event-driven simulator)."""

from __future__ import annotations

import equinox as eqx
import jax
import numpy as np
from jaxtyping import Array, Bool, Float

from stickslip_jax import Friction

Grid, Flags = Float[Array, "..."], Bool[Array, "..."]  # one value per design point


class DesignMap(eqx.Module):
    r"""Stick-slip characteristics at every design point (arrays of the map's shape).

    `amplitude` a (mm, eq 5; 0 where sliding is smooth), `amplitude_ratio` ak/W,
    `frequency` f (Hz), `frequency_ratio` f/f0, `stick_time` T1 (s), `slip_time` T2 (s),
    `natural_frequency` f0 (Hz), `critical_speed` v_c (mm/s, corrected eq 12),
    `stick_slip` (bool), `converged` (the stick-time solve, or the simulation, succeeded),
    `regime` (`stickslip_jax.steady.REGIMES`: 0 steady sliding, 1 stick-slip, 2 re-stick
    failure, where eq (6)'s amplitude is not the motion's).
    """

    amplitude: Grid
    amplitude_ratio: Grid
    frequency: Grid
    frequency_ratio: Grid
    stick_time: Grid
    slip_time: Grid
    natural_frequency: Grid
    critical_speed: Grid
    stick_slip: Flags
    converged: Flags
    regime: Array


class DesignPoints(eqx.Module):
    """Design points: `friction` (array leaves), W (kgf), k (kgf/mm), v (mm/s), all
    broadcastable to `shape`. Leaves are NumPy arrays, not yet broadcast."""

    friction: Friction
    weight: np.ndarray
    stiffness: np.ndarray
    speed: np.ndarray
    shape: tuple[int, ...] = eqx.field(static=True)


def design_points(friction: Friction, weight, stiffness, speed) -> DesignPoints:
    """Check and broadcast the arguments of a map (W kgf, k kgf/mm, v mm/s)."""
    if not isinstance(friction, Friction):
        raise ValueError(f"friction must be a stickslip_jax.Friction, got {type(friction)}")
    friction = jax.tree_util.tree_map(lambda x: np.asarray(x, dtype=float), friction)
    w, k, v = positive(weight, stiffness, speed)
    shapes = [np.shape(x) for x in jax.tree_util.tree_leaves(friction)] + [w.shape, k.shape, v.shape]
    try:
        shape = np.broadcast_shapes(*shapes)
    except ValueError as exc:
        raise ValueError(f"design-map arguments do not broadcast together: {shapes}") from exc
    return DesignPoints(friction, w, k, v, tuple(int(s) for s in shape))


def positive(weight, stiffness, speed) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """W, k, v as float arrays, or a ValueError naming one that is not finite and
    positive everywhere."""
    out = tuple(np.asarray(x, dtype=float) for x in (weight, stiffness, speed))
    for name, x in zip(("weight W", "stiffness k", "drive speed v"), out):
        if not np.all(np.isfinite(x) & (x > 0)):
            raise ValueError(f"{name} must be finite and positive everywhere")
    return out


def outer(*axes):
    """1-D axes reshaped to broadcast as an outer grid: ``outer(W, k, v)`` -> W x k x v."""
    n = len(axes)
    return tuple(np.asarray(a, dtype=float).reshape([-1 if i == j else 1 for j in range(n)])
                 for i, a in enumerate(axes))
