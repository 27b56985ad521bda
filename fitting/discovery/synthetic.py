r"""Synthetic discovery campaigns: smoothed-simulator records with a hidden effect and noise.

`hidden_effect_campaign(friction, effect=NAME, values={param: value})` simulates a
campaign with the parts of `discovery.effects` (or any force term, `extra_force_terms`),
adds white Gaussian noise and returns `Record`s whose `truth` holds the friction and the
effect: every (W, k) of `conditions` at drive speeds `speed_fractions` x the critical
speed $v_c$ (eq 12), each record from a slip end on the steady limit cycle (eqs 5-6) for
about `cycles` cycles, with the fits' smoothing (`model.Settings`) at rtol 1e-7.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np

from stickslip_jax.records import Record
from stickslip_jax.simulation import pad_times
from stickslip_jax.simulation.parts import AbstractForceTerm

from ..data.synthetic import steady_operating_point, truth_values
from .effects import EffectSet
from ..objectives.smooth import SmoothData
from .model import DiscoveryParams, Settings, simulate_campaign

__all__ = ["CONDITIONS", "SPEED_FRACTIONS", "HardeningSpring", "hidden_effect_campaign"]

CONDITIONS = ((12.4, 40.0), (36.0, 86.9), (36.0, 200.0))
"""(W kgf, k kgf/mm): three natural frequencies, so slip-time effects are identifiable."""

SPEED_FRACTIONS = (0.12, 0.18, 0.26, 0.36)
"""Drive speeds as fractions of v_c: 3 x 4 = 12 records."""

GENERATION = Settings(rtol=1e-7, atol=1e-9, max_steps=16384)


def _plan(friction, conditions, speed_fractions, cycles, sample_rate):
    plan = []
    for w, k in conditions:
        for frac in speed_fractions:
            v, _, t1, t2, x1 = steady_operating_point(friction, w, k, frac)
            n = int(math.ceil((cycles * (t1 + t2) + 0.3 * t1) * sample_rate)) + 1
            plan.append((w, k, v, x1, n))
    return plan


def hidden_effect_campaign(
    friction,
    *,
    effect: str | None = None,
    values: dict[str, float] | None = None,
    effects: EffectSet | None = None,
    extra_force_terms: tuple = (),
    hidden_name: str | None = None,
    conditions=CONDITIONS,
    speed_fractions=SPEED_FRACTIONS,
    cycles: int = 4,
    noise: float = 5e-4,
    sample_rate: float = 500.0,
    seed: int = 0,
    lubricant: str = "A",
) -> list[Record]:
    """Records of `friction` with the library `effect` at `values` (natural units) and/or
    `extra_force_terms`; `noise` mm; `seed` for the noise. Units kgf, mm, s."""
    effects = EffectSet.zeros() if effects is None else effects
    if effect is not None:
        effects = effects.with_effect(effect, **(values or {}))
    plan = _plan(friction, conditions, speed_fractions, cycles, sample_rate)
    times = [np.arange(p[4]) / sample_rate for p in plan]
    ts, mask = pad_times(times)
    f = lambda i: jnp.asarray([p[i] for p in plan], dtype=float)  # noqa: E731
    traces = SmoothData(time=jnp.asarray(ts), deflection=jnp.zeros(ts.shape),
                        mask=jnp.asarray(mask), weight=f(0), normal_load=f(0), stiffness=f(1),
                        speed=f(2), start_level=f(3), sigma=jnp.full(len(plan), noise))
    from ..params import EmpiricalFriction

    params = DiscoveryParams(EmpiricalFriction.from_friction(friction), effects, f(3))
    model, ok = simulate_campaign(params, traces, GENERATION, tuple(extra_force_terms))
    if not bool(np.all(np.asarray(ok))):
        raise RuntimeError("the simulator failed on a synthetic record")
    rng = np.random.default_rng(seed)
    truth = {
        "friction": truth_values(friction), "noise_mm": noise, "seed": seed,
        "effect": hidden_name or effect or "none",
        "effect_values": {k: float(v) for k, v in (values or {}).items()},
        "simulator": "simulate_smooth", "smoothing": GENERATION.smoothing,
    }
    records = []
    for i, (w, k, v, _, n) in enumerate(plan):
        x = np.asarray(model[i, :n]) + rng.normal(0.0, noise, n)
        name = f"W{w:g}_k{k:g}_v{v * 60:.4g}mmpmin".replace(".", "p")
        records.append(Record(time=times[i], deflection=x, stiffness=k, weight=w,
                              drive_speed=v, lubricant=lubricant, truth=truth,
                              source=f"{name}.csv"))
    return records


class HardeningSpring(AbstractForceTerm):
    r"""An effect outside the library (for tests): the spring hardens,
    force $k x (1 + \beta x^2)$, i.e. the extra force $+k\beta x^3$ (kgf); `beta` in 1/mm^2."""

    beta: float = 0.0

    def force(self, t, core, own, ctx):
        return ctx.stiffness * self.beta * core.x ** 3
