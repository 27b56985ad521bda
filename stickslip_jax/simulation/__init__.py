r"""Time-domain simulators of the slideway (Fig 5): x(t), the spring deflection in mm.

One verb per simulator, both returning a `Trace` (examples: docs/simulators.md):

- `simulate_exact` (exact.py): the paper's model solved event by event in closed form;
  `simulate_exact_campaign`: B records of different lengths without padding (`slideway`,
  `drive` batched over records, `ts`/`record_index` the flat concatenated samples).
- `simulate_smooth` (smooth.py): the same physics as one smooth ODE in diffrax
  (formulations "latch", the default, "rigid_stick", "velocity"), `model` a `Slideway` or
  a `SmoothModel` with parts (parts.py: force terms, load couplings, measurements, with
  optional states of their own).
- `Trace` (trace.py): time, deflection, slider velocity, sticking, mask, the per-cycle
  table `Cycles`, `steady_sliding`, `result` (`SimulationResult`), `num_events`.
- `synthetic_record` (synthetic.py): a `records.Record` with a `truth` dict;
  `pad_times(list_of_ts) -> (ts [B, N], mask [B, N])` to `vmap` records of different
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
