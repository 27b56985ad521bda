r"""Synthetic campaigns for testing the identification: exact-simulator records with noise.

`synthetic_campaign(friction, ...)` lays out a campaign like the paper's (weights and
stiffnesses x drive speeds, fractions of each (W, k)'s critical speed $v_c$ of eq 12 so
that any parameter set gives stick-slip), simulates every record with `simulate_exact`
(all in one `vmap`) from the steady limit cycle (eqs 5-6) unless `from_rest`, adds white
Gaussian noise of sd `noise` (mm) and returns `Record`s carrying the truth.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import stickslip_jax as ss
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.modes import SlipTime
from stickslip_jax.records import Record
from stickslip_jax.simulation import pad_times, simulate_exact

from ..params import EmpiricalFriction

__all__ = ["draw_prior_friction", "synthetic_campaign", "truth_values"]

def draw_prior_friction(rng: np.random.Generator) -> ss.Friction:
    """Eq (1) + eq (3) parameters drawn from the calibration prior (NumPy `rng`):
    mu_d ~ U(0.15, 0.25), mu_s - mu_d ~ U(0.15, 0.4), gamma log-uniform in [0.1, 1] s^-m,
    m ~ U(0.3, 0.6), delta log-uniform in [30, 100] s^-n, n ~ U(0.8, 1.2)."""
    mu_d = rng.uniform(0.15, 0.25)
    return ss.Friction(ss.KatoStatic(mu_s=mu_d + rng.uniform(0.15, 0.4), mu_d=mu_d,
                                     gamma=np.exp(rng.uniform(np.log(0.1), np.log(1.0))),
                                     m=rng.uniform(0.3, 0.6)),
                       ss.KatoKinetic(delta=np.exp(rng.uniform(np.log(30.0), np.log(100.0))),
                                      n=rng.uniform(0.8, 1.2)))


SPREAD_CONDITIONS = ((36.0, 40.0), (36.0, 86.9), (36.0, 200.0))
"""(W kgf, k kgf/mm) pairs with three different k/W (slip times), so n is identifiable."""


@eqx.filter_jit
def _simulate_batch(friction, weights, stiffs, speeds, x0s, ts, mask, max_events, slip_time):
    def one(w, k, v, x0, t, m):
        sw = ss.Slideway(friction, w, k)
        # times, W and k checked on the host (the steady operating point): no host
        # callbacks, so JAX's persistent cache keeps the program
        return simulate_exact(sw, ConstantSpeed(v), t, initial_deflection=x0, mask=m,
                              max_events=max_events, slip_time=slip_time,
                              cycle_table=False, check=False)

    return jax.vmap(one)(weights, stiffs, speeds, x0s, ts, mask)


def truth_values(friction) -> dict[str, float]:
    """Natural parameters of `friction`: eq (1)+(3) names, or the microsqueeze model's."""
    from stickslip_jax.contact import MicrosqueezeStatic

    if isinstance(friction.static, MicrosqueezeStatic):
        from ..microsqueeze_params import MicrosqueezeFriction

        return MicrosqueezeFriction.from_friction(friction).named_values()
    return EmpiricalFriction.from_friction(friction).named_values()


def synthetic_campaign(friction, *, conditions=SPREAD_CONDITIONS, speed_fractions=(0.03, 0.1, 0.3),
                       cycles: int = 6, noise: float = 5e-4, sample_rate: float = 1000.0,
                       seed: int = 0, lubricant: str = "A", from_rest: bool = False,
                       slip_time: SlipTime | str = SlipTime.PAPER, pad_to: int = 0) -> list[Record]:
    """Records of every (W, k) in `conditions` at speeds `speed_fractions` x v_c(W, k).

    Each record lasts about `cycles` cycles (eq 6) at `sample_rate` Hz; `noise` in mm,
    drawn with `seed`; `pad_to`: simulate on at least this many samples, so that
    campaigns of other parameters reuse one compilation. Units: W kgf, k kgf/mm, v mm/s.
    """
    slip_time = SlipTime.parse(slip_time)
    rng = np.random.default_rng(seed)
    plan = []
    for w, k in conditions:
        for frac in speed_fractions:
            v, st, t1, t2, x1 = steady_operating_point(friction, w, k, frac)
            x0 = 0.0 if from_rest else x1 - 1e-9
            lead = float(st.mu_0) * w / (k * v) if from_rest else 0.0
            duration = lead + cycles * (t1 + t2) + 0.5 * t1
            n = int(math.ceil(duration * sample_rate)) + 1
            plan.append((w, k, v, x0, n, duration))
    times = [np.arange(p[4]) / sample_rate for p in plan]
    ts, mask = pad_times(times + [np.zeros(max(int(pad_to), 1))])
    ts, mask = ts[:-1], mask[:-1]
    max_events = -(-(4 * cycles + 16 + (0 if not from_rest else 4)) // 16) * 16  # buckets
    f = lambda i: jnp.asarray([p[i] for p in plan])  # noqa: E731
    trace = _simulate_batch(friction, f(0), f(1), f(2), f(3), ts, mask, max_events, slip_time)
    truth = {"friction": truth_values(friction), "noise_mm": noise, "seed": seed,
             "slip_time": slip_time.value, "simulator": "simulate_exact"}
    records = []
    for i, (w, k, v, _, n, _) in enumerate(plan):
        x = np.asarray(trace.deflection[i, :n]) + rng.normal(0.0, noise, n)
        name = f"W{w:g}_k{k:g}_v{v * 60:.4g}mmpmin".replace(".", "p")
        records.append(Record(time=times[i], deflection=x, stiffness=k, weight=w, drive_speed=v,
                              lubricant=lubricant, truth=truth, source=f"{name}.csv"))
    return records


def steady_operating_point(friction, weight, stiffness, speed_fraction):
    """Drive speed `speed_fraction` x v_c (mm/s) and its eq (6) steady cycle.

    Returns `(v, steady_state, T1 s, T2 s, x1 mm)`, x1 = (2 mu_m - mu_0) W/k being the
    deflection at the end of a steady slip (eq 5). W in kgf, k in kgf/mm.
    """
    v = speed_fraction * float(ss.critical_speed(friction, weight, stiffness))
    st = ss.steady_state(friction, weight, stiffness, v)
    t1, t2 = float(st.stick_time), float(st.slip_time)
    x1 = (2.0 * float(st.mu_m) - float(st.mu_0)) * weight / stiffness
    return v, st, t1, t2, x1
