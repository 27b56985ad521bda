r"""One call for a design map: `stickslip_fitting.design_map(weight, stiffness, speed, ...)`
-> `DesignStudy`, the map of `stickslip design` (`MapOptions`, `map_study`).

```python
import stickslip_fitting as sf

study = sf.design_map("36", "20:200:40", "0.5:200:40:log")  # W kgf, k kgf/mm, v mm/min
print(study)                    # the summary `stickslip design` prints
print(study.summary())          # pandas DataFrame, one row per grid point
study.plot("map.png")           # the figure of `stickslip design --plot`
study.to_json("map.json")       # the document of `stickslip design --json`
```

Each axis is a string as the command reads it (``"0.5:200:40:log um/s"``; default units
kgf, kgf/mm, mm/min) or numbers in the package's units (kgf, kgf/mm, mm/s)."""

from __future__ import annotations

import dataclasses
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..modes import MapMethod
from .results import ResultDocument, pandas_module

if TYPE_CHECKING:
    import pandas
    from matplotlib.figure import Figure

__all__ = ["DesignStudy", "JSON_ALIASES", "MapOptions", "design_map",
           "figure_axes", "map_study", "parse_grid"]

DIMENSIONS = {"weight": ("force", "kgf"), "stiffness": ("stiffness", "kgf/mm"),
              "speed": ("speed", "mm/min")}
AXES = tuple(DIMENSIONS)
LABELS = {"weight": "W [kgf]", "stiffness": "k [kgf/mm]", "speed": "v [mm/min]"}
SCALE = {"weight": 1.0, "stiffness": 1.0, "speed": 60.0}  # internal units -> the labels'
_METHOD_TITLE = {"steady": "steady analysis", "exact": "exact simulator",
                 "cycle": "time-domain limit cycle"}

POSTERIOR_RATE = 2.7e6
"""Steady analyses a second of a posterior map (grid points x draws), measured on a
2-core machine (41^3 points x 400 draws: 10.3 s, compilation included)."""

POSTERIOR_WARN = 3e8
"""Grid points x draws above which a posterior map warns before it starts (about
2 minutes at `POSTERIOR_RATE`)."""

# Peak memory a grid point, measured with /usr/bin/time on 1.25e5-8e6 points (2-200 draws):
# 70-90 bytes for the map, 1,570 for --json (700 without a posterior), 260 for --csv, 80
# for --netcdf; 59 a point and draw for --max-amplitude (every draw's limit cycle).
_BYTES_PER_POINT = {"map": 128, "--json": 1_600, "--csv": 300, "--netcdf": 100}
_BYTES_PER_POINT_DRAW = 64  # --max-amplitude

JSON_ALIASES = {"stiffness_kgf_per_mm": "stiffness_kgf_mm",
                "drive_speed_mm_per_min": "speed_mm_min",
                "critical_speed_mm_per_min": "critical_speed_mm_min",
                "critical_speed_band_mm_per_min": "critical_speed_band_mm_min"}
"""JSON keys renamed to the one convention (`stickslip_jax.output.UNIT_SUFFIXES`) ->
their old names, still written beside them for one release (`deprecated_keys`); the CSV
columns (`design.netcdf.VARIABLES`) have the new names only."""


def parse_grid(text, dimension: str, default_unit: str, arg: str) -> np.ndarray:
    """``"36"``, ``"10:60:50"``, ``"0.01:50:30:log"``, each optionally followed by a unit
    (``"0.5:20:10 um/s"``) -> 1-D array in internal units (linear or log spacing); numbers
    (not text) are taken in internal units. Values must be finite and positive."""
    from stickslip_jax.units import UnitError, parse_quantity

    if not isinstance(text, str):
        return _positive(text, arg, text)
    text = text.strip()
    parts = text.split(None, 1)
    spec, unit = parts[0], (parts[1] if len(parts) > 1 else default_unit)
    fields = spec.split(":")
    try:
        if len(fields) == 1:
            values = [parse_quantity(f"{fields[0]} {unit}", dimension)]
        elif len(fields) in (3, 4):
            if len(fields) == 4 and fields[3] not in ("lin", "log"):
                raise ValueError(f"spacing must be 'lin' or 'log', got {fields[3]!r}")
            count = int(fields[2])
            if count < 1:
                raise ValueError("count must be >= 1")
            lo, hi = (parse_quantity(f"{f} {unit}", dimension) for f in fields[:2])
            if len(fields) == 4 and fields[3] == "log":
                if lo <= 0 or hi <= 0:
                    raise ValueError("a log grid needs positive ends")
                values = np.geomspace(lo, hi, count)
            else:
                values = np.linspace(lo, hi, count)
        else:
            raise ValueError("use VALUE or START:STOP:COUNT[:log] with an optional unit")
    except (UnitError, ValueError) as exc:
        raise ValueError(f"{arg}: cannot read {text!r} ({exc}); "
                         f"e.g. '10:60:50' or '0.1:100:30:log {default_unit}'") from None
    return _positive(values, arg, text)


def _positive(values, arg, text) -> np.ndarray:
    values = np.atleast_1d(np.asarray(values, dtype=float))
    if values.ndim != 1 or not np.all(np.isfinite(values) & (values > 0)):
        raise ValueError(f"{arg}: values must be finite and positive, got {text!r}")
    return values


@dataclasses.dataclass(frozen=True)
class MapOptions:
    """What a design map computes: the options of `stickslip design`, the keywords of
    `design_map`. `weight`, `stiffness`, `speed`: the grid axes (module doc); `lubricant`,
    `table`: Table 6 (4, 9) of the paper, or `posterior`: a file of draws (`stickslip
    mcmc --json`) or a `CampaignPosterior`, giving P(stick-slip) and credible bands at
    `level` (0.9); `method`: a `MapMethod` (`damping_ratio` zeta with cycle);
    `max_amplitude` (mm): the design to a tolerance, met with probability `meet` (0.95);
    `chunk_size` points a device batch; `progress` a bar; `outputs`: the command's outputs
    the memory check sizes; `normal_load` N (kgf or a string with its unit; None: N = W):
    the map at (W, k, v) is then the paper's at v W/N with lengths and speeds times N/W.
    """

    weight: object
    stiffness: object
    speed: object
    lubricant: str = "A"
    table: int = 6
    posterior: object = None
    level: float | None = None
    method: MapMethod | str = MapMethod.STEADY
    damping_ratio: float | None = None
    max_amplitude: float | None = None
    meet: float | None = None
    chunk_size: int = 65_536
    progress: bool = False
    outputs: tuple[str, ...] = ()
    normal_load: object = None

    def load(self) -> float | None:
        """N in kgf (`normal_load` read with its unit), or None."""
        if self.normal_load is None:
            return None
        values = parse_grid(self.normal_load, "force", "kgf", "--normal-load")
        if values.size != 1:
            raise ValueError(f"--normal-load: one value, got {self.normal_load!r}")
        return float(values[0])

    def __post_init__(self):
        object.__setattr__(self, "method", MapMethod.parse(self.method))

    def axes(self) -> dict[str, np.ndarray]:
        """{axis: 1-D values in internal units (kgf, kgf/mm, mm/s)}."""
        return {name: parse_grid(getattr(self, name), dim, unit, f"--{name}")
                for name, (dim, unit) in DIMENSIONS.items()}

    @property
    def source(self) -> str:
        """The friction parameters in words: the posterior's file or the lubricant."""
        if self.posterior is None:
            return f"lubricant {self.lubricant} (Table {self.table})"
        if isinstance(self.posterior, (str, os.PathLike)):
            return f"posterior {Path(self.posterior).name}"
        return "posterior sample"

    def check(self) -> None:
        """ValueError naming the option and the fix for an option out of range or one
        that cannot act (before any work)."""
        from stickslip_jax.lubricants import lubricants

        if self.lubricant not in lubricants(self.table):
            raise ValueError(f"--lubricant: unknown lubricant {self.lubricant!r}; "
                             f"Table {self.table} has {', '.join(lubricants(self.table))}")
        if self.chunk_size < 1:
            raise ValueError("--chunk-size: must be >= 1")
        _unused_or_in_range("--level", self.level, "--posterior FILE", self.posterior, "0.9")
        _unused_or_in_range("--meet", self.meet, "--max-amplitude AMP", self.max_amplitude,
                            "0.95")
        if self.load() is not None and self.max_amplitude is not None:
            raise ValueError("--normal-load: not with --max-amplitude (the design to a "
                             "tolerance holds N = W); leave one of them out")
        if self.max_amplitude is not None and not self.max_amplitude > 0:
            raise ValueError(f"--max-amplitude: must be positive, got {self.max_amplitude}")
        if self.damping_ratio is not None:
            if self.method is not MapMethod.CYCLE or self.posterior is not None:
                raise ValueError("--damping-ratio: only with --method cycle (and no "
                                 "--posterior)")
            if not 0 <= self.damping_ratio < 1:
                raise ValueError(f"--damping-ratio: must lie in [0, 1), e.g. 0.05, got "
                                 f"{self.damping_ratio}")
        if self.posterior is not None:
            if self.method is not MapMethod.STEADY:
                raise ValueError(f"--method {self.method}: not available with --posterior "
                                 "(steady analysis only)")
            if _is_path(self.posterior) and not Path(self.posterior).exists():
                raise ValueError(f"--posterior: no such file {str(self.posterior)!r}")

    def sample(self):
        """The friction parameters as a `Friction` with leaves of shape (S,): the
        posterior's draws, or the lubricant's one set."""
        import jax

        from ..design import load_samples, samples_from_json

        if self.posterior is None:
            from stickslip_jax.lubricants import lubricant

            return jax.tree_util.tree_map(lambda x: np.asarray(x, float)[None],
                                          lubricant(self.lubricant, table=self.table))
        if _is_path(self.posterior):
            return load_samples(self.posterior)
        return samples_from_json(self.posterior.report, "posterior")


def _is_path(x) -> bool:
    return isinstance(x, (str, os.PathLike))


def _unused_or_in_range(option, value, needs, given, example) -> None:
    """A probability option: in (0, 1), and refused without the option it acts with."""
    if value is None:
        return
    if not 0 < value < 1:
        raise ValueError(f"{option}: must lie between 0 and 1, e.g. {example}, got {value}")
    if given is None:
        raise ValueError(f"{option}: acts only with {needs.split()[0]}; give {needs} or leave "
                         f"{option} out")


def _say_map(shape, how) -> None:
    """The stage line of the map (the `stickslip` logger: silent unless configured)."""
    from stickslip_jax.logs import logger

    n = int(np.prod(shape))
    logger.info(f"map of {' x '.join(map(str, shape))} = {n} point{'s' * (n != 1)} ({how})...")


def _say_posterior_work(shape, draws) -> None:
    """The stage line of a posterior map: its points x draws steady analyses, and a warning
    with the expected time and how to shorten it when they are many."""
    from stickslip_jax.logs import logger

    n = int(np.prod(shape))
    work = float(n) * draws
    _say_map(shape, f"steady analysis over {draws} posterior draw{'s' * (draws != 1)}: "
             f"{work:.3g} analyses")
    if work > POSTERIOR_WARN:
        logger.warning(
            f"--posterior: {n} points x {draws} draws = {work:.3g} steady analyses, about "
            f"{work / POSTERIOR_RATE / 60:.0f} min at {POSTERIOR_RATE:.2g} a second (2 cores); "
            "thin the --posterior file or use fewer grid points to shorten it")


def _check_memory(options: MapOptions, shape, draws: int) -> None:
    """Refuse (one line: the size and how to reduce it) a map whose estimated peak memory,
    the grid's points times what each output needs plus points x draws for
    --max-amplitude, is more than half this machine's."""
    from stickslip_jax.output import check_memory

    n_points = float(np.prod(shape, dtype=float))
    outputs = [o for o in ("--json", "--csv", "--netcdf") if o in options.outputs]
    n_bytes = n_points * (_BYTES_PER_POINT["map"] + sum(_BYTES_PER_POINT[o] for o in outputs))
    what = f"the grid of {' x '.join(map(str, shape))} = {n_points:.3g} points"
    tolerance = options.max_amplitude is not None
    if tolerance:
        n_bytes += n_points * draws * _BYTES_PER_POINT_DRAW
        what += f" x {draws} draw{'s' * (draws != 1)} (--max-amplitude)"
    if outputs:
        what += f" with {', '.join(outputs)}"
    advice = "use fewer grid points"
    if tolerance and draws > 1:
        advice += " or fewer draws (thin the --posterior file)"
    heavy = [o for o in outputs if o != "--netcdf"]
    if heavy:
        advice += (f", or write --netcdf instead of {' and '.join(heavy)} (about "
                   f"{_BYTES_PER_POINT['--netcdf']} bytes a point instead of "
                   f"{sum(_BYTES_PER_POINT[o] for o in heavy):,})")
    check_memory(what, "--weight/--stiffness/--speed", n_bytes, advice=advice)


def map_study(options: MapOptions) -> DesignStudy:
    """The map of `options` (checked first; errors name the command's options)."""
    from stickslip_jax.logs import logger

    from ..design import design_map as map_of, outer, propagate
    from ..design.posterior import sample_size

    options.check()
    axes = options.axes()
    shape = tuple(axes[n].size for n in AXES)
    sample = options.sample()
    draws = sample_size(sample)
    _check_memory(options, shape, draws)
    w, k, v = outer(*(axes[n] for n in AXES))
    s = 1.0 if options.load() is None else options.load() / w  # N/W (`MapOptions`)
    v = v / s
    maps: dict = {"axes": axes}
    if options.posterior is not None:
        _say_posterior_work(shape, draws)
        u = propagate(sample, w, k, v, level=options.level or 0.9,
                      chunk_size=options.chunk_size * 4, progress=options.progress)
        maps.update(probability=u.probability, critical_speed_band=u.critical_speed,
                    critical_speed=u.critical_speed[..., 1], amplitude=u.amplitude[..., 1],
                    amplitude_band=u.amplitude, stick_slip=u.probability >= 0.5)
    else:
        from stickslip_jax.lubricants import lubricant

        _say_map(shape, f"method {options.method}")
        m = map_of(lubricant(options.lubricant, table=options.table), w, k, v,
                   method=options.method, chunk_size=options.chunk_size,
                   progress=options.progress, damping_ratio=options.damping_ratio)
        maps.update({f: getattr(m, f) for f in (
            "amplitude", "amplitude_ratio", "frequency", "frequency_ratio", "stick_time",
            "critical_speed", "stick_slip", "converged", "regime")})
    for key in ("amplitude", "critical_speed", "amplitude_band", "critical_speed_band"):
        if key in maps and options.load() is not None:  # lengths and speeds times N/W
            maps[key] = maps[key] * np.reshape(s, np.shape(s) + (1,) * (maps[key].ndim - 3))
    logger.info("map done")
    if options.max_amplitude is not None:
        logger.info(f"design to a tolerance: {options.max_amplitude * 1e3:g} um...")
        maps["tolerance"] = _tolerance(options, axes, sample, (w, k, v))
    return DesignStudy(maps, options)


def _tolerance(options: MapOptions, axes, sample, grid) -> dict:
    """The meet probability on the grid and, per (W, v), the stiffness that meets the
    tolerance (`stickslip_fitting.design.tolerance`)."""
    from ..design.posterior import sample_size
    from ..design.tolerance import meet_probability, required_stiffness

    meet = 0.95 if options.meet is None else options.meet
    prob = meet_probability(sample, *grid, options.max_amplitude)
    rows = []
    for wi in axes["weight"]:
        for vi in axes["speed"]:
            d = required_stiffness(sample, wi, vi, options.max_amplitude, meet=meet,
                                   start=float(np.median(axes["stiffness"])))
            rows.append({"weight_kgf": d.weight, "drive_speed_mm_per_min": d.speed * 60.0,
                         "stiffness_kgf_per_mm": d.stiffness if d.converged else None,
                         "probability": d.probability, "converged": d.converged})
    return {"max_amplitude_mm": float(options.max_amplitude), "meet": meet,
            "draws": sample_size(sample),
            "amplitude": "time-domain limit cycle (stickslip_jax.limit_cycle)",
            "probability_met": prob.tolist(), "required_stiffness": rows}


def figure_axes(axes: dict, option: str = "plot") -> list[str]:
    """The grid axes a figure shows (one or two); a ValueError naming the figure's option
    otherwise (the command checks it before the map is computed)."""
    grid = [n for n in AXES if axes[n].size > 1]
    if len(grid) == 0 or len(grid) > 2:
        raise ValueError(f"{option}: a figure needs one or two of --weight/--stiffness/--speed "
                         f"as START:STOP:COUNT grids, got {len(grid)}")
    return grid


@dataclasses.dataclass(frozen=True)
class DesignStudy(ResultDocument):
    """The result of `design_map`: stick-slip amplitude and critical speed over W, k, v.
    `summary()` (pandas, the `--csv` columns), `plot(path)`, `to_json(path)` /
    `to_dict()`, `to_csv(path)`, `to_netcdf(path)`: the outputs of `stickslip design`;
    `str(result)`: the summary it prints. `maps`: {"axes": {axis: values}, quantity: array
    [weight][stiffness][speed] in internal units, "tolerance": the design to a
    tolerance}; `options`: the `MapOptions` it was made with.
    """

    maps: dict
    options: MapOptions
    JSON_ALIASES = JSON_ALIASES
    JSON_INDENT = None

    @property
    def inputs(self) -> tuple[str, ...]:
        """The files read (an output may not overwrite one of them)."""
        p = self.options.posterior
        return (os.fspath(p),) if _is_path(p) else ()

    @property
    def report(self) -> dict:
        """The `--json` document before versioning (internal arrays in the units its keys
        name)."""
        from ..design.netcdf import BANDS, VARIABLES

        o, res = self.options, self.maps
        axes = res["axes"]
        doc = {"source": ({"posterior": os.fspath(o.posterior)} if _is_path(o.posterior)
                          else {"posterior": o.source} if o.posterior is not None
                          else {"lubricant": o.lubricant, "table": o.table}),
               "method": o.method.value,
               **({} if o.load() is None else {"normal_load_kgf": o.load()}),
               **({"damping_ratio": o.damping_ratio} if o.damping_ratio is not None else {}),
               "axes": {"weight_kgf": axes["weight"].tolist(),
                        "stiffness_kgf_per_mm": axes["stiffness"].tolist(),
                        "drive_speed_mm_per_min": (axes["speed"] * 60.0).tolist()},
               "shape": list(res["amplitude"].shape),
               "index_order": list(AXES),
               **({} if o.posterior is None else {"level": o.level or 0.9})}
        for key, _, factor, _, _, name in VARIABLES + BANDS:  # the quantities the map has
            if key in res:
                x = np.asarray(res[key])
                doc[name] = (x if x.dtype == bool else x * factor).tolist()
        if "regime" in res:
            from stickslip_jax.steady import REGIMES

            doc["regime"] = np.asarray(res["regime"]).tolist()
            doc["regimes"] = list(REGIMES)  # the names of the codes in "regime"
        if "tolerance" in res:
            doc["tolerance"] = res["tolerance"]
        return doc

    def _columns(self) -> dict[str, np.ndarray]:
        """The long-format columns: the axes, every quantity the map has
        (`design.netcdf.VARIABLES`), `regime` by name, with a tolerance `probability_met`."""
        from stickslip_jax.steady import REGIMES

        from ..design import outer
        from ..design.netcdf import VARIABLES

        res = self.maps
        axes = res["axes"]
        w, k, v = (np.broadcast_to(a, res["amplitude"].shape).ravel()
                   for a in outer(*(axes[n] for n in AXES)))
        cols = {"weight_kgf": w, "stiffness_kgf_per_mm": k, "drive_speed_mm_per_min": v * 60.0}
        for key, _, factor, _, _, name in VARIABLES:
            if key in res:
                x = np.asarray(res[key]).ravel()
                cols[name] = x.astype(int) if factor == 1 and x.dtype == bool else x * factor
        if "regime" in res:
            cols["regime"] = np.asarray([REGIMES[int(r)] for r in np.ravel(res["regime"])])
        if "tolerance" in res:
            cols["probability_met"] = np.ravel(res["tolerance"]["probability_met"])
        return cols

    def summary(self) -> pandas.DataFrame:
        """One row per grid point: the `--csv` columns. Needs pandas."""
        pd = pandas_module("DesignStudy.summary()")
        return pd.DataFrame(self._columns())

    def to_csv(self, path: str | os.PathLike[str] | None = None) -> str:
        """The map as long-format CSV text (the `summary()` columns); written to `path`
        too when given."""
        cols = self._columns()
        lines = [",".join(cols)]
        for i in range(len(cols["weight_kgf"])):
            lines.append(",".join(str(c[i]) if isinstance(c[i], str) else f"{c[i]:.10g}"
                                  for c in cols.values()))
        text, path = "\n".join(lines) + "\n", self.output_path(path, "to_csv")
        if path is not None:
            from stickslip_jax.output import write_text

            write_text(path, text)
        return text

    def to_netcdf(self, path: str | os.PathLike[str]) -> None:
        """The map as NetCDF (`design.netcdf.map_dataset`; needs xarray, the `[netcdf]`
        extra)."""
        from ..design.netcdf import map_dataset, write_netcdf

        write_netcdf(self.output_path(path, "to_netcdf"), map_dataset(self.maps, {
            "method": self.options.method.value, "source": self.options.source,
            "damping_ratio": self.options.damping_ratio}))

    def plot(self, path: str | os.PathLike[str] | None = None) -> Figure:
        """Amplitude and v_c maps (two grid axes) or curves (one), P(stick-slip) for a
        posterior, the boundary dashed; returned, and saved to `path` when given."""
        import matplotlib.pyplot as plt

        from ..report.plots import finish_figure

        path = self.output_path(path, "plot")
        res, o = self.maps, self.options
        axes = res["axes"]
        grid = figure_axes(axes)
        squeeze = tuple(i for i, n in enumerate(AXES) if n not in grid)
        panels = [("amplitude", "amplitude a [mm]", 1.0), ("critical_speed", "v_c [mm/min]", 60.0)]
        if o.posterior is not None:
            panels.append(("probability", "P(stick-slip)", 1.0))
        fig, axs = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 4.2), squeeze=False)
        # A smooth field whose zero level is the stick-slip boundary.
        if o.posterior is not None:
            edge = res["probability"] - 0.5
        elif o.method is not MapMethod.STEADY:
            edge = res["stick_slip"].astype(float) - 0.5
        else:
            edge = np.log(res["critical_speed"] / np.broadcast_to(
                axes["speed"][None, None, :], res["critical_speed"].shape))
        edge = np.squeeze(edge, axis=squeeze)
        crosses = edge.min() < 0 < edge.max()
        # re-stick failure (double slips: eq (6)'s amplitude is not the motion's), hatched
        double = (np.squeeze(np.asarray(res["regime"]) == 2, axis=squeeze) if "regime" in res
                  else None)
        for ax, (key, label, s) in zip(axs[0], panels):
            z = np.squeeze(res[key], axis=squeeze) * s
            if len(grid) == 2:
                _map_panel(fig, ax, [axes[g] * SCALE[g] for g in grid], grid, z, label,
                           edge if crosses else None, double)
            else:
                _curve_panel(ax, axes[grid[0]] * SCALE[grid[0]], grid[0], z, label,
                             edge if crosses else None)
            ax.set_title(f"{label.split(' [')[0]}: {o.source}", fontsize=9)
        fixed = ", ".join(f"{LABELS[n].split(' ')[0]} = {float(axes[n][0]) * SCALE[n]:g} "
                          f"{LABELS[n].split(' ')[1][1:-1]}" for n in AXES if n not in grid)
        boundary = ("" if not crosses else "; dashed: stick-slip boundary"
                    + (" (P = 0.5)" if o.posterior is not None else
                       " (v = v_c)" if o.method is MapMethod.STEADY else ""))
        fig.suptitle(f"{_METHOD_TITLE[o.method.value]}{'; ' + fixed if fixed else ''}"
                     f"{boundary}", fontsize=10)
        fig.tight_layout()
        return finish_figure(fig, path, 120)

    def __str__(self) -> str:
        res = self.maps
        amp, vc, stick = res["amplitude"], res["critical_speed"] * 60.0, res["stick_slip"]
        lines = [f"design map {'x'.join(str(s) for s in amp.shape)} (W x k x v), "
                 f"{_METHOD_TITLE[self.options.method.value]}",
                 f"  stick-slip at {np.mean(stick) * 100:.1f} % of points",
                 f"  amplitude a: {amp.min():.4g} .. {amp.max():.4g} mm",
                 f"  critical speed v_c: {vc.min():.4g} .. {vc.max():.4g} mm/min"]
        if self.options.posterior is not None:
            p = res["probability"]
            lines.append(f"  P(stick-slip): {p.min():.3g} .. {p.max():.3g}")
        t = res.get("tolerance")
        if t is not None:
            lines += [f"tolerance: limit-cycle amplitude <= {t['max_amplitude_mm'] * 1e3:.4g} "
                      f"um with probability >= {t['meet']:g} ({t['draws']} draw(s)):",
                      f"  {'W [kgf]':>9} {'v [mm/min]':>11} {'k needed [kgf/mm]':>18} "
                      f"{'P met':>7}"]
            for row in t["required_stiffness"]:
                k = "not found" if not row["converged"] else f"{row['stiffness_kgf_per_mm']:.5g}"
                lines.append(f"  {row['weight_kgf']:9.4g} {row['drive_speed_mm_per_min']:11.4g} "
                             f"{k:>18} {row['probability']:7.3f}")
            ok = np.asarray(t["probability_met"]) >= t["meet"]
            lines.append(f"  grid points meeting it: {int(ok.sum())} of {ok.size}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        shape = "x".join(str(s) for s in self.maps["amplitude"].shape)
        o = self.options
        return f"DesignStudy({shape}, method={o.method.value!r}, {o.source})"


def _map_panel(fig, ax, xy, grid, z, label, edge, double) -> None:
    """A 2-D panel: the colour map, the boundary dashed, re-stick failure hatched."""
    y, x = xy
    mesh = ax.pcolormesh(x, y, z, shading="auto", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label=label)
    if edge is not None:  # dashed: the boundary v = v_c (or P = 0.5) between the regimes
        ax.contour(x, y, edge, levels=[0.0], colors="w", linewidths=1.5, linestyles="--")
    if double is not None and double.any():
        ax.contourf(x, y, double.astype(float), levels=[0.5, 1.5], colors="none",
                    hatches=["///"])
        ax.plot([], [], " ", label="/// re-stick failure (double slips)")
        ax.legend(loc="best", fontsize=7)
    ax.set_xlabel(LABELS[grid[1]])
    ax.set_ylabel(LABELS[grid[0]])
    if "speed" in grid:
        ax.set_xscale("log") if grid[1] == "speed" else ax.set_yscale("log")


def _curve_panel(ax, x, name, z, label, edge) -> None:
    """A 1-D panel: the curve and the boundary as a dashed vertical line."""
    ax.plot(x, z, "-")
    if edge is not None:
        i = int(np.argmax(np.sign(edge) != np.sign(edge[0])))
        # interpolate the zero crossing of the boundary field between samples
        f = edge[i - 1] / (edge[i - 1] - edge[i])
        xb = x[i - 1] * (x[i] / x[i - 1]) ** f if name == "speed" else \
            x[i - 1] + f * (x[i] - x[i - 1])
        ax.axvline(xb, color="k", ls="--", lw=1, label="stick-slip boundary")
        ax.legend()
    ax.set_xlabel(LABELS[name])
    ax.set_ylabel(label)
    if name == "speed":
        ax.set_xscale("log")


def design_map(weight, stiffness, speed, **options) -> DesignStudy:
    """Stick-slip amplitude and critical speed over a grid of W, k and v, as `stickslip
    design` computes them: each axis a string as the command reads it (``"36"``,
    ``"20:200:40"``, ``"0.5:200:40:log"``, a unit after a space; default units kgf,
    kgf/mm, mm/min) or numbers in kgf, kgf/mm, mm/s; `options` the keywords of
    `MapOptions`. Every mistake raises ValueError naming the keyword, before the map.
    """
    try:
        return map_study(MapOptions(weight, stiffness, speed, **options))
    except ValueError as err:  # the command's option names as the keywords
        raise ValueError(re.sub(r"--([a-z]+)-?([a-z]*)",
                                lambda m: "_".join(filter(None, m.groups())), str(err))
                         ) from None
