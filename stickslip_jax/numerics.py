"""Numerical helpers shared by the physics modules (NaN-safe powers and logs, float
conversion, construction-time checks of concrete values and bisection). Public: the fitting
package's effect families use `safe_power` too."""

import jax
import jax.numpy as jnp
import numpy as np


def as_float(x):
    """`x` as a float array (the converter of every physical field)."""
    return jnp.asarray(x, dtype=float)


def is_concrete(*xs) -> bool:
    """True when no argument is a tracer (checks on values can run)."""
    return not any(isinstance(x, jax.core.Tracer) for x in xs)


def check_positive(owner: str, **values):
    """ValueError naming the offending field when a concrete value is not finite and > 0."""
    if not is_concrete(*values.values()):
        return
    for name, v in values.items():
        arr = np.asarray(v)
        if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
            raise ValueError(f"{owner}: {name} must be finite and > 0, got {arr}")


def bisect(predicate, lo, hi, n: int = 100):
    """The transition of a predicate (False at `lo`, True at `hi`): (lo, hi) after `n`
    halvings (100: float64 interval widths reach adjacent floats); values only."""
    def body(_, lohi):
        lo, hi = lohi
        mid = 0.5 * (lo + hi)
        up = predicate(mid)
        return jnp.where(up, lo, mid), jnp.where(up, mid, hi)

    return jax.lax.fori_loop(0, n, body, (lo, hi))


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
