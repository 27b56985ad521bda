"""stickslip_jax: differentiable stick-slip model of machine-tool slideways.

Implements Kato, Sato, Yamaguchi and Matsubayashi, "Stick-slip motion and
characteristics of friction in machine tool slideway". Internal units: kgf, mm, s
(see `stickslip_jax.units`).

Importing the package enables `jax_enable_x64` for the whole process, by design: every
JAX array of the process is then float64 by default (on JAX if it is imported already,
else through the environment variable `JAX_ENABLE_X64`, which JAX reads when it is
imported and which child processes inherit). The steady analysis, the limit cycle's
implicit gradients and the fits' covariances need float64; code that wants float32 next
to the model should run in its own process. The public names are imported on first use.
"""

import importlib
import importlib.util
import os
import sys

# x64 before the first JAX computation, without importing JAX here (`stickslip --help`
# builds its parser without JAX): on a JAX already imported, else through the variable
# JAX reads when it is imported (so it also reaches processes started from this one).
if "jax" in sys.modules:
    sys.modules["jax"].config.update("jax_enable_x64", True)
else:
    os.environ["JAX_ENABLE_X64"] = "1"

_HOME = {
    "AbstractKineticFriction": "friction", "AbstractStaticFriction": "friction",
    "DerjaguinStatic": "friction", "Friction": "friction", "HoweStatic": "friction",
    "KatoKinetic": "friction", "KatoStatic": "friction", "OkamuraStatic": "friction",
    "PowerLawStatic": "friction",
    "experimental_conditions": "lubricants", "lubricant": "lubricants",
    "static_law": "lubricants",
    "REGIMES": "steady", "SteadyState": "steady", "restick_failure": "steady",
    "critical_speed": "steady", "natural_angular_frequency": "steady",
    "slip_time": "steady", "slip_trajectory": "steady", "steady_map": "steady",
    "steady_state": "steady",
    "Slideway": "slideway",
    "Formulation": "modes", "GaugeOffset": "modes", "SlipTime": "modes",
    "load_table": "tables",
}
"""Public name -> the module that defines it (imported on first use)."""


def __getattr__(name):
    # imported on first use, like a submodule (`stickslip_jax.simulation`): importing the
    # package stays cheap, so the `stickslip` command parses its arguments without JAX
    if name in _HOME:
        value = getattr(importlib.import_module(f".{_HOME[name]}", __name__), name)
        globals()[name] = value
        return value
    if not name.startswith("_") and importlib.util.find_spec(f"{__name__}.{name}") is not None:
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))


__all__ = [
    "AbstractKineticFriction",
    "AbstractStaticFriction",
    "DerjaguinStatic",
    "Formulation",
    "Friction",
    "GaugeOffset",
    "HoweStatic",
    "KatoKinetic",
    "KatoStatic",
    "OkamuraStatic",
    "PowerLawStatic",
    "Slideway",
    "SlipTime",
    "SteadyState",
    "critical_speed",
    "experimental_conditions",
    "load_table",
    "lubricant",
    "natural_angular_frequency",
    "slip_time",
    "slip_trajectory",
    "static_law",
    "steady_map",
    "steady_state",
    "units",
    "REGIMES",
    "restick_failure",
]
