"""`stickslip discover RECORDS...`: which effect is the paper's model missing?

`--base cycle` (default): the per-cycle model of `stickslip fit --objective trace`, a
robust score test of every effect family, refits, and a named effect, "none" or
"unexplained" (`discovery.cycle_workflow`); `--base smooth`: the smoothed simulator
over whole records (`discovery.workflow`, BIC choice). Prints the answer, the gap
(residual RMS) before and after, the candidate and parameter tables; `--json OUT` the
result's document (`discovery.result.Discovery.to_json`, gaps in mm); `--plot OUT.png`
the residuals by phase, the parameters and the traces. The command parses its options
into a base model and calls `api.discovery.discover`, which compares the base friction
laws too with `--compare-laws`.
"""

from __future__ import annotations

NAME = "discover"
HELP = "find the physical effect the paper's model is missing in a campaign of records"


EFFECTS = ("viscous_damping", "stribeck", "drive_periodic_error", "sensor_lowpass",
           "friction_drift", "gauge_drift", "load_coupling", "rate_state", "drive_speed_drift")
"""The choices of --only: the smooth base's candidates, then the cycle base's families,
written out so that the parser does not import the discovery code (tested to agree)."""


def add_arguments(parser):
    parser.add_argument("records", nargs="+", help="record CSV files, directories or globs")
    parser.add_argument("--strict", action="store_true",
                        help="refuse the campaign when any record has no usable stick-slip "
                        "(default: run on the records that have it, list the others)")
    from stickslip_jax.commands.options import add_json_option, add_plot_option, add_quiet_option

    add_json_option(parser, "the result")
    add_plot_option(parser, "the residuals by phase before and after and the traces")
    from stickslip_fitting.modes import Crop, DiscoveryBase

    parser.add_argument("--base", choices=DiscoveryBase.choices(),
                        default=DiscoveryBase.CYCLE.value,
                        help="the base model: per-cycle exact model (default; seconds) or "
                        "the smoothed simulator over whole records (minutes)")
    parser.add_argument("--alpha", type=float, default=0.01,
                        help="false-alarm rate of the cycle base's test over all effect "
                        "families (default 0.01)")
    add_quiet_option(parser)
    parser.add_argument("--top", type=int, default=3,
                        help="how many candidates to refit after the score test (default 3)")
    parser.add_argument("--threshold", type=float, default=None,
                        help="--base smooth: BIC drop needed to name an effect (default 10)")
    parser.add_argument("--only", action="append", choices=EFFECTS, default=None,
                        metavar="EFFECT", help="consider only these effects (repeatable)")
    parser.add_argument("--crop", choices=Crop.choices(), default=None,
                        help="--base smooth: start each record at its first slip end "
                        "(default) or use it whole (it must start just after a slip)")
    parser.add_argument("--max-effects", type=int, default=3, metavar="N",
                        help="--base cycle: name up to N effects one after another, each "
                        "joining the model before the next search (default 3; 1: the "
                        "single best effect)")
    parser.add_argument("--max-evals", type=int, default=80,
                        help="evaluation budget of the base fit (default 80; it stops earlier "
                        "when converged)")
    parser.add_argument("--loss", default="gaussian", metavar="NAME[:PARAMETER]",
                        help="--base cycle: likelihood of the residuals: gaussian (least "
                        "squares, default), student-t[:NU] or huber[:C], as in `stickslip "
                        "fit`; its weights at the base fit are held fixed for every "
                        "family (for spikes or sporadic irregular slips)")
    parser.add_argument("--learn", action="store_true",
                        help="fit the learned correction: with --base cycle a spline over "
                        "the cycle phase (always fitted when the answer is 'unexplained'; "
                        "--learn fits it whatever the answer); with --base smooth an MLP "
                        "friction force, when no effect explains the data")
    parser.add_argument("--compare-laws", action="store_true",
                        help="also fit the base friction laws (the paper's eqs 1 and 3, "
                        "rate-and-state with aging, logarithmic aging) to the same records "
                        "on the smoothed simulator and say which describes them best (BIC "
                        "and held-out cycles; minutes); JSON key 'laws'")


def run(args) -> int:
    import sys

    from stickslip_jax.logs import logger
    from stickslip_jax.output import save_figure, write_json

    from ..api.discovery import discover
    from ..modes import DiscoveryBase
    from ..objectives.losses import parse_loss

    cycle = DiscoveryBase.parse(args.base) is DiscoveryBase.CYCLE
    base = _base(args, cycle, parse_loss(args.loss))  # checked before any file is read
    try:
        found = discover(args.records, base=base, compare_laws=args.compare_laws,
                         outputs={"--json": args.json, "--plot": args.plot},
                         progress=None if args.quiet else logger.info)
    except ValueError as err:  # the verb's keyword is the command's argument
        head, colon, rest = str(err).partition(":")
        if head != "records":
            raise
        raise ValueError(f"RECORDS{colon}{rest}") from None
    for s in found.result.campaign.screening:
        if s.status != "used":
            print(f"warning: {s.name}: {s.status.replace('_', ' ')} ({s.reason}); not used",
                  file=sys.stderr)
    print(found)
    if args.json:
        write_json(args.json, found.report)
    if args.plot:
        from ..report.plots import interruptible

        logger.info("drawing the figure...")
        # in a worker thread: a Ctrl-C in the figure's compilation or rendering takes
        # effect at once, and the JSON above is renamed into place only with the figure
        interruptible(lambda: save_figure(found.result.figure(), args.plot, dpi=120))
    return 0


BASE_OPTIONS = ("only", "top", "alpha", "max_evals", "max_effects", "threshold")
"""The base's fields (and `CycleBase.tuned`'s keywords) that are options of the command:
the base checks them, and its error "name: ..." is printed as "--name: ..."."""


def _base(args, cycle: bool, loss):
    """The base model of `--base` with the command's options (checked by the base)."""
    for option, value in (("--threshold", args.threshold), ("--crop", args.crop)):
        if cycle and value is not None:
            raise ValueError(f"{option}: acts only with --base smooth; add --base smooth or "
                             f"leave {option} out")
    from ..modes import Crop
    from ..objectives.losses import Gaussian

    if not cycle and not isinstance(loss, Gaussian):
        raise ValueError(f"--loss {args.loss}: only with --base cycle (the smoothed base "
                         "fits least squares); drop --loss or use --base cycle")
    only = tuple(args.only) if args.only else None
    try:
        if not cycle:
            from ..discovery.effects import CANDIDATES
            from ..discovery.workflow import SmoothBase

            return SmoothBase(candidates=only or CANDIDATES, top=args.top,
                              threshold=10.0 if args.threshold is None else args.threshold,
                              crop=Crop.parse(args.crop or Crop.SLIP_END), learn=args.learn,
                              max_evals=args.max_evals, strict=args.strict)
        from ..discovery.cycle_workflow import CycleBase

        return CycleBase.tuned(only=only, top=args.top, alpha=args.alpha,
                               max_evals=args.max_evals, strict=args.strict, learn=args.learn,
                               loss=loss, max_effects=args.max_effects)
    except ValueError as err:
        head, colon, rest = str(err).partition(":")
        if head not in BASE_OPTIONS:
            raise
        raise ValueError(f"--{head.replace('_', '-')}{colon}{rest}") from None
