"""stickslip_jax: differentiable stick-slip model of machine-tool slideways.

Implements Kato, Sato, Yamaguchi and Matsubayashi, "Stick-slip motion and
characteristics of friction in machine tool slideway". Internal units: kgf, mm, s
(see `stickslip_jax.units`).

Importing the package enables `jax_enable_x64` for the whole process, by design: every
JAX array of the process is then float64 by default. The flag is set on JAX itself
(`jax.config.update`): at once if JAX is imported already, else right after JAX's first
import. The environment is left as it is, so processes started from this one keep their
own precision unless they import the package too. The steady analysis, the limit cycle's
implicit gradients and the fits' covariances need float64; code that wants float32 next
to the model should run in its own process. The public names are imported on first use.
"""

import importlib
import importlib.util
import os
import sys


class _X64AfterJaxImport:
    """An import finder (first on `sys.meta_path`) that lets the usual finders find JAX,
    then enables x64 on it as soon as its package has run, before any JAX computation;
    it removes itself at JAX's import. The environment (`JAX_ENABLE_X64`) is not touched,
    so child processes do not inherit the setting."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname != "jax":
            return None
        _remove_x64_hook()
        for finder in sys.meta_path:
            find = getattr(finder, "find_spec", None)
            spec = find(fullname, path, target) if find is not None else None
            if spec is not None:
                break
        else:
            return None
        loader = spec.loader
        run = getattr(loader, "exec_module", None)

        def exec_module(module):
            try:
                run(module)
            finally:
                del loader.exec_module
            module.config.update("jax_enable_x64", True)

        try:
            if run is None:
                raise AttributeError("exec_module")
            loader.exec_module = exec_module
        except AttributeError:  # an unusual loader: the variable JAX reads at its import
            os.environ["JAX_ENABLE_X64"] = "1"
        return spec


def _remove_x64_hook() -> None:
    sys.meta_path[:] = [f for f in sys.meta_path if not isinstance(f, _X64AfterJaxImport)]


def _enable_x64() -> None:
    """x64 before the first JAX computation, without importing JAX here (`stickslip
    --help` builds its parser without JAX): on a JAX already imported, else right after
    JAX's import (`_X64AfterJaxImport`)."""
    jax = sys.modules.get("jax")
    if jax is not None and hasattr(jax, "config"):
        jax.config.update("jax_enable_x64", True)
        return
    _remove_x64_hook()
    sys.meta_path.insert(0, _X64AfterJaxImport())


_enable_x64()

_HOME = {name: module for module, names in {
    "friction": ("AbstractKineticFriction", "AbstractStaticFriction", "DerjaguinStatic",
                 "Friction", "HoweStatic", "KatoKinetic", "KatoStatic", "OkamuraStatic",
                 "PowerLawStatic"),
    "lubricants": ("experimental_conditions", "lubricant", "static_law"),
    "steady": ("REGIMES", "SteadyState", "restick_failure", "critical_speed",
               "natural_angular_frequency", "slip_time", "slip_trajectory", "steady_map",
               "steady_state"),
    "slideway": ("Slideway",), "modes": ("Formulation", "GaugeOffset", "SlipTime"),
    "tables": ("load_table",)}.items() for name in names}
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


__all__ = [*sorted(_HOME), "units"]
