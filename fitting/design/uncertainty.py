r"""Push a posterior sample of friction parameters through a design map.

For every design point (W kgf, k kgf/mm, v mm/s) `propagate` evaluates the steady
analysis (eqs 5-7, corrected eq 12) for every draw of the sample and reduces over
the draws on the device: the probability of stick-slip (the fraction of draws with
v < v_c), and the median and central credible band of the critical speed v_c and of
the amplitude a. Only the reduced values come back, so S draws x G points stream in
chunks of about `chunk_size` evaluations, sharded over all devices.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from stickslip_jax import Friction, steady_state

from .chunks import collect, map_chunks
from .points import DesignPoints, positive
from .posterior import sample_size


class UncertainMap(eqx.Module):
    r"""Posterior summaries per design point (arrays of the design shape).

    `probability`: fraction of draws with stick-slip; `critical_speed` (mm/s) and
    `amplitude` (mm): arrays with a last axis of 3 = (lower, median, upper) of the
    central `level` credible band; `amplitude_mean` (mm); `level`.
    """

    probability: Float[Array, "..."]
    critical_speed: Float[Array, "... 3"]
    amplitude: Float[Array, "... 3"]
    amplitude_mean: Float[Array, "..."]
    level: float = eqx.field(static=True)


class _Shared(eqx.Module):
    sample: Friction
    quantiles: Array


def _kernel(points: DesignPoints, shared: _Shared):
    """The draws of `shared.sample` (the points carry no friction) at every point of a chunk."""
    def one(w, k, v):
        s = jax.vmap(steady_state, in_axes=(0, None, None, None))(shared.sample, w, k, v)
        q = shared.quantiles
        return (jnp.mean(s.stick_slip.astype(float)), jnp.quantile(s.critical_speed, q),
                jnp.quantile(s.amplitude, q), jnp.mean(s.amplitude))

    return jax.vmap(one)(points.weight, points.stiffness, points.speed)


def propagate(sample: Friction, weight, stiffness, speed, *, level: float = 0.9,
              chunk_size: int = 262_144, mesh=None, progress: bool = False) -> UncertainMap:
    """Probability of stick-slip and credible bands of v_c and a over a W, k, v map.

    `sample`: a `Friction` with leaves of shape (S,) (`posterior.load_samples`);
    `weight` (kgf), `stiffness` (kgf/mm), `speed` (mm/s) broadcast together to the
    design shape; `level` the central credible mass (0.9 -> 5 % and 95 % quantiles).
    """
    if not 0 < level < 1:
        raise ValueError(f"level must be in (0, 1), got {level}")
    s = sample_size(sample)
    w, k, v = positive(weight, stiffness, speed)
    shape = np.broadcast_shapes(w.shape, k.shape, v.shape)
    q = np.array([(1 - level) / 2, 0.5, (1 + level) / 2])
    shared = _Shared(jax.tree_util.tree_map(np.asarray, sample), q)
    out = collect(map_chunks(_kernel, DesignPoints(None, w, k, v, ()), shape, shared=shared,
                             chunk_size=max(1, chunk_size // s), mesh=mesh, progress=progress,
                             desc="posterior map"),
                  shape)
    prob, vc, amp, amp_mean = out
    return UncertainMap(prob, vc, amp, amp_mean, float(level))
