"""The design points of a campaign, `Campaign`: the records planned or measured, each a
(W kgf, k kgf/mm, v mm/s). Read by `design.experiment` (information, designs, fits) and
`design.posterior` (the records already measured, for `stickslip plan`)."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

__all__ = ["Campaign"]


class Campaign(eqx.Module):
    """Design points of a campaign: W (kgf), k (kgf/mm), v (mm/s), arrays of shape (N,)."""

    weight: Float[Array, " N"]
    stiffness: Float[Array, " N"]
    speed: Float[Array, " N"]

    def __check_init__(self):
        shapes = {jnp.shape(self.weight), jnp.shape(self.stiffness), jnp.shape(self.speed)}
        if len(shapes) != 1 or len(next(iter(shapes))) != 1:
            raise ValueError(f"Campaign needs W, k and v of one shape (N,), got {shapes}")

    def __len__(self):
        return int(np.shape(self.weight)[0])

    def take(self, idx) -> Campaign:
        idx = np.asarray(idx)
        return Campaign(*(np.asarray(x)[idx] for x in (self.weight, self.stiffness, self.speed)))
