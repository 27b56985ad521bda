"""`stickslip design`: maps of stick-slip amplitude and critical speed over W, k and v.

Parses the options into `stickslip_fitting.api.design.MapOptions`, calls `map_study` (what
`stickslip_fitting.design_map` runs) and writes and prints its `DesignStudy`.
"""

from __future__ import annotations

import argparse

from ..modes import MapMethod

NAME = "design"
HELP = ("design map of stick-slip amplitude and critical speed over grids of W, k, v "
        "(steady analysis, or the exact simulator with --exact; a posterior with --posterior)")


def add_arguments(p):
    from stickslip_jax.commands.options import (add_lubricant_options, add_normal_load_option,
                                                quantity)

    add_lubricant_options(p)
    p.add_argument("--weight", required=True,
                   help="slider weight W: VALUE or START:STOP:COUNT[:log] [unit] (default kgf)")
    p.add_argument("--stiffness", required=True,
                   help="drive stiffness k: VALUE or START:STOP:COUNT[:log] [unit] (default kgf/mm)")
    p.add_argument("--speed", required=True,
                   help="drive speed v: VALUE or START:STOP:COUNT[:log] [unit] (default mm/min)")
    add_normal_load_option(p)
    p.add_argument("--posterior", metavar="FILE",
                   help="posterior sample (CSV/JSON with mu_s, mu_d, gamma, m, delta, n) to "
                        "propagate instead of the lubricant: probability of stick-slip, v_c band")
    p.add_argument("--level", type=float, default=None,
                   help="with --posterior: credible level of the v_c band (default 0.9)")
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
    p.add_argument("--meet", type=float, default=None,
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


def options(args):
    """The `MapOptions` of the command line (the method: --method, or exact for --exact; a
    terminal shows the bar unless --quiet, --progress shows it off a terminal too)."""
    import sys

    from ..api.design import MapOptions

    if args.exact and args.method not in (None, MapMethod.EXACT):
        raise ValueError(f"--exact and --method {args.method} disagree: give one of them")
    method = MapMethod.EXACT if args.exact else MapMethod.parse(args.method or "steady")
    return MapOptions(
        args.weight, args.stiffness, args.speed, lubricant=args.lubricant, table=args.table,
        posterior=args.posterior, level=args.level, method=method,
        damping_ratio=args.damping_ratio, max_amplitude=args.max_amplitude, meet=args.meet,
        chunk_size=args.chunk_size, normal_load=args.normal_load,
        progress=not args.quiet and (args.progress or sys.stderr.isatty()),
        outputs=tuple(o for o in ("--json", "--csv", "--netcdf") if getattr(args, o[2:])))


def plot(study, path):
    """The map figure saved to `path` (`DesignStudy.plot`)."""
    return study.plot(path)


def run(args) -> int:
    from stickslip_jax.output import check_outputs

    from ..api.design import figure_axes, map_study

    check_outputs({"--json": args.json, args.plot_option: args.plot, "--csv": args.csv,
                   "--netcdf": args.netcdf}, [args.posterior] if args.posterior else [])
    opts = options(args)
    opts.check()
    if args.plot:  # a figure the grid cannot give: before the work
        figure_axes(opts.axes(), args.plot_option)
    if args.netcdf:
        from ..design.netcdf import import_xarray

        import_xarray("--netcdf")  # before the work: a missing extra is one line
    study = map_study(opts)
    if args.plot:
        from stickslip_jax.logs import logger

        logger.info("drawing the figure...")
        from ..report.plots import interruptible

        interruptible(plot, study, args.plot)
    for option, write in (("json", study.to_json), ("csv", study.to_csv),
                          ("netcdf", study.to_netcdf)):
        path = getattr(args, option)
        if path:
            write(path)
            if path != "-":  # with "-" the summary below goes to stderr
                print(f"wrote {path}")
    print(study)
    if args.plot:
        print(f"  figure: {args.plot}")
    return 0
