"""Numerical helpers shared by the physics modules (NaN-safe powers and logs)."""

import jax.numpy as jnp


def safe_power(t, p):
    """`t**p` for t >= 0 that is 0 at t = 0 with finite (zero) gradients there.

    Uses the double-`where` trick: the unsafe branch never sees t = 0, so neither the
    value nor the gradient with respect to `t` or `p` is NaN or infinite at t = 0.
    """
    positive = t > 0
    t_safe = jnp.where(positive, t, 1.0)
    return jnp.where(positive, t_safe**p, 0.0)


def one_minus_exp_neg(x):
    """`1 - exp(-x)` accurate for small x (`-expm1(-x)`)."""
    return -jnp.expm1(-x)
