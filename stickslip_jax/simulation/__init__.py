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

- `simulate_exact(slideway, drive, ts, *, slip_time="paper"|"self_consistent",
  initial_deflection=0.0, initial_stick_time=0.0, start_time=None, mask=None,
  max_events=64) -> Trace`: the paper's model solved event by event in closed form
  (exact.py).
- `Trace`: `time`, `deflection`, `slider_velocity`, `sticking`, `mask`, `cycles`
  (`Cycles`: breakaway_time, peak, trough, stick_time, slip_time, model_slip_time,
  mu_0, mu_m, restick_failed, valid; `.amplitude()`), `steady_sliding`, `result`
  (`SimulationResult`), `num_events`; `.limit_cycle(last=2)`.
- `pad_times(list_of_ts) -> (ts [B, N], mask [B, N])` to `vmap` records of different
  lengths.
"""

from .exact import SLIP_TIME_MODES, simulate_exact
from .trace import Cycles, SimulationResult, Trace, pad_times

__all__ = [
    "Cycles",
    "SLIP_TIME_MODES",
    "SimulationResult",
    "Trace",
    "pad_times",
    "simulate_exact",
]
