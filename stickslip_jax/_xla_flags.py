"""XLA compiler options the package sets by default (before JAX starts its backend).

`--xla_cpu_use_fusion_emitters=false`: XLA's CPU compiler then emits its fusions with
the classic elemental emitter instead of one MLIR kernel module per fusion. On the
event-driven simulator and the fits this compiles in about half the time and runs as
fast or faster (measured in `benchmarks/fit.py`: the trace program's XLA compilation
2.4 s -> 1.3 s on 2 cores, one simulation of the 12-record campaign 3.7 -> 2.5 ms).

Set only where the user's `XLA_FLAGS` does not name the option already, and only if
the environment variable `STICKSLIP_XLA_DEFAULTS` is not `0`. XLA reads `XLA_FLAGS` once,
when the first computation starts its backend, so importing `stickslip_jax` after JAX
has computed something leaves the options as they were.
"""

import os

DEFAULT_XLA_FLAGS = ("--xla_cpu_use_fusion_emitters=false",)


def set_default_xla_flags(environ=os.environ) -> None:
    """Append `DEFAULT_XLA_FLAGS` to `environ["XLA_FLAGS"]` (module doc)."""
    if environ.get("STICKSLIP_XLA_DEFAULTS", "1").strip() == "0":
        return
    flags = environ.get("XLA_FLAGS", "")
    for flag in DEFAULT_XLA_FLAGS:
        if flag.split("=")[0] not in flags:
            flags = f"{flags} {flag}".strip()
    environ["XLA_FLAGS"] = flags
