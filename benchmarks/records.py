"""Benchmark: reading a campaign of record files (MB/s), fast path against the checked
row-by-row parser, same process.

Writes a campaign of `--records` records of `--samples` samples each (time, deflection
and one extra channel, `repr` precision: about 40 bytes a row) into a temporary folder,
then reads it with `stickslip_jax.records.read_campaign`:

- `fast`: the reader as shipped (NumPy's C parser over all rows; the checked parser only
  when that fails, to name the bad line);
- `checked`: the row-by-row regex parser alone (the fallback that names a bad line), by
  routing `parse_data` to `parse_data_checked`;
- `numpy.loadtxt` of the data rows alone (no header, no checks) for reference.

Prints best-of-`--repeat` wall times, MB/s and the ratio; checks that both paths give
identical records. `--small`: 2 records of 50 k samples (smoke run).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np

from stickslip_jax.records import Record, read_campaign, write_record
from stickslip_jax.records import parse as rec_parse
from stickslip_jax.records import rows as rec_rows


def make_campaign(folder, n_records, n_samples):
    rng = np.random.default_rng(0)
    paths = []
    for i in range(n_records):
        t = np.arange(n_samples) * 1e-3
        x = 0.1 + 0.05 * np.mod(t, 1.0) + 5e-4 * rng.standard_normal(n_samples)
        r = Record(time=t, deflection=x, stiffness=86.9, weight=36.0, drive_speed=5.0 / 60,
                   lubricant="A", channels={"temperature": 21.0 + 0.01 * rng.standard_normal(
                       n_samples)}, channel_units={"temperature": "degC"})
        paths.append(write_record(r, os.path.join(folder, f"run{i}.csv")))
    return [str(p) for p in paths]


def best(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, default=4)
    ap.add_argument("--samples", type=int, default=250_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--small", action="store_true")
    a = ap.parse_args()
    if a.small:
        a.records, a.samples, a.repeat = 2, 50_000, 1
    with tempfile.TemporaryDirectory() as folder:
        paths = make_campaign(folder, a.records, a.samples)
        size = sum(os.path.getsize(p) for p in paths) / 1e6
        t_fast, fast = best(lambda: read_campaign(paths), a.repeat)
        fast_parse = rec_parse.parse_data  # the reader parse_record calls
        rec_parse.parse_data = rec_rows.parse_data_checked
        try:
            t_checked, checked = best(lambda: read_campaign(paths), a.repeat)
        finally:
            rec_parse.parse_data = fast_parse

        def loadtxt():
            return [np.loadtxt(p, delimiter=",", comments="#", skiprows=8) for p in paths]

        t_np, _ = best(loadtxt, a.repeat)
        same = all(x == y for x, y in zip(fast, checked))
    print(f"campaign: {a.records} records x {a.samples} samples, {size:.1f} MB "
          f"(best of {a.repeat}; load average {os.getloadavg()[0]:.2f})")
    print(f"{'reader':<28}{'time [s]':>10}{'MB/s':>10}{'ratio':>8}")
    for name, t in (("fast (shipped)", t_fast), ("checked row-by-row (before)", t_checked),
                    ("numpy.loadtxt (data only)", t_np)):
        print(f"{name:<28}{t:>10.3f}{size / t:>10.1f}{t_checked / t:>8.2f}")
    print(f"records identical: {same}")


if __name__ == "__main__":
    main()
