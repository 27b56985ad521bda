"""Benchmark: a batch of campaign fits (`stickslip fit-batch`) in 1 and in 2 processes.

The batch: the shipped campaign (data/examples, 12 records) and its three stiffness
subsets (4 records each), repeated `--repeat-campaigns` times (default 2: 8 campaigns).
Each run is the `stickslip fit-batch` command started from scratch, so its wall time
includes the imports and the compilation (JAX's persistent compilation cache is off:
`STICKSLIP_CACHE_DIR=""`): the cold figure a user sees. The warm figure is the batch's
own time after start-up (the JSON's "wall_time_s": fitting only, compilation of the first
campaign of each layout included, since every process compiles its own).

Baseline: the same command in 1 process, run in this benchmark. The 2-process run joins
2 CPU processes on localhost with `jax.distributed` (`--coordinator/--num-processes/
--process-id`); each process fits its share of the campaigns and the results are
all-gathered. Printed: wall and fit time, campaigns/s, speed-up, parallel efficiency,
whether both give the same parameters, and a projection for N hosts.

    python benchmarks/fit_batch.py                 # 8 campaigns, features objective
    python benchmarks/fit_batch.py --objective trace --repeat-campaigns 1
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from design import free_port  # benchmarks/design.py, beside this script

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "data" / "examples"


def campaigns(repeat: int) -> list[str]:
    one = [str(EXAMPLES)] + [str(EXAMPLES / f"A_W36_k{k}_*.csv") for k in ("128.5", "27.3",
                                                                            "86.9")]
    return one * repeat


def run_batch(specs, n_processes: int, objective: str, folder: str):
    """Wall time (s) of `stickslip fit-batch` on `n_processes` processes, and process 0's
    JSON document."""
    exe = str(Path(sys.executable).with_name("stickslip"))
    out = os.path.join(folder, f"batch{n_processes}.json")
    env = {**os.environ, "STICKSLIP_CACHE_DIR": ""}
    base = [exe, "fit-batch", *specs, "-q", "--objective", objective, "--json", out]
    port = str(free_port())
    dist = (lambda i: ["--coordinator", f"localhost:{port}", "--num-processes",
                       str(n_processes), "--process-id", str(i)]) if n_processes > 1 else \
        (lambda i: [])
    t = time.perf_counter()
    procs = [subprocess.Popen(base + dist(i), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, env=env) for i in range(n_processes)]
    results = [p.communicate(timeout=3600) for p in procs]
    wall = time.perf_counter() - t
    for p, (_, err) in zip(procs, results):
        if p.returncode not in (0, 3):
            raise RuntimeError(f"fit-batch failed ({p.returncode}):\n{err[-3000:]}")
    return wall, json.loads(Path(out).read_text())


def _values(doc):
    return [(c["campaign"], n, p["value"]) for c in doc["campaigns"] if c["result"]
            for n, p in c["result"]["parameters"].items()]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat-campaigns", type=int, default=2,
                    help="how many times the 4 campaigns are repeated (default 2: 8)")
    ap.add_argument("--objective", default="features", choices=("features", "trace", "both"))
    ap.add_argument("--hosts", default="1,2,4,8,16,64",
                    help="host counts of the projection (comma-separated)")
    args = ap.parse_args(argv)
    specs = campaigns(args.repeat_campaigns)
    print(f"batch: {len(specs)} campaigns (objective {args.objective}); machine: "
          f"{os.cpu_count()} cores")
    with tempfile.TemporaryDirectory() as folder:
        wall1, doc1 = run_batch(specs, 1, args.objective, folder)
        wall2, doc2 = run_batch(specs, 2, args.objective, folder)
    fit1, fit2 = doc1["wall_time_s"], doc2["wall_time_s"]
    n = len(specs)
    print(f"{'processes':<12}{'wall [s] (cold)':>17}{'fitting [s] (warm)':>20}"
          f"{'campaigns/s':>13}")
    print(f"{'1 (baseline)':<12}{wall1:>17.1f}{fit1:>20.1f}{n / wall1:>13.3g}")
    print(f"{'2':<12}{wall2:>17.1f}{fit2:>20.1f}{n / wall2:>13.3g}")
    eff = wall1 / (2.0 * wall2)
    same = all(a[:2] == b[:2] and (a[2] is None and b[2] is None  # not identifiable: null
                                   or None not in (a[2], b[2])
                                   and abs(a[2] - b[2]) <= 1e-9 * max(abs(a[2]), 1e-300))
               for a, b in zip(_values(doc1), _values(doc2)))
    print(f"speed-up 2 / 1: {wall1 / wall2:.2f}x cold, {fit1 / fit2:.2f}x fitting only; "
          f"parallel efficiency {eff * 100:.0f} % (cold); same parameters: "
          f"{'yes' if same else 'NO'}")
    print("projection for N hosts (each host adds one process's rate times the measured "
          "2-process efficiency; campaigns are independent, so the only shared work is the "
          "final all-gather of the reports, a few kB per campaign):")
    print(f"{'hosts':<12}{'campaigns/s':>13}")
    rate1 = n / wall1
    for h in (int(x) for x in args.hosts.split(",")):
        print(f"{h:<12}{(rate1 if h == 1 else h * rate1 * eff):>13.3g}")


if __name__ == "__main__":
    main()
