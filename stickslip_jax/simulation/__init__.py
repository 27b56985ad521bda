r"""Time-domain simulators of the slideway (Fig 5): x(t), the spring deflection in mm.

One verb per simulator, both returning a `Trace` (see `trace.py`):

```python
from stickslip_jax import Slideway, lubricant
from stickslip_jax.drives import ConstantSpeed, SpeedProgram
from stickslip_jax.simulation import simulate_exact

slideway = Slideway(lubricant("A"), weight=36.0, stiffness=86.9)   # kgf, kgf/mm
drive = ConstantSpeed(1.0 / 60)                                    # mm/s (1 mm/min)
ts = jnp.linspace(0.0, 60.0, 60_001)                               # s
trace = simulate_exact(slideway, drive, ts)                        # eqx.filter_jit it
trace.deflection, trace.slider_velocity, trace.cycles.amplitude()
```

- `simulate_exact(slideway, drive, ts, *, slip_time=SlipTime.PAPER|SELF_CONSISTENT (or
  "paper"|"self_consistent"; `stickslip_jax.modes.SlipTime`),
  initial_deflection=0.0, initial_stick_time=0.0, start_time=None, mask=None,
  max_events=64) -> Trace`: the paper's model solved event by event in closed form
  (exact.py).
- `simulate_exact_campaign(slideway, drive, ts, record_index, *, slip_time=SlipTime.PAPER,
  initial_deflection=0.0, initial_stick_time=0.0, max_events=64) -> Trace`: B records of
  different lengths without padding: `slideway`/`drive` batched over records (jax.vmap),
  `ts`/`record_index` the flat concatenated samples [N]; flat x(t), per-record cycles.
- `Trace`: `time`, `deflection`, `slider_velocity`, `sticking`, `mask`, `cycles`
  (`Cycles`: breakaway_time, peak, trough, stick_time, slip_time, model_slip_time,
  mu_0, mu_m, restick_failed, valid; `.amplitude()`), `steady_sliding`, `result`
  (`SimulationResult`), `num_events`; `.limit_cycle(last=2)`.
- `simulate_smooth(model, drive, ts, *, smoothing=1e-3, formulation="latch",
  slip_time=SlipTime.PAPER, rtol=1e-8,
  atol=1e-10, solver=None, max_steps=16384, initial_deflection=0.0,
  initial_stick_time=0.0, mask=None, adjoint=None, dt0=None) -> Trace`: the same physics
  as one smooth ODE in diffrax (smooth.py; formulations "latch" (default, not stiff, Tsit5),
  "rigid_stick" and "velocity" (stiff, Kvaerno5)), `model` a `Slideway` or a
  `SmoothModel(slideway, force_terms=(), load=ConstantLoad(), measurement=IdealGauge())`.
  Parts (parts.py): `AbstractForceTerm.force`, `AbstractLoadCoupling.normal_load`,
  `AbstractMeasurement.observe` (+ `noise_std`), optional own states via `num_states`,
  `init_state`, `state_derivative`; `Core`, `Context`; examples `ViscousDamping(c)`,
  `ConstantLoad()`, `IdealGauge(offset, noise_std)`. Gradients are verified against
  finite differences for "latch" at smoothing 1e-4...1e-2 and rtol <= 1e-9, "rigid_stick" at
  1e-3 with rtol 1e-10, "velocity" at smoothing >= 0.03.
- `synthetic_record(slideway, drive, duration, sample_rate, *, noise_std, seed,
  smoothing=None, ...) -> records.Record` with a `truth` dict (synthetic.py).
- `pad_times(list_of_ts) -> (ts [B, N], mask [B, N])` to `vmap` records of different
  lengths.
"""

import importlib

from ..modes import SlipTime
from .exact import simulate_exact, simulate_exact_campaign
from .parts import (AbstractForceTerm, AbstractLoadCoupling, AbstractMeasurement, AbstractPart,
                    ConstantLoad, Context, Core, IdealGauge, ViscousDamping)
from .trace import Cycles, SimulationResult, Trace, pad_times

_LAZY = {"DEFAULT_SMOOTHING": "smooth", "SmoothModel": "smooth", "cycles_from_samples": "smooth",
         "simulate_smooth": "smooth", "synthetic_record": "synthetic"}
"""Names imported on first use: the smoothed simulator loads diffrax, which the exact
simulator and the fits of the cycle features and traces do not need."""


def __getattr__(name):
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = ["AbstractForceTerm", "AbstractLoadCoupling", "AbstractMeasurement", "AbstractPart",
           "ConstantLoad", "Context", "Core", "Cycles", "DEFAULT_SMOOTHING", "IdealGauge",
           "SmoothModel", "ViscousDamping", "cycles_from_samples", "simulate_smooth",
           "synthetic_record", "SlipTime", "SimulationResult", "Trace", "pad_times",
           "simulate_exact", "simulate_exact_campaign"]
