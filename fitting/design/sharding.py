r"""Spread a batch of design points over every device JAX sees (`jax.sharding`).

A batch is any pytree whose leaves share a leading axis. `shard_batch` pads that axis
to a multiple of the device count and places it on a one-axis `Mesh` named
``"batch"`` with `NamedSharding(mesh, P("batch"))`; shared arguments (a posterior
sample, solver settings) are replicated with `replicate`. A jitted, vmapped kernel
applied to such arrays runs on all devices at once (GSPMD), and every point gets the
same arithmetic as on one device, so the results are identical.

Several hosts: start every process with the same script and call
``jax.distributed.initialize()`` (coordinator address, process count and id from the
cluster, e.g. SLURM sets them automatically) before any other JAX call. Then
`jax.devices()` lists the devices of *all* hosts and `batch_mesh()` spans them.
`stickslip_fitting.design.chunks.map_chunks` (what `design_map` runs) then gives each
process a contiguous block of every chunk, computed on a mesh of its own devices, and
all-gathers the blocks (`jax.experimental.multihost_utils.process_allgather`), so every
process ends with the whole map (every process computes the same cheap grid of design
points); write files from ``jax.process_index() == 0`` only. For other uses,
`shard_batch` builds a global array over several processes with
`jax.make_array_from_callback` (each process supplying the rows its devices hold) and
`to_host` gathers one; a kernel with a data-dependent loop should not run on such an
array, since its stop condition then needs an all-reduce between processes per step.
"""

from __future__ import annotations

import jax
import numpy as np
from jax.sharding import Mesh, NamedSharding
from jax.sharding import PartitionSpec as P

AXIS = "batch"


def batch_mesh(devices=None) -> Mesh:
    """A one-axis mesh named ``"batch"`` over `devices` (default: every device JAX sees)."""
    devices = jax.devices() if devices is None else list(devices)
    if not devices:
        raise ValueError("batch_mesh needs at least one device")
    return Mesh(np.asarray(devices), (AXIS,))


def padded_size(n: int, multiple: int) -> int:
    """Smallest multiple of `multiple` that is >= `n` (and >= `multiple`)."""
    return max(multiple, -(-n // multiple) * multiple)


def pad_batch(batch, size: int):
    """Pad every leaf's leading axis to `size` by repeating its last row (a valid point)."""

    def pad(x):
        x = np.asarray(x)
        extra = size - x.shape[0]
        if extra < 0:
            raise ValueError(f"batch of {x.shape[0]} rows is longer than the padded size {size}")
        if extra == 0:
            return x
        return np.concatenate([x, np.repeat(x[-1:], extra, axis=0)], axis=0)

    return jax.tree_util.tree_map(pad, batch)


def _put(x, sharding):
    x = np.asarray(x)
    if jax.process_count() == 1:
        return jax.device_put(x, sharding)
    return jax.make_array_from_callback(x.shape, sharding, lambda idx: x[idx])


def shard_batch(batch, mesh: Mesh):
    """Place a host batch (leading axis a multiple of ``mesh.size``) split along ``"batch"``."""
    ndev = mesh.size
    for leaf in jax.tree_util.tree_leaves(batch):
        if np.ndim(leaf) == 0 or np.shape(leaf)[0] % ndev:
            raise ValueError(
                f"leading axis {np.shape(leaf)} is not a multiple of the {ndev} devices; "
                "pad it with pad_batch first")
    sharding = NamedSharding(mesh, P(AXIS))
    return jax.tree_util.tree_map(lambda x: _put(x, sharding), batch)


def replicate(tree, mesh: Mesh):
    """Copy every array leaf of `tree` to every device of `mesh`."""
    sharding = NamedSharding(mesh, P())

    def put(x):
        if isinstance(x, (np.ndarray, jax.Array, float, int)):
            return _put(x, sharding)
        return x

    return jax.tree_util.tree_map(put, tree)


def to_host(x) -> np.ndarray:
    """A (possibly multi-host) sharded array as one NumPy array on this process."""
    if isinstance(x, jax.Array) and not x.is_fully_addressable:
        from jax.experimental import multihost_utils

        return np.asarray(multihost_utils.process_allgather(x, tiled=True))
    return np.asarray(x)
