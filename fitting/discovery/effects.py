r"""The candidate-effect library: physics the paper's model leaves out, as simulator parts.

Every effect is a part of the smoothed simulator (`stickslip_jax.simulation.parts`)
with one or two parameters that are **zero when the effect is absent**, a short
`NAME` and an `EXPLANATION` for an engineer. Units are internal (kgf, mm, s).

| name | part | parameters (zero = absent) |
|---|---|---|
| `viscous_damping` | force $-c\,\dot y$ | `c` kgf*s/mm |
| `stribeck` | force $+N b \tanh(\dot y / v_s)$ | `b` (-), $v_s$ fixed (mm/s) |
| `drive_periodic_error` | drive $u + e(u)$, $e = a_s \sin(2\pi u/\lambda) + a_c(\cos(2\pi u/\lambda) - 1)$ | `a_sin`, `a_cos` mm; pitch $\lambda$ fixed |
| `sensor_lowpass` | gauge reads a first-order low-pass of $x$ | `time_constant` s |
| `friction_drift` | $\mu_s$, $\mu_d$ (so $\mu_0$, $\mu_m$) shift by $r\,t$ | `rate` 1/s |
| `gauge_drift` | gauge zero drifts, reads $x + r t$ | `rate` mm/s |
| `load_coupling` | normal load $N = W + \kappa k x$ (drive moment, ch. 6) | `kappa` (-) |
| `rate_state` | extra kinetic friction $b\,e^{-s/L}$ decaying with slip distance $s$ | `b` (-), $L$ fixed mm |

`EffectSet.zeros()` is the paper's model; `EffectSet.smooth_model(slideway)` has every
effect present (inactive ones at zero), so one compiled residual function serves the base
and every candidate. `EffectGauge` composes the effects on what the gauge reads.

`SCALES`: a typical detectable size of each parameter (fit coordinate = value / scale).
`SIGNS`: +1 where physics requires >= 0 (a passive damper dissipates; a recording chain
is causal; rate-and-state friction is highest at breakaway and decays), 0 for either
sign; a fitted value of the wrong sign is never named (`ranking`).
"""

from __future__ import annotations

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from stickslip_jax.friction import AbstractKineticFriction, AbstractStaticFriction, Friction
from stickslip_jax.simulation.parts import (
    AbstractForceTerm,
    AbstractLoadCoupling,
    AbstractMeasurement,
)
from stickslip_jax.simulation.smooth import SmoothModel
from stickslip_jax.slideway import Slideway

__all__ = [
    "CANDIDATES",
    "DrivePeriodicError",
    "EffectGauge",
    "EffectSet",
    "FrictionDrift",
    "GaugeDrift",
    "LoadCoupling",
    "RateState",
    "SensorLowpass",
    "Stribeck",
    "ViscousDamping",
    "load_referred_friction",
]

Scalar = Float[Array, ""]


def _f(x):
    return jnp.asarray(x, dtype=float)


class _Effect:
    """Mixin: a library entry; `PARAMS` names the zero-when-absent fields (module doc)."""

    NAME: ClassVar[str]
    EXPLANATION: ClassVar[str]
    PARAMS: ClassVar[tuple[str, ...]]
    UNITS: ClassVar[tuple[str, ...]]
    SCALES: ClassVar[tuple[float, ...]]
    SIGNS: ClassVar[tuple[int, ...]]

    @classmethod
    def unphysical(cls, values: dict[str, float]) -> str | None:
        """Why `values` ({param: natural value}) break a required sign, or None."""
        bad = [f"{p} = {values[p]:.3g} < 0" for p, s in zip(cls.PARAMS, cls.SIGNS)
               if s > 0 and values[p] < 0]
        return "; ".join(bad) or None


class ViscousDamping(AbstractForceTerm, _Effect):
    r"""Viscous force $-c\,\dot y$ on the slider (kgf), c in kgf*s/mm."""

    NAME = "viscous_damping"
    EXPLANATION = (
        "A force proportional to the slider velocity (a viscous oil film or a damper) "
        "resists the slip, so slips are slower and smaller than dry friction predicts.")
    PARAMS, UNITS, SCALES, SIGNS = ("c",), ("kgf*s/mm",), (0.05,), (1,)

    c: Scalar = eqx.field(converter=_f, default=0.0)

    def force(self, t, core, own, ctx):
        return -self.c * core.ydot


class Stribeck(AbstractForceTerm, _Effect):
    r"""Kinetic friction changing with slip velocity: $\Delta\mu = -b\tanh(\dot y/v_s)$.

    Force $+N b \tanh(\dot y / v_s)$ (kgf); `b` > 0: friction falls with speed (Stribeck
    curve), `b` < 0: it rises (viscous-like); `v_s` (mm/s) fixed.
    """

    NAME = "stribeck"
    EXPLANATION = (
        "The kinetic friction coefficient changes with slip velocity (falling friction, "
        "the Stribeck curve), so the slip accelerates or brakes as it speeds up.")
    PARAMS, UNITS, SCALES, SIGNS = ("b",), ("-",), (0.01,), (0,)

    b: Scalar = eqx.field(converter=_f, default=0.0)
    v_s: float = eqx.field(static=True, default=1.0)

    def force(self, t, core, own, ctx):
        return ctx.normal_load * self.b * jnp.tanh(core.ydot / self.v_s)


class DrivePeriodicError(AbstractForceTerm, _Effect):
    r"""Drive position error periodic in the drive position (lead screw or gear): the
    true drive displacement is $u + e(u)$ (module doc, $e(0) = 0$), so the part adds the
    force $k\,e(u)$ (kgf) and `EffectGauge` adds $e(u)$ to the deflection read."""

    NAME = "drive_periodic_error"
    EXPLANATION = (
        "The drive does not advance uniformly: its position error repeats every screw "
        "or gear pitch, so the spring is loaded faster and slower in turn.")
    PARAMS, UNITS, SCALES, SIGNS = ("a_sin", "a_cos"), ("mm", "mm"), (1e-3, 1e-3), (0, 0)

    a_sin: Scalar = eqx.field(converter=_f, default=0.0)
    a_cos: Scalar = eqx.field(converter=_f, default=0.0)
    pitch: float = eqx.field(static=True, default=0.05)

    def error(self, u):
        """Drive position error e(u) in mm at nominal drive position u (mm)."""
        ph = 2.0 * jnp.pi * u / self.pitch
        return self.a_sin * jnp.sin(ph) + self.a_cos * (jnp.cos(ph) - 1.0)

    def error_rate(self, u, udot):
        """de/dt (mm/s) for drive position u (mm) and speed udot (mm/s)."""
        ph = 2.0 * jnp.pi * u / self.pitch
        w = 2.0 * jnp.pi / self.pitch
        return (self.a_sin * jnp.cos(ph) - self.a_cos * jnp.sin(ph)) * w * udot

    def force(self, t, core, own, ctx):
        return ctx.stiffness * self.error(ctx.drive_position)


class SensorLowpass(AbstractMeasurement, _Effect):
    r"""First-order low-pass recording chain: reads $z$ with $\tau\dot z = x - z$.

    State $e = x - z$ (mm): $\dot e = \dot x - e/\tau_{eff}$, reading $x - e$, with
    $\tau_{eff} = \tau_{min} + \tau$ for $\tau \ge 0$, $\tau_{min}/(1 - \tau/\tau_{min})$
    below (s): positive (a negative trial $\tau$ cannot make the filter unstable), with
    slope 1 at 0, so the Jacobian at $\tau = 0$ (score test) is the physical one-sided
    slope (a symmetric smooth floor has slope 1/2 there: it doubled the predicted step).
    $\tau_{min}$ = 10 us: $\tau = 0$ reads $x$ to within $10^{-5}\,\dot x$.
    """

    NAME = "sensor_lowpass"
    EXPLANATION = (
        "The recording chain (strain-gauge amplifier and oscillograph) is a low-pass "
        "filter: the fast slips are recorded late and rounded.")
    PARAMS, UNITS, SCALES, SIGNS = ("time_constant",), ("s",), (5e-4,), (1,)
    TAU_MIN: ClassVar[float] = 1e-5
    num_states: ClassVar[int] = 1

    time_constant: Scalar = eqx.field(converter=_f, default=0.0)
    noise_std: Scalar = eqx.field(converter=_f, default=0.0)

    def effective_time_constant(self):
        tau, tmin = self.time_constant, self.TAU_MIN
        neg = jnp.minimum(tau, 0.0)  # the safe branch: no 1/0 where tau >= tmin
        return jnp.where(tau >= 0.0, tmin + tau, tmin / (1.0 - neg / tmin))

    def init_state(self, ctx):
        # the filter lags a steady ramp at drive speed by tau * v
        return jnp.reshape(self.effective_time_constant() * ctx.drive_speed, (1,))

    def lag_derivative(self, signal_rate, own):
        return signal_rate - own / self.effective_time_constant()

    def state_derivative(self, t, core, own, ctx):
        return self.lag_derivative(ctx.drive_speed - core.ydot, own)

    def observe(self, t, core, own, ctx):
        return core.x - own[0]


class FrictionDrift(AbstractForceTerm, _Effect):
    r"""All friction coefficients shift by $r\,t$ during a record ($t$ from its start):
    $\mu_0$ and $\mu_m$ (eqs 1, 3) shift alike, an extra force
    $-N\,r\,t\,\mathrm{sign}(\dot y)$ (kgf, the simulator's smoothed sign)."""

    NAME = "friction_drift"
    EXPLANATION = (
        "The friction level changes slowly during a record (warming up, running in), "
        "so peaks and troughs climb or sink from cycle to cycle.")
    PARAMS, UNITS, SCALES, SIGNS = ("rate",), ("1/s",), (2e-3,), (0,)

    rate: Scalar = eqx.field(converter=_f, default=0.0)

    def force(self, t, core, own, ctx):
        return -ctx.normal_load * self.rate * t * ctx.sign(core.ydot)


class GaugeDrift(AbstractMeasurement, _Effect):
    """The gauge zero drifts linearly: reads x + rate * t (mm, t in s from the record start)."""

    NAME = "gauge_drift"
    EXPLANATION = (
        "The strain-gauge zero drifts during a record (temperature of the bridge), so "
        "the whole trace tilts while the slider's motion is unchanged.")
    PARAMS, UNITS, SCALES, SIGNS = ("rate",), ("mm/s",), (1e-3,), (0,)

    rate: Scalar = eqx.field(converter=_f, default=0.0)
    noise_std: Scalar = eqx.field(converter=_f, default=0.0)

    def observe(self, t, core, own, ctx):
        return core.x + self.rate * t


class LoadCoupling(AbstractLoadCoupling, _Effect):
    r"""Normal load changed by the drive moment (chapter 6): $N = W + \kappa\,k x$ (kgf);
    the spring force acts above the friction plane, and its moment loads the slideway.

    Discovery fits apparent friction coefficients, referred to $W$
    (`load_referred_friction`): a stick breaks away at $kx = W\mu_0/(1 - \kappa\mu_0)$,
    so a law fitted without the effect has absorbed $\mu_{app} = \mu/(1 - \kappa\mu)$
    and what is left for $\kappa$ is the slip (the softer spring $k(1 - \kappa\mu_m)$).
    With physical coefficients the $\kappa$ direction is nearly collinear with the
    friction level and so non-linear that no refit moved (measured: the Gauss-Newton step
    to the score test's size raised chi-square 70-fold).
    """

    NAME = "load_coupling"
    EXPLANATION = (
        "The drive force acts above the sliding surface; its moment presses the slider "
        "down (or lifts it), so the normal load and the friction grow with the spring force.")
    PARAMS, UNITS, SCALES, SIGNS = ("kappa",), ("-",), (0.1,), (0,)

    kappa: Scalar = eqx.field(converter=_f, default=0.0)

    def normal_load(self, t, core, own, ctx):
        return ctx.normal_load + self.kappa * ctx.stiffness * core.x  # N (W) + kappa k x


def _load_referred(mu, kappa):
    return mu / (1.0 + kappa * mu)


def _apparent(mu, kappa):
    return mu / (1.0 - kappa * mu)


class LoadReferredStatic(AbstractStaticFriction):
    r"""Static law $\mu_0 = g(\mu_{0,app}(T_1))$, $g(\mu) = \mu/(1 + \kappa\mu)$: the
    physical coefficient (against $N$) of an apparent law (against $W$, `LoadCoupling`)."""

    apparent: AbstractStaticFriction
    kappa: Scalar
    mu_d: Scalar

    def __init__(self, apparent, kappa):
        self.apparent, self.kappa = apparent, kappa
        self.mu_d = _load_referred(apparent.mu_d, kappa)

    def __call__(self, stick_time):
        return _load_referred(self.apparent(stick_time), self.kappa)


class LoadReferredKinetic(AbstractKineticFriction):
    r"""Kinetic law (eq 3) of apparent coefficients, in physical ones: $\mu_m =
    g(\mu_{m,app}(g^{-1}(\mu_0), g^{-1}(\mu_d), T_2))$, $g^{-1}(\mu) = \mu/(1 - \kappa\mu)$."""

    apparent: AbstractKineticFriction
    kappa: Scalar

    def __call__(self, mu_0, mu_d, slip_time):
        k = self.kappa
        return _load_referred(self.apparent(_apparent(mu_0, k), _apparent(mu_d, k), slip_time), k)


def load_referred_friction(apparent: Friction, kappa) -> Friction:
    """The physical `Friction` (against N = W + kappa k x) with the breakaway and
    slip-centre forces of the `apparent` law against W (`LoadCoupling`)."""
    return Friction(LoadReferredStatic(apparent.static, kappa),
                    LoadReferredKinetic(apparent.kinetic, kappa))


class RateState(AbstractForceTerm, _Effect):
    r"""Kinetic friction that evolves with slip distance: $\Delta\mu = b\,e^{-s/L}$.

    State $s$, the slip distance since breakaway (mm): $\dot s = |\dot y|(1 - w) - s w/t_r$
    with $w = \exp(-(\dot y/(4\varepsilon))^8)$ the simulator's stick weight,
    $t_r = \pi/(40\,\omega_0)$ (it resets while sticking). Force
    $-N\,b\,e^{-s/L}\,(1-w)\,\mathrm{sign}(\dot y)$ (kgf); `L` (mm) fixed.
    """

    NAME = "rate_state"
    EXPLANATION = (
        "Kinetic friction relaxes over a characteristic slip distance (rate-and-state "
        "friction) instead of being set by the slip time, so each slip starts stiffer.")
    PARAMS, UNITS, SCALES, SIGNS = ("b",), ("-",), (0.01,), (1,)
    num_states: ClassVar[int] = 1

    b: Scalar = eqx.field(converter=_f, default=0.0)
    length: float = eqx.field(static=True, default=0.005)

    def _weight(self, core, ctx):
        # clipped so that wild Newton iterates give 0 with finite tangents, not 0 * inf
        q2 = jnp.minimum((core.ydot / (4.0 * ctx.eps)) ** 2, 9.0)
        return jnp.exp(-(q2 ** 4))

    def state_derivative(self, t, core, own, ctx):
        w = self._weight(core, ctx)
        t_r = jnp.pi / ctx.omega0 / 40.0
        speed = jnp.sqrt(core.ydot * core.ydot + ctx.eps * ctx.eps) - ctx.eps
        return jnp.reshape(speed * (1.0 - w) - own[0] * w / t_r, (1,))

    def force(self, t, core, own, ctx):
        w = self._weight(core, ctx)
        decay = jnp.exp(-jnp.maximum(own[0], 0.0) / self.length)
        return -ctx.normal_load * self.b * decay * (1.0 - w) * ctx.sign(core.ydot)


class EffectGauge(AbstractMeasurement):
    r"""What the gauge reads with the measurement-side effects together (mm):
    low-pass of the true deflection $x + e(u)$ (drive error), plus the gauge drift."""

    lowpass: SensorLowpass = SensorLowpass()
    drift: GaugeDrift = GaugeDrift()
    drive_error: DrivePeriodicError = DrivePeriodicError()
    noise_std: Scalar = eqx.field(converter=_f, default=0.0)
    num_states: ClassVar[int] = 1

    def init_state(self, ctx):
        return self.lowpass.init_state(ctx)

    def state_derivative(self, t, core, own, ctx):
        rate = (ctx.drive_speed - core.ydot
                + self.drive_error.error_rate(ctx.drive_position, ctx.drive_speed))
        return self.lowpass.lag_derivative(rate, own)

    def observe(self, t, core, own, ctx):
        true_x = core.x + self.drive_error.error(ctx.drive_position)
        return true_x - own[0] + self.drift.rate * t


class EffectSet(eqx.Module):
    """One instance of every library effect (all zero = the paper's model)."""

    viscous_damping: ViscousDamping = ViscousDamping()
    stribeck: Stribeck = Stribeck()
    drive_periodic_error: DrivePeriodicError = DrivePeriodicError()
    sensor_lowpass: SensorLowpass = SensorLowpass()
    friction_drift: FrictionDrift = FrictionDrift()
    gauge_drift: GaugeDrift = GaugeDrift()
    load_coupling: LoadCoupling = LoadCoupling()
    rate_state: RateState = RateState()

    @classmethod
    def zeros(cls) -> EffectSet:
        """The paper's model: every effect zero, at its class's fixed shape settings."""
        return cls()

    def with_effect(self, name: str, **values) -> EffectSet:
        """A copy with effect `name`'s parameters set (natural units)."""
        part = getattr(self, effect_field(name))
        bad = [k for k in values if k not in part.PARAMS]
        if bad:
            raise ValueError(f"{name} has parameters {part.PARAMS}, not {bad}")
        for k, v in values.items():
            part = eqx.tree_at(lambda p: getattr(p, k), part, _f(v))
        return eqx.tree_at(lambda s: getattr(s, effect_field(name)), self, part)

    def smooth_model(self, slideway: Slideway, extra_force_terms: tuple = ()) -> SmoothModel:
        """The `SmoothModel` with every effect of the set (plus `extra_force_terms`)."""
        gauge = EffectGauge(lowpass=self.sensor_lowpass, drift=self.gauge_drift,
                            drive_error=self.drive_periodic_error)
        forces = (self.viscous_damping, self.stribeck, self.drive_periodic_error,
                  self.friction_drift, self.rate_state)
        return SmoothModel(slideway, force_terms=forces + tuple(extra_force_terms),
                           load=self.load_coupling, measurement=gauge)


CANDIDATES: tuple[str, ...] = tuple(f for f in EffectSet.__dataclass_fields__)
"""Names of the library effects, in a fixed order."""


def effect_field(name: str) -> str:
    if name not in CANDIDATES:
        raise ValueError(f"unknown effect {name!r}; choose from {', '.join(CANDIDATES)}")
    return name
