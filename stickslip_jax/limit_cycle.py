r"""The stick-slip limit cycle of the time-domain model: the fixed point of the one-cycle
map, at any drive speed (chapter 5's model without eq (12)'s cut-off).

**The one-cycle map** (`cycle_map`; W kgf, k kgf/mm, v mm/s, deflections x in mm). A
stick starts at rest with deflection $x_1$; the deflection climbs as $x_1 + vt$ until the
spring force reaches the static friction, $k(x_1 + vT_1) = W\mu_0(T_1)$ (eq 1), at
$x_2 = x_1 + vT_1$. The slip from rest under the constant kinetic friction
$\mu_m = \mu_m(\mu_0, T_2)$ of eq (3) ($T_2 = \pi/\omega_0$, eq 7, as the paper's
simulator uses it) is eq (10) in closed form: in the phase plane $(\omega_0 (x - c),
\dot y - v)$, $c = \mu_m W/k$, the motion is a circle, so the slider stops at
$x_1' = 2c - x_2$ after $(2\pi - 2\arctan(\omega_0 (x_2 - c)/v))/\omega_0$. When
$k x_1' > W\mu_d$ (the static friction at $T_1 = 0$) it slips again at once from rest,
now with $\mu_m(\mu_d) = \mu_d$: $x_1'' = 2c_d - x_1'$, $c_d = \mu_d W/k$ (re-stick
failure, `stickslip_jax.steady.restick_failure`; a second re-slip cannot follow).

**Its fixed point** $x_1' = x_1$ (the limit cycle the exact simulator settles on) is one
equation in $T_1$: with one slip $x_1 = c - vT_1/2$ and the breakaway condition give

$$\frac{k v T_1}{2} = W\left(\mu_0(T_1) - \mu_m(T_1)\right),$$

eq (6) itself, now at every speed; with a re-slip, $x_1 = x_1 - vT_1 + 2(c - c_d)$ gives
$k v T_1 / 2 = W(\mu_m(T_1) - \mu_d)$. Which case holds does not depend on $T_1$ for
eq (3) ($e^{-\delta T_2^n} > 1/2$). It is solved for $\log T_1$ by Newton's method
(optimistix) from above, with implicit-function gradients, so `limit_cycle` is
differentiable in the friction parameters and the design (W, k, v) and vmaps.

Against eq (12): the paper's $v_c$ is the speed where this $T_1$ equals $T_0 = T_2$, not
where the fixed point disappears. For eq (1) with $m < 1$ the fixed point exists at every
speed (the static friction rises faster than linearly from $T_1 = 0$), with an amplitude
that falls smoothly: the undamped model has no sharp stick-slip boundary, only the speed
where the amplitude falls below a tolerance (`tolerance_speed`). Lubricant A, W 36 kgf,
k 86.9 kgf/mm: $v_c$ = 48.9 mm/min, the limit cycle 8.01 / 7.32 / 5.66 um at 52 / 60 / 90
mm/min (the exact simulator's values to 1e-12).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import Array, Float

from .friction import Friction
from .steady import (RESTICK_FAILURE, STICK_SLIP, critical_speed, natural_angular_frequency,
                     restick_failure, slip_time)

__all__ = ["LimitCycle", "cycle_map", "limit_cycle", "tolerance_speed"]

_TWO_PI = 2.0 * math.pi
_LOG_T_START = math.log(1e12)


def _slip_from_rest(d, v, omega):
    """Duration (s) of a slip from rest whose deflection starts `d` mm above its centre."""
    return (_TWO_PI - 2.0 * jnp.arctan2(omega * d, v)) / omega


def _double(friction: Friction, t2):
    """Re-stick failure (a re-slip after every slip) at slip time `t2`: eq (3)'s
    exp(-delta T2^n) > 1/2, judged at a T1 of 1 s (independent of T1 for eq (3))."""
    return restick_failure(friction, friction.static(jnp.ones_like(t2)), t2)


def _stick_time_residual(log_t1, args):
    friction, weight, stiffness, speed, t2, double = args
    t1 = jnp.exp(log_t1)
    mu_0 = friction.static(t1)
    mu_m = friction.kinetic(mu_0, friction.mu_d, t2)
    drop = jnp.where(double, mu_m - friction.mu_d, mu_0 - mu_m)
    drop = jnp.maximum(drop, 1e-300)
    return jnp.log(drop) + jnp.log(2.0 * weight / (stiffness * speed)) - log_t1


class LimitCycle(eqx.Module):
    """The limit cycle at one design point (mm, s, Hz).

    `stick_time` $T_1$; `slip_time`: the actual duration of the slip (both slips with a
    re-slip; not eq (7)'s $T_2$, which sets $\\mu_m$); `peak` $x_2$ and `trough` $x_1$
    (deflections at breakaway and where the stick starts); `amplitude` $(x_2 - x_1)/2$
    (eq 5's a with one slip); `frequency` $1/(T_1 + $ slip time$)$; `critical_speed`:
    eq (12)'s $v_c$ (mm/s), for comparison; `regime`: `steady.STICK_SLIP` or
    `steady.RESTICK_FAILURE`; `result`: the root finder's `optimistix.RESULTS`."""

    stick_time: Float[Array, "..."]
    slip_time: Float[Array, "..."]
    peak: Float[Array, "..."]
    trough: Float[Array, "..."]
    amplitude: Float[Array, "..."]
    frequency: Float[Array, "..."]
    critical_speed: Float[Array, "..."]
    regime: Array
    result: optx.RESULTS


def _check(weight, stiffness, speed):
    out = []
    for x, name in ((weight, "weight W"), (stiffness, "stiffness k"), (speed, "drive speed v")):
        x = jnp.asarray(x, dtype=float)
        if x.ndim:
            raise ValueError(f"limit_cycle takes scalars ({name}); use jax.vmap over points")
        out.append(eqx.error_if(x, ~(x > 0), f"{name} must be positive"))
    return out


@eqx.filter_jit
def limit_cycle(friction: Friction, weight, stiffness, speed, rtol: float = 1e-13,
                max_steps: int = 200) -> LimitCycle:
    r"""The fixed point of the one-cycle map (module doc) at W (kgf), k (kgf/mm), v (mm/s);
    scalars (`jax.vmap` for many points)."""
    if not isinstance(friction, Friction):
        raise ValueError(f"friction must be a Friction, got {type(friction)}")
    weight, stiffness, speed = _check(weight, stiffness, speed)
    t2 = slip_time(weight, stiffness)
    omega = natural_angular_frequency(weight, stiffness)
    double = _double(friction, t2)
    sol = optx.root_find(_stick_time_residual, optx.Newton(rtol=rtol, atol=rtol),
                         jnp.asarray(_LOG_T_START),
                         args=(friction, weight, stiffness, speed, t2, double),
                         max_steps=max_steps, throw=False)
    t1 = jnp.exp(sol.value)
    mu_0 = friction.static(t1)
    mu_m = friction.kinetic(mu_0, friction.mu_d, t2)
    peak = mu_0 * weight / stiffness
    trough = peak - speed * t1
    c = mu_m * weight / stiffness
    c_d = friction.mu_d * weight / stiffness
    first = _slip_from_rest(peak - c, speed, omega)
    second = _slip_from_rest((2.0 * c - peak) - c_d, speed, omega)
    slip = first + jnp.where(double, second, 0.0)
    return LimitCycle(
        stick_time=t1, slip_time=slip, peak=peak, trough=trough,
        amplitude=0.5 * (peak - trough), frequency=1.0 / (t1 + slip),
        critical_speed=critical_speed(friction, weight, stiffness),
        regime=jnp.where(double, RESTICK_FAILURE, STICK_SLIP), result=sol.result)


def cycle_map(friction: Friction, weight, stiffness, speed, trough):
    r"""One cycle of the model from a stick that starts at rest with deflection `trough`
    (mm): the deflection where the next stick starts (module doc), and the stick time
    $T_1$ (s). Scalars; the breakaway is found by bisection (values only: a check of
    `limit_cycle`, not a differentiable path)."""
    weight, stiffness, speed = _check(weight, stiffness, speed)
    t2 = slip_time(weight, stiffness)
    x1 = jnp.asarray(trough, dtype=float)

    def margin(t1):
        return stiffness * (x1 + speed * t1) - weight * friction.static(t1)

    hi = (weight * friction.static.asymptote() / stiffness - x1) / speed + 1.0

    def body(_, lohi):
        lo, hi = lohi
        mid = 0.5 * (lo + hi)
        below = margin(mid) < 0
        return jnp.where(below, mid, lo), jnp.where(below, hi, mid)

    lo, hi = jax.lax.fori_loop(0, 200, body, (jnp.zeros_like(x1), jnp.maximum(hi, 0.0)))
    t1 = jnp.where(margin(0.0) >= 0, 0.0, 0.5 * (lo + hi))
    x2 = x1 + speed * t1
    mu_0 = friction.static(t1)
    c = friction.kinetic(mu_0, friction.mu_d, t2) * weight / stiffness
    after = 2.0 * c - x2
    c_d = friction.mu_d * weight / stiffness
    return jnp.where(stiffness * after > weight * friction.mu_d, 2.0 * c_d - after, after), t1


@eqx.filter_jit
def tolerance_speed(friction: Friction, weight, stiffness, amplitude, rtol: float = 1e-12,
                    max_steps: int = 200):
    r"""The drive speed (mm/s) above which the limit cycle's amplitude (mm) stays below
    `amplitude`: the time-domain model's stick-slip boundary for a tolerance (module
    doc). The amplitude $vT_1/2$ falls with $v$; solved in $\log v$ by Newton's method
    from eq (12)'s $v_c$, differentiable by the implicit function theorem. Returns
    (speed, `optimistix.RESULTS`)."""
    amplitude = jnp.asarray(amplitude, dtype=float)
    amplitude = eqx.error_if(amplitude, ~(amplitude > 0), "amplitude tolerance must be positive")

    def residual(log_v, args):
        fr, w, k, a = args
        cyc = limit_cycle(fr, w, k, jnp.exp(log_v))
        return jnp.log(cyc.amplitude) - jnp.log(a)

    v0 = jnp.log(critical_speed(friction, weight, stiffness))
    sol = optx.root_find(residual, optx.Newton(rtol=rtol, atol=rtol), v0,
                         args=(friction, jnp.asarray(weight, float),
                               jnp.asarray(stiffness, float), amplitude),
                         max_steps=max_steps, throw=False)
    return jnp.exp(sol.value), sol.result
