r"""One period of the steady spring-force cycle (chapter 5), sampled for the tilt lag.

Stick: the force climbs at $k v$ from $F_1 = (2\mu_m - \mu_0) W$ to $F_0 = \mu_0 W$
in $T_1$ (eqs 5-6). Slip: eq (11), $F = ((\mu_0 - \mu_m)\cos\omega_0 t + \mu_m) W$ for
$0 \le t \le T_2 = \pi/\omega_0$ (eq 7), back to $F_1$. Above the critical speed (eq 12,
corrected) the slider slides steadily with $F = \mu_d W$ (a constant "cycle").

The stick is sampled on a linear grid merged with a geometric one crowded at the start
of the stick, where the recovering tilt turns (its minimum) within a lag time that can
be far shorter than $T_1$.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from ..friction import Friction
from ..steady import SteadyState, steady_state

Series, Scalar = Float[Array, " n"], Float[Array, ""]


class ForceCycle(eqx.Module):
    """One steady cycle: `time` (s, from the start of the stick to the end of the slip),
    `force` (kgf, $F = kx$), peak `f0` = $F_0$ and trough `f1` = $F_1$ (kgf), `period`
    (s), `stick_slip` flag and the `steady` analysis it came from."""

    time: Series
    force: Series
    f0: Scalar
    f1: Scalar
    period: Scalar
    stick_slip: Bool[Array, ""]
    steady: SteadyState

    @property
    def force_drop(self) -> Scalar:
        r"""$\Delta F = F_0 - F_1$ in kgf (Fig 47, Fig 53's parameter)."""
        return self.f0 - self.f1


def _stick_fractions(n_stick: int):
    n_lin = n_stick // 2
    n_geo = n_stick - n_lin
    lin = jnp.linspace(0.0, 1.0, n_lin)
    geo = jnp.geomspace(1e-7, 1.0, n_geo + 1)[:-1]
    return jnp.sort(jnp.concatenate([lin, geo]))


def steady_force_cycle(friction: Friction, weight, stiffness, speed, n_stick: int = 256,
                       n_slip: int = 48) -> ForceCycle:
    r"""The steady stick-slip force cycle of eqs (5)-(7), (11) at drive speed `speed` (mm/s),
    slider weight `weight` (kgf), spring stiffness `stiffness` (kgf/mm); scalars (vmap for
    many). Returns a `ForceCycle` with `n_stick + n_slip` samples whose last force equals
    the first (ready for `lag_response(..., periodic=True)`)."""
    st = steady_state(friction, weight, stiffness, speed)
    w = jnp.asarray(weight, dtype=float)
    stick = st.stick_slip
    mu_0 = jnp.where(stick, st.mu_0, friction.mu_d)
    mu_m = jnp.where(stick, st.mu_m, friction.mu_d)
    t1 = jnp.where(stick, st.stick_time, st.slip_time)
    t2 = st.slip_time
    f0 = mu_0 * w
    f1 = (2.0 * mu_m - mu_0) * w
    ts_stick = _stick_fractions(n_stick) * t1
    f_stick = f1 + (f0 - f1) * ts_stick / t1
    phase = jnp.linspace(0.0, jnp.pi, n_slip + 1)[1:]
    ts_slip = t1 + phase / jnp.pi * t2
    f_slip = ((mu_0 - mu_m) * jnp.cos(phase) + mu_m) * w
    return ForceCycle(time=jnp.concatenate([ts_stick, ts_slip]),
                      force=jnp.concatenate([f_stick, f_slip]), f0=f0, f1=f1, period=t1 + t2,
                      stick_slip=stick, steady=st)
