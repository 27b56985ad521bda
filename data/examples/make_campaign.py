"""Make the example campaign of data/examples/: lubricant A (Table 6), the slider
weight W = 36.0 kgf of Table 1 with its three spring stiffnesses k = 27.3, 86.9 and
128.5 kgf/mm (three different k/W, hence three slip times T2 = pi sqrt(W/(g k)),
eq 7, so that delta and n of eq (3) can both be found), four drive speeds below each
pair's critical speed v_c (eq 12: about 133, 49 and 34 mm/min), 0.5 um white noise on
the deflection.

Each record lasts 6.5 steady stick-slip periods (the first, from rest, is longer),
sampled at 500 Hz (1 kHz for the stiffest spring), about 17 samples per slip, and is
simulated by the exact simulator. Run from the repository root:
    .venv/bin/python data/examples/make_campaign.py
It removes the campaign's old CSV files, writes the 12 new ones and truth.json (the
parameters, in kgf, mm, s).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from stickslip_jax import Slideway, critical_speed, lubricant, steady_state
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.records import write_record
from stickslip_jax.simulation.synthetic import friction_truth, synthetic_record
from stickslip_jax.units import from_mm_per_min

WEIGHT_KGF = 36.0
# (stiffness kgf/mm, sample rate Hz, drive speeds mm/min): speeds from about 4 % to
# 60 % of each spring's critical speed, so that the stick times span a factor ~40.
CONDITIONS = (
    (27.3, 500.0, (5.0, 12.0, 30.0, 75.0)),
    (86.9, 500.0, (2.0, 5.0, 12.0, 30.0)),
    (128.5, 1000.0, (1.5, 4.0, 9.0, 20.0)),
)
NOISE_MM = 0.5e-3
PERIODS = 6.5
HERE = Path(__file__).resolve().parent


def main():
    friction = lubricant("A")
    for old in HERE.glob("*.csv"):
        old.unlink()
    entries = []
    seed = 0
    W = WEIGHT_KGF
    for k, rate, speeds in CONDITIONS:
        sw = Slideway(friction, W, k)
        vc = float(critical_speed(friction, W, k))
        for v_min in speeds:
            v = from_mm_per_min(v_min)
            assert v < vc, (k, v_min)
            ss = steady_state(friction, W, k, v)
            assert bool(ss.stick_slip), (W, k, v_min)
            duration = float(np.ceil(PERIODS * float(ss.stick_time + ss.slip_time)))
            rec = synthetic_record(sw, ConstantSpeed(v), duration, rate,
                                   noise_std=NOISE_MM, seed=seed, lubricant="A",
                                   note=f"synthetic: lubricant A, W {W} kgf, k {k} kgf/mm, "
                                        f"v {v_min} mm/min")
            name = f"A_W{W:g}_k{k:g}_v{v_min:g}mm-min.csv"
            write_record(rec, HERE / name)
            entries.append({"file": name, "weight_kgf": W, "stiffness_kgf_mm": k,
                            "drive_speed_mm_s": v, "drive_speed_mm_min": v_min,
                            "critical_speed_mm_min": vc * 60.0,
                            "duration_s": duration, "sample_rate_hz": rate,
                            "seed": seed, "cycles": rec.truth["cycles"],
                            "steady_amplitude_mm": float(ss.amplitude),
                            "steady_stick_time_s": float(ss.stick_time),
                            "slip_time_s": float(np.pi * np.sqrt(W / (9806.65 * k)))})
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
