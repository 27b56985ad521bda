r"""Smoothed, differentiable simulator: the paper's stick-slip model as one smooth ODE.

State: spring deflection $x$ (mm), slider velocity $\dot y$ (mm/s), a stick-time state
$\tau$ (s), the breakaway-friction memory and the states of the parts (parts.py). With
drive speed $\dot u(t)$, normal load $N$ (= W for the paper), $\varepsilon = \eta\,v_{ref}$
(mm/s; $\eta$ = `smoothing`, $v_{ref}$ the largest drive speed), $r = \dot y/\varepsilon$,
$\sigma = e^{-(r/4)^8}$ (1 while the slider rests), $t_r = T_0/40$, $T_0 = \pi/\omega_0$,
and $\mu_{sl} = \mu_m(q, \mu_d, T_2)$ of eq (3), $T_2 = \pi/\omega_0$ (eq 7,
`SlipTime.PAPER`) or given in s. Three formulations (`Formulation`):

- **latch** (default; not stiff, explicit `diffrax.Tsit5`): with the net force of eq (2)
  $F = F_a - N\mu_{sl}$, $F_a = k x + \sum_i F_i$ (kgf),
  $M\ddot y = s_w(r)\min(F, 0) + [s_a(r/K) + (1 - s_a(r/K))\,s_F]\max(F, 0)$
  (`latch_acceleration`): a slip ends by an algebraic decay, a resting slider does not
  creep and breaks away once $F_a$ reaches $N\mu_0(\tau)$; slips run forward only. The
  clock and the memory stop once the slider moves, $\tau$ resets in a slip at rate
  $20/T_0$, the memory catches up after a restick at rate $4/(\tau + T_0/20)$; the
  step-size controller's error norm leaves these two states out. About 130-150 steps
  per cycle at rtol 1e-8. Measured (tests): amplitude error vs exact linear in $\eta$
  (1.2 %, 0.10 %, 0.008 % at $\eta$ = 1e-2, 1e-3, 1e-4 at 3 mm/min), steps independent
  of $\eta$, gradients within 1e-4 of finite differences for $\eta$ = 1e-2 ... 1e-4 at
  rtol 1e-9 and 1e-10.
- **rigid_stick** (stiff, Kvaerno5): friction balances $F_a$ and pins $\dot y$ to 0 while
  $|F_a| < N\mu_0(\tau)$ and the slider rests (`rigid_stick_friction`); the memory holds
  the last stick time. Amplitude within 0.15 % of the exact simulator at $\eta = 10^{-3}$
  on the benchmark campaign, error linear in $\eta$ (1.3 % at $10^{-2}$, 30 mm/min);
  gradients at $\eta = 10^{-3}$ need rtol 1e-10.
- **velocity** (stiff, Kvaerno5): $M\ddot y = k x - N\,[\mu_{sl}\tanh(8r) + (\mu_0(\tau) -
  \mu_{sl})\,r\,e^{(1-r^2)/2}] + \sum_i F_i$ (`friction_curve`: peak $N\mu_0$ at $r = 1$),
  $\dot\tau = \sigma - (1-\sigma)\tau/t_r$, $\dot q = \sigma(\mu_0(\tau) - q)/t_r$; the
  breakaway is late by about $\sqrt{2\eta}/\omega_0$ (5 % amplitude near $v_c$ at
  $\eta = 0.03$), gradients match finite differences to 1e-4 for $\eta \ge 0.03$.

Samples are rendered from the accepted steps by cubic Hermite interpolation (Kvaerno5's
own interpolant), so a run costs more the larger `max_steps` is. Gradients are taken
through the solver (discretise-then-optimise). Parts with fast states (a 10 us sensor
low-pass) make any formulation stiff: pass an implicit `solver`.

**Other friction laws** (`stickslip_jax.friction`). A kinetic law of the velocity
(`AbstractVelocityKinetic`) sets $\mu_{sl}$ at $\dot y$ in any formulation. A rate-and-state
law (`RateStateKinetic`) replaces the switch: $M\ddot y = k x - N\mu(\dot y, \theta) +
\sum_i F_i$, the state $\theta$ (s) in the place of $\tau$, solved by Kvaerno5 (stiff while
it creeps); the slider starts as at a slip end: moving with the drive, in the state where
the law balances the spring there, healed by the initial stick time
(`RateStateKinetic.start`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import diffrax as dfx
import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import Array, ArrayLike, Float

from ..drives import AbstractDrive
from ..friction import AbstractVelocityKinetic, RateStateKinetic
from ..modes import Formulation, SlipTime
from ..slideway import Slideway
from .exact import check_inputs, count_at_or_before
from .parts import (AbstractForceTerm, AbstractLoadCoupling, AbstractMeasurement,
                    ConstantLoad, Context, Core, IdealGauge)
from .trace import Cycles, SimulationResult, Trace

DEFAULT_SMOOTHING = 1e-3
r"""Default $\eta$ (all formulations): the sharpest rigid stick whose gradients the tests
verify (amplitude within 0.2 % of the exact simulator on the benchmark)."""


class SmoothModel(eqx.Module):
    """The slideway plus the optional parts of the smoothed simulator.

    `slideway` (friction laws, W kgf, k kgf/mm); `force_terms` a tuple of
    `AbstractForceTerm`; `load` an `AbstractLoadCoupling` (default N = W);
    `measurement` an `AbstractMeasurement` (default: ideal gauge).
    """

    slideway: Slideway
    force_terms: tuple = ()
    load: AbstractLoadCoupling = ConstantLoad()
    measurement: AbstractMeasurement = IdealGauge()

    def __check_init__(self):
        if not isinstance(self.slideway, Slideway):
            raise ValueError(f"slideway must be a Slideway, got {type(self.slideway)}")
        if not isinstance(self.force_terms, tuple) or not all(
            isinstance(f, AbstractForceTerm) for f in self.force_terms):
            raise ValueError("force_terms must be a tuple of AbstractForceTerm")
        if not isinstance(self.load, AbstractLoadCoupling):
            raise ValueError("load must be an AbstractLoadCoupling")
        if not isinstance(self.measurement, AbstractMeasurement):
            raise ValueError("measurement must be an AbstractMeasurement")

    def parts(self):
        return (*self.force_terms, self.load, self.measurement)


def default_solver(rtol: float = 1e-8, atol: float = 1e-10):
    """Kvaerno5 (5th-order ESDIRK, L-stable) with a full Newton solve of each stage (the
    chord iteration fails near breakaway, where the Jacobian changes fast)."""
    return dfx.Kvaerno5(root_finder=optx.Newton(rtol=rtol, atol=atol))


def smoothing_velocity(drive: AbstractDrive, smoothing):
    """The velocity scale eps = smoothing * (largest drive speed), mm/s."""
    _, _, speeds = drive.knots()
    return smoothing * jnp.max(jnp.abs(speeds))


def friction_curve(r, mu_0, mu_slip):
    r"""Friction coefficient against $r = \dot y/\varepsilon$: peak $\mu_0$ near $r = 1$,
    kinetic level $\mu_{sl}$ for $|r| \gg 1$ (module docstring)."""
    return mu_slip * jnp.tanh(8.0 * r) + (mu_0 - mu_slip) * r * jnp.exp(0.5 * (1.0 - r * r))


def stick_weight(r):
    r"""$\sigma = \exp(-(r/4)^8)$: 1 while sticking ($|r| \lesssim 1$), 0 while slipping."""
    return jnp.exp(-((r / 4.0) ** 8))


def rigid_stick_friction(applied, r, N, mu0, mu_slip, drop, smoothing):
    r"""Stick weight $\sigma = s_F e^{-r^2}$, $s_F = \tfrac12[1 + \tanh z]$,
    $z = (N\mu_0 - |F_a|)/(\eta N D)$, and friction (kgf) $F = \sigma(F_a + N\mu_0 r) +
    (1 - \sigma)N\mu_{sl}\tanh(8r)$ of the rigid stick: it balances the applied force $F_a$
    (kgf) and pins $\dot y$ to 0 while sticking, is eq (3)'s kinetic friction while
    slipping; $N D$ the friction drop (kgf)."""
    z = (N * mu0 - jnp.abs(applied)) / (smoothing * N * drop)
    sig = 0.5 * (1.0 + jnp.tanh(z)) * jnp.exp(-r * r)
    f = sig * (applied + N * mu0 * r) + (1.0 - sig) * N * mu_slip * jnp.tanh(8.0 * r)
    return sig, f


def slip_weight(r):
    r"""Latch: $s_w = 1 - e^{-r^2}$ ($r > 0$, else 0), the weight of the kinetic friction
    on a moving slider; flat at 0, so a slip comes to rest algebraically,
    $\dot y \sim \varepsilon^2/(C t)$ (Jacobian $O(1/t)$, not $O(1/\varepsilon)$)."""
    rp = jnp.maximum(r, 0.0)
    return -jnp.expm1(-rp * rp)


def drive_weight(r):
    r"""Latch: $s_a = e^{-1/r^2}$ ($r > 0$, else 0), the weight with which a positive net
    force drives a moving slider; flat to all orders at 0, so only the breakaway switch
    $s_F$ starts a slip."""
    rp = jnp.maximum(r, 0.0)
    safe = jnp.where(rp > 0, rp, 1.0)
    return jnp.where(rp > 0, jnp.exp(-1.0 / (safe * safe)), 0.0)


LATCH_ONSET = 10.0
"""Latch formulation: a resting slider's creep must reach `LATCH_ONSET` * eps before the
slip takes over (`drive_weight(r / LATCH_ONSET)`)."""


def latch_shift(M, k, v, force_drop):
    r"""Offset $z_0 = \tfrac12\ln(2 K M k v^2 / (N D)^2)$ of the latch's breakaway switch
    ($K$ = `LATCH_ONSET`, M kgf s^2/mm, k kgf/mm, v mm/s, force drop $N D$ kgf): the switch
    tail $s_F \approx e^{2z}$ lets the slider creep to $K\varepsilon$ at
    $e^{2z} = 2KMkv^2/(ND)^2$ (z near -4 at 3 mm/min); the offset moves that onset to
    $F_a = N\mu_0$."""
    return 0.5 * jnp.log(2.0 * LATCH_ONSET * M * k * v * v / (force_drop * force_drop))


def latch_acceleration(applied, r, N, mu0, mu_slip, drop, smoothing, shift=0.0):
    r"""$s_w$ and the net force (kgf) $M\ddot y$ of the latch (module docstring), with the
    breakaway switch $s_F = \tfrac12[1 + \tanh((F_a - N\mu_0)/(\eta N D) + z_0)]$
    ($z_0$ = `shift`, `latch_shift`; $F_a$, $N D$ in kgf; `r` = $\dot y/\varepsilon$)."""
    s_w = slip_weight(r)
    s_a = drive_weight(r / LATCH_ONSET)
    s_f = 0.5 * (1.0 + jnp.tanh((applied - N * mu0) / (smoothing * N * drop) + shift))
    net = applied - N * mu_slip
    force = s_w * jnp.minimum(net, 0.0) + (s_a + (1.0 - s_a) * s_f) * jnp.maximum(net, 0.0)
    return s_w, force


def slip_friction(friction, memory, ydot, slip_time):
    """Kinetic friction coefficient of a slip: a law of the velocity at `ydot` (mm/s), else
    the mean kinetic friction of the breakaway level `memory` and the slip time (s)."""
    if isinstance(friction.kinetic, AbstractVelocityKinetic):
        return friction.kinetic.at_velocity(ydot, memory, friction.mu_d)
    return friction.kinetic(memory, friction.mu_d, slip_time)


def rate_state_rates(friction, core: Core, applied, N, M):
    r"""Rate-and-state law (module docstring): $\ddot y$ (mm/s^2) under the applied force
    (kgf) and normal load N (kgf), $\dot\theta$, and 0 for the constant fourth state."""
    kin = friction.kinetic
    mu = kin.coefficient(core.ydot, core.tau, friction.mu_d)
    return (applied - N * mu) / M, kin.state_rate(core.ydot, core.tau), 0.0 * core.mu_0_memory


def rate_state_start(slideway: Slideway, v_drive, x0, stick_time):
    r"""Initial core state of a rate-and-state law (module docstring): the deflection `x0`
    (mm), the velocity (mm/s) and state (s) of `RateStateKinetic.start` for the spring's
    friction level $kx_0/N$ at the drive speed `v_drive` (mm/s), `stick_time` (s) after
    a slip end."""
    fr = slideway.friction
    v0, theta0 = fr.kinetic.start(slideway.stiffness * x0 / slideway.load, v_drive,
                                  stick_time, fr.mu_d)
    return jnp.stack([x0, v0, theta0, fr.mu_d + 0.0 * x0])


class _Dynamics(NamedTuple):
    """The smoothed model's ODE: `vector_field(t, y, args)` over the states y = (core
    vector [x, ydot, tau, 4th], parts' states), `make_core` (core vector -> `Core`),
    `context` (t -> `Context`), the slip time `T2` (s) of eq (3), the smoothing velocity
    `eps` (mm/s), whether the 4th core state is the last stick time (`rigid`; mu_0
    itself otherwise) and the model's parts."""

    vector_field: Callable
    make_core: Callable
    context: Callable
    T2: Array
    eps: Array
    rigid: bool
    parts: tuple


def _dynamics(model: SmoothModel, drive: AbstractDrive, *, slip_time, smoothing: float,
              formulation: Formulation, rs: bool, latch: bool) -> _Dynamics:
    """The vector field of `model` driven by `drive` in `formulation` (`rs`: a rate-and-
    state kinetic law; `latch`: the latch formulation), with what it is built from."""
    sw = model.slideway
    friction, static = sw.friction, sw.friction.static
    W, k = sw.weight, sw.stiffness
    M, omega = sw.mass, sw.omega0
    T2 = jnp.pi / omega if isinstance(slip_time, SlipTime) else jnp.asarray(slip_time, float)
    t_r = jnp.pi / omega / 40.0
    t_r_latch = jnp.pi / omega / 20.0  # latch: tau resets by e^-20 or more in a slip
    t_reset = t_r / 10.0
    eps = smoothing_velocity(drive, smoothing)
    parts = model.parts()
    floor = 1e-2 * (static.asymptote() - friction.mu_d)

    def _drop_scale(mu0):  # the friction drop mu_0 - mu_m, floored (0 at tau = 0)
        return mu0 - friction.kinetic(mu0, friction.mu_d, T2) + floor

    def context(t):
        return Context(weight=W, stiffness=k, mass=M, omega0=omega, eps=eps,
                       drive_position=drive.position(t), drive_speed=drive.speed(t),
                       normal_load=sw.load)

    rigid = formulation is not Formulation.VELOCITY and not rs

    def make_core(cv):
        # 4th state: rigid_stick and latch the last stick time (s), "velocity" mu_0 itself
        return Core(cv[0], cv[1], cv[2], static(cv[3]) if rigid else cv[3])

    def split(y):
        core_vec, own = y
        return make_core(core_vec), own

    def vector_field(t, y, args):
        core, own = split(y)
        ctx = context(t)
        n_force = len(model.force_terms)
        N = model.load.normal_load(t, core, own[n_force], ctx)
        ctx = eqx.tree_at(lambda c: c.normal_load, ctx, N)
        mu0 = static(core.tau)
        mu_sl = slip_friction(friction, core.mu_0_memory, core.ydot, T2)
        tau, memory = y[0][2], y[0][3]
        r = core.ydot / eps
        extra = sum((f.force(t, core, o, ctx) for f, o in zip(model.force_terms, own)),
                    jnp.zeros(()))
        applied = k * core.x + extra
        rest = stick_weight(r)  # 1 while the slider rests
        if rs:
            ydd, d_tau, d_memory = rate_state_rates(friction, core, applied, N, M)
        elif latch:
            drop = _drop_scale(mu0)
            v_d = jnp.maximum(jnp.abs(ctx.drive_speed), eps)
            shift = latch_shift(M, k, v_d, N * drop)
            _, f_net = latch_acceleration(applied, r, N, mu0, mu_sl, drop, smoothing, shift)
            ydd = f_net / M
            # clock and memory stop once the slip is under way (r > 2); after a restick
            # the memory catches up with tau algebraically (not stiff)
            d_memory = rest * (1.0 + 4.0 * (tau - memory) / (tau + t_r_latch))
        elif formulation is Formulation.VELOCITY:
            f_fric = N * friction_curve(r, mu0, mu_sl)
            ydd = (k * core.x - f_fric + extra) / M
            d_memory = rest * (mu0 - memory) / t_r
        else:
            _, f_fric = rigid_stick_friction(applied, r, N, mu0, mu_sl, _drop_scale(mu0),
                                             smoothing)
            ydd = (applied - f_fric) / M
            # the memory equals tau while sticking, is frozen while slipping and relaxes
            # to the new tau in t_r / 10 after a restick
            d_memory = rest * (1.0 + (tau - memory) / t_reset)
        if not rs:  # the stick clock runs at rest and resets in a slip
            d_tau = rest - (1.0 - rest) * tau / (t_r_latch if latch else t_r)
        d_core = jnp.stack([ctx.drive_speed - core.ydot, ydd, d_tau, d_memory])
        d_own = tuple(p.state_derivative(t, core, o, ctx) for p, o in zip(parts, own))
        return d_core, d_own

    return _Dynamics(vector_field=vector_field, make_core=make_core, context=context, T2=T2,
                     eps=eps, rigid=rigid, parts=parts)


def simulate_smooth(model: SmoothModel | Slideway, drive: AbstractDrive, ts: Float[ArrayLike, " N"],
                    *, smoothing: float = DEFAULT_SMOOTHING,
                    slip_time: SlipTime | str | float = SlipTime.PAPER, rtol: float = 1e-8,
                    atol: float = 1e-10, solver: dfx.AbstractSolver | None = None,
                    max_steps: int = 16384, initial_deflection: Float[ArrayLike, ""] = 0.0,
                    initial_stick_time: Float[ArrayLike, ""] = 0.0, mask: ArrayLike | None = None,
                    adjoint: dfx.AbstractAdjoint | None = None, dt0: float | None = None,
                    formulation: Formulation | str = Formulation.LATCH) -> Trace:
    r"""Simulate the smoothed model (module docstring) on the sample times `ts` (s).

    - `model`: a `SmoothModel`, or a `Slideway` (then no extra parts); `drive`: any
      `AbstractDrive` (its knots are step-size jump points when there are at most 256).
    - `smoothing`: dimensionless $\eta$ (where each formulation's gradients are verified:
      module docstring); `slip_time`: `SlipTime.PAPER` ("paper") or seconds.
    - `rtol`, `atol` (mm, mm/s), `solver` (default Kvaerno5; Tsit5 for "latch"), `max_steps`,
      `adjoint` (default `RecursiveCheckpointAdjoint`), `dt0` (s, default automatic).
    - `formulation`: a `Formulation` or its value (module docstring).
    - The slider starts at rest with `initial_deflection` (mm), stuck for
      `initial_stick_time` (s), at `ts[0]` (a rate-and-state law: module docstring).

    Returns a `Trace`: `deflection` is what the measurement part observes (mm, noise-free),
    `slider_velocity` (mm/s), `sticking` = $|\dot y| < 3\varepsilon$, `cycles` estimated from
    the samples (`cycles_from_samples`), `result` (`solver_failed` if diffrax did not
    succeed), `num_events` = accepted steps.
    """
    if isinstance(model, Slideway):
        model = SmoothModel(model)
    if not isinstance(model, SmoothModel):
        raise ValueError(f"model must be a SmoothModel or Slideway, got {type(model)}")
    if not isinstance(drive, AbstractDrive):
        raise ValueError(f"drive must be an AbstractDrive, got {type(drive)}")
    if isinstance(slip_time, str):
        slip_time = SlipTime.parse(slip_time)
        if slip_time != SlipTime.PAPER:
            raise ValueError('slip_time must be "paper" or a number of seconds '
                             '(the smoothed simulator has no self-consistent mode)')
    formulation = Formulation.parse(formulation)
    ts = jnp.asarray(ts, dtype=float)
    if ts.ndim != 1 or ts.shape[0] < 2:
        raise ValueError("ts must be a 1-D array of at least two times (s); vmap for batches")
    mask = jnp.ones(ts.shape, bool) if mask is None else jnp.asarray(mask, bool)
    rs = isinstance(model.slideway.friction.kinetic, RateStateKinetic)
    latch = formulation is Formulation.LATCH and not rs
    # concrete inputs checked (`check_inputs`); the rendering from the accepted steps
    # needs sorted sample times
    check_inputs("simulate_smooth", model.slideway, ts)
    if solver is None:
        solver = dfx.Tsit5() if latch else default_solver(rtol, atol)

    sw = model.slideway
    friction, static = sw.friction, sw.friction.static
    W = sw.weight
    t0, t1 = ts[0], jnp.max(ts)
    vector_field, make_core, context, T2, eps, rigid, parts = _dynamics(
        model, drive, slip_time=slip_time, smoothing=smoothing, formulation=formulation,
        rs=rs, latch=latch)

    tau0, x0 = (jnp.asarray(v, float) + 0.0 * W for v in (initial_stick_time, initial_deflection))
    core0 = rate_state_start(sw, smoothing_velocity(drive, 1.0), x0, tau0) if rs else (
        jnp.stack([x0, 0.0 * W, tau0 + 0.0 * W, (tau0 if rigid else static(tau0)) + 0.0 * W]))
    ctx0 = context(t0)
    y0 = (core0, tuple(p.init_state(ctx0) for p in parts))

    kt, _, _ = drive.knots()
    if latch:
        # the error norm leaves out the clock and the memory (module docstring)
        def norm(err):
            core_err, own_err = err
            return optx.rms_norm((core_err[:2], own_err))
    else:
        norm = optx.rms_norm
    pid = dfx.PIDController(rtol=rtol, atol=atol, pcoeff=0.3, icoeff=0.4, norm=norm)
    # a drive with one knot (constant speed) has no jump inside the run
    clip = kt.shape[0] <= 256 and not (latch and kt.shape[0] == 1)
    controller = dfx.ClipStepSizeController(pid, jump_ts=kt) if clip else pid
    sol = dfx.diffeqsolve(
        dfx.ODETerm(vector_field), solver, t0=t0, t1=t1, dt0=dt0, y0=y0,
        saveat=dfx.SaveAt(steps=True), stepsize_controller=controller, max_steps=max_steps,
        adjoint=dfx.RecursiveCheckpointAdjoint() if adjoint is None else adjoint, throw=False)
    # all samples at once from the steps: no loop over the samples, and no `SaveAt(ts)`,
    # whose run-time check of the times is a host callback
    core_ts, own_ts = _hermite_at(vector_field, t0, y0, sol, ts)

    def observe(t, cv, ov):
        core = make_core(cv)
        return model.measurement.observe(t, core, ov[-1], context(t))

    deflection = jax.vmap(observe)(ts, core_ts, own_ts)
    ydot = core_ts[:, 1]
    sticking = jnp.abs(ydot) < 3.0 * eps
    ok = sol.result == dfx.RESULTS.successful
    result = SimulationResult.where(ok, SimulationResult.successful,
                                    SimulationResult.solver_failed)
    cycles = cycles_from_samples(ts, core_ts[:, 0], sticking, mask, friction, T2,
                                 max_cycles=64, t_start=t0 - tau0)
    late = ts >= 0.5 * (t0 + t1)
    steady = ~jnp.any(sticking & mask & late)  # no stick in the second half of the run
    return Trace(time=ts, deflection=deflection, slider_velocity=ydot, sticking=sticking, mask=mask,
                 cycles=cycles, steady_sliding=steady, result=result,
                 num_events=jnp.asarray(sol.stats["num_accepted_steps"]).astype(int))


def _hermite_at(vector_field, t0, y0, sol, ts):
    """The solution at the times `ts` (sorted) from the accepted steps (`SaveAt(steps=True)`):
    on each step the cubic Hermite polynomial of the states and their derivatives at both
    ends (4th-order accurate, like the solver's own interpolant), all samples at once: one
    binary search of each sample among the step times, one row gather of the step's
    coefficients, Horner's rule."""
    n = jnp.asarray(sol.stats["num_accepted_steps"])
    leaves, treedef = jax.tree_util.tree_flatten(sol.ys)
    leaves0 = jax.tree_util.tree_leaves(y0)
    sizes = [int(math.prod(l.shape[1:])) for l in leaves]
    flat = jnp.concatenate(
        [jnp.concatenate([l0.reshape(1, -1), l.reshape(l.shape[0], -1)]) for l0, l in
         zip(leaves0, leaves)], axis=1)  # [S + 1, C]
    times = jnp.concatenate([jnp.reshape(t0, (1,)), sol.ts])
    # the unused tail of the buffers (inf) repeats the last accepted step
    rows = jnp.arange(times.shape[0])
    times = jnp.where(rows <= n, times, times[n])
    flat = jnp.where((rows <= n)[:, None], flat, flat[n])

    def unflat(v):
        parts, i = [], 0
        for l, size in zip(leaves, sizes):
            parts.append(v[i:i + size].reshape(l.shape[1:]))
            i += size
        return jax.tree_util.tree_unflatten(treedef, parts)

    def deriv(t, v):
        d = vector_field(t, unflat(v), None)
        return jnp.concatenate([jnp.reshape(x, (-1,)) for x in jax.tree_util.tree_leaves(d)])

    dflat = jax.vmap(deriv)(times, flat)
    h = times[1:] - times[:-1]
    h_safe = jnp.where(h > 0, h, 1.0)[:, None]
    hd0, hd1 = h[:, None] * dflat[:-1], h[:, None] * dflat[1:]
    dy = flat[1:] - flat[:-1]
    # coefficients of the powers of (t - t_step) (cubic Hermite), one [S, 4] table per
    # component so that a component nobody reads is never gathered; each table is
    # materialised once by a scatter (XLA would otherwise fuse the table, vector field
    # included, into the gather and recompute it for every sample)
    coef = jnp.stack([flat[:-1], dflat[:-1], (3.0 * dy - 2.0 * hd0 - hd1) / h_safe ** 2,
                      (hd0 + hd1 - 2.0 * dy) / h_safe ** 3], axis=-1)  # [S, C, 4]
    rows = jnp.arange(coef.shape[0])

    def materialise(a):
        return jnp.zeros_like(a).at[rows].set(a)

    start = materialise(times[:-1])
    idx = jnp.clip(count_at_or_before(times, ts) - 1, 0, jnp.maximum(n - 1, 0))
    dt = ts - start[idx]
    cols = []
    for j in range(flat.shape[1]):
        c = materialise(coef[:, j, :])[idx]
        cols.append(((c[:, 3] * dt + c[:, 2]) * dt + c[:, 1]) * dt + c[:, 0])
    return jax.vmap(unflat)(jnp.stack(cols, axis=1))


def cycles_from_samples(time, deflection, sticking, mask, friction, slip_time, *,
                        max_cycles: int = 64, t_start=None) -> Cycles:
    r"""Per-cycle table estimated from sampled x(t) (mm) and a sticking mask.

    Breakaway = last sticking sample before a slipping one; slip end = first sticking
    sample after slipping. `peak`/`trough` are the sampled extremes next to these
    transitions, so they carry the sampling error ($v\,\Delta t$ and slip speed times
    $\Delta t$ near the ends); `mu_0`, `mu_m` are eq (1) and eq (3) at the estimated
    $T_1$ and `slip_time`. `restick_failed` is never set (it is not observable here).
    """
    s, m = sticking, mask
    brk = s[:-1] & ~s[1:] & m[1:]
    end = ~s[:-1] & s[1:] & m[1:]
    # cycle c runs from the (c+1)-th breakaway to the next; its slip end is the last end
    # in that range (counts and binary searches, no scatter over the samples)
    n_brk = jax.lax.associative_scan(jnp.add, brk.astype(jnp.int32))
    n_end = jax.lax.associative_scan(jnp.add, end.astype(jnp.int32))
    c = jnp.arange(max_cycles, dtype=jnp.int32)
    last = brk.shape[0] - 1
    i_b = jnp.minimum(jnp.searchsorted(n_brk, c + 1, side="left"), last)
    i_next = jnp.searchsorted(n_brk, c + 2, side="left")  # next breakaway (or the end)
    broke = c < n_brk[-1]
    ends_before_next = n_end[jnp.clip(i_next - 1, 0, last)]
    ended = broke & (ends_before_next > n_end[i_b])
    i_e = jnp.minimum(jnp.searchsorted(n_end, ends_before_next, side="left"), last)
    z = jnp.zeros((max_cycles,))
    t_b = jnp.where(broke, time[i_b], z)
    peak = jnp.where(broke, jnp.maximum(deflection[i_b], deflection[i_b + 1]), z)
    t_e = jnp.where(ended, time[i_e + 1], z)
    trough = jnp.where(ended, jnp.minimum(deflection[i_e], deflection[i_e + 1]), z)
    valid = broke & ended
    t_first = time[0] if t_start is None else t_start
    prev_end = jnp.concatenate([jnp.asarray(t_first)[None], t_e[:-1]])
    t1 = jnp.maximum(t_b - prev_end, 0.0)
    mu0 = friction.static(t1)
    mum = friction.kinetic(mu0, friction.mu_d, slip_time)
    v = lambda a: jnp.where(valid, a, 0.0)  # noqa: E731
    return Cycles(
        breakaway_time=v(t_b), peak=v(peak), trough=v(trough), stick_time=v(t1),
        slip_time=v(t_e - t_b), model_slip_time=v(jnp.broadcast_to(slip_time, z.shape)),
        mu_0=v(mu0), mu_m=v(mum), restick_failed=jnp.zeros((max_cycles,), bool), valid=valid)
