r"""Smoothed, differentiable simulator: the paper's stick-slip model as one smooth stiff ODE.

State: spring deflection $x$ (mm), slider velocity $\dot y$ (mm/s), a stick-time state
$\tau$ (s), the breakaway-friction memory $q$ (dimensionless) and the states of the
parts (parts.py). With drive speed $\dot u(t)$, normal load $N$ (= W for the paper),
$r = \dot y/\varepsilon$:

$$\dot x = \dot u - \dot y,\qquad
M\ddot y = k x - N\,[\mu_{sl}\,\tanh(8r) + (\mu_0(\tau) - \mu_{sl})\,r\,e^{(1-r^2)/2}]
          + \textstyle\sum_i F_i,$$
$$\dot\tau = \sigma - (1-\sigma)\,\tau/t_r,\qquad \dot q = \sigma\,(\mu_0(\tau) - q)/t_r,\qquad
\sigma = \exp(-(r/4)^8),\qquad \mu_{sl} = \mu_m(q, \mu_d, T_2)\ \text{(eq 3)}.$$

- The friction curve against $r$ rises steeply from 0, peaks at $r \approx 1$ at
  $N\mu_0(\tau)$ (the bump $r e^{(1-r^2)/2}$ has its maximum 1 at $r = 1$) and falls to
  the kinetic level $N\mu_{sl}$ for $r \gtrsim 5$.
- While the slider sticks ($|r| \lesssim 1$, $\sigma = 1$) it creeps at $\dot y \le \varepsilon$;
  $\tau$ grows at rate 1 (it *is* the stick time $T_1$) and $q$ follows $\mu_0(\tau)$.
- When $k x$ exceeds $N\mu_0(\tau)$ the slider breaks away; for $|r| \gg 1$ friction is the
  constant mean kinetic friction $\mu_m N$ of eq (3), with the memory $q = \mu_0(T_1)$
  frozen ($\sigma = 0$), and $\tau$ decays to 0 (time constant $t_r = T_0/40$,
  $T_0 = \pi/\omega_0$) so that the next stick starts afresh.
- $T_2$ in eq (3) is $\pi/\omega_0$ (eq 7, `slip_time="paper"`) or a given value in s.

**Two formulations.** The equations above are `formulation="velocity"`. The default
`formulation="rigid_stick"` (`rigid_stick_friction`) switches in the force instead: the
slider sticks while $|F_a| = |k x + \sum_i F_i| < N\mu_0(\tau)$ *and* it rests
($e^{-r^2}$), with friction $= F_a$ plus a term pinning $\dot y$ to 0, so the stick is
rigid (no creep); the switch $\tfrac12[1+\tanh z]$ has width $\eta$ times the friction drop
$N(\mu_0 - \mu_m)$; the stick clock $\tau$ runs while $\sigma(r) = e^{-(r/4)^8} \approx 1$
(it stops only once the slider moves), and the memory holds the last stick time
($\tau$ itself while sticking, frozen while slipping, relaxing to the new $\tau$ in
$t_r/10$ after a restick).

**Smoothing scale.** One dimensionless number `smoothing` $=\eta$ sets the velocity
scale $\varepsilon = \eta\, v_{ref}$ (mm/s), $v_{ref}$ the largest drive speed, and (rigid
stick) the relative width of the force switch. Rigid stick, default $\eta = 10^{-3}$:
limit-cycle amplitude within 0.15 % of the exact simulator on the benchmark campaign,
error linear in $\eta$ (1.3 % at $\eta = 10^{-2}$, 30 mm/min). Velocity formulation: the
breakaway is late by about $\sqrt{2\eta}/\omega_0$, 5 % amplitude error near $v_c$ at
$\eta = 0.03$; its gradients match finite differences to 1e-4 for $\eta \ge 0.03$ at
rtol 1e-9 and 1e-10 (tests). Rigid-stick gradients at $\eta = 10^{-3}$ need rtol 1e-10.

The ODE is stiff (relaxation rate $\sim g\mu_0/\varepsilon$ while sticking), so the
default solver is the L-stable implicit `diffrax.Kvaerno5` with a PID step-size
controller; gradients are taken through the solver (discretise-then-optimise), which
matches finite differences when the tolerances resolve the switching layers (tests).
"""

from __future__ import annotations

import diffrax as dfx
import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import Array, ArrayLike, Float

from ..drives import AbstractDrive
from ..slideway import Slideway
from ..units import G_MM_S2
from .parts import (
    AbstractForceTerm,
    AbstractLoadCoupling,
    AbstractMeasurement,
    ConstantLoad,
    Context,
    Core,
    IdealGauge,
)
from .trace import Cycles, SimulationResult, Trace


FORMULATIONS = ("rigid_stick", "velocity")
DEFAULT_SMOOTHING = 1e-3
"""Default smoothing of the rigid-stick formulation: the sharpest whose gradients the tests
verify (limit-cycle amplitude within 0.2 % of the exact simulator on the benchmark)."""


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
            isinstance(f, AbstractForceTerm) for f in self.force_terms
        ):
            raise ValueError("force_terms must be a tuple of AbstractForceTerm")
        if not isinstance(self.load, AbstractLoadCoupling):
            raise ValueError("load must be an AbstractLoadCoupling")
        if not isinstance(self.measurement, AbstractMeasurement):
            raise ValueError("measurement must be an AbstractMeasurement")

    def parts(self):
        return (*self.force_terms, self.load, self.measurement)


def default_solver(rtol: float = 1e-8, atol: float = 1e-10):
    """Kvaerno5 (5th-order ESDIRK, L-stable) with a full Newton solve of each stage.

    The default chord iteration (Jacobian reused) fails near breakaway, where the
    Jacobian changes fast, and takes ten times more steps; full Newton does not.
    """
    return dfx.Kvaerno5(root_finder=optx.Newton(rtol=rtol, atol=atol))


def smoothing_velocity(drive: AbstractDrive, smoothing):
    """The velocity scale eps = smoothing * (largest drive speed), mm/s."""
    _, _, speeds = drive.knots()
    return smoothing * jnp.max(jnp.abs(speeds))


def friction_curve(r, mu_0, mu_slip):
    r"""Friction coefficient against $r = \dot y/arepsilon$: peak $\mu_0$ near $r = 1$,
    kinetic level $\mu_{sl}$ for $|r| \gg 1$ (module docstring)."""
    return mu_slip * jnp.tanh(8.0 * r) + (mu_0 - mu_slip) * r * jnp.exp(0.5 * (1.0 - r * r))


def stick_weight(r):
    r"""$\sigma = \exp(-(r/4)^8)$: 1 while sticking ($|r| \lesssim 1$), 0 while slipping."""
    return jnp.exp(-((r / 4.0) ** 8))


def rigid_stick_friction(applied, r, N, mu0, mu_slip, drop, smoothing):
    r"""Stick weight $\sigma$ and friction force (kgf) of the rigid-stick formulation.

    $\sigma = s_F\,s_v$, $s_F = \tfrac12[1 + \tanh z]$, $z = (N\mu_0 - |F_a|)/(\eta N D)$,
    $s_v = e^{-r^2}$: sticking needs both the applied force $F_a$ (kgf) below the
    breakaway force $N\mu_0(\tau)$ (switch width $\eta$ times the friction drop $N D$) and
    the slider at rest ($r = \dot y/\varepsilon$). Friction
    $F = \sigma\,(F_a + N\mu_0 r) + (1 - \sigma)\,N\mu_{sl}\tanh(8 r)$: while sticking
    it balances $F_a$ and pins $\dot y$ to 0 (relaxation time $\varepsilon/(g\mu_0)$);
    while slipping it is the kinetic friction of eq (3).
    """
    z = (N * mu0 - jnp.abs(applied)) / (smoothing * N * drop)
    sig = 0.5 * (1.0 + jnp.tanh(z)) * jnp.exp(-r * r)
    f = sig * (applied + N * mu0 * r) + (1.0 - sig) * N * mu_slip * jnp.tanh(8.0 * r)
    return sig, f


def simulate_smooth(
    model: SmoothModel | Slideway,
    drive: AbstractDrive,
    ts: Float[ArrayLike, " N"],
    *,
    smoothing: float = DEFAULT_SMOOTHING,
    slip_time: str | float = "paper",
    rtol: float = 1e-8,
    atol: float = 1e-10,
    solver: dfx.AbstractSolver | None = None,
    max_steps: int = 16384,
    initial_deflection: Float[ArrayLike, ""] = 0.0,
    initial_stick_time: Float[ArrayLike, ""] = 0.0,
    mask: ArrayLike | None = None,
    adjoint: dfx.AbstractAdjoint | None = None,
    dt0: float | None = None,
    formulation: str = "rigid_stick",
) -> Trace:
    r"""Simulate the smoothed model (module docstring) on the sample times `ts` (s).

    - `model`: a `SmoothModel`, or a `Slideway` (then no extra parts).
    - `drive`: any `AbstractDrive`; its knots are step-size jump points when there are
      at most 256 of them.
    - `smoothing`: dimensionless $\eta$ (default `DEFAULT_SMOOTHING` = 0.03; gradients are
      verified against finite differences for $\eta \ge$ 0.03 at rtol <= 1e-9); `slip_time`: "paper" or seconds.
    - `rtol`, `atol` (mm, mm/s), `solver` (default Kvaerno5), `max_steps`, `adjoint`
      (default `RecursiveCheckpointAdjoint`), `dt0` (s, default automatic).
    - The slider starts at rest with `initial_deflection` (mm), stuck for
      `initial_stick_time` (s), at `ts[0]`.

    Returns a `Trace`: `deflection` is what the measurement part observes (mm,
    noise-free), `slider_velocity` (mm/s), `sticking` = $|\dot y| < 3\varepsilon$,
    `cycles` estimated from the samples (`cycles_from_samples`), `result`
    (`solver_failed` if diffrax did not succeed), `num_events` = accepted steps.
    """
    if isinstance(model, Slideway):
        model = SmoothModel(model)
    if not isinstance(model, SmoothModel):
        raise ValueError(f"model must be a SmoothModel or Slideway, got {type(model)}")
    if not isinstance(drive, AbstractDrive):
        raise ValueError(f"drive must be an AbstractDrive, got {type(drive)}")
    if isinstance(slip_time, str) and slip_time != "paper":
        raise ValueError('slip_time must be "paper" or a number of seconds '
                         '(the smoothed simulator has no self-consistent mode)')
    if formulation not in FORMULATIONS:
        raise ValueError(f"formulation must be one of {FORMULATIONS}, got {formulation!r}")
    ts = jnp.asarray(ts, dtype=float)
    if ts.ndim != 1 or ts.shape[0] < 2:
        raise ValueError("ts must be a 1-D array of at least two times (s); vmap for batches")
    mask = jnp.ones(ts.shape, bool) if mask is None else jnp.asarray(mask, bool)
    solver = default_solver(rtol, atol) if solver is None else solver

    sw = model.slideway
    friction, static = sw.friction, sw.friction.static
    W = eqx.error_if(sw.weight, ~(sw.weight > 0), "slider weight W must be positive")
    k = eqx.error_if(sw.stiffness, ~(sw.stiffness > 0), "stiffness k must be positive")
    M = W / G_MM_S2
    omega = jnp.sqrt(G_MM_S2 * k / W)
    t0, t1 = ts[0], jnp.max(ts)
    T2 = jnp.pi / omega if isinstance(slip_time, str) else jnp.asarray(slip_time, float)
    t_r = jnp.pi / omega / 40.0
    t_reset = t_r / 10.0
    eps = smoothing_velocity(drive, smoothing)
    parts = model.parts()
    floor = 1e-2 * (static.asymptote() - friction.mu_d)

    def _drop_scale(mu0):
        # the breakaway-to-slip friction drop mu_0 - mu_m of a stick of the current length,
        # floored (it is 0 at tau = 0)
        return mu0 - friction.kinetic(mu0, friction.mu_d, T2) + floor

    def context(t):
        return Context(
            weight=W, stiffness=k, mass=M, omega0=omega, drive_position=drive.position(t),
            drive_speed=drive.speed(t), eps=eps, normal_load=W,
        )

    rigid = formulation == "rigid_stick"

    def make_core(cv):
        # rigid_stick keeps the stick time of the last stick (s) as its 4th state and hands
        # the parts mu_0 of it; "velocity" keeps mu_0 itself
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
        mu_sl = friction.kinetic(core.mu_0_memory, friction.mu_d, T2)
        tau, memory = y[0][2], y[0][3]
        r = core.ydot / eps
        extra = sum((f.force(t, core, o, ctx) for f, o in zip(model.force_terms, own)),
                    jnp.zeros(()))
        if formulation == "velocity":
            sig = stick_weight(r)
            f_fric = N * friction_curve(r, mu0, mu_sl)
            ydd = (k * core.x - f_fric + extra) / M
            d_memory = sig * (mu0 - memory) / t_r
            rest = sig
        else:
            applied = k * core.x + extra
            sig, f_fric = rigid_stick_friction(applied, r, N, mu0, mu_sl,
                                               _drop_scale(mu0), smoothing)
            ydd = (applied - f_fric) / M
            # the memory equals tau while sticking (exactly, once settled) and is frozen
            # while slipping; after a restick it relaxes to the new tau in t_r / 10
            rest = stick_weight(r)  # the slider rests (flat for r < 2): the stick clock runs
            d_memory = rest * (1.0 + (tau - memory) / t_reset)
        d_core = jnp.stack([
            ctx.drive_speed - core.ydot,
            ydd,
            rest - (1.0 - rest) * tau / t_r,
            d_memory,
        ])
        d_own = tuple(p.state_derivative(t, core, o, ctx) for p, o in zip(parts, own))
        return d_core, d_own

    tau0 = jnp.asarray(initial_stick_time, dtype=float)
    core0 = jnp.stack([jnp.asarray(initial_deflection, float) + 0.0 * W, 0.0 * W,
                       tau0 + 0.0 * W, (tau0 if rigid else static(tau0)) + 0.0 * W])
    ctx0 = context(t0)
    y0 = (core0, tuple(p.init_state(ctx0) for p in parts))

    kt, _, _ = drive.knots()
    pid = dfx.PIDController(rtol=rtol, atol=atol, pcoeff=0.3, icoeff=0.4)
    controller = dfx.ClipStepSizeController(pid, jump_ts=kt) if kt.shape[0] <= 256 else pid
    sol = dfx.diffeqsolve(
        dfx.ODETerm(vector_field), solver, t0=t0, t1=t1, dt0=dt0, y0=y0,
        saveat=dfx.SaveAt(ts=ts), stepsize_controller=controller, max_steps=max_steps,
        adjoint=dfx.RecursiveCheckpointAdjoint() if adjoint is None else adjoint, throw=False,
    )
    core_ts, own_ts = sol.ys

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
    return Trace(
        time=ts, deflection=deflection, slider_velocity=ydot, sticking=sticking, mask=mask,
        cycles=cycles, steady_sliding=steady, result=result,
        num_events=jnp.asarray(sol.stats["num_accepted_steps"]).astype(int),
    )


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
    cid = jnp.cumsum(brk.astype(int)) - 1
    drop = jnp.full_like(cid, max_cycles)
    bid = jnp.where(brk, cid, drop)
    eid = jnp.where(end & (cid >= 0), cid, drop)
    z = jnp.zeros((max_cycles,))

    def put(ids, v):
        return z.at[ids].set(v, mode="drop")

    t_b = put(bid, time[:-1])
    peak = put(bid, jnp.maximum(deflection[:-1], deflection[1:]))
    t_e = put(eid, time[1:])
    trough = put(eid, jnp.minimum(deflection[:-1], deflection[1:]))
    broke = put(bid, jnp.ones_like(time[:-1])) > 0
    ended = put(eid, jnp.ones_like(time[:-1])) > 0
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
        mu_0=v(mu0), mu_m=v(mum), restick_failed=jnp.zeros((max_cycles,), bool), valid=valid,
    )
