r"""Missing-physics discovery: which effect does the paper's model leave out?

`engine.discover(records, base)` runs one pipeline over a base model: the per-cycle
`cycle_workflow.CycleBase` (default; `cycle_effects`, `cycle_model`, `stages`) or the
smoothed whole-record `workflow.SmoothBase` (`--base smooth`; `effects`, `model`,
`ranking`, `residuals`, `learned`); both answer with `result.Discovery`. `synthetic`
makes campaigns with a hidden effect, for tests and benchmarks.
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
