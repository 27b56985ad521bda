"""Synthetic records: a simulated run with white noise, as a `Record` whose `truth` holds
the parameters it was made from (internal units: kgf, mm, s), the noise, seed and simulator."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..drives import AbstractDrive, ConstantSpeed, SpeedProgram
from ..modes import Formulation, SlipTime
from ..slideway import Slideway
from .exact import simulate_exact
from .smooth import simulate_smooth
from .trace import SimulationResult


def friction_truth(slideway: Slideway) -> dict:
    """The slideway's parameters as a JSON-able dict: law names and float fields."""

    def fields(module):
        out = {"law": type(module).__name__}
        for name, value in vars(module).items():
            if isinstance(value, jax.Array | np.ndarray | float | int):
                out[name] = float(value)
        return out

    return {"static": fields(slideway.friction.static),
            "kinetic": fields(slideway.friction.kinetic),
            "weight_kgf": float(slideway.weight),
            "stiffness_kgf_mm": float(slideway.stiffness),
            **({} if slideway.normal_load is None
               else {"normal_load_kgf": float(slideway.normal_load)})}


_exact = eqx.filter_jit(simulate_exact)
_smooth = eqx.filter_jit(simulate_smooth)


def synthetic_record(slideway: Slideway, drive: AbstractDrive, duration: float, sample_rate: float,
                     *, noise_std: float = 0.0, seed: int = 0, smoothing: float | None = None,
                     max_events: int | None = None, lubricant: str | None = None,
                     note: str | None = None):
    """Simulate `duration` s sampled at `sample_rate` Hz and return a noisy `Record`.

    `noise_std` in mm; `seed` for `jax.random.PRNGKey`; `smoothing` None = exact
    simulator, else the smoothed one with that smoothing; `max_events` (exact) defaults
    to 4 events per expected cycle from the steady analysis plus drive knots, at least 64.
    Raises ValueError if the simulation fails (result code not successful).
    """
    from ..records import Record

    if not duration > 0 or not sample_rate > 0:
        raise ValueError("duration and sample rate must be positive")
    n = int(round(duration * sample_rate)) + 1
    if n < 2:
        raise ValueError("--duration * --sample-rate gives fewer than two samples")
    ts = jnp.arange(n) / float(sample_rate)
    if smoothing is None:
        if max_events is None:
            max_events = _event_budget(slideway, drive, duration)
        trace = _exact(slideway, drive, ts, max_events=max_events)
        simulator = {"name": "exact", "slip_time": SlipTime.PAPER.value,
                     "max_events": max_events}
    else:
        trace = _smooth(slideway, drive, ts, smoothing=jnp.asarray(smoothing),
                        formulation=Formulation.LATCH)
        simulator = {"name": "smooth", "formulation": Formulation.LATCH.value,
                     "smoothing": float(smoothing), "slip_time": SlipTime.PAPER.value}
    if not bool(trace.result == SimulationResult.successful):
        raise ValueError(f"simulation failed: {trace.result}")
    x = np.asarray(trace.deflection)
    noise = noise_std * np.asarray(jax.random.normal(jax.random.PRNGKey(seed), x.shape))
    truth = {"friction": friction_truth(slideway), "noise_mm": float(noise_std), "seed": int(seed),
             "simulator": simulator, "steady_sliding": bool(trace.steady_sliding),
             "cycles": int(np.sum(np.asarray(trace.cycles.valid)))}
    kwargs = {}
    if isinstance(drive, ConstantSpeed):
        kwargs["drive_speed"] = float(drive.v)
    elif isinstance(drive, SpeedProgram):
        kwargs["drive_program"] = tuple(
            (float(a), float(b)) for a, b in zip(drive.start_times, drive.speeds))
    else:
        kwargs["drive"] = np.asarray(drive.position(ts))
    return Record(time=np.asarray(ts), deflection=x + noise, stiffness=float(slideway.stiffness),
                  weight=float(slideway.weight), lubricant=lubricant, note=note, truth=truth,
                  normal_load=None if slideway.normal_load is None else float(slideway.normal_load),
                  **kwargs)


def _event_budget(slideway: Slideway, drive: AbstractDrive, duration: float) -> int:
    """A static event budget: 4 per cycle at the slowest nonzero speed's steady T1."""
    from ..steady import steady_state

    _, _, speeds = drive.knots()
    sp = np.asarray(speeds)
    v = float(sp[sp > 0].min()) if np.any(sp > 0) else 1.0
    ss = steady_state(slideway.friction, slideway.weight, slideway.stiffness, v,
                      normal_load=slideway.normal_load)
    period = float(ss.stick_time + ss.slip_time) if bool(ss.stick_slip) else float(
        ss.slip_time)
    budget = 4 * int(np.ceil(duration / max(period, 1e-9))) + 2 * sp.size + 16
    return int(2 ** int(np.ceil(np.log2(max(budget, 64)))))
