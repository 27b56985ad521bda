r"""Dieterich-Ruina rate-and-state friction with the aging and the slip evolution laws.

$$\mu(v, \theta) = \mu_* + a\ln(v/v_0) + b\ln(v_0\theta/D_c)$$
(Dieterich 1979, J. Geophys. Res. 84, 2161; Ruina 1983, J. Geophys. Res. 88, 10359;
Marone 1998, Annu. Rev. Earth Planet. Sci. 26, 643), the state $\theta$ (s, the
contact age) evolving by
- the aging law (`AgingLaw`): $\dot\theta = 1 - v\theta/D_c$ (it heals at rest:
  $\theta$ grows like the stick time);
- the slip law (`SlipLaw`): $\dot\theta = -(v\theta/D_c)\ln(v\theta/D_c)$ (it evolves
  only with slip).

At $v \to 0$ the logarithm is regularised (Rice and Ben-Zion 1996, Proc. Natl. Acad.
Sci. 93, 3811; Lapusta et al. 2000, J. Geophys. Res. 105, 23765):
$\mu = a\,\mathrm{asinh}[v/(2v_0)\,e^{\psi/a}]$, $\psi = \mu_* + b\ln(v_0\theta/D_c)$: odd
in $v$, with a finite slope at $v = 0$, and equal to the law above to within
$e^{-2\psi/a}(v_0/v)^2$. The smoothed simulator integrates $\theta$ as an ODE state
(`stickslip_jax.simulation.simulate_smooth`). Units: $v$, $v_0$ mm/s; $D_c$ mm; $\theta$ s;
$\mu_*$, $a$, $b$ dimensionless; $\mu_*$ is the steady-state friction at $v_0$.

`rate_state_friction` builds the `Friction` pair: the static law is the aging law's
healing at rest from the steady state at $v_0$, read at $v_0$ (`LogAgingStatic` with
$\beta = b$, $t_c = D_c/v_0$), and the kinetic law (`RateStateKinetic`) carries the whole
law. Its mean-kinetic interface (`__call__`) returns the steady-state friction at $v_0$.
"""

from __future__ import annotations

import abc

import equinox as eqx
import jax.numpy as jnp

from ..numerics import as_float
from .kinetic import AbstractKineticFriction, Friction
from .log_aging import LogAgingStatic
from .static import Scalar

PSI_CAP = 500.0
r"""$\psi/a$ is capped here inside the exponential of the law near rest, $|z| \le 1$
(`RateStateKinetic.coefficient`): the slope at rest of friction levels above 500 a."""
STATE_FLOOR = 1e-100
r"""$v_0\theta/D_c$ is floored here inside the logarithm: a contact age of $10^{-100}
D_c/v_0$, no physical state, but a trial $\theta \le 0$ of an implicit solver's Newton
iteration gets a finite law, and the law's derivative in the state, $b/\theta$, stays
finite (at a floor of 1e-300 it overflowed)."""
EXP_CAP = 700.0
"""Exponents above this are capped in `velocity_at` (no overflow to infinity)."""
LOG_STATE_CAP = 50.0
r"""`state_at` keeps $\ln(v_0\theta/D_c)$ within this of 0 ($\theta$ within $e^{\pm 50}$
of $D_c/v_0$: far beyond any contact age, and finite)."""


class AbstractStateEvolution(eqx.Module):
    r"""An evolution law $\dot\theta(v, \theta)$ of the rate-and-state variable."""

    @abc.abstractmethod
    def rate(self, velocity, theta, d_c):
        r"""$\dot\theta$ (dimensionless) at the velocity (mm/s), state (s) and $D_c$ (mm)."""


class AgingLaw(AbstractStateEvolution):
    r"""Dieterich's aging law, $\dot\theta = 1 - |v|\theta/D_c$."""

    def rate(self, velocity, theta, d_c):
        return 1.0 - jnp.abs(velocity) * theta / d_c


class SlipLaw(AbstractStateEvolution):
    r"""Ruina's slip law, $\dot\theta = -(|v|\theta/D_c)\ln(|v|\theta/D_c)$ (0 at rest)."""

    def rate(self, velocity, theta, d_c):
        x = jnp.abs(velocity) * theta / d_c
        safe = jnp.where(x > 0, x, 1.0)
        return jnp.where(x > 0, -safe * jnp.log(safe), 0.0)


class RateStateKinetic(AbstractKineticFriction):
    r"""The rate-and-state law (module docstring) with $\mu_* = \mu_d$ (the `Friction`'s
    shared level): `a`, `b` dimensionless, `d_c` in mm, `v_0` in mm/s, `evolution` an
    `AbstractStateEvolution`."""

    a: Scalar = eqx.field(converter=as_float)
    b: Scalar = eqx.field(converter=as_float)
    d_c: Scalar = eqx.field(converter=as_float)
    v_0: Scalar = eqx.field(converter=as_float)
    evolution: AbstractStateEvolution = AgingLaw()

    def psi_over_a(self, theta, mu_d):
        r"""$\psi/a$ at the state (s), with $v_0\theta/D_c$ floored at `STATE_FLOOR`."""
        ratio = jnp.maximum(self.v_0 * theta / self.d_c, STATE_FLOOR)
        return (mu_d + self.b * jnp.log(ratio)) / self.a

    def coefficient(self, velocity, theta, mu_d):
        r"""Regularised friction coefficient at the velocity (mm/s) and state (s),
        $a\,\mathrm{asinh}(z)$, $z = v/(2v_0)\,e^{\psi/a}$: directly where $|z| \le 1$
        ($\psi/a$ capped at `PSI_CAP` there), and elsewhere as
        $a\,\mathrm{sign}(v)[\ln|z| + \ln(1 + \sqrt{1 + z^{-2}})]$ from
        $\ln|z| = \ln(|v|/2v_0) + \psi/a$: the same law, whose value and derivatives stay
        finite at every finite velocity and state (the exponential overflowed in a slip that
        runs away, and its derivatives turned to infinity times zero)."""
        s = self.psi_over_a(theta, mu_d)
        speed = jnp.abs(velocity)
        moving = speed > 0
        log_z = jnp.log(0.5 * jnp.where(moving, speed, self.v_0) / self.v_0) + s
        far = moving & (log_z > 0)
        lz = jnp.where(far, log_z, 1.0)
        outer = jnp.sign(velocity) * (lz + jnp.log1p(jnp.sqrt(1.0 + jnp.exp(-2.0 * lz))))
        near = jnp.where(far, 0.0, velocity)
        inner = jnp.arcsinh(0.5 * near / self.v_0 * jnp.exp(jnp.minimum(s, PSI_CAP)))
        return self.a * jnp.where(far, outer, inner)

    def velocity_at(self, mu, theta, mu_d):
        """The velocity (mm/s) at which the regularised law gives `mu` in state `theta`
        (exponents capped at `EXP_CAP`)."""
        s = self.psi_over_a(theta, mu_d)
        return self.v_0 * (jnp.exp(jnp.minimum(mu / self.a - s, EXP_CAP))
                           - jnp.exp(jnp.minimum(-mu / self.a - s, EXP_CAP)))

    def state_at(self, mu, velocity, mu_d):
        r"""The state (s) at which the regularised law gives `mu` (> 0) at `velocity`
        (mm/s, > 0): $\psi = a\ln[(2v_0/v)\sinh(\mu/a)]$ solved for $\theta$, in logarithms
        (no overflow), $\mu/a$ floored at 1e-6 and $\ln(v_0\theta/D_c)$ clipped to
        $\pm$`LOG_STATE_CAP`."""
        m = jnp.maximum(mu / self.a, 1e-6)
        psi = self.a * (jnp.log(self.v_0 / velocity) + m + jnp.log(-jnp.expm1(-2.0 * m)))
        log_ratio = jnp.clip((psi - mu_d) / self.b, -LOG_STATE_CAP, LOG_STATE_CAP)
        return self.d_c / self.v_0 * jnp.exp(log_ratio)

    def start(self, mu, v_drive, stick_time, mu_d):
        r"""Initial (velocity mm/s, state s) of a slider held by the friction level `mu`
        (the spring's $kx_0/N$) at a slip end, `stick_time` (s) after it: at a trough the
        deflection stops falling, so the slider moves with the drive ($\dot y = $
        `v_drive`), in the state where the law balances `mu` there (`state_at`); the state
        heals by `stick_time` (the aging law at rest) and the velocity is where the law
        balances `mu` in that state. With no load (`mu` <= 0) the state is the steady
        state $D_c/$`v_drive` and the slider rests."""
        theta = stick_time + jnp.where(mu > 0, self.state_at(mu, v_drive, mu_d),
                                       self.d_c / v_drive)
        return self.velocity_at(mu, theta, mu_d), theta

    def state_rate(self, velocity, theta):
        r"""$\dot\theta$ of the evolution law."""
        return self.evolution.rate(velocity, theta, self.d_c)

    def steady(self, velocity, mu_d):
        r"""Steady-state friction $\mu_* + (a - b)\ln(v/v_0)$ at the velocity (mm/s)."""
        return mu_d + (self.a - self.b) * jnp.log(jnp.abs(velocity) / self.v_0)

    def __call__(self, mu_0, mu_d, slip_time):
        shape = jnp.broadcast_shapes(jnp.shape(mu_0), jnp.shape(slip_time))
        return jnp.broadcast_to(jnp.asarray(mu_d, dtype=float), shape)


def rate_state_friction(mu_ref, a, b, d_c, v_0, evolution=AgingLaw()) -> Friction:
    r"""The `Friction` of a rate-and-state law (module docstring): $\mu_*$ = `mu_ref`
    at `v_0` (mm/s), `a`, `b`, `d_c` (mm), `evolution` `AgingLaw()` or `SlipLaw()`."""
    static = LogAgingStatic(mu_d=mu_ref, beta=b, t_c=as_float(d_c) / as_float(v_0))
    return Friction(static, RateStateKinetic(a, b, d_c, v_0, evolution))
