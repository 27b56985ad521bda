"""`stickslip fit RECORDS...`: friction parameters of a campaign, with errors and diagnostics.

Prints the table of `report.fit_table` (values, standard errors, 95 % intervals, truth
when the records carry it, warnings, fit quality); `--json OUT` writes the same as JSON,
`--plot OUT.png` the diagnostic figure. `--model microsqueeze` fits h_e (mm) and Q (mm^4)
in place of gamma and m (`solve.microsqueeze`).
"""

from __future__ import annotations

from stickslip_jax.modes import GaugeOffset, SlipTime

from ..modes import FrictionLaw, ModelModes, Objective

NAME = "fit"
HELP = "fit the friction parameters (eq 1, eq 3) to a campaign of records"


def add_arguments(parser):
    parser.add_argument("records", nargs="+", help="record CSV files, directories or globs")
    add_campaign_fit_arguments(
        parser,
        objective_help="fit the cycle features (default, fast), every sample of the "
                       "traces through the exact simulator restarted per cycle, both "
                       "(weights 1/2 each), or whole records through the smoothed simulator "
                       "(slow; tests the timing of every slip); all but features start from "
                       "the features fit, and their intervals use a cluster-robust "
                       "covariance (per stick phase; per record for smooth)",
        strict_help="refuse the campaign when any record has no usable stick-slip "
                    "(default: fit the records that have it, list the others)")
    parser.add_argument("--law", choices=FrictionLaw.choices(), default=FrictionLaw.PAPER.value,
                        help="base friction law: the paper's eqs (1), (3) (default), "
                        "Dieterich-Ruina rate-and-state with the aging or the slip law, or "
                        "logarithmic aging with a log-velocity kinetic friction (whole records "
                        "through the smoothed simulator; docs/friction-laws.md)")
    from stickslip_jax.commands.options import add_json_option, add_plot_option, add_quiet_option

    add_json_option(parser, "the result")
    add_plot_option(parser, "the diagnostic figure")
    add_quiet_option(parser)


def add_campaign_fit_arguments(parser, *, objective_help: str, strict_help: str,
                               old_offset_name: bool = True):
    """The options of one campaign's fit, shared by `fit`, `mcmc` and `fit-batch` (each
    with its own help for --objective and --strict); the hidden old name --offset of
    --gauge-offset unless `old_offset_name` is False."""
    import argparse

    parser.add_argument("--model", choices=("empirical", "microsqueeze"), default="empirical",
                        help="static-friction law: eq (1) (default) or the microsqueeze law")
    parser.add_argument("--gauge-offset", dest="offset", choices=GaugeOffset.choices(),
                        default=GaugeOffset.ZERO.value,
                        help="gauge offset: trust the zero (default), or read it from the first "
                        "sample of records that start with the spring relaxed")
    if old_offset_name:  # the old name (pitch's --drive-offset is a length: one name a concept)
        parser.add_argument("--offset", dest="offset", choices=GaugeOffset.choices(),
                            default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    parser.add_argument("--slip-time", choices=SlipTime.choices(), default=SlipTime.PAPER.value,
                        help="T2 in eq (3): pi/omega0 (eq 7, default) or the actual slip time")
    parser.add_argument("--objective", choices=Objective.choices(),
                        default=Objective.FEATURES.value, help=objective_help)
    parser.add_argument("--strict", action="store_true", help=strict_help)
    parser.add_argument("--fix", action="append", default=[], metavar="NAME=VALUE",
                        help="hold a parameter fixed, e.g. --fix n=1 (repeatable)")
    parser.add_argument("--loss", default="gaussian", metavar="NAME[:PARAMETER]",
                        help="likelihood of the residuals: gaussian (least squares, default), "
                        "student-t[:NU] (heavy-tailed, nu 4 unless given) or huber[:C] "
                        "(C 1.345 noise standard deviations unless given): for records with "
                        "sporadic irregular slips or outliers the model does not describe")
    from stickslip_jax.commands.options import viscosity

    parser.add_argument("--eta", type=viscosity(), default=None,
                        help="--model microsqueeze: lubricant viscosity, Pa*s unless a unit "
                        "is given: '0.216', '216 cP', '2.2e-8 kgf*s/mm^2', '230 cSt at 870 "
                        "kg/m^3' (default: the records' lubricant in Table 11, else A)")
    parser.add_argument("--surface", default=None,
                        help="--model microsqueeze: surface pair of Table 10 (default S1G1)")


def check_model_options(args) -> dict[str, float]:
    """The held parameters of `--fix` (`parse_fix` for `args.model`'s law), with --eta and
    --surface refused unless `--model microsqueeze` (an option that cannot act): checks
    of `fit`, `mcmc` and `fit-batch` before any work (and before JAX starts, which
    `fit-batch --coordinator` needs)."""
    micro = args.model == "microsqueeze"
    for option, value in (("--eta", args.eta), ("--surface", args.surface)):
        if value is not None and not micro:
            raise ValueError(f"{option}: only used with --model microsqueeze; add it, or "
                             f"leave out {option}")
    from ..params import parse_fix

    if micro:  # imported only here: it loads the contact model (and diffrax)
        from ..microsqueeze_params import MicrosqueezeFriction as law
    return parse_fix(args.fix, law if micro else None)


def fit_from_args(args, *, objective: Objective | str = "features", outputs=None):
    """The `CampaignFit` of `api.campaign.fit_campaign` (or `fit_law_campaign` for `--law`)
    with the command line's options parsed into objects; `outputs` ({option: path}) are
    checked against the records read before the fit. Every user error is a ValueError
    naming the option or file."""
    from ..api.campaign import fit_campaign
    from ..objectives.losses import parse_loss

    objective = Objective.parse(objective)
    loss = parse_loss(args.loss)
    modes = ModelModes(offset=GaugeOffset.parse(args.offset, "offset"),
                       slip_time=SlipTime.parse(args.slip_time))
    law = FrictionLaw.parse(getattr(args, "law", FrictionLaw.PAPER))
    if law is not FrictionLaw.PAPER:
        return _fit_law_from_args(args, law, objective, modes, loss, outputs)
    fixed = check_model_options(args)
    from ..params import EmpiricalFriction as friction_law

    pair = None
    if args.model == "microsqueeze":  # imported only here: the contact model loads diffrax
        from ..api.campaign import surface_option
        from ..microsqueeze_params import MicrosqueezeFriction as friction_law

        pair = surface_option(args.surface or "S1G1", "--surface")
    return fit_campaign(args.records, friction_law, fixed, objective=objective, loss=loss,
                        modes=modes, strict=getattr(args, "strict", False), eta=args.eta,
                        pair=pair, surface=args.surface or "S1G1", outputs=outputs)


def _fit_law_from_args(args, law, objective, modes, loss, outputs):
    """`fit_from_args` for a base law other than the paper's (`api.campaign.fit_law_campaign`)."""
    from ..api.campaign import fit_law_campaign
    from ..objectives.losses import Gaussian
    from ..params import parse_fix
    from ..solve.laws import LAW_PARAMS

    if args.model != "empirical" or args.eta is not None or args.surface is not None:
        raise ValueError(f"--law {law}: the law replaces --model; leave out --model, --eta "
                         "and --surface")
    if objective not in (Objective.FEATURES, Objective.SMOOTH) or not isinstance(loss, Gaussian):
        raise ValueError(f"--law {law}: fitted through whole records (--objective smooth) "
                         "with the Gaussian --loss only")
    fixed = parse_fix(args.fix, LAW_PARAMS[law])
    return fit_law_campaign(args.records, law, fixed, modes=modes,
                            strict=getattr(args, "strict", False), outputs=outputs)


def run(args) -> int:
    import sys

    from stickslip_jax.output import versioned, write_json

    from ..report.fit_table import fit_text

    result = fit_from_args(args, objective=args.objective,
                           outputs={"--json": args.json, "--plot": args.plot})
    print(fit_text(result.report, result.notes))  # the table and the campaign's notes
    if args.json:
        write_json(args.json, versioned(result.report))
        if args.json != "-":
            print(f"wrote {args.json}")
    if args.plot:
        from stickslip_jax.logs import logger

        from ..report.plots import campaign_fit_figure, interruptible

        logger.info("drawing the figure...")
        interruptible(campaign_fit_figure, result.fit, result.uncertainty, result.campaign,
                      args.plot)
        print(f"wrote {args.plot}")
    if not result.report["converged"]:
        print("stickslip fit: the fit did not converge (see the warnings): the values above "
              "are not an optimum", file=sys.stderr)
        return 3
    return 0
