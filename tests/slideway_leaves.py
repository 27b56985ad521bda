"""Shared by the simulator tests: getters of a `Slideway`'s friction parameters by name
(eqx.tree_at targets, for gradients leaf by leaf), the test slideway and drive speed of
the smoothed-simulator tests, and the amplitude of a trace's last cycles."""

import numpy as np

from stickslip_jax import Slideway, lubricant

SW = Slideway(lubricant("A"), 36.0, 86.9)
V = 0.05  # mm/s (3 mm/min): stick time about 1.6 s


def amplitude_after(x, ts, t_from):
    """Half the peak-to-peak deflection (mm) of `x` over the samples at `ts` >= `t_from`."""
    sel = np.asarray(ts) >= t_from
    x = np.asarray(x)[sel]
    return 0.5 * (x.max() - x.min())

FRICTION_LEAVES = {
    "mu_s": lambda s: s.friction.static.mu_s,
    "mu_d": lambda s: s.friction.static.mu_d,
    "gamma": lambda s: s.friction.static.gamma,
    "m": lambda s: s.friction.static.m,
    "delta": lambda s: s.friction.kinetic.delta,
    "n": lambda s: s.friction.kinetic.n,
}
