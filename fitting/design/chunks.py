r"""Stream a large batch through a jitted kernel in fixed-size, sharded chunks.

`map_chunks(kernel, batch, shape)` evaluates ``kernel(chunk, shared)`` on chunks of
``chunk_size`` points. The batch leaves only need to *broadcast* to `shape` (an outer
grid of W, k and v costs no memory), so a map can be far larger than memory as long as
the consumer of the chunks keeps up. Every chunk has the same padded shape, so the
kernel compiles once; chunk ``i + 1`` is dispatched before chunk ``i`` is copied back,
so device work and host transfers overlap. Chunks are split over all devices
(`design.sharding`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterator

import equinox as eqx
import jax
import numpy as np

from .sharding import batch_mesh, pad_batch, padded_size, replicate, shard_batch, to_host


def gather_rows(batch, shape: tuple[int, ...], start: int, stop: int):
    """Rows `start:stop` of the flattened broadcast of every leaf of `batch` to `shape`."""
    idx = np.unravel_index(np.arange(start, stop), shape) if shape else ()

    def take(x):
        x = np.broadcast_to(np.asarray(x), shape)
        return x[idx] if shape else np.broadcast_to(x, (stop - start,))

    return jax.tree_util.tree_map(take, batch)


def map_chunks(kernel: Callable, batch, shape: tuple[int, ...], *, shared=None,
               chunk_size: int = 65_536, mesh=None, progress: bool = False,
               desc: str = "design map") -> Iterator[tuple[int, int, object]]:
    """Yield ``(start, stop, result)`` for consecutive chunks of the flattened batch.

    `kernel(chunk, shared)` is vmapped over the leading axis of `chunk` and returns a
    pytree with that leading axis; it is jitted once per kernel object. `result` holds
    NumPy arrays of ``stop - start`` rows. `mesh` defaults to all devices; `chunk_size`
    is rounded up to a multiple of the device count.
    """
    shape = tuple(int(s) for s in shape)
    total = math.prod(shape)
    if total == 0:
        return
    if chunk_size < 1:
        raise ValueError(f"chunk_size must be >= 1, got {chunk_size}")
    mesh = batch_mesh() if mesh is None else mesh
    size = padded_size(min(chunk_size, total), mesh.size)
    fn = _jitted(kernel)
    local, part, first = _process_share(mesh, size)
    across = local is not mesh  # several processes: each computes its block, then gather
    shared_dev = replicate(shared, local) if shared is not None else None
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=total, desc=desc, unit="pt", unit_scale=True, leave=False)

    def dispatch(start):
        stop = min(start + size, total)
        rows = pad_batch(gather_rows(batch, shape, start, stop), size)
        if across:  # this process's rows only (_process_share)
            rows = jax.tree_util.tree_map(lambda x: x[first:first + part], rows)
        return start, stop, fn(shard_batch(rows, local), shared_dev)

    pending = dispatch(0)
    try:
        while pending is not None:
            start, stop, out = pending
            pending = dispatch(stop) if stop < total else None
            host = jax.tree_util.tree_map(
                lambda x: _gather(x, across)[: stop - start], out)
            if bar is not None:
                bar.update(stop - start)
            yield start, stop, host
    finally:
        if bar is not None:
            bar.close()


def _process_share(mesh, size: int):
    """(local mesh, rows per process, this process's first row) of a chunk of `size` rows.

    Several processes (`jax.distributed`): each computes its own block of every chunk on
    its own devices, all-gathered afterwards (`_gather`). A chunk sharded over several
    processes would run a data-dependent loop (the exact simulator's `while_loop`) in
    lock-step, an all-reduce per iteration, which made 2 processes no faster than one
    (benchmarks/design.py)."""
    n_proc = jax.process_count()
    if n_proc == 1:
        return mesh, size, 0
    mine = [d for d in mesh.devices.flat if d.process_index == jax.process_index()]
    if not mine or len(mine) * n_proc != mesh.size:
        raise ValueError(f"the mesh's {mesh.size} devices are not spread evenly over the "
                         f"{n_proc} processes (this one holds {len(mine)}); use a mesh with "
                         "the same number of devices on every process")
    part = size // n_proc
    return batch_mesh(mine), part, jax.process_index() * part


def _gather(x, across_processes: bool) -> np.ndarray:
    """A result block on the host: with several processes, every process's block in
    process order (`multihost_utils.process_allgather`)."""
    x = to_host(x)
    if not across_processes:
        return x
    from jax.experimental import multihost_utils

    return np.asarray(multihost_utils.process_allgather(x, tiled=True))


@functools.cache
def _jitted(kernel):
    """`kernel` jitted once per kernel object (its compilation reused by every map)."""
    return eqx.filter_jit(kernel)


def collect(chunks: Iterator[tuple[int, int, object]], shape: tuple[int, ...]):
    """Assemble the chunks of `map_chunks` into one pytree of NumPy arrays of `shape`."""
    total = math.prod(shape)
    out = None
    for start, stop, res in chunks:
        if out is None:
            out = jax.tree_util.tree_map(lambda x: np.empty((total,) + x.shape[1:], dtype=x.dtype),
                                         res)
        jax.tree_util.tree_map(lambda o, x: o.__setitem__(slice(start, stop), x), out, res)
    if out is None:
        raise ValueError("empty map: every axis needs at least one point")
    return jax.tree_util.tree_map(lambda o: o.reshape(tuple(shape) + o.shape[1:]), out)
