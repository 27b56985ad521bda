"""`stickslip design`: maps of stick-slip amplitude and critical speed over W, k and v."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..modes import MapMethod

NAME = "design"
HELP = ("design map of stick-slip amplitude and critical speed over grids of W, k, v "
        "(steady analysis, or the exact simulator with --exact; a posterior with --posterior)")

DIMENSIONS = {"weight": ("force", "kgf"), "stiffness": ("stiffness", "kgf/mm"),
              "speed": ("speed", "mm/min")}


def parse_grid(text: str, dimension: str, default_unit: str, arg: str) -> np.ndarray:
    """``"36"``, ``"10:60:50"``, ``"0.01:50:30:log"``, each optionally followed by a unit
    (``"0.5:20:10 um/s"``) -> 1-D array in internal units (linear or log spacing)."""
    from stickslip_jax.units import UnitError, parse_quantity

    text = str(text).strip()
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
            lo = parse_quantity(f"{fields[0]} {unit}", dimension)
            hi = parse_quantity(f"{fields[1]} {unit}", dimension)
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
    values = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(values) & (values > 0)):
        raise ValueError(f"{arg}: values must be finite and positive, got {text!r}")
    return values


_METHOD_TITLE = {"steady": "steady analysis", "exact": "exact simulator",
                 "cycle": "time-domain limit cycle"}


def _damping(args):
    """--damping-ratio, checked: None, or zeta in [0, 1) with --method cycle."""
    zeta = getattr(args, "damping_ratio", None)
    if zeta is None:
        return None
    if _method(args) is not MapMethod.CYCLE or args.posterior:
        raise ValueError("--damping-ratio: only with --method cycle (and no --posterior)")
    if not 0 <= zeta < 1:
        raise ValueError(f"--damping-ratio: must lie in [0, 1), e.g. 0.05, got {zeta}")
    return zeta


def _method(args) -> MapMethod:
    """The map's method: --method, or `exact` for the old --exact flag."""
    if args.exact and args.method not in (None, MapMethod.EXACT):
        raise ValueError(f"--exact and --method {args.method} disagree: give one of them")
    return MapMethod.EXACT if args.exact else MapMethod.parse(args.method or "steady")


def add_arguments(p):
    from stickslip_jax.commands.options import quantity

    p.add_argument("--lubricant", default="A", help="paper lubricant (Table 6: A, C)")
    p.add_argument("--table", type=int, default=6, choices=(4, 6, 9),
                   help="table of eq (1) parameters (default 6; 4 and 9 borrow delta, n of A)")
    p.add_argument("--weight", required=True,
                   help="slider weight W: VALUE or START:STOP:COUNT[:log] [unit] (default kgf)")
    p.add_argument("--stiffness", required=True,
                   help="drive stiffness k: VALUE or START:STOP:COUNT[:log] [unit] (default kgf/mm)")
    p.add_argument("--speed", required=True,
                   help="drive speed v: VALUE or START:STOP:COUNT[:log] [unit] (default mm/min)")
    p.add_argument("--posterior", metavar="FILE",
                   help="posterior sample (CSV/JSON with mu_s, mu_d, gamma, m, delta, n) to "
                        "propagate instead of the lubricant: probability of stick-slip, v_c band")
    p.add_argument("--level", type=float, default=0.9, help="credible level of the v_c band")
    p.add_argument("--method", choices=MapMethod.choices(), default=None,
                   help="steady: eqs (5)-(7) and (12) (default); exact: the exact simulator "
                   "run for 8 cycles; cycle: the time-domain limit cycle as the fixed point "
                   "of the one-cycle map (exact, at every speed, fast)")
    p.add_argument("--exact", action="store_true",
                   help="the same as --method exact (the old name)")
    p.add_argument("--max-amplitude", type=quantity("length", "mm"), default=None,
                   metavar="AMP",
                   help="design to a tolerance: the probability (over --posterior's draws, "
                   "or 0/1 for the lubricant) that the time-domain limit cycle's amplitude "
                   "stays at or below AMP (mm unless a unit is given, e.g. '1um') at every "
                   "grid point, and per (W, v) the stiffness that meets it with --meet")
    p.add_argument("--meet", type=float, default=0.95,
                   help="with --max-amplitude: the probability to meet (default 0.95)")
    from stickslip_jax.commands.options import add_json_option, add_plot_option

    add_plot_option(p, "the map figure", hidden=("--out",))
    add_json_option(p, "the map", bare=True)
    p.add_argument("--csv", metavar="OUT.csv",
                   help="write the map as a long-format CSV: one row per (W, k, v) point "
                   "with every quantity in its own column, units in the header (pandas, R, "
                   "spreadsheets read it as is)")
    p.add_argument("--netcdf", metavar="OUT.nc",
                   help="write the map as NetCDF (an xarray Dataset: dimensions W, k, v with "
                   "units, one variable per quantity; needs the [netcdf] extra, xarray)")
    p.add_argument("--damping-ratio", type=float, default=None, metavar="ZETA",
                   help="with --method cycle: viscous damping ratio zeta (0 <= zeta < 1) of "
                   "the slider's own mode; the damped limit cycle ends at a sharp boundary "
                   "(stickslip_jax.limit_cycle.boundary_speed)")
    p.add_argument("--chunk-size", type=int, default=65_536, help="points per device batch")
    from stickslip_jax.commands.options import add_quiet_option

    add_quiet_option(p)
    # a deprecated opt-in flag: the bar shows by default on a terminal; --progress shows it
    # off a terminal too
    p.add_argument("--progress", action="store_true", help=argparse.SUPPRESS)


def _progress(args) -> bool:
    """Progress bar on stderr: on a terminal unless --quiet; always with --progress."""
    import sys

    return not args.quiet and (args.progress or sys.stderr.isatty())


def _axes(args):
    axes = {}
    for name, (dim, unit) in DIMENSIONS.items():
        axes[name] = parse_grid(getattr(args, name), dim, unit, f"--{name}")
    return axes


def _say_map(shape, how) -> None:
    """The stage line of the map (the `stickslip` logger: stderr unless --quiet)."""
    from stickslip_jax.logs import logger

    n = int(np.prod(shape))
    logger.info(f"map of {' x '.join(map(str, shape))} = {n} point{'s' * (n != 1)} ({how})...")


POSTERIOR_RATE = 2.7e6
"""Steady analyses a second of `design --posterior` (grid points x draws), measured on a
2-core machine (41^3 points x 400 draws: 10.3 s, compilation included)."""

POSTERIOR_WARN = 3e8
"""Grid points x draws above which `design --posterior` warns before it starts (about
2 minutes at `POSTERIOR_RATE`)."""


def _draws(sample) -> int:
    """The number of draws of a posterior sample (a pytree of equal-length arrays)."""
    import jax

    return int(np.size(jax.tree_util.tree_leaves(sample)[0]))


def _say_posterior_work(shape, sample) -> None:
    """The stage line of a posterior map: its points x draws steady analyses, and a warning
    with the expected time and how to shorten it when they are many (the runtime grows as
    points x draws)."""
    from stickslip_jax.logs import logger

    draws = _draws(sample)
    n = int(np.prod(shape))
    work = float(n) * draws
    _say_map(shape, f"steady analysis over {draws} posterior draw{'s' * (draws != 1)}: "
             f"{work:.3g} analyses")
    if work > POSTERIOR_WARN:
        logger.warning(
            f"--posterior: {n} points x {draws} draws = {work:.3g} steady analyses, about "
            f"{work / POSTERIOR_RATE / 60:.0f} min at {POSTERIOR_RATE:.2g} a second (2 cores); "
            "thin the --posterior file or use fewer grid points to shorten it")


# Peak memory of a map, measured with /usr/bin/time on 1.25e5-8e6 point grids (design
# --posterior, 2-200 draws): about 70-90 bytes a grid point for the map itself, plus
# 1,570 a point for --json (Python lists of every array, then the text; 700 without
# --posterior), 260 for --csv, 80 for --netcdf, and 59 a point and draw for
# --max-amplitude (its meet probability holds every draw's limit cycle at every point).
# A 300^3 grid with 2 draws and --json had reached 6.8 GB when it was stopped.
_BYTES_PER_POINT = {"map": 128, "--json": 1_600, "--csv": 300, "--netcdf": 100}
_BYTES_PER_POINT_DRAW = 64  # --max-amplitude


def _check_memory(args, shape, sample) -> None:
    """Refuse (one line: the size and how to reduce it) a map whose estimated peak memory,
    the grid's points times what each output needs plus points x draws for
    --max-amplitude, is more than half this machine's."""
    from stickslip_jax.output import check_memory

    n_points = float(np.prod(shape, dtype=float))
    draws = 1 if sample is None else _draws(sample)
    outputs = [o for o in ("--json", "--csv", "--netcdf") if getattr(args, o[2:])]
    per_point = _BYTES_PER_POINT["map"] + sum(_BYTES_PER_POINT[o] for o in outputs)
    n_bytes = n_points * per_point
    what = f"the grid of {' x '.join(map(str, shape))} = {n_points:.3g} points"
    if args.max_amplitude is not None:
        n_bytes += n_points * draws * _BYTES_PER_POINT_DRAW
        what += f" x {draws} draw{'s' * (draws != 1)} (--max-amplitude)"
    if outputs:
        what += f" with {', '.join(outputs)}"
    advice = "use fewer grid points"
    if args.max_amplitude is not None and draws > 1:
        advice += " or fewer draws (thin the --posterior file)"
    heavy = [o for o in outputs if o != "--netcdf"]
    if heavy:
        advice += (f", or write --netcdf instead of {' and '.join(heavy)} (about "
                   f"{_BYTES_PER_POINT['--netcdf']} bytes a point instead of "
                   f"{sum(_BYTES_PER_POINT[o] for o in heavy):,})")
    check_memory(what, "--weight/--stiffness/--speed", n_bytes, advice=advice)


def compute(args):
    """The map as a dict of NumPy arrays (internal units) plus its axes."""
    from stickslip_jax.lubricants import lubricant, lubricants

    from ..design import design_map, load_samples, outer, propagate

    if args.lubricant not in lubricants(args.table):
        raise ValueError(f"--lubricant: unknown lubricant {args.lubricant!r}; "
                         f"Table {args.table} has {', '.join(lubricants(args.table))}")
    if args.chunk_size < 1:
        raise ValueError("--chunk-size: must be >= 1")
    if not 0 < args.level < 1:
        raise ValueError("--level: must be between 0 and 1, e.g. 0.9")
    axes = _axes(args)
    shape = tuple(axes[n].size for n in ("weight", "stiffness", "speed"))
    sample = None
    if args.posterior:
        if _method(args) is not MapMethod.STEADY:
            raise ValueError(f"--method {_method(args)}: not available with --posterior "
                             "(steady analysis only)")
        if not Path(args.posterior).exists():
            raise ValueError(f"--posterior: no such file {args.posterior!r}")
        sample = load_samples(args.posterior)
    _check_memory(args, shape, sample)
    w, k, v = outer(axes["weight"], axes["stiffness"], axes["speed"])
    out = {"axes": axes}
    if args.posterior:
        _say_posterior_work(shape, sample)
        u = propagate(sample, w, k, v, level=args.level, chunk_size=args.chunk_size * 4,
                      progress=_progress(args))
        out.update(probability=u.probability, critical_speed_band=u.critical_speed,
                   critical_speed=u.critical_speed[..., 1], amplitude=u.amplitude[..., 1],
                   amplitude_band=u.amplitude, stick_slip=u.probability >= 0.5)
        return out
    friction = lubricant(args.lubricant, table=args.table)
    _say_map(shape, f"method {_method(args)}")
    m = design_map(friction, w, k, v, method=_method(args),
                   chunk_size=args.chunk_size, progress=_progress(args),
                   damping_ratio=_damping(args))
    out.update(amplitude=m.amplitude, amplitude_ratio=m.amplitude_ratio, frequency=m.frequency,
               frequency_ratio=m.frequency_ratio, stick_time=m.stick_time,
               critical_speed=m.critical_speed, stick_slip=m.stick_slip, converged=m.converged,
               regime=m.regime)
    return out


JSON_ALIASES = {
    "stiffness_kgf_per_mm": "stiffness_kgf_mm",
    "drive_speed_mm_per_min": "speed_mm_min",
    "critical_speed_mm_per_min": "critical_speed_mm_min",
    "critical_speed_band_mm_per_min": "critical_speed_band_mm_min",
}
"""JSON keys renamed to the one convention (`stickslip_jax.output.UNIT_SUFFIXES`) ->
their old names, still written beside them for one release (`deprecated_keys`). The
--csv columns have the same names (`CSV_COLUMNS`) and no aliases (a CSV header cannot
carry them)."""


def to_json(args, res) -> dict:
    axes = res["axes"]
    doc = {
        "source": {"posterior": args.posterior} if args.posterior
        else {"lubricant": args.lubricant, "table": args.table},
        "method": _method(args).value,
        **({"damping_ratio": _damping(args)} if _damping(args) is not None else {}),
        "axes": {"weight_kgf": axes["weight"].tolist(),
                 "stiffness_kgf_per_mm": axes["stiffness"].tolist(),
                 "drive_speed_mm_per_min": (axes["speed"] * 60.0).tolist()},
        "shape": list(res["amplitude"].shape),
        "index_order": ["weight", "stiffness", "speed"],
        "amplitude_mm": res["amplitude"].tolist(),
        "critical_speed_mm_per_min": (res["critical_speed"] * 60.0).tolist(),
        "stick_slip": res["stick_slip"].tolist(),
    }
    if "regime" in res:
        from stickslip_jax.steady import REGIMES

        doc["regime"] = np.asarray(res["regime"]).tolist()
        doc["regimes"] = list(REGIMES)  # the names of the codes in "regime"
    if args.posterior:
        doc["level"] = args.level
        doc["probability_stick_slip"] = res["probability"].tolist()
        doc["critical_speed_band_mm_per_min"] = (res["critical_speed_band"] * 60.0).tolist()
        doc["amplitude_band_mm"] = res["amplitude_band"].tolist()
    else:
        doc.update(
            amplitude_ratio=res["amplitude_ratio"].tolist(),
            frequency_hz=res["frequency"].tolist(),
            frequency_ratio=res["frequency_ratio"].tolist(),
            stick_time_s=res["stick_time"].tolist(),
            converged=res["converged"].tolist(),
        )
    return doc


LABELS = {"weight": "W [kgf]", "stiffness": "k [kgf/mm]", "speed": "v [mm/min]"}


def _figure_grid(args, axes) -> list[str]:
    """The grid axes a figure shows (one or two); a ValueError naming the figure's option
    otherwise (`run` checks it before the map is computed)."""
    grid = [n for n in ("weight", "stiffness", "speed") if axes[n].size > 1]
    if len(grid) == 0 or len(grid) > 2:
        raise ValueError(f"{args.plot_option}: a figure needs one or two of "
                         "--weight/--stiffness/--speed "
                         f"as START:STOP:COUNT grids, got {len(grid)}")
    return grid


def plot(args, res, path):
    """Amplitude and v_c maps (2 grid axes) or curves (1 grid axis), the stick-slip
    boundary dashed where the grid crosses it; saved to `path` and closed (the `Figure`
    is returned for inspection)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    axes = res["axes"]
    grid = _figure_grid(args, axes)
    scale = {"weight": 1.0, "stiffness": 1.0, "speed": 60.0}
    squeeze = tuple(i for i, n in enumerate(("weight", "stiffness", "speed")) if n not in grid)
    panels = [("amplitude", "amplitude a [mm]", 1.0), ("critical_speed", "v_c [mm/min]", 60.0)]
    if args.posterior:
        panels.append(("probability", "P(stick-slip)", 1.0))
    fig, axs = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 4.2), squeeze=False)
    # A smooth field whose zero level is the stick-slip boundary.
    if args.posterior:
        edge = res["probability"] - 0.5
    elif _method(args) is not MapMethod.STEADY:
        edge = res["stick_slip"].astype(float) - 0.5
    else:
        edge = np.log(res["critical_speed"] / np.broadcast_to(
            axes["speed"][None, None, :], res["critical_speed"].shape))
    edge = np.squeeze(edge, axis=squeeze)
    crosses = edge.min() < 0 < edge.max()
    title = (f"posterior {Path(args.posterior).name}" if args.posterior
             else f"lubricant {args.lubricant} (Table {args.table})")
    # re-stick failure (double slips: eq (6)'s amplitude is not the motion's), hatched
    double = (np.squeeze(np.asarray(res["regime"]) == 2, axis=squeeze) if "regime" in res
              else None)
    for ax, (key, label, s) in zip(axs[0], panels):
        z = np.squeeze(res[key], axis=squeeze) * s
        if len(grid) == 2:
            x = axes[grid[1]] * scale[grid[1]]
            y = axes[grid[0]] * scale[grid[0]]
            mesh = ax.pcolormesh(x, y, z, shading="auto", cmap="viridis")
            fig.colorbar(mesh, ax=ax, label=label)
            if crosses:  # dashed: the boundary v = v_c (or P = 0.5) between the regimes
                ax.contour(x, y, edge, levels=[0.0], colors="w", linewidths=1.5,
                           linestyles="--")
            if double is not None and double.any():
                ax.contourf(x, y, double.astype(float), levels=[0.5, 1.5], colors="none",
                            hatches=["///"])
                ax.plot([], [], " ", label="/// re-stick failure (double slips)")
                ax.legend(loc="best", fontsize=7)
            ax.set_xlabel(LABELS[grid[1]])
            ax.set_ylabel(LABELS[grid[0]])
            if "speed" in grid:
                ax.set_xscale("log") if grid[1] == "speed" else ax.set_yscale("log")
        else:
            x = axes[grid[0]] * scale[grid[0]]
            ax.plot(x, z, "-")
            if crosses:
                i = int(np.argmax(np.sign(edge) != np.sign(edge[0])))
                # interpolate the zero crossing of the boundary field between samples
                f = edge[i - 1] / (edge[i - 1] - edge[i])
                xb = x[i - 1] * (x[i] / x[i - 1]) ** f if grid[0] == "speed" else \
                    x[i - 1] + f * (x[i] - x[i - 1])
                ax.axvline(xb, color="k", ls="--", lw=1, label="stick-slip boundary")
                ax.legend()
            ax.set_xlabel(LABELS[grid[0]])
            ax.set_ylabel(label)
            if grid[0] == "speed":
                ax.set_xscale("log")
        ax.set_title(f"{label.split(' [')[0]}: {title}", fontsize=9)
    fixed = ", ".join(f"{LABELS[n].split(' ')[0]} = {float(axes[n][0]) * scale[n]:g} "
                      f"{LABELS[n].split(' ')[1][1:-1]}"
                      for n in ("weight", "stiffness", "speed") if n not in grid)
    boundary = ("" if not crosses else "; dashed: stick-slip boundary"
                + (" (P = 0.5)" if args.posterior else
                   " (v = v_c)" if _method(args) is MapMethod.STEADY else ""))
    fig.suptitle(f"{_METHOD_TITLE[_method(args)]}"
                 f"{'; ' + fixed if fixed else ''}{boundary}", fontsize=10)
    fig.tight_layout()
    from stickslip_jax.output import save_figure

    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return fig


def run(args) -> int:
    from stickslip_jax.output import check_outputs

    check_outputs({"--json": args.json, args.plot_option: args.plot, "--csv": args.csv,
                   "--netcdf": args.netcdf},
                  [args.posterior] if args.posterior else [])
    _damping(args)
    if args.plot:
        _figure_grid(args, _axes(args))  # a figure the grid cannot give: before the work
    if args.max_amplitude is not None:
        _check_tolerance_options(args)
    if args.netcdf:
        from ..design.netcdf import import_xarray

        import_xarray("--netcdf")  # before the work: a missing extra is one line
    from stickslip_jax.logs import logger

    res = compute(args)
    logger.info("map done")
    if args.max_amplitude is not None:
        logger.info(f"design to a tolerance: {args.max_amplitude * 1e3:g} um...")
        res["tolerance"] = tolerance(args, res)
    if args.plot:
        logger.info("drawing the figure...")
        plot(args, res, args.plot)
    if args.json:
        from stickslip_jax.output import versioned, write_json

        doc = to_json(args, res)
        if "tolerance" in res:
            doc["tolerance"] = res["tolerance"]
        write_json(args.json, versioned(doc, JSON_ALIASES), indent=None)
        if args.json != "-":  # with "-" the summary below goes to stderr
            print(f"wrote {args.json}")
    if args.csv:
        from stickslip_jax.output import write_text

        write_text(args.csv, long_csv(res))
        print(f"wrote {args.csv}")
    if args.netcdf:
        from ..design.netcdf import map_dataset, write_netcdf

        source = (f"posterior {args.posterior}" if args.posterior
                  else f"lubricant {args.lubricant} (Table {args.table})")
        write_netcdf(args.netcdf, map_dataset(res, {"method": _method(args).value, "source": source,
                                                    "damping_ratio": _damping(args)}))
        print(f"wrote {args.netcdf}")
    amp, vc, stick = res["amplitude"], res["critical_speed"] * 60.0, res["stick_slip"]
    print(f"design map {'x'.join(str(s) for s in amp.shape)} (W x k x v), "
          f"{_METHOD_TITLE[_method(args)]}")
    print(f"  stick-slip at {np.mean(stick) * 100:.1f} % of points")
    print(f"  amplitude a: {amp.min():.4g} .. {amp.max():.4g} mm")
    print(f"  critical speed v_c: {vc.min():.4g} .. {vc.max():.4g} mm/min")
    if args.posterior:
        print(f"  P(stick-slip): {res['probability'].min():.3g} .. {res['probability'].max():.3g}")
    if "tolerance" in res:
        t = res["tolerance"]
        print(f"tolerance: limit-cycle amplitude <= {t['max_amplitude_mm'] * 1e3:.4g} um with "
              f"probability >= {t['meet']:g} ({t['draws']} draw(s)):")
        print(f"  {'W [kgf]':>9} {'v [mm/min]':>11} {'k needed [kgf/mm]':>18} {'P met':>7}")
        for row in t["required_stiffness"]:
            k = ("not found" if not row["converged"]
                 else f"{row['stiffness_kgf_per_mm']:.5g}")
            print(f"  {row['weight_kgf']:9.4g} {row['drive_speed_mm_per_min']:11.4g} {k:>18} "
                  f"{row['probability']:7.3f}")
        ok = np.asarray(t["probability_met"]) >= t["meet"]
        print(f"  grid points meeting it: {int(ok.sum())} of {ok.size}")
    if args.plot:
        print(f"  figure: {args.plot}")
    return 0


def _check_tolerance_options(args) -> None:
    """--meet and --max-amplitude in range (`run` checks them before the map)."""
    if not 0 < args.meet < 1:
        raise ValueError(f"--meet: must lie between 0 and 1, e.g. 0.95, got {args.meet}")
    if not args.max_amplitude > 0:
        raise ValueError(f"--max-amplitude: must be positive, got {args.max_amplitude}")


def tolerance(args, res) -> dict:
    """--max-amplitude: the meet probability on the grid and, per (W, v), the stiffness
    that meets the tolerance (`stickslip_fitting.design.tolerance`)."""
    import jax

    from ..design import load_samples, outer
    from ..design.tolerance import meet_probability, required_stiffness

    _check_tolerance_options(args)
    if args.posterior:
        sample = load_samples(args.posterior)
    else:
        from stickslip_jax.lubricants import lubricant

        sample = jax.tree_util.tree_map(lambda x: jax.numpy.asarray(x, float)[None],
                                        lubricant(args.lubricant, table=args.table))
    axes = res["axes"]
    w, k, v = outer(axes["weight"], axes["stiffness"], axes["speed"])
    prob = meet_probability(sample, w, k, v, args.max_amplitude)
    rows = []
    for wi in axes["weight"]:
        for vi in axes["speed"]:
            d = required_stiffness(sample, wi, vi, args.max_amplitude, meet=args.meet,
                                   start=float(np.median(axes["stiffness"])))
            rows.append({"weight_kgf": d.weight, "drive_speed_mm_per_min": d.speed * 60.0,
                         "stiffness_kgf_per_mm": d.stiffness if d.converged else None,
                         "probability": d.probability, "converged": d.converged})
    draws = _draws(sample)
    return {"max_amplitude_mm": float(args.max_amplitude), "meet": args.meet, "draws": draws,
            "amplitude": "time-domain limit cycle (stickslip_jax.limit_cycle)",
            "probability_met": prob.tolist(), "required_stiffness": rows}


CSV_COLUMNS = (  # (key in the map, column, factor from internal units)
    ("amplitude", "amplitude_mm", 1.0),
    ("amplitude_ratio", "amplitude_ratio", 1.0),
    ("frequency", "frequency_hz", 1.0),
    ("frequency_ratio", "frequency_ratio", 1.0),
    ("stick_time", "stick_time_s", 1.0),
    ("critical_speed", "critical_speed_mm_per_min", 60.0),
    ("probability", "probability_stick_slip", 1.0),
    ("stick_slip", "stick_slip", 1),
    ("converged", "converged", 1),
)


def long_csv(res) -> str:
    """The map as long-format CSV text: columns weight_kgf, stiffness_kgf_per_mm,
    drive_speed_mm_per_min, then every quantity the map has (`CSV_COLUMNS`), `regime` by
    name and, with --max-amplitude, `probability_met`; the JSON's key names (a CSV header
    cannot carry the JSON's deprecated aliases, `JSON_ALIASES`)."""
    from stickslip_jax.steady import REGIMES

    from ..design import outer

    axes = res["axes"]
    w, k, v = (np.broadcast_to(a, res["amplitude"].shape).ravel()
               for a in outer(axes["weight"], axes["stiffness"], axes["speed"]))
    cols = {"weight_kgf": w, "stiffness_kgf_per_mm": k, "drive_speed_mm_per_min": v * 60.0}
    for key, name, factor in CSV_COLUMNS:
        if key in res:
            x = np.asarray(res[key]).ravel()
            cols[name] = x.astype(int) if factor == 1 and x.dtype == bool else x * factor
    if "regime" in res:
        cols["regime"] = np.asarray([REGIMES[int(r)] for r in np.asarray(res["regime"]).ravel()])
    if "tolerance" in res:
        cols["probability_met"] = np.asarray(res["tolerance"]["probability_met"]).ravel()
    lines = [",".join(cols)]
    for i in range(w.size):
        lines.append(",".join(str(c[i]) if isinstance(c[i], str) else f"{c[i]:.10g}"
                              for c in cols.values()))
    return "\n".join(lines) + "\n"
