r"""Steady-state stick-slip analysis, chapter 5 of the paper.

For a slider of weight $W$ (kgf) on a spring of stiffness $k$ (kgf/mm) driven at
$v$ (mm/s), with friction laws $\mu_0(T_1)$ and $\mu_m(\mu_0, T_2)$:

- slip time, eq (7): $T_2 = \pi\sqrt{W/(g k)} = 1/(2 f_0)$;
- stick time, eq (6) generalised to any law: $k v T_1 / (2W) = \mu_0(T_1) - \mu_m(\mu_0(T_1), T_2)$;
- amplitude, eq (5): $a = (\mu_0 - \mu_m) W / k = v T_1 / 2$ (half the peak-to-peak swing);
- with a normal load $N$ apart from the weight, $N$ replaces $W$ in eqs (5), (6) and (12)
  (the friction force is $\mu N$) while $T_2$ keeps the inertia $W/g$;
- frequency $f = 1/(T_1 + T_2)$;
- critical speed, eq (12) as corrected in NOTES.md item 3: eq (6) at $T_1 = T_2 = T_0$,
  $v_c = 2 W (\mu_0(T_0) - \mu_m(T_0)) / (k T_0)$.

Above $v_c$ there is no stick-slip: `amplitude`, `stick_time`, `frequency` are 0 and
`stick_slip` is False, with finite gradients.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import Array, ArrayLike, Bool, Float

from .friction import Friction
from .implicit import newton_root
from .numerics import check_positive
from .units import G_MM_S2

_LOG_T_START = math.log(1e12)


def natural_angular_frequency(weight, stiffness):
    r"""$\omega_0 = \sqrt{g k / W}$ in rad/s; W in kgf, k in kgf/mm."""
    return jnp.sqrt(G_MM_S2 * stiffness / weight)


def slip_time(weight, stiffness):
    r"""Eq (7): $T_2 = \pi \sqrt{W/(g k)}$ in s; W in kgf, k in kgf/mm."""
    return jnp.pi / natural_angular_frequency(weight, stiffness)


def slip_from_rest(d, v, omega):
    r"""Duration (s) of a slip from rest that starts `d` mm above its centre $\mu_m W/k$,
    drive at v (mm/s), $\omega_0$ (1/s): $(2\pi - 2\arctan(\omega_0 d/v))/\omega_0$ (eq 10
    in closed form)."""
    return (2.0 * jnp.pi - 2.0 * jnp.arctan2(omega * d, v)) / omega


def critical_speed(friction: Friction, weight, stiffness, normal_load=None):
    r"""Critical drive speed $v_c$ in mm/s, corrected eq (12) (NOTES.md item 3).

    $v_c = \frac{2W}{k T_0}(\mu_0(T_0) - \mu_m(\mu_0(T_0), T_0))$, $T_0 = \pi\sqrt{W/(gk)}$.
    For eq (1) + eq (3) this is
    $\frac{2W}{kT_0}(\mu_s-\mu_d)(1-e^{-\gamma T_0^m})(1-e^{-\delta T_0^n})$;
    `normal_load` N (kgf) replaces the leading W when given.
    """
    t0 = slip_time(weight, stiffness)
    load = weight if normal_load is None else normal_load
    return 2.0 * load * friction.drop(t0, t0) / (stiffness * t0)


def _log_residual(log_t1, args):
    friction, weight, stiffness, speed, t2 = args
    t1 = jnp.exp(log_t1)
    drop = jnp.maximum(friction.drop(t1, t2), 1e-300)
    return jnp.log(drop) + jnp.log(2.0 * weight / (stiffness * speed)) - log_t1


STEADY_SLIDING, STICK_SLIP, RESTICK_FAILURE = 0, 1, 2
"""Values of `SteadyState.regime`."""

REGIMES = ("steady sliding", "stick-slip", "re-stick failure")
"""Names of the regimes, indexed by `SteadyState.regime`."""


def restick_failure(friction: Friction, mu_0, slip_time):
    r"""True where a slip cannot end in a stick: with the mean kinetic friction $\mu_m$ of
    eq (3) the deflection falls by $2(\mu_0 - \mu_m)W/k$ during the slip (eq 5), so the
    spring force at its end is $k x_1 = W(2\mu_m - \mu_0)$; above $W\mu_d$ (the static
    friction at $T_1 = 0$, eq 1) the slider slips again at once: double slips. That is
    $\mu_m - \mu_d > \mu_0 - \mu_m$, for eq (3) $e^{-\delta T_2^n} > 1/2$; eq (6)'s
    amplitude does not describe the motion there. `slip_time` $T_2$ in s."""
    mu_m = friction.kinetic(mu_0, friction.mu_d, slip_time)
    return (mu_m - friction.mu_d) > (mu_0 - mu_m)


class SteadyState(eqx.Module):
    """Steady stick-slip cycle (chapter 5). Units: s, mm, Hz, mm/s; ratios dimensionless.
    `regime`: `STEADY_SLIDING` (v >= v_c of eq 12), `STICK_SLIP`, or `RESTICK_FAILURE`
    (a slip cannot end in a stick, `restick_failure`: the amplitude and stick time of
    eqs 5-6 are then not the motion's)."""

    stick_time: Float[Array, "..."]
    slip_time: Float[Array, "..."]
    amplitude: Float[Array, "..."]
    amplitude_ratio: Float[Array, "..."]
    frequency: Float[Array, "..."]
    natural_frequency: Float[Array, "..."]
    frequency_ratio: Float[Array, "..."]
    critical_speed: Float[Array, "..."]
    mu_0: Float[Array, "..."]
    mu_m: Float[Array, "..."]
    stick_slip: Bool[Array, "..."]
    result: optx.RESULTS
    regime: Array


_NAMES = ("weight W", "stiffness k", "drive speed v")


def steady_state(friction: Friction, weight: Float[ArrayLike, ""], stiffness: Float[ArrayLike, ""],
                 speed: Float[ArrayLike, ""], rtol: float = 1e-13, max_steps: int = 100,
                 normal_load: Float[ArrayLike, ""] | None = None) -> SteadyState:
    r"""Steady stick-slip of eqs (5)-(7) and (12) at one design point.

    `weight` W in kgf, `stiffness` k in kgf/mm, `speed` v in mm/s (all scalars; use
    `jax.vmap` for many points); `normal_load` N in kgf (None: the paper's N = W). Eq (6)
    is solved for $\log T_1$ with an optimistix Newton root finder started above the root
    (the residual is concave in $\log T_1$, so Newton converges monotonically); its
    derivative follows from the implicit function theorem (`implicit.newton_root`: first
    derivatives, no host callback, so programs that differentiate it are cached).

    W, k and v are converted to arrays before the (cached) compiled call, so new
    Python-float values do not trigger recompilation; concrete values are checked here
    (ValueError), traced ones are the caller's to check (no host callbacks in the program).
    """
    values = [jnp.asarray(x, dtype=float) for x in (weight, stiffness, speed)]
    load = None if normal_load is None else jnp.asarray(normal_load, dtype=float)
    check_positive("steady_state", **dict(zip(_NAMES, values)),
                   **({} if load is None else {"normal load N": load}))
    return _steady_state(_strong_floats(friction), *values, rtol, max_steps, load)


def _strong_floats(tree):
    """Floating leaves (Python floats, weak-typed arrays) as float64 arrays: one compilation."""
    return jax.tree_util.tree_map(lambda x: jnp.asarray(x, dtype=float)
                                  if isinstance(x, float) or eqx.is_inexact_array(x)
                                  else x, tree)


@eqx.filter_jit
def _steady_state(friction, weight, stiffness, speed, rtol, max_steps,
                  normal_load=None) -> SteadyState:
    if not isinstance(friction, Friction):
        raise ValueError(f"friction must be a Friction, got {type(friction)}")
    weight, stiffness, speed = (jnp.asarray(x, dtype=float) for x in (weight, stiffness, speed))
    if weight.ndim or stiffness.ndim or speed.ndim:
        raise ValueError("steady_state takes scalars; use jax.vmap over design points")
    load = weight if normal_load is None else normal_load

    t2 = slip_time(weight, stiffness)
    omega0 = jnp.pi / t2
    v_c = critical_speed(friction, weight, stiffness, load)
    stick = speed < v_c
    # Above v_c solve at a safe speed and mask (double-where: finite gradients).
    v_solve = jnp.where(stick, speed, 0.5 * v_c)
    log_t1, solved = newton_root(_log_residual, jnp.asarray(_LOG_T_START),
                                 (friction, load, stiffness, v_solve, t2), rtol, max_steps)
    t1 = jnp.exp(log_t1)
    mu_0 = friction.static(t1)
    mu_m = friction.kinetic(mu_0, friction.mu_d, t2)
    amplitude = (mu_0 - mu_m) * load / stiffness
    zero = jnp.zeros_like(t1)
    t1 = jnp.where(stick, t1, zero)
    amplitude = jnp.where(stick, amplitude, zero)
    f0 = omega0 / (2 * jnp.pi)
    freq = jnp.where(stick, 1.0 / (t1 + t2), zero)
    mu_0_out = jnp.where(stick, mu_0, friction.static(t2))
    mu_m_out = jnp.where(stick, mu_m, friction.mu_d + zero)
    result = optx.RESULTS.where(stick, solved, optx.RESULTS.successful)
    fails = restick_failure(friction, mu_0, t2)
    regime = jnp.where(stick, jnp.where(fails, RESTICK_FAILURE, STICK_SLIP), STEADY_SLIDING)
    return SteadyState(stick_time=t1, slip_time=t2, amplitude=amplitude,
                       amplitude_ratio=amplitude * stiffness / load, frequency=freq,
                       natural_frequency=f0, frequency_ratio=freq / f0, critical_speed=v_c,
                       mu_0=mu_0_out, mu_m=mu_m_out, stick_slip=stick, result=result, regime=regime)


def steady_map(friction: Friction, weight, stiffness, speed) -> SteadyState:
    """`steady_state` under `jax.vmap` over broadcast arrays of W (kgf), k (kgf/mm), v (mm/s)."""
    w, k, v = jnp.broadcast_arrays(jnp.asarray(weight, float), jnp.asarray(stiffness, float),
                                   jnp.asarray(speed, float))
    shape = w.shape
    check_positive("steady_map", **dict(zip(_NAMES, (w, k, v))))
    out = _vmapped_steady(_strong_floats(friction), w.ravel(), k.ravel(), v.ravel())
    return jax.tree_util.tree_map(lambda x: x.reshape(shape) if hasattr(x, "reshape") else x, out)


@eqx.filter_jit
def _vmapped_steady(friction, w, k, v):
    return jax.vmap(_steady_state, in_axes=(None, 0, 0, 0, None, None))(friction, w, k, v, 1e-13,
                                                                        100)


class SlipTrajectory(eqx.Module):
    """Slip phase of eq (11): time (s), deflection x (mm) and xdot/omega0 (mm)."""

    time: Float[Array, " n"]
    deflection: Float[Array, " n"]
    velocity_over_omega0: Float[Array, " n"]


def slip_trajectory(
    friction: Friction, weight, stiffness, stick_time, num: int = 101) -> SlipTrajectory:
    r"""Eq (11): $x = \{(\mu_0 - \mu_m)\cos\omega_0 t + \mu_m\} W/k$ for $0 \le t \le \pi/\omega_0$.

    The v -> 0 limit of the slip (NOTES.md item 7); the phase plane of Figs 34-35 plots
    `deflection` against `velocity_over_omega0` (both mm).
    """
    omega0 = natural_angular_frequency(weight, stiffness)
    t2 = jnp.pi / omega0
    mu_0 = friction.static(stick_time)
    mu_m = friction.kinetic(mu_0, friction.mu_d, t2)
    t = jnp.linspace(0.0, t2, num)
    scale = weight / stiffness
    x = ((mu_0 - mu_m) * jnp.cos(omega0 * t) + mu_m) * scale
    xdot_over_w = -(mu_0 - mu_m) * jnp.sin(omega0 * t) * scale
    return SlipTrajectory(t, x, xdot_over_w)
