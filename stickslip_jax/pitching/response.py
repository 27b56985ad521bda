r"""Tilt of the slider from any spring-force history: the exact discrete-time lag.

The lag of `LinearLag` is a linear ODE; with the input taken piecewise linear between
samples (first-order hold) each mode advances exactly by
$\theta_{k+1} = a\,\theta_k + (1-b)\,u_{k+1} + (b-a)\,u_k$, with $x = \Delta t/\tau$,
$a = e^{-x}$, $b = (1-e^{-x})/x$. The recurrence runs as one `lax.scan` (a
`lax.associative_scan` would be parallel but compiles several times slower inside the
fits, for no gain on CPU); uneven sampling is fine.

Everything here is linear in the force: the response to a stick ramp followed by a drop
is the sum of the rise $\varepsilon_u$ and the recovery $\varepsilon_d$ of section 6.3.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .model import DrivePoint, LinearLag, PitchingModel, TiltPlane

_X_SMALL = 1e-8


def _step_coefficients(dt, tau):
    """a = exp(-dt/tau), b = (1 - a)/(dt/tau), NaN-free at dt = 0 and tau -> 0."""
    tau = jnp.maximum(tau, 1e-300)
    x = dt / tau
    small = x < _X_SMALL
    x_safe = jnp.where(small, 1.0, x)
    a = jnp.exp(-x)
    b = jnp.where(small, 1.0 - 0.5 * x, -jnp.expm1(-x_safe) / x_safe)
    return a, b


def _mode_response(u, ts, tau, initial):
    """One first-order mode of static gain 1 driven by u (shape (n,)), from `initial`."""
    dt = jnp.diff(ts)
    a, b = _step_coefficients(dt, tau)
    c = (1.0 - b) * u[1:] + (b - a) * u[:-1]
    initial = jnp.asarray(initial, dtype=u.dtype)

    def step(theta, ac):
        theta = ac[0] * theta + ac[1]
        return theta, theta

    _, theta = jax.lax.scan(step, initial, (a, c))
    return jnp.concatenate([initial[None], theta])


def lag_response(lag: LinearLag, u: Float[Array, " n"], ts: Float[Array, " n"], time_scale=1.0,
                 periodic: bool = False) -> Float[Array, " n"]:
    r"""Response of `lag` to the input history `u` sampled at times `ts` (s).

    `u` is the static tilt (any unit; the output has the same unit). The time constants
    are multiplied by `time_scale` (the viscosity ratio $\eta/\eta_{ref}$). With
    `periodic=False` the slider starts in equilibrium with `u[0]` (it rested under the
    initial force); with `periodic=True`, `u` is one period ending where it started
    (`u[-1] == u[0]`) and the result is the exact periodic steady state (each mode's
    start value solves $\theta_0 = e^{-P/\tau}\theta_0 + r(P)$).
    Implements the lag of section 6.3 (curves $\varepsilon_u$, $\varepsilon_d$).
    """
    u = jnp.asarray(u, dtype=float)
    ts = jnp.asarray(ts, dtype=float)
    if u.ndim != 1 or u.shape != ts.shape or u.shape[0] < 2:
        raise ValueError(f"lag_response: u and ts must be 1-D of equal length >= 2, got "
                         f"{u.shape} and {ts.shape}")
    return _lag_response(lag, u, ts, jnp.asarray(time_scale, dtype=float), periodic)


@eqx.filter_jit
def _lag_response(lag, u, ts, time_scale, periodic):
    taus = lag.time_constants * time_scale

    def one(tau, w):
        if periodic:
            r = _mode_response(w * u, ts, tau, 0.0)
            tau_safe = jnp.maximum(tau, 1e-300)
            theta0 = r[-1] / -jnp.expm1(-(ts[-1] - ts[0]) / tau_safe)
            return r + theta0 * jnp.exp(-(ts - ts[0]) / tau_safe)
        return _mode_response(w * u, ts, tau, w * u[0])

    modes = jax.vmap(one)(taus, lag.weights)
    return lag.instantaneous_weight * u + jnp.sum(modes, axis=0)


def filtered_force(
    model: PitchingModel, plane: str, force, ts, periodic: bool = False) -> Float[Array, " n"]:
    r"""The spring force (kgf) seen through the squeeze lag of `plane`: $\tilde F(t)$ with
    tilt $\varepsilon = c\,(\text{arm})\,\tilde F$. Independent of the drive point, so one
    call serves every height and offset."""
    p = model.plane(plane)
    return lag_response(p.lag, force, ts, model.viscosity_ratio, periodic=periodic)


class TiltTrace(eqx.Module):
    """Tilt history: `time` (s), `pitch` and `yaw` angles (rad), `static_pitch` and
    `static_yaw` (rad, the line eps_s the slider would follow without lag),
    `displacement` at the model's measuring points (mm, shape (n, points))."""

    time: Float[Array, " n"]
    pitch: Float[Array, " n"]
    yaw: Float[Array, " n"]
    static_pitch: Float[Array, " n"]
    static_yaw: Float[Array, " n"]
    displacement: Float[Array, "n points"]


def point_displacements(model: PitchingModel, pitch, yaw) -> Float[Array, "... points"]:
    r"""Displacement (mm) of each measuring point: $\delta_i = \varepsilon\,(s_i - s_{pivot})$
    with $\varepsilon$ the pitch angle for vertical points and the yaw angle for horizontal
    points (rad)."""
    pts = model.points
    is_pitch = jnp.asarray(pts.is_pitch)
    lever = jnp.where(is_pitch, pts.positions - model.pitch.pivot, pts.positions - model.yaw.pivot)
    pitch = jnp.asarray(pitch)[..., None]
    yaw = jnp.asarray(yaw)[..., None]
    return jnp.where(is_pitch, pitch, yaw) * lever


def plane_tilt(plane: TiltPlane, arm, filtered) -> Float[Array, "..."]:
    """Tilt angle (rad) = compliance (rad/(kgf mm)) * arm (mm) * lagged force (kgf)."""
    return plane.compliance * arm * filtered


@eqx.filter_jit
def tilt_history(model: PitchingModel, ts: Float[Array, " n"], force: Float[Array, " n"],
                 drive: DrivePoint, periodic: bool = False) -> TiltTrace:
    r"""Pitching and yawing of the slider under the spring force history `force` (kgf,
    $F = kx$) sampled at `ts` (s), driven at `drive` (mm). Works on any trace, simulated or
    measured. Moments $M_v = F(h - h_{Mv})$, $M_h = F(l - l_{Mh})$ (section 6.2, 6.4),
    static tilt $cM$, lag of section 6.3. See `lag_response` for `periodic`.
    """
    ts = jnp.asarray(ts, dtype=float)
    force = jnp.asarray(force, dtype=float)
    fv = filtered_force(model, "pitch", force, ts, periodic)
    fh = filtered_force(model, "yaw", force, ts, periodic)
    arm_v = model.pitch.arm(drive.height)
    arm_h = model.yaw.arm(drive.offset)
    pitch = plane_tilt(model.pitch, arm_v, fv)
    yaw = plane_tilt(model.yaw, arm_h, fh)
    return TiltTrace(time=ts, pitch=pitch, yaw=yaw,
                     static_pitch=plane_tilt(model.pitch, arm_v, force),
                     static_yaw=plane_tilt(model.yaw, arm_h, force),
                     displacement=point_displacements(model, pitch, yaw))


def rise_curve(lag: LinearLag, force_rate, ts, time_scale=1.0) -> Float[Array, " n"]:
    r"""The rise $\varepsilon_u$ (Figs 54-55) as a fraction of the static line: response to
    a force ramp $F = \dot F t$ from rest, divided by the static gain, so the result is in
    kgf (multiply by compliance * arm for rad). `force_rate` in kgf/s, `ts` in s from 0."""
    ts = jnp.asarray(ts, dtype=float)
    return lag_response(lag, force_rate * ts, ts, time_scale)


def recovery_curve(lag: LinearLag, drop, ts, time_scale=1.0) -> Float[Array, " n"]:
    r"""The recovery $\varepsilon_d$ (Fig 56): after the force falls by `drop` (kgf) at
    t = 0 and stays, the lagged force (kgf, relative to the final value) decays from
    `drop` to 0 (for a pure first-order lag, `drop * exp(-t/tau)`). `ts` in s, ts[0] = 0."""
    ts = jnp.asarray(ts, dtype=float)
    # Rest at `drop`, then a step to 0 just after t = 0: first-order hold over [0, 0+].
    t = jnp.concatenate([ts[:1], ts])
    u = jnp.concatenate([jnp.full((1,), drop, dtype=float), jnp.zeros_like(ts)])
    return lag_response(lag, u, t, time_scale)[1:]
