"""Make the example campaign of data/examples/: lubricant A (Table 6), the three
(W, k) pairs of Table 1, four drive speeds below the critical speed v_c (about
49 mm/min for all three pairs), 0.5 um white noise on the deflection.

Each record lasts 6.5 steady stick-slip periods (the first, from rest, is longer),
sampled at 500 Hz (about 10 samples per slip), simulated by the exact simulator.
Run from the repository root:  .venv/bin/python data/examples/make_campaign.py
It rewrites the 12 CSV files and truth.json (the parameters, in kgf, mm, s).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from stickslip_jax import Slideway, experimental_conditions, lubricant, steady_state
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.records import write_record
from stickslip_jax.simulation.synthetic import friction_truth, synthetic_record
from stickslip_jax.units import from_mm_per_min

SPEEDS_MM_MIN = (2.0, 5.0, 12.0, 30.0)
SAMPLE_RATE = 500.0
NOISE_MM = 0.5e-3
PERIODS = 6.5
HERE = Path(__file__).resolve().parent


def main():
    friction = lubricant("A")
    entries = []
    seed = 0
    for W, k in experimental_conditions():
        sw = Slideway(friction, W, k)
        for v_min in SPEEDS_MM_MIN:
            v = from_mm_per_min(v_min)
            ss = steady_state(friction, W, k, v)
            assert bool(ss.stick_slip), (W, k, v_min)
            duration = float(np.ceil(PERIODS * float(ss.stick_time + ss.slip_time)))
            rec = synthetic_record(sw, ConstantSpeed(v), duration, SAMPLE_RATE,
                                   noise_std=NOISE_MM, seed=seed, lubricant="A",
                                   note=f"synthetic: lubricant A, W {W} kgf, k {k} kgf/mm, "
                                        f"v {v_min} mm/min")
            name = f"A_W{W:g}_k{k:g}_v{v_min:g}mm-min.csv"
            write_record(rec, HERE / name)
            entries.append({"file": name, "weight_kgf": W, "stiffness_kgf_mm": k,
                            "drive_speed_mm_s": v, "drive_speed_mm_min": v_min,
                            "duration_s": duration, "sample_rate_hz": SAMPLE_RATE,
                            "seed": seed, "cycles": rec.truth["cycles"],
                            "steady_amplitude_mm": float(ss.amplitude),
                            "steady_stick_time_s": float(ss.stick_time)})
            seed += 1
    truth = {"lubricant": "A", "table": 6,
             "friction": {key: friction_truth(Slideway(friction, 1.0, 1.0))[key]
                          for key in ("static", "kinetic")},
             "noise_mm": NOISE_MM, "simulator": "exact (slip_time=paper)",
             "units": "kgf, mm, s", "records": entries}
    (HERE / "truth.json").write_text(json.dumps(truth, indent=2) + "\n")
    print(f"wrote {len(entries)} records and truth.json to {HERE}")


if __name__ == "__main__":
    main()
