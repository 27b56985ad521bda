"""`stickslip plan`: propose the next records that most reduce the friction-parameter uncertainty."""

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


MAX_BUDGET = 1000
"""Most records one plan proposes (the greedy design adds them one at a time)."""


def run(args) -> int:
    from stickslip_jax.output import check_outputs

    from ..design import PARAMETERS, Noise, candidate_grid, greedy_design, observables
    from ..design.posterior import plan_sources

    if args.json_source is not None:  # `plan --json SOURCE ...`: the old bare --json
        args.sources = [args.json_source, *args.sources]
    if not args.sources:
        raise ValueError("RECORDS-OR-PRIOR: give a lubricant name, a prior JSON or a "
                         "posterior sample (and records already measured)")
    check_outputs({"--json": args.json}, [s for s in args.sources if Path(s).exists()])
    if not 1 <= args.budget <= MAX_BUDGET:
        raise ValueError(f"--budget: must lie in 1-{MAX_BUDGET} records (a plan proposes "
                         f"records one at a time), got {args.budget}")
    if not all(x > 0 for x in args.noise):
        raise ValueError("--noise: every noise level must be positive")
    u, sd, existing, desc = plan_sources(args.sources, args.table, args.prior_sd)
    axes = (_values(args.weights, "force", "kgf", "--weights"),
            _values(args.stiffnesses, "stiffness", "kgf/mm", "--stiffnesses"),
            _values(args.speeds, "speed", "mm/min", "--speeds"))
    from stickslip_jax.output import check_memory

    # the Fisher matrix of every candidate (6 x 6) and its observables, per greedy step;
    # checked before the grid of candidates is built (3000^3 of them died building it)
    n_cands = float(np.prod([np.size(a) for a in axes], dtype=float))
    check_memory(f"{' x '.join(str(np.size(a)) for a in axes)} = {n_cands:.3g} candidate "
                 "records", "--weights/--stiffnesses/--speeds", n_cands * 64 * 8)
    cands = candidate_grid(*axes)
    if args.no_repeats and args.budget > len(cands):
        raise ValueError(f"--budget: {args.budget} exceeds the {len(cands)} candidates")
    noise = Noise(*args.noise)
    from stickslip_jax.logs import logger

    logger.info(f"choosing {args.budget} of {len(cands)} candidate records "
                f"({args.criterion}-optimal)...")
    plan = greedy_design(u, cands, args.budget, noise=noise, prior_sd=sd, existing=existing,
                         repeats=not args.no_repeats,
                         criterion=DesignCriterion.parse(args.criterion))
    logger.info("plan done")
    rows = []
    for i in range(args.budget):
        w, k, v = (float(np.asarray(x)[i]) for x in
                   (plan.campaign.weight, plan.campaign.stiffness, plan.campaign.speed))
        _, mask = observables(u, w, k, v)
        rows.append({"weight_kgf": w, "stiffness_kgf_per_mm": k,
                     "drive_speed_mm_per_min": v * 60.0,
                     "stick_slip_expected": bool(np.asarray(mask)[0] > 0)})
    # the parameter rows: the estimate (log coordinates) with its sd before and after
    from ..params import UNITS
    from ..report.rows import ParameterEstimate

    before, after = ([ParameterEstimate.from_log(p, UNITS[p], x, s)
                      for p, x, s in zip(PARAMETERS, u, sds)]
                     for sds in (plan.sd_before, plan.sd_after))
    doc = {"source": desc, "criterion": args.criterion,
           "estimate": {e.name: e.value for e in before},
           "relative_sd_before": {e.name: e.log_sd for e in before},
           "relative_sd_after": {e.name: e.log_sd for e in after}, "records": rows}
    if args.json:
        from stickslip_jax.output import versioned, write_json

        write_json(args.json, versioned(doc, JSON_ALIASES))
        if args.json != "-":  # with "-" the table below goes to stderr
            print(f"wrote {args.json}")
    print(f"plan from {desc}: {args.budget} record(s), {args.criterion}-optimal, "
          f"{len(cands)} candidates")
    print(f"{'#':>3} {'W [kgf]':>9} {'k [kgf/mm]':>11} {'v [mm/min]':>11}  regime")
    for i, r in enumerate(rows, 1):
        regime = "stick-slip" if r["stick_slip_expected"] else "smooth"
        print(f"{i:>3} {r['weight_kgf']:>9.4g} {r['stiffness_kgf_per_mm']:>11.4g} "
              f"{r['drive_speed_mm_per_min']:>11.4g}  {regime}")
    print("relative sd of the parameters (sd of log), before -> after:")
    for b, a in zip(before, after):
        print(f"  {b.name:>6}: {b.log_sd:.3g} -> {a.log_sd:.3g}")
    print("note: the design is local to the estimate; record one or two proposals, re-fit, "
          "and plan again (see stickslip_fitting.design.sequential_campaign)")
    return 0
