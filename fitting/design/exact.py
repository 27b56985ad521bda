r"""Design-map kernel from the exact event-driven simulator (`simulate_exact`).

Each design point (friction, W kgf, k kgf/mm, v mm/s) is simulated from rest at zero
deflection under a constant drive speed for `N_CYCLES` whole stick-slip cycles, a stick
with the slip and, under re-stick failure, the re-slip from rest that follow it counted
as one cycle (the event budget, `max_events = EVENTS_PER_CYCLE N_CYCLES`, holds that many
re-slip cycles; the horizon is an upper bound on the time they take: the first climb to
$\mu_0 W/k$ plus, per cycle, a climb of at most $2(\mu_0(\infty) - \mu_d)W/k$ and two
slips of at most $2\pi/\omega_0$ each). The map takes the `N_CYCLES`-th whole cycle
(the last, if the horizon ends the run before) as the limit cycle: amplitude
$(x_2 - x_1)/2$ (eq 5; to the end of the re-slip), stick time $T_1$, actual slip time
$T_2$ (both slips), frequency $1/(T_1 + T_2)$. Stick-slip means the run still sticks in
that cycle ($T_1 > 0$, no `steady_sliding`); the critical speed column is corrected eq
(12), as in the steady map. `converged` means the run slid steadily, or that cycle's
amplitude and the previous whole cycle's agree within `LIMIT_CYCLE_RTOL` (the limit cycle
is reached).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from stickslip_jax import Slideway, critical_speed, slip_time
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.simulation import simulate_exact
from stickslip_jax.steady import RESTICK_FAILURE, STEADY_SLIDING, STICK_SLIP, restick_failure

from .points import DesignMap, DesignPoints

N_CYCLES = 8

EVENTS_PER_CYCLE = 4
"""Event budget per cycle: a stick and a slip, then with re-stick failure a stick of
T1 = 0 and the re-slip (a one-slip cycle needs 2; with 2 a re-slip run held only half
its cycles)."""


LIMIT_CYCLE_RTOL = 1e-3


def _last(values, valid, back: int = 0):
    """Value at the last (`back` = 0) True entry of `valid`, or the one `back` True entries
    before it (0 if there is none). Counted over the True entries, not the indices: with
    re-slips the entries alternate between a stick and its re-slip (not valid), and the
    previous cycle is two indices back."""
    rank = jnp.cumsum(valid)  # 1 at the first True entry
    target = rank[-1] - back
    idx = jnp.argmax(valid & (rank == target))
    return jnp.where(target >= 1, values[idx], 0.0)


def exact_point(friction, weight, stiffness, speed, n_cycles: int = N_CYCLES):
    """Limit cycle of one design point from `simulate_exact` (see the module docstring)."""
    slideway = Slideway(friction, weight, stiffness)
    t2 = slip_time(weight, stiffness)
    mu_inf = friction.static.asymptote()
    scale = weight / stiffness
    horizon = (mu_inf * scale + n_cycles * 2.0 * (mu_inf - friction.mu_d) * scale) / speed
    horizon = horizon + n_cycles * 4.0 * t2 + 4.0 * t2  # two slips per cycle with re-slips
    ts = jnp.stack([jnp.zeros_like(horizon), horizon])
    trace = simulate_exact(slideway, ConstantSpeed(speed), ts,
                           max_events=EVENTS_PER_CYCLE * n_cycles)
    cyc = trace.cycles
    # with re-slips (re-stick failure) every cycle is a stick, a slip and a slip again
    # from rest (a "cycle" of T1 = 0): the last stick with the slip(s) that follow it
    valid = cyc.valid & (cyc.stick_time > 0)
    n = valid.shape[0]
    reslip = cyc.valid & (cyc.stick_time == 0)
    follow = jnp.concatenate([reslip[1:], jnp.zeros((1,), bool)])  # entry i+1 re-slips
    follow_amp = jnp.concatenate([cyc.amplitude()[1:], jnp.zeros((1,))])
    follow_t2 = jnp.concatenate([cyc.slip_time[1:], jnp.zeros((1,))])
    amp_all = cyc.amplitude() + jnp.where(follow, follow_amp, 0.0)
    t2_all = cyc.slip_time + jnp.where(follow, follow_t2, 0.0)
    # a stick whose re-slip fell outside the event budget is not a whole cycle
    last_idx = jnp.max(jnp.where(valid, jnp.arange(n), -1))
    whole = valid & ~((jnp.arange(n) == last_idx) & jnp.any(reslip) & ~follow)
    # the n_cycles-th whole cycle: the budget holds n_cycles re-slip cycles (4 events
    # each) and up to twice as many one-slip cycles, of which the first n_cycles are used
    valid = whole & (jnp.cumsum(whole) <= n_cycles)
    n_valid = jnp.sum(valid)
    t1 = _last(cyc.stick_time, valid)
    t2_actual = _last(t2_all, valid)
    amp = _last(amp_all, valid)
    settled = jnp.abs(amp - _last(amp_all, valid, 1)) <= LIMIT_CYCLE_RTOL * amp
    # the simulator's `steady_sliding` flag also marks re-stick failures (re-slips)
    sliding = trace.steady_sliding & ~jnp.any(cyc.valid & cyc.restick_failed)
    stick = (n_valid >= 2) & (t1 > 0) & ~sliding
    zero = jnp.zeros_like(amp)
    f0 = 1.0 / (2.0 * t2)
    freq = jnp.where(stick, 1.0 / jnp.where(stick, t1 + t2_actual, 1.0), zero)
    amp = jnp.where(stick, amp, zero)
    return DesignMap(
        amplitude=amp, amplitude_ratio=amp * stiffness / weight, frequency=freq,
        frequency_ratio=freq / f0, stick_time=jnp.where(stick, t1, zero),
        slip_time=jnp.where(stick, t2_actual, t2), natural_frequency=f0,
        critical_speed=critical_speed(friction, weight, stiffness), stick_slip=stick,
        converged=((n_valid >= 2) & settled) | sliding,
        regime=jnp.where(stick, jnp.where(restick_failure(friction, friction.static(t1), t2),
                                          RESTICK_FAILURE, STICK_SLIP), STEADY_SLIDING))


def exact_kernel(points: DesignPoints, shared=None) -> DesignMap:
    """`exact_point` vmapped over a chunk of design points (leaves of shape (n,))."""
    return jax.vmap(exact_point)(points.friction, points.weight, points.stiffness, points.speed)
