"""Convert the measured paper-on-paper stick-slip records of Colas, Pustelnik et al.
(repository npusteln/stickslip, commit 84acb9815970600307a3edb4758b1594fb7f2e1c,
`data_raw/k{168,1002,2254}Nm_v42.mat`, licence CeCILL-B, see LICENSE-CeCILL-B.txt and
README.md here) into the stickslip record format.

The source files hold `t` (s, sampled at 2 kHz) and `Fnorm` = F/(m g), the spring force
on the slider over its weight (the authors' ex1.m: "normalized force applied on the
slider", plotted as F/mg [-]); slider mass m = 30.7 g (ex1.m), drive speed
V = 42 um/s, spring stiffness k in the file name (N/m). Written here: `force [N]` =
Fnorm * m * g with g = 9.80665 m/s^2, time from the window's first sample (the
original start time is in the note), nothing else changed (no filtering: the
impulsive noise and the quantisation are part of the test).

Usage: python data/real/convert_npusteln.py SOURCE_DIR [OUT_DIR]
SOURCE_DIR holds the three .mat files (e.g. data_raw/ of a checkout of the source
repository at the commit above); OUT_DIR defaults to this folder.
"""

from __future__ import annotations

import os
import sys

import numpy as np
from scipy.io import loadmat

MASS_KG = 30.7e-3
G = 9.80665
SPEED_UM_S = 42.0
WINDOWS = {  # stiffness N/m -> (start s after the record's first sample, duration s)
    168: (0.0, 60.0),
    1002: (0.0, 30.0),
    2254: (0.0, 10.0),
}
CITATION = ("J. Colas, N. Pustelnik, C. Oliver, P. Abry, J.-C. Geminard, V. Vidal, "
            "Nonlinear denoising for solid friction dynamics characterization, "
            "Physical Review E (2019; accepted, as the source's README cites it)")


def convert(source_dir: str, out_dir: str) -> list[str]:
    written = []
    for k, (start, duration) in WINDOWS.items():
        src = os.path.join(source_dir, f"k{k}Nm_v42.mat")
        mat = loadmat(src)
        t = np.asarray(mat["t"], float).ravel()
        f_norm = np.asarray(mat["Fnorm"], float).ravel()
        sel = (t >= t[0] + start) & (t < t[0] + start + duration)
        t0 = float(t[sel][0])
        time = np.round(t[sel] - t0, 6)
        force = f_norm[sel] * MASS_KG * G
        lines = [
            "# stickslip-record: 1",
            f"# stiffness: {k} N/m",
            f"# slider_mass: {MASS_KG} kg",
            f"# drive_speed: {SPEED_UM_S} um/s",
            "# lubricant: none (paper on paper, dry)",
            f"# note: measured by Colas et al. (ENS de Lyon), npusteln/stickslip "
            f"data_raw/k{k}Nm_v42.mat from t = {t0:.4f} s; licence CeCILL-B; cite: {CITATION}",
            "time [s],force [N]",
        ]
        body = "\n".join(f"{a:.4f},{b!r}" for a, b in zip(time.tolist(), force.tolist()))
        out = os.path.join(out_dir, f"paper_k{k}Nm_v42um-s.csv")
        with open(out, "w", encoding="utf-8") as fh:
            fh.write("\n".join(lines) + "\n" + body + "\n")
        written.append(out)
    return written


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    here = os.path.dirname(os.path.abspath(__file__))
    for path in convert(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else here):
        print("wrote", path)
