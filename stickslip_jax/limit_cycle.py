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

Eq (12)'s $v_c$ is where this $T_1$ equals $T_0 = T_2$, not where the fixed point
disappears: for eq (1) with $m < 1$ it exists at every speed, its amplitude falling
smoothly (`tolerance_speed`: where it falls below a tolerance; docs/model.md gives the
numbers for lubricant A, equal to the exact simulator's to 1e-12).

**Damping** (`limit_cycle(..., damping_ratio=zeta)`, `cycle_map(..., damping_ratio=zeta)`,
`boundary_speed`). The paper's equation of motion (eq 2) has no damping, so a small limit
cycle persists at every speed. With a viscous force $c\dot y$ on the slider (relative to
the slideway, as a lubricant film gives it; $c = 2\zeta M\omega_0$, $M = W/g$,
$\omega_0 = \sqrt{kg/W}$, so $\zeta$ is the damping ratio of the slideway's own mode) the
stick is unchanged (the slider is at rest) and a slip from rest at deflection $x_b$ under
the constant $\mu_m$ of eq (3) (still at $T_2 = \pi/\omega_0$) is a damped oscillation
about $x_{eq} = \mu_m W/k + 2\zeta v/\omega_0$: with $d = x_b - x_{eq}$,
$\omega_d = \omega_0\sqrt{1 - \zeta^2}$, the slider's velocity is

$$\dot y(t) = v + e^{-\zeta\omega_0 t}\left(-v\cos\omega_d t
  + \frac{\omega_0^2 d + \zeta\omega_0 v}{\omega_d}\sin\omega_d t\right)$$

and the deflection $x_{eq} + e^{-\zeta\omega_0 t}(d\cos\omega_d t + (v + \zeta\omega_0
d)\sin(\omega_d t)/\omega_d)$. The slip ends where $\dot y$ returns to zero, between
its first maximum and first minimum (closed-form times; the root by bisection with an
implicit-function gradient); if that minimum is positive the slider never stops again
(steady sliding). A re-slip from rest with $\mu_d$ follows while $kx > W\mu_d$. The fixed
point is found by bisection in $\log T_1$ on "the slider stops and the residual is
positive"; where the stopping region begins with a positive residual there is no limit
cycle with a stick. Unlike the undamped model this happens at a finite speed,
`boundary_speed`, where a finite cycle vanishes at once (docs/model.md: lubricant A at
$\zeta$ = 0.01, 0.05, 0.1). `damping_ratio=0` reproduces the undamped map to 1e-11.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import Array, Float

from .friction import Friction
from .implicit import newton_root, with_implicit_gradient
from .numerics import bisect, check_positive, is_concrete
from .steady import (RESTICK_FAILURE, STEADY_SLIDING, STICK_SLIP, critical_speed,
                     natural_angular_frequency, restick_failure, slip_from_rest, slip_time)

__all__ = ["LimitCycle", "boundary_speed", "cycle_map", "limit_cycle", "tolerance_speed"]

_LOG_T_START = math.log(1e12)


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


_WKV = ("weight W", "stiffness k", "drive speed v")


def _check(owner, names, *values):
    """The values (named `names`) as float scalars; a concrete value that is not finite
    and > 0 raises ValueError here, on the host. A value the caller's jit, vmap or grad
    traces is the caller's to check: the compiled programs have no host callbacks, so
    JAX's persistent compilation cache keeps them."""
    out = [jnp.asarray(x, dtype=float) for x in values]
    if any(x.ndim for x in out):
        raise ValueError(f"{owner} takes scalars ({', '.join(names)}); use jax.vmap over points")
    check_positive(owner, **dict(zip(names, out)))
    return out


def limit_cycle(friction: Friction, weight, stiffness, speed, rtol: float = 1e-13,
                max_steps: int = 200, damping_ratio=None, normal_load=None) -> LimitCycle:
    r"""The fixed point of the one-cycle map (module doc) at W (kgf), k (kgf/mm), v (mm/s);
    scalars (`jax.vmap` for many points).

    `damping_ratio` $\zeta$ (dimensionless, $0 \le \zeta < 1$; default None: the paper's
    undamped model, solved by Newton's method): the map of the damped model (module
    section "Damping"), solved by bisection in $\log T_1$ with implicit gradients. Where
    it has no fixed point with a stick (above `boundary_speed`) the result is steady
    sliding: `regime` `STEADY_SLIDING`, amplitude, stick time and frequency 0.

    `normal_load` N (kgf; None: the paper's N = W): the cycle of the slideway whose
    friction is mu N and inertia W/g, which is the cycle at (N, k N/W, v W/N) with its
    lengths and speeds times N/W (its equation of motion divided by N/W). Concrete values
    are checked on the host (`_check`); new values do not compile the program again."""
    if not isinstance(friction, Friction):
        raise ValueError(f"friction must be a Friction, got {type(friction)}")
    weight, stiffness, speed = _check("limit_cycle", _WKV, weight, stiffness, speed)
    zeta = None if damping_ratio is None else _check_zeta(damping_ratio)
    if normal_load is None:
        return _limit_cycle(friction, weight, stiffness, speed, rtol, max_steps, zeta)
    s = _check("limit_cycle", ("normal load N",), normal_load)[0] / weight
    c = _limit_cycle(friction, weight * s, stiffness * s, speed / s, rtol, max_steps, zeta)
    return eqx.tree_at(lambda c: (c.peak, c.trough, c.amplitude, c.critical_speed), c,
                       (c.peak * s, c.trough * s, c.amplitude * s, c.critical_speed * s))


@eqx.filter_jit
def _limit_cycle(friction, weight, stiffness, speed, rtol, max_steps, zeta) -> LimitCycle:
    if zeta is not None:
        return _damped_limit_cycle(friction, weight, stiffness, speed, zeta)
    t2 = slip_time(weight, stiffness)
    omega = natural_angular_frequency(weight, stiffness)
    double = _double(friction, t2)
    log_t1, result = newton_root(_stick_time_residual, jnp.asarray(_LOG_T_START),
                                 (friction, weight, stiffness, speed, t2, double),
                                 rtol, max_steps)
    t1 = jnp.exp(log_t1)
    mu_0 = friction.static(t1)
    mu_m = friction.kinetic(mu_0, friction.mu_d, t2)
    peak = mu_0 * weight / stiffness
    trough = peak - speed * t1
    c = mu_m * weight / stiffness
    c_d = friction.mu_d * weight / stiffness
    first = slip_from_rest(peak - c, speed, omega)
    second = slip_from_rest((2.0 * c - peak) - c_d, speed, omega)
    slip = first + jnp.where(double, second, 0.0)
    return LimitCycle(stick_time=t1, slip_time=slip, peak=peak, trough=trough,
                      amplitude=0.5 * (peak - trough), frequency=1.0 / (t1 + slip),
                      critical_speed=critical_speed(friction, weight, stiffness),
                      regime=jnp.where(double, RESTICK_FAILURE, STICK_SLIP), result=result)


def cycle_map(friction: Friction, weight, stiffness, speed, trough, damping_ratio=None):
    r"""One cycle of the model from a stick that starts at rest with deflection `trough`
    (mm): the deflection where the next stick starts (module doc), and the stick time
    $T_1$ (s). Scalars; the breakaway is found by bisection (values only: a check of
    `limit_cycle`, not a differentiable path). With `damping_ratio` $\zeta$: the damped
    model's cycle (module section "Damping"); the deflection is NaN where the slider
    never stops again (steady sliding)."""
    weight, stiffness, speed = _check("cycle_map", _WKV, weight, stiffness, speed)
    t2 = slip_time(weight, stiffness)
    x1 = jnp.asarray(trough, dtype=float)

    def margin(t1):
        return stiffness * (x1 + speed * t1) - weight * friction.static(t1)

    hi = (weight * friction.static.asymptote() / stiffness - x1) / speed + 1.0
    lo, hi = bisect(lambda t: margin(t) >= 0, jnp.zeros_like(x1), jnp.maximum(hi, 0.0), n=200)
    t1 = jnp.where(margin(0.0) >= 0, 0.0, 0.5 * (lo + hi))
    x2 = x1 + speed * t1
    mu_0 = friction.static(t1)
    if damping_ratio is not None:
        zeta = _check_zeta(damping_ratio)
        omega = natural_angular_frequency(weight, stiffness)
        x, _, _, stopped = _damped_slips(friction, weight, stiffness, speed, omega, zeta, x2,
                                         friction.kinetic(mu_0, friction.mu_d, t2))
        return jnp.where(stopped, x, jnp.nan), t1
    c = friction.kinetic(mu_0, friction.mu_d, t2) * weight / stiffness
    after = 2.0 * c - x2
    c_d = friction.mu_d * weight / stiffness
    return jnp.where(stiffness * after > weight * friction.mu_d, 2.0 * c_d - after, after), t1


def tolerance_speed(friction: Friction, weight, stiffness, amplitude, rtol: float = 1e-12,
                    max_steps: int = 200):
    r"""The drive speed (mm/s) above which the limit cycle's amplitude (mm) stays below
    `amplitude`: the time-domain model's stick-slip boundary for a tolerance (module
    doc). The amplitude $vT_1/2$ falls with $v$; solved in $\log v$ by Newton's method
    from eq (12)'s $v_c$, differentiable by the implicit function theorem. Returns
    (speed, `optimistix.RESULTS`). Values checked as in `limit_cycle`."""
    names = (*_WKV[:2], "amplitude tolerance")
    return _tolerance_speed(friction, *_check("tolerance_speed", names, weight, stiffness,
                                              amplitude), rtol, max_steps)


@eqx.filter_jit
def _tolerance_speed(friction, weight, stiffness, amplitude, rtol, max_steps):
    def residual(log_v, args):
        fr, w, k, a = args
        cyc = limit_cycle(fr, w, k, jnp.exp(log_v))
        return jnp.log(cyc.amplitude) - jnp.log(a)

    v0 = jnp.log(critical_speed(friction, weight, stiffness))
    log_v, result = newton_root(residual, v0, (friction, weight, stiffness, amplitude),
                                rtol, max_steps)
    return jnp.exp(log_v), result


# --------------------------------------------------------------------------------------
# Viscous damping: the one-cycle map of the damped model and its sharp boundary
# --------------------------------------------------------------------------------------

_N_RESLIP = 4  # re-slips from rest followed after one slip at most
_LOG_T_LO, _LOG_T_HI = math.log(1e-12), math.log(1e12)


def _damped_slip(x_start, mu, weight, stiffness, speed, omega, zeta):
    r"""One slip from rest of the damped model (eq (2) with $c\dot y$; module section
    "Damping"): the slider starts at rest with deflection `x_start` (mm) under a constant
    kinetic friction `mu`. Returns (deflection at the end, duration s, stopped): the slip
    ends at the first $t > 0$ where the slider's velocity returns to zero; `stopped` is
    False where it never does (its velocity's first minimum stays positive: from then on
    the slider slides for ever)."""
    wd = omega * jnp.sqrt(1.0 - zeta**2)
    x_eq = mu * weight / stiffness + 2.0 * zeta * speed / omega
    d = x_start - x_eq

    def velocity(t, d=d, v=speed):
        # slider velocity (mm/s): v + e^{-zeta w t} (P cos wd t + Q sin wd t), P = -v
        q = (omega**2 * d + zeta * omega * v) / wd
        return v + jnp.exp(-zeta * omega * t) * (-v * jnp.cos(wd * t) + q * jnp.sin(wd * t))

    q = (omega**2 * d + zeta * omega * speed) / wd
    a = zeta * omega * speed + wd * q  # = w^2 (d + 2 zeta v / w) > 0 after breakaway
    b = zeta * omega * q - wd * speed
    t_max = jnp.arctan2(a, b) / wd  # the velocity's first maximum, then its minimum
    t_min = t_max + jnp.pi / wd
    stopped = velocity(t_min) <= 0.0
    lo, hi = bisect(lambda t: velocity(t) <= 0.0, t_max, t_min)
    t_end = jnp.where(stopped, 0.5 * (lo + hi), t_min)
    t_end = with_implicit_gradient(t_end, velocity)
    z = jnp.exp(-zeta * omega * t_end) * (
        d * jnp.cos(wd * t_end) + (speed + zeta * omega * d) / wd * jnp.sin(wd * t_end))
    return x_eq + z, t_end, stopped


def _damped_slips(friction, weight, stiffness, speed, omega, zeta, peak, mu_m):
    """The slip from breakaway at `peak` (mm) with eq (3)'s `mu_m`, then the re-slips from
    rest (with $\\mu_d$) while the spring force exceeds $W\\mu_d$. Returns (deflection where
    the next stick starts, total slip time, number of slips, stopped)."""
    x, t, stopped = _damped_slip(peak, mu_m, weight, stiffness, speed, omega, zeta)

    def body(_, state):
        x, t, stopped, n = state
        again = stopped & (stiffness * x > weight * friction.mu_d)
        x2, t2, s2 = _damped_slip(x, friction.mu_d, weight, stiffness, speed, omega, zeta)
        return (jnp.where(again, x2, x), t + jnp.where(again, t2, 0.0),
                jnp.where(again, s2, stopped), n + again)

    x, t, stopped, n = jax.lax.fori_loop(0, _N_RESLIP, body, (x, t, stopped, jnp.ones((), int)))
    stopped = stopped & (stiffness * x <= weight * friction.mu_d)
    return x, t, n, stopped


def _damped_residual(log_t1, friction, weight, stiffness, speed, omega, zeta, t2):
    """Fixed-point residual (mm) of the damped one-cycle map at stick time e^log_t1:
    (deflection where the next stick starts) - (where this one started), with the
    number of slips and whether the slider stops."""
    t1 = jnp.exp(log_t1)
    mu_0 = friction.static(t1)
    peak = mu_0 * weight / stiffness
    mu_m = friction.kinetic(mu_0, friction.mu_d, t2)
    x, slip, n, stopped = _damped_slips(friction, weight, stiffness, speed, omega, zeta,
                                        peak, mu_m)
    return x - (peak - speed * t1), (slip, n, stopped, peak)


def _check_zeta(zeta):
    zeta = jnp.asarray(zeta, dtype=float)
    if zeta.ndim:
        raise ValueError("damping_ratio takes a scalar; use jax.vmap over values")
    if is_concrete(zeta) and not 0 <= float(zeta) < 1:
        raise ValueError(f"damping ratio zeta must lie in [0, 1), got {float(zeta)}")
    return zeta


def _damped_limit_cycle(friction, weight, stiffness, speed, zeta) -> LimitCycle:
    t2 = slip_time(weight, stiffness)
    omega = natural_angular_frequency(weight, stiffness)
    args = (friction, weight, stiffness, speed, omega, zeta, t2)

    def settles_above(log_t1):
        r, (_, _, stopped, _) = _damped_residual(log_t1, *args)
        return stopped & (r > 0)

    lo, hi = bisect(settles_above, jnp.asarray(_LOG_T_LO), jnp.asarray(_LOG_T_HI))
    r_lo, (_, n_lo, stop_lo, peak_lo) = _damped_residual(lo, *args)
    r_hi, (_, n_hi, stop_hi, _) = _damped_residual(hi, *args)
    # a root: the map stops on both sides of the transition, with the same slips, and
    # the residual vanishes there (to round-off); not the edge of the region where the
    # slider stops (there the residual jumps from "never stops" to > 0: steady sliding)
    small = 1e-9 * peak_lo
    found = (stop_lo & stop_hi & (n_lo == n_hi) & (jnp.abs(r_lo) <= small)
             & (jnp.abs(r_hi) <= small) & settles_above(jnp.asarray(_LOG_T_HI)))
    log_t1 = with_implicit_gradient(hi, lambda s: _damped_residual(s, *args)[0])
    _, (slip, n, _, peak) = _damped_residual(log_t1, *args)
    t1 = jnp.exp(log_t1)
    zero = jnp.zeros_like(t1)
    trough = peak - speed * t1
    return LimitCycle(
        stick_time=jnp.where(found, t1, zero), slip_time=jnp.where(found, slip, zero),
        peak=jnp.where(found, peak, zero), trough=jnp.where(found, trough, zero),
        amplitude=jnp.where(found, 0.5 * (peak - trough), zero),
        frequency=jnp.where(found, 1.0 / (t1 + slip), zero),
        critical_speed=critical_speed(friction, weight, stiffness),
        regime=jnp.where(found, jnp.where(n > 1, RESTICK_FAILURE, STICK_SLIP), STEADY_SLIDING),
        result=optx.RESULTS.successful)


def boundary_speed(friction: Friction, weight, stiffness, damping_ratio,
                   speed_range=(1e-6, 1e5)):
    r"""The damped model's sharp stick-slip boundary (mm/s): the drive speed above which
    the one-cycle map with damping ratio $\zeta$ has no fixed point with a stick (the
    slider, once it slips, never stops again: steady sliding), at W (kgf), k (kgf/mm).
    Bisection in $\log v$ over `speed_range` (mm/s); `inf` where a limit cycle exists at
    its top (the undamped model, $\zeta = 0$, for eq (1) with $m < 1$), 0 where none exists
    at its bottom. Scalars (`jax.vmap` over $\zeta$ or design points); values only,
    checked as in `limit_cycle`."""
    if not isinstance(friction, Friction):
        raise ValueError(f"friction must be a Friction, got {type(friction)}")
    weight, stiffness = _check("boundary_speed", _WKV[:2], weight, stiffness)
    return _boundary_speed(friction, weight, stiffness, _check_zeta(damping_ratio), speed_range)


@eqx.filter_jit
def _boundary_speed(friction, weight, stiffness, zeta, speed_range):
    friction, weight, stiffness, zeta = jax.lax.stop_gradient((friction, weight, stiffness, zeta))

    def sliding(log_v):
        c = _damped_limit_cycle(friction, weight, stiffness, jnp.exp(log_v), zeta)
        return c.regime == STEADY_SLIDING

    lo, hi = (jnp.log(jnp.asarray(x, dtype=float)) for x in speed_range)
    a, b = bisect(sliding, lo, hi, n=60)
    v = jnp.exp(0.5 * (a + b))
    return jnp.where(sliding(lo), 0.0, jnp.where(sliding(hi), v, jnp.inf))
