"""Shared by the simulator tests: getters of a `Slideway`'s friction parameters by name
(eqx.tree_at targets, for gradients leaf by leaf), the test slideway and drive speed of
the smoothed-simulator tests, and the amplitude of a trace's last cycles and its error
against the exact simulator's."""

import numpy as np

from stickslip_jax import Slideway, lubricant

SW = Slideway(lubricant("A"), 36.0, 86.9)
V = 0.05  # mm/s (3 mm/min): stick time about 1.6 s


def amplitude_after(x, ts, t_from):
    """Half the peak-to-peak deflection (mm) of `x` over the samples at `ts` >= `t_from`."""
    sel = np.asarray(ts) >= t_from
    x = np.asarray(x)[sel]
    return 0.5 * (x.max() - x.min())


def amplitude_error_against_exact():
    """Sample times (s) of a 6.5 s run of `SW` at `V`, and a function of a deflection
    trace on them: the relative error of its last cycle's amplitude against the exact
    simulator's."""
    import equinox as eqx
    import jax.numpy as jnp

    from stickslip_jax.drives import ConstantSpeed
    from stickslip_jax.simulation import simulate_exact

    ts = jnp.linspace(0.0, 6.5, 6501)
    # compiled whole: one program, which JAX's persistent cache keeps for the other
    # module's process (op by op, some 90 small programs compiled in each)
    ex = eqx.filter_jit(simulate_exact)(SW, ConstantSpeed(V), ts, max_events=16)
    c = ex.cycles
    t_from = float(c.breakaway_time[int(c.valid.sum()) - 1]) - 0.2  # the last cycle
    amp = amplitude_after(ex.deflection, ts, t_from)
    return ts, lambda x: abs(amplitude_after(x, ts, t_from) / amp - 1)

FRICTION_LEAVES = {
    "mu_s": lambda s: s.friction.static.mu_s,
    "mu_d": lambda s: s.friction.static.mu_d,
    "gamma": lambda s: s.friction.static.gamma,
    "m": lambda s: s.friction.static.m,
    "delta": lambda s: s.friction.kinetic.delta,
    "n": lambda s: s.friction.kinetic.n,
}
