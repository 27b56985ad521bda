r"""An independent rate-and-state stick-slip generator (SciPy), for testing the law comparison.

Shares no code with `stickslip_jax` but the `Record` container: the slider of weight W
(kgf) on a spring k (kgf/mm), pulled at the constant speed V (mm/s), obeys
(W/g) v' = k x - W mu, x' = V - v, with the Dieterich-Ruina law
mu = a asinh(v / (2 v0) exp(psi / a)), psi = mu_ref + b ln(v0 theta / Dc), integrated in the
log of the state, L = ln(theta / s), by the implicit Radau method (BDF where Radau
fails) of `scipy.integrate.solve_ivp` with the analytic Jacobian, from rest at x = 0 (the
record keeps the start-up stick):
aging law L' = exp(-L) - v / Dc, slip law L' = -(v / Dc) ln(v exp(L) / Dc).
Units kgf, mm, s; g = 9806.65 mm/s^2.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import integrate

G = 9806.65


@dataclasses.dataclass(frozen=True)
class RateState:
    mu_ref: float = 0.2
    a: float = 0.008
    b: float = 0.016
    d_c: float = 5e-4  # mm
    v_0: float = 1e-3  # mm/s
    aging: bool = True  # False: slip law


def simulate(law: RateState, *, weight, stiffness, speed, duration, rate_hz, noise_mm,
             seed):
    """Sample times (s) and the measured deflection (mm, noise `noise_mm`) of one record."""
    W, k, V = float(weight), float(stiffness), float(speed)
    mass = W / G
    a, b, dc, v0 = law.a, law.b, law.d_c, law.v_0

    def rhs(t, s):
        x, v, L = s
        psi = law.mu_ref + b * (math.log(v0 / dc) + L)
        mu = a * math.asinh(0.5 * v / v0 * math.exp(min(psi / a, 500.0)))
        if law.aging:
            dL = math.exp(-L) - abs(v) / dc
        else:
            q = abs(v) * math.exp(L) / dc
            dL = -(abs(v) / dc) * math.log(q) if q > 0 else 0.0
        return [V - v, (k * x - W * mu) / mass, dL]

    def jac(t, s):
        x, v, L = s
        e = math.exp(min((law.mu_ref + b * (math.log(v0 / dc) + L)) / a, 500.0))
        z = 0.5 * v / v0 * e
        h = math.hypot(1.0, z)
        sv = math.copysign(1.0, v) if v else 0.0
        if law.aging:
            row = [0.0, -sv / dc, -math.exp(-L)]
        else:
            lq = math.log(abs(v) / dc) + L if v else 0.0
            row = [0.0, -sv / dc * (lq + 1.0), -abs(v) / dc]
        return [[0.0, -1.0, 0.0], [k / mass, -W * a * 0.5 * e / (v0 * h) / mass,
                                   -W * b * z / h / mass], row]

    t = np.arange(int(round(duration * rate_hz))) / rate_hz
    for method in ("Radau", "BDF"):
        sol = integrate.solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0, math.log(dc / V)],
                                  method=method, jac=jac, t_eval=t, rtol=1e-9,
                                  atol=[1e-11, 1e-11, 1e-9])
        if sol.success:
            break
    else:
        raise RuntimeError(sol.message)
    rng = np.random.default_rng(seed)
    return t, sol.y[0] + noise_mm * rng.standard_normal(t.size)


def campaign(law: RateState, *, runs=((36.0, 86.9), (20.0, 27.3)), speeds=(1.0, 4.0),
             duration=8.0, rate_hz=1000.0, noise_mm=5e-4, seed=0):
    """`Record`s of every (W kgf, k kgf/mm) of `runs` at every speed (mm/min)."""
    from stickslip_jax.records import Record

    out = []
    for i, ((W, k), v) in enumerate((r, v) for r in runs for v in speeds):
        t, x = simulate(law, weight=W, stiffness=k, speed=v / 60.0, duration=duration,
                        rate_hz=rate_hz, noise_mm=noise_mm, seed=1000 * seed + i)
        out.append(Record.from_arrays(t, x, stiffness=k, weight=W, drive_speed=v / 60.0,
                                      note=f"rate-state W{W:g} k{k:g} v{v:g}"))
    return out
