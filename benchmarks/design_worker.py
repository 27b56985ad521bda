"""One process of the multi-process design-map benchmark (run by benchmarks/design.py):
``python design_worker.py PROCESS_ID NUM_PROCESSES PORT POINTS METHOD REPEAT``.

Joins a `jax.distributed` job on localhost (`stickslip_jax.distributed.initialize`, the
machinery of tests/distributed_map.py) before anything touches JAX's devices, computes a
`design_map` of POINTS random design points (`benchmarks/design.py`'s `points`, the same
on every process) split over every process's devices, and prints one JSON line: the best
wall time of REPEAT runs after compilation (s), the CPU time per wall time of that run
(the cores it kept busy), with the process index and device count.
"""

import json
import sys
import time

from stickslip_jax.distributed import initialize

pid, n_proc, port = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
n_points, method, repeat = int(sys.argv[4]), sys.argv[5], int(sys.argv[6])
initialize(f"localhost:{port}", n_proc, pid)

import jax  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from design import points  # noqa: E402

from stickslip_fitting.design import design_map  # noqa: E402

f, w, k, v = points(n_points, seed=2)
m = design_map(f, w, k, v, method=method, chunk_size=n_points)  # compile
best, cores = float("inf"), 0.0
for _ in range(repeat):
    t, c = time.perf_counter(), time.process_time()
    m = design_map(f, w, k, v, method=method, chunk_size=n_points)
    wall = time.perf_counter() - t
    if wall < best:
        best, cores = wall, (time.process_time() - c) / wall
print(json.dumps({"process": jax.process_index(), "processes": jax.process_count(),
                  "devices": len(jax.devices()), "seconds": best, "cores_busy": cores,
                  "checksum": float(np.nansum(np.asarray(m.amplitude)))}))
