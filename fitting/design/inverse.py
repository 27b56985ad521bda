r"""Inverse design through the steady analysis: the stiffest-free / heaviest-allowed drive.

Corrected eq (12) gives the critical speed $v_c(W, k)$ (mm/s), which falls
monotonically with the stiffness $k$ and rises with the weight $W$; eqs (5)-(7) give
the stick-slip amplitude $a(W, k, v)$ (mm), which falls with $k$ and rises with $W$
wherever $v < v_c$. At a feed rate $v$:

- `minimum_stiffness(friction, W, v)`: the smallest $k$ with $v_c(W, k) \le v$ (smooth
  sliding at the feed); with ``amplitude_tolerance=tol`` the smallest $k$ for which
  either the sliding is smooth or $a \le$ tol.
- `maximum_weight(friction, k, v)`: the largest $W$ with $v_c \le v$, or with
  ``amplitude_tolerance`` the largest $W$ with smooth sliding or $a \le$ tol.

Both solve $\log v_c = \log v$ (or $\log a = \log \mathrm{tol}$) in $\log k$ / $\log W$
with `optimistix.Newton` through the steady analysis, so the answer is differentiable in
the friction parameters, W, k and v in turn.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import Array, Bool, Float

from stickslip_jax import Friction, critical_speed, slip_time, steady_state
from stickslip_jax.numerics import check_positive

_LOG_MIN, _LOG_MAX = jnp.log(1e-6), jnp.log(1e9)
_EDGE = 1e-9


class InverseDesign(eqx.Module):
    r"""Answer of an inverse design at one feed rate.

    `value`: the stiffness (kgf/mm) or weight (kgf) found; `critical_speed` v_c (mm/s)
    and `amplitude` a (mm, 0 if smooth) at that design and the feed rate;
    `limited_by_amplitude`: True when the amplitude tolerance, not smooth sliding,
    set the answer; `result`: optimistix result code of the Newton solves.
    """

    value: Float[Array, ""]
    critical_speed: Float[Array, ""]
    amplitude: Float[Array, ""]
    limited_by_amplitude: Bool[Array, ""]
    result: optx.RESULTS


def _newton(fn, u0, args, lower, upper, rtol):
    solver = optx.Newton(rtol=rtol, atol=rtol)
    return optx.root_find(fn, solver, u0, args=args, max_steps=100, throw=False,
                          options=dict(lower=lower, upper=upper))


def _pair(u, other, for_weight):
    """(W, k) with the unknown exp(u) in the weight's place or the stiffness's."""
    return (jnp.exp(u), other) if for_weight else (other, jnp.exp(u))


def _log_vc(u, args):
    friction, other, log_v, for_weight = args
    return jnp.log(critical_speed(friction, *_pair(u, other, for_weight))) - log_v


def _log_a(u, args):
    friction, other, speed, log_tol, for_weight = args
    return jnp.log(steady_state(friction, *_pair(u, other, for_weight), speed).amplitude) - log_tol


def _answer(friction, u, other, for_weight, feed, by_amp, results) -> InverseDesign:
    """The design exp(u) with v_c and a there; the first failed solve's result code."""
    s = steady_state(friction, *_pair(u, other, for_weight), feed)
    result = results[0]
    for r in results[1:]:
        result = optx.RESULTS.where(result == optx.RESULTS.successful, r, result)
    return InverseDesign(jnp.exp(u), s.critical_speed, s.amplitude, by_amp, result)


def minimum_stiffness(friction: Friction, weight, feed, amplitude_tolerance=None,
                      rtol: float = 1e-12) -> InverseDesign:
    r"""Smallest stiffness k (kgf/mm) that stops stick-slip at feed `feed` (mm/s) for a
    slider of `weight` W (kgf), or that keeps its amplitude under `amplitude_tolerance`
    (mm). Corrected eq (12) and eqs (5)-(7).
    """
    return _design(_leaves(friction), *_arrays({"weight W": weight, "feed rate v": feed,
                                                "amplitude_tolerance": amplitude_tolerance}),
                   rtol, False)


def maximum_weight(friction: Friction, stiffness, feed, amplitude_tolerance=None,
                   rtol: float = 1e-12) -> InverseDesign:
    r"""Largest slider weight W (kgf) that slides smoothly at feed `feed` (mm/s) on a
    drive of `stiffness` k (kgf/mm), or whose stick-slip amplitude stays under
    `amplitude_tolerance` (mm). Corrected eq (12) and eqs (5)-(7).
    """
    return _design(_leaves(friction), *_arrays({"stiffness k": stiffness, "feed rate v": feed,
                                                "amplitude_tolerance": amplitude_tolerance}),
                   rtol, True)


def _leaves(friction):
    if not isinstance(friction, Friction):
        raise ValueError(f"friction must be a Friction, got {type(friction)}")
    return jax.tree_util.tree_map(
        lambda x: jnp.asarray(x, dtype=float) if isinstance(x, (int, float)) else x, friction)


def _arrays(values: dict):
    """The values as float scalars (arrays: new values do not recompile; None stays None),
    checked > 0 where concrete (a traced one is the caller's to check: no host callbacks
    in the program, so JAX's persistent compilation cache keeps it)."""
    out = {k: None if x is None else jnp.asarray(x, dtype=float) for k, x in values.items()}
    for name, x in out.items():
        if x is not None and x.ndim:
            raise ValueError(f"{name} must be a scalar; use jax.vmap for many designs")
    check_positive("inverse design", **{k: x for k, x in out.items() if x is not None})
    return out.values()


@eqx.filter_jit
def _design(friction, other, feed, tol, rtol, for_weight: bool):
    """The weight (`for_weight`) or the stiffness at which v_c reaches the feed, or with a
    tolerance the amplitude reaches it. v_c and a rise with W and fall with k, so the
    amplitude's root lies above the critical weight and below the critical stiffness."""
    u0 = jnp.log(30.0) if for_weight else jnp.log(100.0)
    sol_c = _newton(_log_vc, u0, (friction, other, jnp.log(feed), for_weight),
                    _LOG_MIN, _LOG_MAX, rtol)
    u_c = sol_c.value
    if tol is None:
        return _answer(friction, u_c, other, for_weight, feed, jnp.asarray(False),
                       [sol_c.result])
    # Just at the critical design the stick time equals the slip time, eq (5): a = v T0 / 2.
    a_edge = 0.5 * feed * slip_time(*_pair(u_c, other, for_weight))
    by_amp = tol >= a_edge
    if for_weight:
        u_a, lower, upper = u_c + _EDGE, u_c + _EDGE, _LOG_MAX
    else:
        u_a, lower, upper = u_c - _EDGE, _LOG_MIN, u_c - _EDGE
    sol_a = _newton(_log_a, u_a, (friction, other, feed, jnp.log(tol), for_weight),
                    lower, upper, rtol)
    u = jnp.where(by_amp, sol_a.value, u_c)
    res_a = optx.RESULTS.where(by_amp, sol_a.result, optx.RESULTS.successful)
    return _answer(friction, u, other, for_weight, feed, by_amp, [sol_c.result, res_a])
