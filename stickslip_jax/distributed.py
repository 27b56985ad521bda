"""Join a `jax.distributed` job: maps and batches across processes and hosts.

Import and call `initialize` before anything else touches JAX's devices (importing this
module does not): a process that has already computed something cannot join.
`stickslip_fitting.design.sharding` then spreads design points over every process's
devices; see its docstring.
"""

from __future__ import annotations

import jax

__all__ = ["initialize"]


def initialize(coordinator: str, num_processes: int, process_id: int) -> None:
    """Join a `jax.distributed` job before any other JAX call: `coordinator` "host:port"
    (process 0's address), `num_processes`, this process's `process_id` (0 ... n-1). On
    CPU the processes exchange results through gloo (JAX's CPU collectives), so the same
    code runs across CPU processes of one machine or many (tested with 2 processes on
    localhost, `tests/test_distributed.py`). Afterwards `jax.devices()` lists every
    process's devices, `batch_mesh` spans them and `design_map` splits its points over
    them; every process ends with the whole map."""
    if not (isinstance(num_processes, int) and num_processes >= 1):
        raise ValueError(f"num_processes must be a positive integer, got {num_processes!r}")
    if not (isinstance(process_id, int) and 0 <= process_id < num_processes):
        raise ValueError(f"process_id must lie in 0 ... {num_processes - 1}, got {process_id!r}")
    host, _, port = str(coordinator).rpartition(":")
    if not host or not port.isdigit():
        raise ValueError(f"coordinator must be HOST:PORT, got {coordinator!r}")
    jax.config.update("jax_cpu_collectives_implementation", "gloo")
    jax.distributed.initialize(coordinator_address=coordinator, num_processes=num_processes,
                               process_id=process_id)
