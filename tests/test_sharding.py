"""Sharding of design maps over devices (stickslip_fitting.design.sharding): 2 forced host devices
give results identical to one device. The 2-device run is a subprocess because
XLA_FLAGS must be set before JAX starts."""

import os
import subprocess
import sys
import textwrap

import jax
import numpy as np
import pytest

from stickslip_fitting.design.sharding import batch_mesh, pad_batch, padded_size, shard_batch

SCRIPT = textwrap.dedent(
    """
    import jax, numpy as np
    import stickslip_jax as ss
    from stickslip_fitting.design import batch_mesh, design_map, outer
    assert jax.device_count() == 2, jax.devices()
    f = ss.lubricant("A")
    w, k, v = outer(np.linspace(10, 60, 7), np.linspace(20, 150, 5), np.geomspace(0.01, 90, 3) / 60)
    both = batch_mesh()
    one = batch_mesh(jax.devices()[:1])
    m2 = design_map(f, w, k, v, chunk_size=32, mesh=both)
    m1 = design_map(f, w, k, v, chunk_size=32, mesh=one)
    for name in ("amplitude", "stick_time", "frequency", "critical_speed", "stick_slip", "converged"):
        a, b = getattr(m2, name), getattr(m1, name)
        assert np.array_equal(a, b), (name, np.max(np.abs(a - b)))
    assert 0 < m2.stick_slip.mean() < 1
    # the chunk really is split: each device holds half of the rows
    from stickslip_fitting.design.sharding import shard_batch
    x = shard_batch(np.arange(8.0), both)
    assert sorted(len(s.data) for s in x.addressable_shards) == [4, 4]
    print("SHARDED-OK")
    """
)


def test_two_forced_host_devices_equal_one_device(tmp_path):
    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=2",
               JAX_PLATFORMS="cpu")
    script = tmp_path / "sharded.py"
    script.write_text(SCRIPT)
    proc = subprocess.run([sys.executable, str(script)], env=env, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "SHARDED-OK" in proc.stdout


def test_pad_and_shard_on_one_device():
    assert padded_size(5, 2) == 6 and padded_size(6, 2) == 6 and padded_size(0, 4) == 4
    tree = {"a": np.arange(5.0), "b": np.arange(10.0).reshape(5, 2)}
    padded = pad_batch(tree, 8)
    np.testing.assert_array_equal(padded["a"], [0, 1, 2, 3, 4, 4, 4, 4])
    np.testing.assert_array_equal(padded["b"][-1], [8, 9])
    with pytest.raises(ValueError, match="longer"):
        pad_batch(tree, 3)
    mesh = batch_mesh()
    out = shard_batch(padded, mesh)
    assert isinstance(out["a"], jax.Array)
    np.testing.assert_array_equal(np.asarray(out["a"]), padded["a"])
    if mesh.size > 1:
        with pytest.raises(ValueError, match="multiple"):
            shard_batch({"a": np.arange(mesh.size + 1.0)}, mesh)
