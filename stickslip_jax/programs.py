"""Compiled programs and the process's memory maps: their release between campaigns.

XLA's CPU backend loads each kernel of a compiled program as its own memory mappings
(code, read-only data, data). Measured: 18 maps for a small program, about
100 for a test program of 30 matrix and FFT steps, about 2,400 for a discovery campaign.
JAX keeps every compiled program, and each campaign's shapes compile new ones.

Linux caps a process's maps at `vm.max_map_count` (65,530 by default). When a
compilation needs a map beyond it, LLVM fails ("LLVM compilation error: Cannot allocate
memory") and the process dies with a segmentation fault in `backend_compile_and_load`.
There is no Python exception to catch. A process that runs many campaigns reaches the
cap: a notebook, a batch, or the slow tests (about 27 discovery campaigns).

`release_programs` drops JAX's compiled programs (`jax.clear_caches`) when the process
uses more than a fraction of its maps. They compile again at their next use; a new
campaign's shapes compile anyway. The campaign-level verbs (`fit_features`,
`discover_cycles`) call it before they start. Where `/proc` is missing (not Linux) it
does nothing.
"""

from __future__ import annotations

import gc
import pathlib
from typing import NamedTuple

import jax

__all__ = ["MAP_FRACTION", "ProgramRelease", "map_limit", "maps_in_use", "release_programs"]

MAP_FRACTION = 0.5
"""Release when more than this fraction of the map limit is in use. Half the default
limit leaves room for about 13 discovery campaigns before the next check."""


class ProgramRelease(NamedTuple):
    """What `release_programs` found and did (maps are counts; None where unknown)."""

    released: bool
    maps_before: int | None
    maps_after: int | None
    limit: int | None


def maps_in_use() -> int | None:
    """The memory maps of this process (lines of /proc/self/maps), or None."""
    try:
        with open("/proc/self/maps", "rb") as fh:
            return sum(1 for _ in fh)
    except OSError:
        return None


def map_limit() -> int | None:
    """The kernel's cap on a process's memory maps (vm.max_map_count), or None."""
    try:
        return int(pathlib.Path("/proc/sys/vm/max_map_count").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return None


def release_programs(fraction: float = MAP_FRACTION, *, limit: int | None = None
                     ) -> ProgramRelease:
    """Drop JAX's compiled programs when more than `fraction` of the map limit is in use
    (module doc). `limit`: the cap to compare with (default `map_limit()`; tests)."""
    if not 0.0 < fraction <= 1.0:
        raise ValueError(f"release_programs: fraction must be in (0, 1], got {fraction}")
    before = maps_in_use()
    limit = map_limit() if limit is None else limit
    if before is None or limit is None or before <= fraction * limit:
        return ProgramRelease(False, before, before, limit)
    jax.clear_caches()
    gc.collect()
    return ProgramRelease(True, before, maps_in_use(), limit)
