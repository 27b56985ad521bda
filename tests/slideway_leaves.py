"""Getters of a `Slideway`'s friction parameters by name (eqx.tree_at targets), shared by
the simulator tests that check gradients leaf by leaf."""

FRICTION_LEAVES = {
    "mu_s": lambda s: s.friction.static.mu_s,
    "mu_d": lambda s: s.friction.static.mu_d,
    "gamma": lambda s: s.friction.static.gamma,
    "m": lambda s: s.friction.static.m,
    "delta": lambda s: s.friction.kinetic.delta,
    "n": lambda s: s.friction.kinetic.n,
}
