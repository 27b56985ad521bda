r"""Spread a batch of design points over every device JAX sees (`jax.sharding`).

A batch is any pytree whose leaves share a leading axis. `shard_batch` places it
(padded by `pad_batch` to a multiple of the device count) on a one-axis `Mesh` named
``"batch"``; shared arguments are copied to every device with `replicate`. A jitted,
vmapped kernel on such arrays runs on all devices at once with the same arithmetic as on
one, so the results are identical.

Several hosts: call ``jax.distributed.initialize()`` in every process before any other
JAX call; `batch_mesh()` then spans the devices of all hosts. `chunks.map_chunks` gives
each process its own block of every chunk and all-gathers the blocks, so every process
ends with the whole map (write files from process 0 only). `shard_batch` also builds a
global array over several processes and `to_host` gathers one; a kernel with a
data-dependent loop should not run on such an array (its stop condition would need an
all-reduce between processes per step).
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
