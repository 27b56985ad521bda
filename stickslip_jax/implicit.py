r"""Scalar roots with the implicit function theorem's derivative: a root $y^*(\theta)$ of
$f(y, \theta) = 0$ found without gradients gets the tangent $-\partial_\theta f / f'(y^*)$
(`with_implicit_gradient`); `newton_root` is optimistix's Newton method with it (the
stick-time equations of `steady` and `limit_cycle`). optimistix's own implicit derivative
checks its linear solve at run time with a host callback, and JAX's persistent compilation
cache keeps no program that has one.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx


def newton_root(fn, y0, args, rtol: float, max_steps: int):
    """The root of the scalar `fn(y, args)` by Newton's method from `y0` (optimistix,
    rtol = atol = `rtol`), with the implicit function theorem's derivative in the arrays
    of `args`, and its `optimistix.RESULTS` (not raised)."""
    fixed = jax.tree_util.tree_map(lambda x: jax.lax.stop_gradient(x) if eqx.is_array(x) else x,
                                   args)
    sol = optx.root_find(fn, optx.Newton(rtol=rtol, atol=rtol), y0, args=fixed,
                         max_steps=max_steps, throw=False)
    return with_implicit_gradient(sol.value, lambda y: fn(y, args)), sol.result


def with_implicit_gradient(root, fn):
    r"""`root` (a root of `fn`, found without gradients) with the derivative of the
    implicit function theorem: value `root`, tangent $-\partial_\theta f / f'$ for the
    $\theta$ that `fn` closes over. First derivatives only (the slope $f'$ is held fixed).
    A zero slope (a masked branch that is not a root) counts as slope 1, so that its
    tangent stays finite and a `jnp.where` that drops it gives no NaN gradient."""
    root = jax.lax.stop_gradient(root)
    value, slope = jax.jvp(fn, (root,), (jnp.ones_like(root),))
    slope = jax.lax.stop_gradient(slope)
    return _implicit_tangent(root, value, -1.0 / jnp.where(slope != 0, slope, 1.0))


@jax.custom_jvp
def _implicit_tangent(root, value, scale):
    """`root`, with the tangent `scale` times the tangent of `value` (an `fn(root)` that
    carries $\\partial_\\theta f$). Not differentiated, the value is the root exactly
    (also where the slope is zero or `value` not finite) and the compiled program
    computes neither `value` nor `scale`."""
    return root


@_implicit_tangent.defjvp
def _implicit_tangent_jvp(primals, tangents):
    root, value, scale = primals
    # the value as an expression in `value`, so that a derivative taken around this one
    # (a root inside the residual of another root) sees the same tangent
    return root + (value - jax.lax.stop_gradient(value)) * scale, tangents[1] * scale
