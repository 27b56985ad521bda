r"""Missing-physics discovery: which effect does the paper's model leave out?

The default (`stickslip discover`) works on the per-cycle model of the trace objective:

- `cycle_effects`: effect families with scanned shapes and physical bounds.
- `cycle_model`: the per-cycle model with every effect (`CycleModel`: residuals and
  forward-mode Jacobian blocks); equal to the trace objective at zero effects.
- `cycle_workflow`: `discover_cycles(records) -> CycleDiscovery` (robust score test,
  refits, decision, "unexplained").
- `engine`: the one pipeline both bases run through (`discover(records, base)` over an
  `AbstractBaseModel`: `cycle_workflow.CycleBase`, `workflow.SmoothBase`).

The whole-record workflow on the smoothed simulator (`--base smooth`):

- `effects`: the candidate-effect library (parts of the smoothed simulator).
- `model`: campaign traces, the all-effects model and its one compiled
  residual/Jacobian function (`Problem`).
- (the fits: `subproblems.AbstractProblem.solve`, the project's one Levenberg-Marquardt
  driven from Python)
- `residuals`: residual analysis and the misspecification test.
- `ranking`: score test of every candidate at the base fit, refits of the best few,
  the choice by BIC or "none".
- `learned`: a learned (MLP) friction correction and a sparse regression naming its
  variables, for when no candidate explains the residuals.
- `synthetic`: campaigns with a hidden effect, for tests and benchmarks.
- `workflow`: `discover(records) -> SmoothDiscovery`.
- `result`: the one result type `Discovery` (`CycleDiscovery`, `SmoothDiscovery`).
"""

import importlib

__all__ = ["CANDIDATES", "Discovery", "EffectSet", "discover"]

_HOME = {"CANDIDATES": "effects", "EffectSet": "effects", "Discovery": "result",
         "discover": "workflow"}


def __getattr__(name):
    # imported on first use: the workflow pulls in scipy.stats (about 0.6 s), which every
    # `stickslip` command would otherwise pay while building its argument parser
    if name in _HOME:
        return getattr(importlib.import_module(f".{_HOME[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
