r"""Exact event-driven simulation of the paper's stick-slip model (chapters 2-5, Fig 6).

The spring deflection is $x = u(t) - y + x_0$ ($u$ drive displacement, $y$ slider
displacement, both mm). Two phases alternate:

- **stick** (slider at rest, $\dot y = 0$): $x$ follows the drive,
  $x(t) = x_s + u(t) - u(t_s)$, while $k x < \mu_0(T_1) W$ with $T_1 = t - t_s$ the time
  since the stick began (eq 1 or any static law). Breakaway is the first root of
  $r(t) = k x(t) - W \mu_0(t - t_s)$, found knot segment by knot segment of the
  piecewise-linear drive with a safeguarded Newton iteration started at the right end
  of the bracket (for a concave $\mu_0$, $r$ is convex on a segment so the iteration is
  monotone and the root unique).
- **slip**: eq (2) with constant mean kinetic friction $\mu_m W$ (eq 3),
  $M\ddot y = k x - \mu_m W$, i.e. eq (10) $M\ddot x + k x = \mu_m W$ while the drive speed
  $v$ is constant, whose closed form is
  $x = c + (x_0 - c)\cos\omega_0\tau + \frac{v - \dot y_0}{\omega_0}\sin\omega_0\tau$,
  $c = \mu_m W/k$. The slip ends when $\dot y = v - \dot x$ returns to zero,
  $\omega_0\tau^* = \psi + \arccos(-v/R)$ (mod $2\pi$), $R = \sqrt{\omega_0^2 (x_0 - c)^2 +
  (\dot y_0 - v)^2}$, $\psi = \operatorname{atan2}(\omega_0(x_0 - c), \dot y_0 - v)$. For a slip that
  starts from rest this is $\omega_0 T_2 = 2\pi - 2\arctan(\omega_0 (x_2 - c)/v)$ and it ends at
  exactly $x_1 = 2c - x_2$ (so eq (5) holds for every cycle at constant speed).
  A knot of the drive inside a slip is an event: the closed form restarts there.

$T_2$ in eq (3) (`SlipTime`): $\pi/\omega_0$ (eq 7, "paper") or the actual slip duration
("self_consistent", a scalar root solve; predicted at the speed at breakaway when the
drive changes speed inside the slip).

If a slip ends with $k x_1 > \mu_0(0) W$ the slider cannot stick: the next stick lasts
$T_1 = 0$, it slips on with $\mu_0(0) = \mu_d$ (flag `restick_failed`, trace flag
`steady_sliding`); that slip ends at $2\mu_d W/k - x_1 < \mu_d W/k$, so the event loop
always moves forward. A slip that can never end (the drive outruns the slider after a
speed increase) also sets `steady_sliding`.

Events run in a `lax.scan` of `ceil(max_events / 2)` steps, each one cycle (the stick,
then the slip up to its end or the next drive knot); unused steps are masked, so the
simulator is jit/vmap/grad compatible. Rendering places the phase starts among the sorted
samples and gathers each sample's closed-form coefficients; the slip's trigonometric
terms are expanded by the angle-addition formulas so that the samples need only
$\cos\omega_0 t$, $\sin\omega_0 t$ (`_cos_sin`, about 10 ns a sample; the event loop
costs a few hundred microseconds a campaign). Event times are differentiated by the
implicit function theorem; gradients are exact between bifurcations (a change in the
number of cycles).
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..drives import AbstractDrive
from ..implicit import with_implicit_gradient
from ..modes import SlipTime
from ..numerics import bisect, check_positive, is_concrete
from ..slideway import Slideway
from ..steady import slip_from_rest
from .trace import Cycles, SimulationResult, Trace

_TWO_PI = 2.0 * jnp.pi


def _newton_root(fun, lo, hi, max_iter=80, active=True):
    """Root of `fun` in [lo, hi] with fun(lo) < 0 <= fun(hi): Newton from `hi`, bisection
    whenever a step leaves the bracket. Values only (call under stop_gradient).
    Where `active` is False no iteration runs (returns `hi`)."""

    def tol(x):
        return 4e-16 * jnp.maximum(jnp.abs(x), 1.0)

    def cond(c):
        lo, hi, x, dx, i = c
        return (i < max_iter) & (jnp.abs(dx) > tol(x))

    def body(c):
        lo, hi, x, _, i = c
        f, fp = jax.jvp(fun, (x,), (jnp.ones_like(x),))
        lo = jnp.where(f < 0, x, lo)
        hi = jnp.where(f < 0, hi, x)
        newton = x - f / jnp.where(fp != 0, fp, 1.0)
        # a step below the tolerance is accepted even where rounding puts it on or just
        # outside the bracket (converged); otherwise bisect when it leaves the bracket
        tiny = jnp.abs(newton - x) <= tol(x)
        ok = (fp != 0) & (((newton > lo) & (newton < hi)) | tiny)
        x_new = jnp.where(ok, newton, 0.5 * (lo + hi))
        x_new = jnp.where(f == 0, x, x_new)
        return lo, hi, x_new, x_new - x, i + 1

    init = (lo, hi, hi, jnp.asarray(jnp.inf), jnp.where(active, 0, max_iter))
    return jax.lax.while_loop(cond, body, init)[2]


def count_at_or_before(edges, ts):
    """For sorted `edges` and sorted `ts`: how many edges are <= each t, i.e.
    `searchsorted(edges, ts, side="right")`. Up to 64 edges, each sample is compared with
    all of them (one fused pass, no loop to compile); for more, the edges are placed
    among the samples (E binary searches) and counted by a cumulative sum."""
    if edges.shape[0] <= 64:
        return jnp.searchsorted(edges, ts, side="right", method="compare_all")
    pos = jnp.searchsorted(ts, edges, side="left").astype(jnp.int32)
    return _count_positions(pos, ts.shape[0])


def _count_positions(pos, n):
    """For each sample index j < n: how many of the integer positions `pos` are <= j
    (a scatter of ones and a cumulative sum)."""
    counts = jnp.zeros((n,), jnp.int32).at[jnp.ravel(pos)].add(1, mode="drop")
    return jax.lax.associative_scan(jnp.add, counts)


def _drive_at(knot_table, t):
    """Drive position (mm) and speed (mm/s) at times t (any shape) from the knot table
    [K, 3] (times s, positions mm, speeds mm/s) of `AbstractDrive.knots`."""
    kt = knot_table[:, 0]
    if kt.shape[0] == 1:
        t_k, u_k, s_k = knot_table[0]
        return u_k + s_k * (t - t_k), jnp.broadcast_to(s_k, jnp.shape(t))
    method = "compare_all" if kt.shape[0] <= 16 else "scan"
    i = jnp.clip(jnp.searchsorted(kt, t, side="right", method=method) - 1,
                 0, kt.shape[0] - 1)
    t_k, u_k, s_k = jnp.moveaxis(knot_table[i], -1, 0)
    return u_k + s_k * (t - t_k), s_k


def _render(ts, row, coef, omega, u):
    """x(t) (mm), slider velocity (mm/s) and the sticking flag on the sample times `ts`
    (s) from each sample's phase row `row` (an index into the coefficient table `coef`
    [R, 4], stick rows at even indices), omega0 (1/s, scalar or per sample) and the drive
    position `u` (mm) at `ts`. Each row is x = P + G u(t) + A cos(omega t) +
    B sin(omega t), ydot = V + omega (A sin - B cos), G = 1 while sticking (the closed
    forms of the stick and of eq (10))."""
    sticking = (row % 2) == 0
    P, A, Bs, V = (coef[row][:, j] for j in range(4))
    cs, sn = _cos_sin(omega * ts)
    deflection = P + jnp.where(sticking, u, 0.0) + A * cs + Bs * sn
    velocity = V + omega * (A * sn - Bs * cs)
    return deflection, velocity, sticking


def _slip_state(x0, yd0, c, v, omega, tau):
    """Closed form of eq (10) from (x0 mm, yd0 mm/s) after tau s: returns (x, ydot)."""
    cs, sn = jnp.cos(omega * tau), jnp.sin(omega * tau)
    x = c + (x0 - c) * cs + (v - yd0) / omega * sn
    yd = v + omega * (x0 - c) * sn - (v - yd0) * cs
    return x, yd


_SIN_COEF = tuple((-1.0) ** j / math.factorial(2 * j + 1) for j in range(11))
_COS_COEF = tuple((-1.0) ** j / math.factorial(2 * j) for j in range(12))


def _cos_sin(phi):
    """(cos phi, sin phi) for many angles: reduction to [0, 2 pi), half angle in
    [-pi/2, pi/2), Taylor series of degree 21/22. Error below 1e-15 on [0, 2 pi) (the
    slip angles), growing like phi * 1e-16 outside; vectorises, about ten times faster
    than XLA's float64 cos and sin on CPU."""
    phi = phi - _TWO_PI * jnp.floor(phi / _TWO_PI)  # [0, 2 pi)
    h = 0.5 * (phi - jnp.pi)  # [-pi/2, pi/2); phi = 2 h + pi
    h2 = h * h
    ps, pc = _SIN_COEF[-1], _COS_COEF[-1]
    for a in _SIN_COEF[-2::-1]:
        ps = ps * h2 + a
    for a in _COS_COEF[-2::-1]:
        pc = pc * h2 + a
    sh, ch = h * ps, pc
    return sh * sh - ch * ch, -2.0 * sh * ch


class _State(eqx.Module):
    t: Array
    x: Array
    yd: Array
    sticking: Array
    t_stick: Array
    c: Array  # slip equilibrium mu_m W / k (mm)
    done: Array
    steady: Array
    slip_start: Array


def simulate_exact(slideway: Slideway, drive: AbstractDrive, ts: Float[ArrayLike, " N"], *,
                   slip_time: SlipTime | str = SlipTime.PAPER,
                   initial_deflection: Float[ArrayLike, ""] = 0.0,
                   initial_stick_time: Float[ArrayLike, ""] = 0.0,
                   start_time: Float[ArrayLike, ""] | None = None, mask: ArrayLike | None = None,
                   max_events: int = 64, cycle_table: bool = True, check: bool = True) -> Trace:
    r"""Simulate the paper's stick-slip model exactly (events in closed form) on times `ts`.

    - `slideway`: friction laws, weight W (kgf), stiffness k (kgf/mm), normal load N (kgf).
    - `drive`: any `AbstractDrive` (u(t) in mm, piecewise linear).
    - `ts` (s): sample times, non-decreasing (checked); the simulation runs from `start_time`
      (default `ts[0]`) to `max(ts)`.
    - `slip_time`: a `SlipTime` or its value, "paper" ($T_2 = \pi/\omega_0$ in eq 3,
      eq 7) or "self_consistent".
    - `initial_deflection` (mm) and `initial_stick_time` (s): the slider starts at rest,
      having stuck for `initial_stick_time` already.
    - `mask`: optional bool array like `ts` (False on padding), copied into the trace.
    - `max_events` (static): stick and slip phases, 2 per cycle at constant speed (a drive
      knot crossed in a slip costs 2 more); running out gives `max_events_reached`.
    - `cycle_table` (static): False leaves out the per-cycle table (`Trace.cycles` None),
      which the fits do not need to trace, differentiate or compile.
    - `check` (static): False leaves out the checks of concrete inputs (`check_inputs`)
      for callers that checked them.

    Returns a `Trace` (deflection in mm, slider velocity in mm/s, `Cycles`).
    jit-compatible (wrap in `eqx.filter_jit`), `vmap` over records of padded `ts`
    (see `pad_times`), differentiable between bifurcations. For a campaign of records
    of different lengths `simulate_exact_campaign` avoids rendering padding.
    """
    slip_time = _check_arguments(slideway, drive, slip_time, max_events)
    ts = jnp.asarray(ts, dtype=float)
    if ts.ndim != 1 or ts.shape[0] < 1:
        raise ValueError("ts must be a non-empty 1-D array of times (s); vmap for batches")
    mask = jnp.ones(ts.shape, bool) if mask is None else jnp.asarray(mask, bool)
    if check:
        check_inputs("simulate_exact", slideway, ts)
    t_start = ts[0] if start_time is None else jnp.asarray(start_time, dtype=float)
    ev = _events(slideway, drive, t_start, jnp.max(ts), initial_deflection, initial_stick_time,
                 slip_time=slip_time, max_events=max_events, cycle_table=cycle_table)
    # each sample's phase row: how many phase starts are at or before it
    n_rows = ev.row_time.shape[0]
    row = jnp.clip(count_at_or_before(ev.row_time, ts) - 1, 0, n_rows - 1)
    u = _drive_at(ev.knot_table, ts)[0]
    deflection, velocity, sticking = _render(ts, row, ev.coef, ev.omega, u)
    return Trace(time=ts, deflection=deflection, slider_velocity=velocity, sticking=sticking,
                 mask=mask, cycles=ev.cycles, steady_sliding=ev.steady_sliding, result=ev.result,
                 num_events=ev.num_events)


def _check_arguments(slideway, drive, slip_time, max_events) -> SlipTime:
    """Check the arguments; return `slip_time` as a `SlipTime`."""
    if not isinstance(slideway, Slideway):
        raise ValueError(f"slideway must be a Slideway, got {type(slideway)}")
    if not isinstance(drive, AbstractDrive):
        raise ValueError(f"drive must be an AbstractDrive, got {type(drive)}")
    if not isinstance(max_events, int) or max_events < 2:
        raise ValueError("max_events must be a Python int >= 2")
    return SlipTime.parse(slip_time)


class _Events(eqx.Module):
    """The event loop's output for one record: phase rows for rendering (start time s,
    closed-form coefficients [R, 4], rows alternate stick/slip), the cycle table, flags."""

    row_time: Array
    coef: Array
    knot_table: Array
    omega: Array
    cycles: Cycles | None
    steady_sliding: Array
    result: SimulationResult
    num_events: Array


def check_inputs(owner: str, slideway: Slideway, ts=None) -> None:
    """ValueError where a concrete input of a simulator is impossible: W, k or N (kgf,
    kgf/mm) not finite and > 0, sample times `ts` (s) that go back. Values the caller's
    jit, vmap or grad traces are the caller's to check: the simulators' programs have no
    host callbacks, so JAX's persistent compilation cache keeps them."""
    check_positive(owner, **{"weight W": slideway.weight, "stiffness k": slideway.stiffness,
                             "normal load N": slideway.load})
    if ts is not None and is_concrete(ts) and np.any(np.diff(np.asarray(ts)) < 0):
        raise ValueError(f"{owner}: ts must be non-decreasing (sample times, s)")


class _Setup(NamedTuple):
    """What every step of one record's event loop reads: the friction law, the friction
    load W (kgf, the paper's N = W), k (kgf/mm), omega0 (rad/s), the drive's knots
    (times `kt` s; `bounds` with the run's end `t_end` appended; `knot_table` [K, 3] of
    time, position, speed), the restick level mu_0(0), the gradient-free W, k and
    mu_0(infinity) of the root brackets, and the `SlipTime`."""

    friction: object
    W: Array
    k: Array
    omega: Array
    kt: Array
    bounds: Array
    t_end: Array
    knot_table: Array
    mu_restick: Array
    W_sg: Array
    k_sg: Array
    mu_cap: Array
    slip_time: SlipTime


def _events(slideway, drive, t_start, t_end, initial_deflection, initial_stick_time, *,
            slip_time, max_events, cycle_table=True) -> _Events:
    """Run the stick/slip events of one record from `t_start` to `t_end` (s)."""
    t_start = jnp.asarray(t_start, dtype=float)
    t_end = jnp.asarray(t_end, dtype=float)
    friction = slideway.friction
    static = friction.static
    # W is the friction load N below (the paper's N = W); the inertia is weight / g
    W, k, omega = slideway.load, slideway.stiffness, slideway.omega0
    kt, ku, ks = drive.knots()
    bounds = jnp.concatenate([kt, t_end[None]])
    mu_restick = static(jnp.asarray(0.0))

    W_sg, k_sg = jax.lax.stop_gradient((W, k))
    mu_cap = jax.lax.stop_gradient(static.asymptote())

    knot_table = jnp.stack([kt, ku, ks], axis=1)
    setup = _Setup(friction=friction, W=W, k=k, omega=omega, kt=kt, bounds=bounds, t_end=t_end,
                   knot_table=knot_table, mu_restick=mu_restick, W_sg=W_sg, k_sg=k_sg,
                   mu_cap=mu_cap, slip_time=slip_time)

    zero = jnp.zeros(())
    x0 = jnp.asarray(initial_deflection, dtype=float) + zero
    init = _State(t=t_start + zero, x=x0, yd=zero, sticking=jnp.asarray(True),
                  t_stick=t_start - jnp.asarray(initial_stick_time, dtype=float), c=zero,
                  done=t_start >= t_end, steady=jnp.asarray(False), slip_start=t_start + zero)
    n_steps = (max_events + 1) // 2
    final, (rows, info) = jax.lax.scan(functools.partial(_step, setup), init, None,
                                       length=n_steps)
    # interleave the stick and slip halves of each step: phase order
    rows, info = (jax.tree_util.tree_map(lambda a, b: jnp.stack([a, b], axis=1).reshape(
        (2 * n_steps,) + a.shape[1:]), *halves) for halves in (rows, info))
    return _Events(
        row_time=rows["t"], coef=rows["coef"], knot_table=knot_table, omega=omega,
        cycles=_cycle_table(info, max_events) if cycle_table else None,
        steady_sliding=final.steady,
        result=SimulationResult.where(
            final.done, SimulationResult.successful, SimulationResult.max_events_reached),
        num_events=jnp.sum(rows["active"]).astype(int))


def _step(setup: _Setup, s: _State, _):
    """One cycle of the event loop: the stick (if the slider rests), then the slip; the
    two phase rows and the two event records."""
    stick_on = ~s.done & s.sticking
    s1, info1, u1, _ = _stick_step(setup, s, stick_on)
    s1 = _keep(stick_on, s1, s)
    slip_on = ~s1.done & ~s1.sticking
    s2, info2, _, v2 = _slip_step(setup, s1, slip_on)
    s2 = _keep(slip_on, s2, s1)
    rows = (_stick_row(s, stick_on, u1), _slip_row(setup, s1, slip_on, v2))
    return s2, (rows, (info1, info2))


def _keep(active, new, old):
    return jax.tree_util.tree_map(lambda a, b: jnp.where(active, a, b), new, old)


def _model_t2(setup: _Setup, x_b, v_b, mu0, active):
    """The slip time T2 (s) of eq (3) for a breakaway at deflection `x_b` (mm), drive
    speed `v_b` (mm/s) and mu_0: pi / omega0, or the root of the slip's own duration."""
    omega = setup.omega
    if setup.slip_time == SlipTime.PAPER:
        return jnp.pi / omega

    p = (x_b, v_b, mu0, setup.friction, setup.W, setup.k, omega)

    def g(T2, p=p):
        x_b, v_b, mu0, friction, W, k, omega = p
        mum = friction.kinetic(mu0, friction.mu_d, T2)
        return T2 - slip_from_rest(x_b - mum * W / k, v_b, omega)

    p_sg = jax.lax.stop_gradient(p)
    lo, hi = jax.lax.stop_gradient((jnp.pi / omega, _TWO_PI / omega))
    root = 0.5 * sum(bisect(lambda T2: ~(g(T2, p_sg) < 0), lo, jnp.where(active, hi, lo), 64))
    return with_implicit_gradient(root, g)


def _stick_step(setup: _Setup, s: _State, active):
    """The stick from state `s` to its breakaway (the first root of k x - W mu_0, knot
    segment by segment), or to the run's end when none comes."""
    friction, W, k, bounds, t_end = setup.friction, setup.W, setup.k, setup.bounds, setup.t_end
    static = friction.static
    u_t, v_t = _drive_at(setup.knot_table, s.t)
    x_b_all = s.x + _drive_at(setup.knot_table, bounds)[0] - u_t
    # mu_0 at the segment ends and at the stick's current time, in one evaluation
    mu_all = static(jnp.append(jnp.maximum(bounds - s.t_stick, 0.0), s.t - s.t_stick))
    r_b = k * x_b_all - W * mu_all[:-1]
    valid_b = (bounds > s.t) & (bounds <= t_end)
    r_start = k * s.x - W * mu_all[-1]
    immediate = r_start >= 0
    hit = valid_b & (r_b >= 0)
    found = jnp.any(hit)
    j = jnp.argmax(hit)
    hi = bounds[j]
    lo = jnp.maximum(s.t, jnp.max(jnp.where(valid_b & (bounds < hi), bounds, -jnp.inf)))
    u_lo, v_seg = _drive_at(setup.knot_table, lo)
    x_lo = s.x + u_lo - u_t
    hi_safe = jnp.where(found, hi, s.t + 1.0)
    lo_safe = jnp.where(found, lo, s.t)
    p = (x_lo, lo_safe, v_seg, s.t_stick, k, W, static)

    def fun(tp, p=p):
        x_lo, t_lo, v_seg, t_stick, k, W, static = p
        return k * (x_lo + v_seg * (tp - t_lo)) - W * static(tp - t_stick)

    p_sg = jax.lax.stop_gradient(p)
    lo_sg, hi_sg = jax.lax.stop_gradient((lo_safe, hi_safe))
    # A tighter right end: where k x reaches W mu_0(infinity) (an upper bound of the
    # root when the law is bounded by its asymptote; used only if r >= 0 there).
    x_lo_sg, v_sg = p_sg[0], p_sg[2]
    W_sg, k_sg = setup.W_sg, setup.k_sg
    t_cap = lo_sg + (W_sg * setup.mu_cap - k_sg * x_lo_sg) / (k_sg * jnp.where(v_sg > 0, v_sg, 1.0))
    use_cap = (v_sg > 0) & (t_cap > lo_sg) & (t_cap < hi_sg)
    t_cap = jnp.where(use_cap, t_cap, hi_sg)
    hi_sg = jnp.where(use_cap & (fun(t_cap, p_sg) >= 0), t_cap, hi_sg)
    run = active & found & ~immediate
    root = _newton_root(lambda tp: fun(tp, p_sg), lo_sg, hi_sg, active=run)
    t_b = with_implicit_gradient(root, fun)
    t_b = jnp.where(immediate, s.t, jnp.where(found, t_b, t_end))
    x_b = jnp.where(immediate, s.x, x_lo + v_seg * (t_b - lo_safe))
    v_b = jnp.where(immediate, v_t, v_seg)
    breaks = immediate | found
    T1 = t_b - s.t_stick
    mu0 = static(T1)
    T2 = _model_t2(setup, x_b, v_b, mu0, active & breaks)
    mum = friction.kinetic(mu0, friction.mu_d, T2)
    new = _State(t=t_b, x=x_b, yd=jnp.zeros_like(s.yd), sticking=~breaks, t_stick=s.t_stick,
                 c=jnp.where(breaks, mum * W / k, s.c), done=~breaks, steady=s.steady,
                 slip_start=jnp.where(breaks, t_b, s.slip_start))
    info = dict(is_break=breaks & active, t_b=t_b, x2=x_b, T1=T1, mu0=mu0, mum=mum, T2model=T2,
                is_end=jnp.asarray(False), t_stop=t_b, x1=x_b, restick=jnp.asarray(False))
    return new, info, u_t, v_t


def _slip_step(setup: _Setup, s: _State, active):
    """The slip from state `s` (closed form of eq 10) to its end, the next drive knot or
    the run's end, whichever comes first."""
    W, k, omega, t_end = setup.W, setup.k, setup.omega, setup.t_end
    u_t, v = _drive_at(setup.knot_table, s.t)
    later = setup.kt > s.t
    t_next = jnp.min(jnp.where(later, setup.kt, jnp.inf))
    A = omega * (s.x - s.c)
    B = s.yd - v
    R2 = A * A + B * B
    R = jnp.sqrt(jnp.where(R2 > 0, R2, 1.0))
    stops = (R2 > 0) & (R > v)
    R_safe = jnp.where(stops, R, 2.0 * v + 1.0)
    theta = jnp.mod(jnp.arctan2(A, B) + jnp.arccos(-v / R_safe), _TWO_PI)
    t_stop = s.t + theta / omega
    stop_here = stops & (t_stop <= t_next) & (t_stop <= t_end)
    t_new = jnp.where(stop_here, t_stop, jnp.minimum(t_next, t_end))
    x_new, yd_new = _slip_state(s.x, s.yd, s.c, v, omega, t_new - s.t)
    yd_new = jnp.where(stop_here, 0.0, yd_new)
    restick = stop_here & (k * x_new > W * setup.mu_restick)
    never = ~stops & ~(t_next < t_end)
    new = _State(t=t_new, x=x_new, yd=yd_new, sticking=stop_here,
                 t_stick=jnp.where(stop_here, t_new, s.t_stick), c=s.c,
                 done=~stop_here & (t_new >= t_end), steady=s.steady | restick | never,
                 slip_start=s.slip_start)
    info = dict(is_break=jnp.asarray(False), t_b=s.slip_start, x2=s.x, T1=jnp.zeros_like(s.t),
                mu0=jnp.zeros_like(s.t), mum=s.c * k / W, T2model=jnp.zeros_like(s.t),
                is_end=stop_here & active, t_stop=t_new, x1=x_new, restick=restick & active)
    return new, info, u_t, v


def _row_time(s: _State, active):
    """A phase row's start time (s): an inactive row before the end (the stick half of a
    step that starts in a slip) keeps the current time, so the row times stay sorted for
    rendering, and the slip row after it, at the same time, is the one rendered; a row
    after the end is never rendered (infinity)."""
    return jnp.where(active, s.t, jnp.where(s.done, jnp.inf, s.t))


def _stick_row(s: _State, active, u_t):
    """The stick row that starts at state `s` (the drive at `u_t` mm): its start time (s)
    and closed-form coefficients for rendering, x = (x_s - u(t_s)) + u(t). Rendered only
    where it is active (`_row_time`), that is where the slider sticks."""
    z = jnp.zeros_like(s.x)
    return dict(t=_row_time(s, active), active=active, coef=jnp.stack([s.x - u_t, z, z, z]))


def _slip_row(setup: _Setup, s: _State, active, v_t):
    """The slip row that starts at state `s` (drive speed `v_t` mm/s): its start time (s)
    and the closed-form coefficients of eq (10) for rendering. The slip's cos/sin of
    omega (t - t_row) are expanded by the angle-addition formulas so that the samples need
    cos/sin of omega t only (no per-sample row time). Rendered only where it is active
    (`_row_time`), that is where the slider slips."""
    omega = setup.omega
    t = _row_time(s, active)
    Q = s.x - s.c
    S = (v_t - s.yd) / omega
    phase = omega * jnp.where(jnp.isfinite(t), t, setup.t_end)
    c_row, s_row = jnp.cos(phase), jnp.sin(phase)
    coef = jnp.stack([s.c, Q * c_row - S * s_row, Q * s_row + S * c_row, v_t])
    return dict(t=t, active=active, coef=coef)


def _cycle_table(info, max_events: int) -> Cycles:
    """Scatter the per-event records into one row per cycle (breakaway + slip end)."""
    n = max_events // 2 + 1
    is_break, is_end = info["is_break"], info["is_end"]
    cid = jnp.cumsum(is_break.astype(int)) - 1
    drop = jnp.full_like(cid, n)
    bid = jnp.where(is_break, cid, drop)
    eid = jnp.where(is_end & (cid >= 0), cid, drop)
    z = jnp.zeros((n,))

    def put(ids, v, base=z):
        return base.at[ids].set(v, mode="drop")

    broke = put(bid, jnp.ones_like(cid, float)) > 0
    ended = put(eid, jnp.ones_like(cid, float)) > 0
    t_b = put(bid, info["t_b"])
    t_stop = put(eid, info["t_stop"])
    valid = broke & ended
    v = lambda a: jnp.where(valid, a, 0.0)  # noqa: E731
    return Cycles(breakaway_time=v(t_b), peak=v(put(bid, info["x2"])),
                  trough=v(put(eid, info["x1"])), stick_time=v(put(bid, info["T1"])),
                  slip_time=v(t_stop - t_b), model_slip_time=v(put(bid, info["T2model"])),
                  mu_0=v(put(bid, info["mu0"])), mu_m=v(put(bid, info["mum"])),
                  restick_failed=valid & (put(eid, info["restick"].astype(float)) > 0), valid=valid)


def simulate_exact_campaign(slideway: Slideway, drive: AbstractDrive, ts: Float[ArrayLike, " N"],
                            record_index: ArrayLike, *, slip_time: SlipTime | str = SlipTime.PAPER,
                            initial_deflection: Float[ArrayLike, "..."] = 0.0,
                            initial_stick_time: Float[ArrayLike, "..."] = 0.0,
                            max_events: int = 64) -> Trace:
    r"""Simulate a campaign of B records of different lengths exactly, without padding.

    The samples of all records are given as ONE flat array: `ts` (s, shape [N]) holds
    record 0's times, then record 1's, ...; `record_index` (int, [N], non-decreasing,
    values 0..B-1, every record at least one sample) says which record each sample
    belongs to. Within a record the times are non-decreasing (checked); each record
    runs from its first to its last sample time.

    - `slideway`, `drive`: batched over the records, every array leaf with leading axis
      B (built with `jax.vmap`, docs/simulators.md; shared friction parameters are then
      broadcast, and gradients with respect to them still flow).
    - `initial_deflection` (mm), `initial_stick_time` (s): scalars or [B].
    - `slip_time`, `max_events`: as in `simulate_exact`.

    The cheap cycle loop runs vmapped over the records, the rendering (about 10 ns a
    sample) once over the N real samples with the same `_render`, so x(ts) equals
    per-record `simulate_exact` to rounding.

    Returns a `Trace` whose `time`, `deflection` (mm), `slider_velocity` (mm/s),
    `sticking`, `mask` (all True) are flat [N] like `ts`, and whose `cycles` ([B, C]),
    `steady_sliding`, `result` and `num_events` ([B]) are per record. jit-compatible:
    compiles once per (B, N, max_events); differentiable like `simulate_exact`.
    """
    slip_time = _check_arguments(slideway, drive, slip_time, max_events)
    ts = jnp.asarray(ts, dtype=float)
    rec = jnp.asarray(record_index)
    if ts.ndim != 1 or ts.shape[0] < 1 or rec.shape != ts.shape:
        raise ValueError("ts and record_index must be 1-D arrays of the same, non-zero length")
    if not jnp.issubdtype(rec.dtype, jnp.integer):
        raise ValueError("record_index must be an integer array (the record of each sample)")
    leaves = [x for x in jax.tree_util.tree_leaves((slideway, drive)) if eqx.is_array(x)]
    if not leaves or any(x.ndim < 1 for x in leaves):
        raise ValueError("slideway and drive must be batched over the records (leading "
                         "axis B on every array leaf; build them with jax.vmap)")
    n_rec = slideway.weight.shape[0]
    if any(x.shape[0] != n_rec for x in leaves):
        raise ValueError(f"every array leaf of slideway and drive needs leading axis "
                         f"B = {n_rec} (records)")
    check_inputs("simulate_exact_campaign", slideway)
    if is_concrete(ts, rec):
        r, t = np.asarray(rec), np.asarray(ts)
        if np.any(np.diff(r) < 0) or r[0] < 0 or r[-1] >= n_rec:
            raise ValueError("record_index must be non-decreasing with values 0..B-1")
        if np.unique(r).size < n_rec:
            raise ValueError("every record needs at least one sample (record_index)")
        if np.any((np.diff(r) == 0) & (np.diff(t) < 0)):
            raise ValueError("ts must be non-decreasing within each record (s)")
    rec = rec.astype(jnp.int32)
    n = ts.shape[0]
    ids = jnp.arange(n_rec, dtype=jnp.int32)
    first = jnp.searchsorted(rec, ids, side="left").astype(jnp.int32)
    stop = jnp.searchsorted(rec, ids, side="right").astype(jnp.int32)
    x0 = jnp.broadcast_to(jnp.asarray(initial_deflection, dtype=float), (n_rec,))
    T0 = jnp.broadcast_to(jnp.asarray(initial_stick_time, dtype=float), (n_rec,))

    def one(slideway, drive, t0, t1, x0, T0):
        return _events(slideway, drive, t0, t1, x0, T0, slip_time=slip_time,
                       max_events=max_events)

    ev = jax.vmap(one)(slideway, drive, ts[first], ts[jnp.maximum(stop - 1, first)], x0, T0)

    # Place each record's phase starts among its own samples (binary search in
    # [first, stop)): position = index of the first sample at or after the start, so
    # the positions of all records are sorted and sample j's global phase row is the
    # number of positions <= j, minus one.
    n_rows = ev.row_time.shape[1]
    lo = jnp.broadcast_to(first[:, None], (n_rec, n_rows))
    hi = jnp.broadcast_to(stop[:, None], (n_rec, n_rows))
    for _ in range(max(1, math.ceil(math.log2(n + 1)))):
        mid = (lo + hi) // 2
        right = (lo < hi) & (ts[jnp.minimum(mid, n - 1)] < ev.row_time)
        lo, hi = jnp.where(right, mid + 1, lo), jnp.where(right | (lo >= hi), hi, mid)
    local = _count_positions(lo, n) - 1 - rec * n_rows
    row = rec * n_rows + jnp.clip(local, 0, n_rows - 1)
    knots = ev.knot_table[rec]  # [N, K, 3]: each sample's drive knots
    u = jax.vmap(lambda kn, t: _drive_at(kn, t)[0])(knots, ts)
    deflection, velocity, sticking = _render(
        ts, row, ev.coef.reshape(n_rec * n_rows, 4), ev.omega[rec], u)
    return Trace(time=ts, deflection=deflection, slider_velocity=velocity, sticking=sticking,
                 mask=jnp.ones((n,), bool), cycles=ev.cycles, steady_sliding=ev.steady_sliding,
                 result=ev.result, num_events=ev.num_events)
