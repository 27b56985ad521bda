"""`stickslip plan`: propose the next records that most reduce the friction-parameter uncertainty.

The command parses its options (the candidate axes with their units) and calls
`api.plan.plan_records`, whose `RecordPlan` it prints and writes."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np

from ..modes import DesignCriterion
from ..api.design import JSON_ALIASES, parse_grid  # the renamed keys: design's W, k, v

NAME = "plan"
HELP = ("propose the next records (W, k, v) that best identify mu_s, mu_d, gamma, m, delta, n "
        "(greedy D-optimal design from the Fisher information of the steady analysis)")

PRIOR_HELP = """Plan a few records at a time and re-plan after fitting them: the
design is computed at the current estimate. Sources (one or more): a paper lubricant name (A, C: its parameters are the
estimate); the JSON summary of `stickslip mcmc --json` (median and sd per parameter); a
prior JSON {"mean": {"mu_s": .., ..., "n": ..}, "sd": {...}} with sd the
standard deviation of log(parameter) (a relative error; a number applies to all); a
posterior sample (CSV/JSON with columns mu_s, mu_d, gamma, m, delta, n: its log-mean is
the estimate and its log-sd the prior); and record files (# stickslip-record) already
measured, whose conditions count as existing records."""


def add_arguments(p):
    # nargs="*": an old `plan --json SOURCE ...` (bare --json) parses SOURCE as --json's
    # value; `_JsonOrOldSource` gives it back to the sources
    p.add_argument("sources", nargs="*", metavar="RECORDS-OR-PRIOR", help=PRIOR_HELP)
    p.add_argument("--budget", type=int, default=4, help="number of records to propose")
    p.add_argument("--table", type=int, default=6, choices=(4, 6, 9),
                   help="table of eq (1) parameters of a lubricant name (default 6)")
    p.add_argument("--weights", default="11.3,36.0,53.2",
                   help="candidate slider weights: comma list or START:STOP:COUNT (kgf)")
    p.add_argument("--stiffnesses", default="27.3,86.9,128.5",
                   help="candidate stiffnesses: comma list or START:STOP:COUNT (kgf/mm)")
    p.add_argument("--speeds", default="0.0022:92:12:log",
                   help="candidate drive speeds: comma list or START:STOP:COUNT[:log] [unit] "
                        "(default mm/min)")
    p.add_argument("--prior-sd", type=float, default=0.5,
                   help="sd of log(parameter) of the prior when the source gives none")
    p.add_argument("--noise", type=float, nargs=4, default=(0.05, 0.05, 0.01, 0.01),
                   metavar=("LOG_A", "LOG_T1", "MU_0", "MU_M"),
                   help="noise sd per record: relative for a and T1, absolute for mu_0, mu_m")
    p.add_argument("--criterion", choices=DesignCriterion.choices(),
                   default=DesignCriterion.D.value,
                   help="D: maximise det of the information; A: minimise the mean variance")
    p.add_argument("--no-repeats", action="store_true", help="never propose the same record twice")
    from stickslip_jax.commands.options import add_json_option, add_quiet_option

    add_json_option(p, "the plan", bare=True, action=_JsonOrOldSource)
    p.set_defaults(json_source=None)
    add_quiet_option(p)


class _JsonOrOldSource(argparse.Action):
    """`--json OUT`, where `plan --json A ...` meant a bare --json and the source A before
    --json took a file: a value that is a lubricant name or an existing input (a record,
    a prior, a posterior; not an earlier plan) is kept as a source (`args.json_source`)
    and --json becomes "-", so an old script neither fails nor overwrites its prior."""

    def __call__(self, parser, namespace, value, option_string=None):
        namespace.json_source = None
        if value not in (None, "-") and _is_record(value):
            raise argparse.ArgumentError(self, f"{value} is a record file (an input); give "
                                         "the plan a new file name such as plan.json")
        if value not in (None, "-") and _is_source(value):
            namespace.json_source, value = value, "-"
        namespace.json = value


def _is_record(value: str) -> bool:
    if not os.path.isfile(value):  # a named pipe would block the read
        return False
    try:
        with open(value, "rb") as fh:
            return fh.read(40).lstrip().startswith(b"# stickslip-record")
    except OSError:
        return False


def _is_source(value: str) -> bool:
    path = Path(value)
    if not path.is_file():
        from stickslip_jax.lubricants import lubricants

        return any(value in lubricants(t) for t in (4, 6, 9))
    try:
        old = json.loads(path.read_text()) if path.suffix.lower() == ".json" else None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        old = None
    return not (isinstance(old, dict) and "criterion" in old and "relative_sd_after" in old)


def _values(text, dim, unit, arg):
    if "," in text:
        return np.concatenate([parse_grid(t, dim, unit, arg) for t in text.split(",")])
    return parse_grid(text, dim, unit, arg)


PLAN_OPTIONS = ("budget", "noise", "weights/stiffnesses/speeds")
"""The plan verb's keywords that are options of the command: its error "name: ..." is
printed as "--name: ..."."""


def run(args) -> int:
    from stickslip_jax.output import check_outputs

    from ..api.plan import plan_records
    from ..design import Noise

    if args.json_source is not None:  # `plan --json SOURCE ...`: the old bare --json
        args.sources = [args.json_source, *args.sources]
    if not args.sources:
        raise ValueError("RECORDS-OR-PRIOR: give a lubricant name, a prior JSON or a "
                         "posterior sample (and records already measured)")
    check_outputs({"--json": args.json}, [s for s in args.sources if Path(s).exists()])
    try:
        plan = plan_records(args.sources, _values(args.weights, "force", "kgf", "--weights"),
                            _values(args.stiffnesses, "stiffness", "kgf/mm", "--stiffnesses"),
                            _values(args.speeds, "speed", "mm/min", "--speeds"),
                            budget=args.budget, table=args.table, prior_sd=args.prior_sd,
                            noise=Noise(*args.noise), repeats=not args.no_repeats,
                            criterion=DesignCriterion.parse(args.criterion))
    except ValueError as err:
        head, colon, rest = str(err).partition(":")
        if head not in PLAN_OPTIONS:
            raise
        raise ValueError(f"--{head.replace('/', '/--')}{colon}{rest}") from None
    if args.json:
        from stickslip_jax.output import versioned, write_json

        write_json(args.json, versioned(plan.report, JSON_ALIASES))
        if args.json != "-":  # with "-" the table below goes to stderr
            print(f"wrote {args.json}")
    print(plan)
    return 0
