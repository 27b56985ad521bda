r"""Design maps: steady stick-slip (chapter 5) over grids or samples of W, k, v and friction.

`design_map(friction, weight, stiffness, speed)` evaluates `stickslip_jax.steady_state`
(eqs 5-7 and corrected eq 12) at every point of the *broadcast* of W (kgf), k (kgf/mm),
v (mm/s) and every leaf of `friction` (a grid of parameters or a posterior sample):
``design_map(f, W[:, None], k[None, :], v)`` is a W x k map at one speed. The points
stream through `chunks.map_chunks`; `iter_design_map` yields the chunks for maps that do
not fit in memory. ``method=MapMethod.EXACT`` and ``MapMethod.CYCLE`` take the limit cycle
of the exact simulator instead (`design.exact`, `stickslip_jax.limit_cycle`).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import optimistix as optx

from stickslip_jax import Friction, steady_state
from stickslip_jax import slip_time as ss_slip_time
from stickslip_jax.steady import STEADY_SLIDING

from ..modes import MapMethod, check_member
from .chunks import collect, map_chunks
from .exact import exact_kernel
from .points import DesignMap, DesignPoints, design_points, outer

__all__ = ["DesignMap", "DesignPoints", "design_map", "design_points", "iter_design_map", "outer",
           "steady_kernel", "cycle_kernel", "exact_kernel"]


def steady_kernel(points: DesignPoints, shared=None) -> DesignMap:
    """`steady_state` vmapped over a chunk of design points (leaves of shape (n,))."""
    s = jax.vmap(steady_state)(points.friction, points.weight, points.stiffness, points.speed)
    return DesignMap(amplitude=s.amplitude, amplitude_ratio=s.amplitude_ratio,
                     frequency=s.frequency, frequency_ratio=s.frequency_ratio,
                     stick_time=s.stick_time, slip_time=s.slip_time,
                     natural_frequency=s.natural_frequency, critical_speed=s.critical_speed,
                     stick_slip=s.stick_slip,
                     converged=jnp.asarray(s.result == optx.RESULTS.successful), regime=s.regime)


def cycle_kernel(points: DesignPoints, shared=None) -> DesignMap:
    """`stickslip_jax.limit_cycle.limit_cycle` (the one-cycle map's fixed point: the exact
    simulator's settled cycle, at any speed, re-slips included) vmapped over a chunk of
    design points. `stick_slip` is True wherever the fixed point exists (every speed for
    eq (1) with m < 1: the undamped model has no sharp boundary; threshold `amplitude`
    for a tolerance); `critical_speed` stays eq (12)'s for comparison. `shared`: None,
    or the damping ratio zeta of the damped model (`limit_cycle(..., damping_ratio=)`),
    whose stick-slip ends at a sharp boundary."""
    from stickslip_jax.limit_cycle import limit_cycle

    def one(f, w, k, v):
        return limit_cycle(f, w, k, v, damping_ratio=shared)

    c = jax.vmap(one)(points.friction, points.weight, points.stiffness, points.speed)
    ok = c.result == optx.RESULTS.successful
    f0 = 1.0 / (2.0 * jax.vmap(ss_slip_time)(points.weight, points.stiffness))
    zero = jnp.zeros_like(c.amplitude)
    stick = ok & (c.stick_time > 0)
    return DesignMap(
        amplitude=jnp.where(stick, c.amplitude, zero),
        amplitude_ratio=jnp.where(stick, c.amplitude * points.stiffness / points.weight, zero),
        frequency=jnp.where(stick, c.frequency, zero),
        frequency_ratio=jnp.where(stick, c.frequency / f0, zero),
        stick_time=jnp.where(stick, c.stick_time, zero), slip_time=c.slip_time,
        natural_frequency=f0, critical_speed=c.critical_speed, stick_slip=stick,
        converged=jnp.asarray(ok), regime=jnp.where(stick, c.regime, STEADY_SLIDING))


def _kernel(method: MapMethod):
    if method is MapMethod.EXACT:
        return exact_kernel
    return cycle_kernel if method is MapMethod.CYCLE else steady_kernel


def iter_design_map(friction: Friction, weight, stiffness, speed, *,
                    method: MapMethod = MapMethod.STEADY,
                    chunk_size: int = 65_536, mesh=None, progress: bool = False,
                    damping_ratio=None):
    """Yield ``(start, stop, DesignMap)`` chunks of the flattened map (NumPy leaves).

    Use it to stream maps larger than memory to disk or into a reduction; the map's
    shape is ``design_points(...).shape``.
    """
    check_member("method", method, MapMethod)
    points = design_points(friction, weight, stiffness, speed)
    batch = DesignPoints(points.friction, points.weight, points.stiffness, points.speed, ())
    shared = None
    if damping_ratio is not None:
        if method is not MapMethod.CYCLE:
            raise ValueError(f"damping_ratio: only MapMethod.CYCLE has damping, not {method}")
        if not 0 <= float(damping_ratio) < 1:
            raise ValueError(f"damping ratio must lie in [0, 1), got {damping_ratio}")
        shared = jnp.asarray(float(damping_ratio))
    yield from map_chunks(_kernel(method), batch, points.shape, shared=shared,
                          chunk_size=chunk_size, mesh=mesh, progress=progress,
                          desc=f"{method.value} map")


def design_map(friction: Friction, weight, stiffness, speed, **options) -> DesignMap:
    r"""Stick-slip characteristics over the broadcast of friction parameters, W, k and v.

    Units in: W kgf, k kgf/mm, v mm/s; out as in `DesignMap`. `options` (those of
    `iter_design_map`): `method` a `MapMethod` (STEADY: eqs 5-7, 12, fast; CYCLE or
    EXACT; its value, "exact", is read as the member, a ValueError naming the choices
    otherwise); `chunk_size` points a chunk, sharded over `mesh` (default: all devices);
    `progress` a tqdm bar; `damping_ratio` (CYCLE only): zeta of the damped limit cycle,
    whose stick-slip boundary is sharp.
    """
    if "method" in options:
        options["method"] = MapMethod.parse(options["method"], "method")
    points = design_points(friction, weight, stiffness, speed)
    if math.prod(points.shape) == 0:
        raise ValueError("empty design map: every axis needs at least one point")
    return collect(iter_design_map(friction, weight, stiffness, speed, **options),
                   points.shape)
