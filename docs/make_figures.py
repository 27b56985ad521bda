"""Regenerate the committed figures of the README and the documentation site in
`docs/images/`, each drawn by the command it illustrates (`--plot`):

| file | command |
|---|---|
| `fit.png` | `stickslip fit data/examples/*.csv` (the shipped campaign: the fit overlay) |
| `mcmc_corner.png` | `stickslip mcmc data/examples/*.csv` (all 12 records, 32 walkers x 5000 steps), at 80 dpi |
| `design_map.png` | `stickslip design` over k x v (lubricant A, W = 36 kgf) |
| `discover.png` | `stickslip discover` on a small campaign with viscous damping |
| `record.png` | `stickslip plot` of one shipped record |
| `pitch.png` | `stickslip pitch --fit` on two synthetic records with tilt channels |
| `fit_batch.png` | `stickslip fit-batch` of the shipped campaign, whole and per spring |

Each figure gets a caption strip at its foot saying what data made it (`CAPTIONS`) and on
which machine (CPU model, cores, date, jax version and backend); the pixels above it are
the command's own. The script first prints the machine, then the time and size of each
figure.

    .venv/bin/python docs/make_figures.py [NAME ...]   # all, or only these (fit, design, ...)
"""

from __future__ import annotations

import contextlib
import io
import os
import pathlib
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"
EXAMPLES = sorted(str(p) for p in (ROOT / "data" / "examples").glob("*.csv"))

MCMC_WALKERS, MCMC_STEPS = 32, 5000
"""The corner figure's chain: 3750 steps after burn-in, about 60 autocorrelation times
(tau is 55-60 steps on the shipped campaign), where `stickslip mcmc` asks for 50."""

CAPTIONS = {
    "fit": "Data: the 12 shipped records of data/examples (synthetic, lubricant A, W = 36 "
           "kgf, k = 27.3/86.9/128.5 kgf/mm, 1.5-75 mm/min, 0.5 um noise).",
    "mcmc_corner": f"Data: all 12 records of data/examples (synthetic; red lines: the truth "
                   f"of data/examples/truth.json); emcee, {MCMC_WALKERS} walkers x "
                   f"{MCMC_STEPS} steps, burn-in {MCMC_STEPS // 4}.",
    "design_map": "No data: lubricant A's friction parameters (paper, Table 6), W = 36 kgf, "
                  "a 40 x 40 grid of k x v, steady analysis.",
    "discover": "Data: 4 synthetic records of lubricant A with viscous damping (ratio 0.15), "
                "which the paper's model lacks (tests/independent_records.py).",
    "record": "Data: data/examples/A_W36_k86.9_v5mm-min.csv (synthetic, lubricant A).",
    "pitch": "Data: 2 synthetic records of the chapter-6 tilt model, drive points (20, 30) "
             "and (60, -30) mm, 2e-5 mm noise; measured channels pitch_1 and pitch_3 only.",
    "fit_batch": "Data: data/examples as one campaign and split by spring (k = 27.3, 86.9, "
                 "128.5 kgf/mm).",
}
"""The caption strip of each figure: what data made it."""


def machine() -> str:
    """One line: CPU model, cores (usable / present), date (UTC), jax version and backend."""
    import datetime
    import platform

    import jax

    cpu = platform.processor() or platform.machine()
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return (f"machine: {cpu}, {usable} of {os.cpu_count()} cores usable, {date}, "
            f"jax {jax.__version__} ({jax.default_backend()}), {platform.system()} "
            f"{platform.release()}, Python {platform.python_version()}")


def png_dpi(path: pathlib.Path) -> int:
    """The PNG's resolution as saved (its pHYs chunk); 100 when it has none."""
    from PIL import Image

    with Image.open(path) as im:
        return int(round(im.info.get("dpi", (100, 100))[0]))


def add_caption(path: pathlib.Path, text: str) -> None:
    """Append a caption strip with `text` (one or more lines) below the PNG at `path`; the
    pixels above are copied unchanged (`figimage` at the PNG's own size and resolution),
    then the whole stored with a 256-colour palette (`compact`)."""
    import matplotlib.image as mpimg
    from matplotlib.figure import Figure

    dpi = png_dpi(path)
    img = mpimg.imread(str(path))
    h, w = img.shape[:2]
    strip = int(round((0.15 + 0.15 * (text.count("\n") + 1)) * dpi))  # 8-point lines, margins
    fig = Figure(figsize=(w / dpi, (h + strip) / dpi), dpi=dpi, facecolor="white")
    fig.figimage(img, 0, strip, origin="upper")
    fig.text(0.01, 0.5 * strip / (h + strip), text, fontsize=8, va="center", ha="left",
             style="italic")
    buffer = io.BytesIO()
    fig.savefig(buffer, dpi=dpi, format="png")
    compact(buffer, path, dpi)


def compact(png, path: pathlib.Path, dpi: int) -> None:
    """Write the PNG `png` (a path or file object) to `path` with a 256-colour palette
    (median cut): line figures look the same at a third of the bytes (the docs keep each
    figure under 400 KiB). Written to a temporary file beside `path`, then renamed."""
    from PIL import Image

    with Image.open(png) as im:
        small = im.convert("RGB").quantize(256, method=Image.Quantize.MEDIANCUT)
    tmp = path.with_name(path.name + ".tmp")
    small.save(tmp, format="PNG", optimize=True, dpi=(dpi, dpi))
    os.replace(tmp, path)


def _discovery_campaign(folder: pathlib.Path) -> list[str]:
    """Four records of lubricant A (W, k = 36 kgf, 86.9 kgf/mm and 20 kgf, 27.3 kgf/mm at
    5 and 10 mm/min) with viscous damping the paper's model lacks (damping ratio 0.15),
    made by the tests' independent SciPy generator (`tests/independent_records.py`, the
    campaign of `tests/test_cycle_discovery.py`, where discovery names the damping)."""
    sys.path.insert(0, str(ROOT / "tests"))
    import independent_records as ir
    from stickslip_jax.records import write_record

    records = ir.campaign(physics=ir.Physics(damping_ratio=0.15), seed=12,
                          runs=((36.0, 86.9), (20.0, 27.3)), speeds=(5.0, 10.0), cycles=5.0)
    paths = []
    for i, r in enumerate(records):
        paths.append(str(folder / f"damped{i}.csv"))
        write_record(r, paths[-1])
    return paths


def _corner(tmp: pathlib.Path, out: pathlib.Path) -> None:
    """`stickslip mcmc`'s corner plot (`stickslip_fitting.report.plots.corner_plot`, the
    function behind `mcmc --plot`) from the run's JSON draws, without the scatter of
    single draws and at 80 dpi: the command's 100 dpi figure is a 0.5 MB file."""
    import json

    import numpy as np

    from stickslip_fitting.report.plots import corner_plot
    from stickslip_jax.output import save_figure

    doc = json.loads((tmp / "mcmc.json").read_text())
    rows = doc["parameters"]
    fig = corner_plot(np.asarray(doc["samples"]), doc["names"], plot_datapoints=False,
                      truth={n: r["truth"] for n, r in rows.items() if r.get("truth") is not None},
                      units={n: r["unit"] for n, r in rows.items()})
    save_figure(fig, str(out), dpi=80)


def pitch_records(folder: pathlib.Path, stem: str = "pitch") -> list[str]:
    """Two records with tilt channels pitch_1, pitch_3 from the chapter-6 model (2e-5 mm
    noise), driven at (h, l) = (20, 30) and (60, -30) mm; files STEM0.csv, STEM1.csv in
    `folder` (also used by tests/test_json_keys.py)."""
    import numpy as np

    from stickslip_jax import pitching as pt
    from stickslip_jax.records import Record, write_record

    t = np.arange(601) * 0.02
    phase = (t % 2.0) / 2.0
    force = np.where(phase < 0.95, 5.0 + 7.0 * phase / 0.95, 12.0 - 7.0 * (phase - 0.95) / 0.05)
    model = pt.default_model()
    paths = []
    for i, (h, o) in enumerate([(20.0, 30.0), (60.0, -30.0)]):
        disp = np.asarray(pt.tilt_history(model, t, force, pt.DrivePoint(h, o)).displacement)
        disp = disp + 2e-5 * np.random.default_rng(i).standard_normal(disp.shape)
        rec = Record(time=t, deflection=force / 86.9, stiffness=86.9, weight=36.0,
                     drive_speed=0.05, channels={"pitch_1": disp[:, 0], "pitch_3": disp[:, 2]},
                     channel_units={"pitch_1": "um", "pitch_3": "um"},
                     extra_header={"drive_height": f"{h} mm", "drive_offset": f"{o} mm"})
        paths.append(str(write_record(rec, folder / f"{stem}{i}.csv", channel_units="original")))
    return paths


def figures(tmp: pathlib.Path) -> dict[str, list[str]]:
    """{name: the stickslip command line that draws docs/images/NAME.png}."""
    return {
        "fit": lambda: ["fit", *EXAMPLES],
        "mcmc_corner": lambda: ["mcmc", *EXAMPLES, "--steps", str(MCMC_STEPS),
                                "--walkers", str(MCMC_WALKERS), "--seed", "1",
                                "--draws", "8000", "--json", str(tmp / "mcmc.json")],
        "design_map": lambda: ["design", "--lubricant", "A", "--weight", "36",
                               "--stiffness", "20:200:40", "--speed", "0.5:200:40:log"],
        "discover": lambda: ["discover", *_discovery_campaign(tmp)],
        "record": lambda: ["plot", str(ROOT / "data/examples/A_W36_k86.9_v5mm-min.csv")],
        "pitch": lambda: ["pitch", *pitch_records(tmp), "--fit"],
        "fit_batch": lambda: ["fit-batch", str(ROOT / "data/examples"),
                              *(str(ROOT / f"data/examples/A_W36_k{k}_*.csv")
                                for k in ("27.3", "86.9", "128.5"))],
    }


def main(argv=None) -> int:
    os.environ.setdefault("MPLBACKEND", "Agg")
    from stickslip_jax.cli import main as stickslip

    only = list(sys.argv[1:] if argv is None else argv)
    IMAGES.mkdir(parents=True, exist_ok=True)
    print(machine(), flush=True)
    total = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        todo = figures(pathlib.Path(tmp))
        unknown = set(only) - set(todo)
        if unknown:
            raise SystemExit(f"unknown figure(s) {sorted(unknown)}; choose from {sorted(todo)}")
        for name, argv_of in todo.items():
            if only and name not in only:
                continue
            t0 = time.perf_counter()
            out = IMAGES / f"{name}.png"
            argv = argv_of()
            quiet = ["--quiet"] if argv[0] in ("fit", "mcmc", "design", "discover",
                                               "fit-batch") else []
            plot = [] if name == "mcmc_corner" else ["--plot", str(out)]
            with contextlib.redirect_stdout(io.StringIO()):
                rc = stickslip([*argv, *quiet, *plot])
            if rc != 0:
                raise SystemExit(f"{name}: stickslip exited {rc}")
            if name == "mcmc_corner":
                _corner(pathlib.Path(tmp), out)
            add_caption(out, f"{CAPTIONS[name]}\nDrawn by docs/make_figures.py; {machine()}.")
            print(f"{name}: {time.perf_counter() - t0:.1f} s, {out.stat().st_size / 1024:.0f} KiB",
                  flush=True)
    print(f"all: {time.perf_counter() - total:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
