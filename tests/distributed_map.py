"""One process of a `jax.distributed` design map (run by tests/test_distributed.py):
`python distributed_map.py PROCESS_ID NUM_PROCESSES PORT OUT.npy`."""

import sys

from stickslip_jax.distributed import initialize

pid, n, port, out = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3], sys.argv[4]
initialize(f"localhost:{port}", n, pid)

import jax  # noqa: E402
import numpy as np  # noqa: E402

import stickslip_jax as ss  # noqa: E402
from stickslip_fitting.design import design_map, outer  # noqa: E402

w, k, v = outer(np.linspace(10, 60, 5), np.linspace(20, 130, 6), np.linspace(1, 60, 7) / 60)
m = design_map(ss.lubricant("A"), w, k, v, chunk_size=64)
np.save(out, np.stack([np.asarray(m.amplitude), np.asarray(m.critical_speed),
                       np.asarray(m.stick_time)]))
print(f"process {jax.process_index()} of {jax.process_count()}, {len(jax.devices())} devices")
