"""`stickslip discover RECORDS...`: which effect is the paper's model missing?

Fits the paper's model to the full traces, analyses the residuals, ranks the library
of candidate effects by a score test, refits the best few and names the one that
lowers BIC enough, or answers "none" (`fitting.discovery.workflow`). Prints the answer,
the gap (residual RMS) before and after, the candidate table and the parameters
before and after. `--json OUT` writes {"effect", "explanation", "gap_before",
"gap_after", "criterion", "candidates": [{"name", "score", "delta_criterion"}...],
"parameters_before", "parameters_after", ...} (gaps in mm); `--plot OUT.png` the
residuals by phase before and after and the traces.
"""

from __future__ import annotations

import json

NAME = "discover"
HELP = "find the physical effect the paper's model is missing in a campaign of records"


def add_arguments(parser):
    from fitting.discovery.effects import CANDIDATES

    parser.add_argument("records", nargs="+", help="record CSV files, directories or globs")
    parser.add_argument("--strict", action="store_true",
                        help="refuse the campaign when any record has no usable stick-slip "
                        "(default: run on the records that have it, list the others)")
    parser.add_argument("--json", metavar="OUT", help="write the result as JSON")
    parser.add_argument("--plot", metavar="OUT.png", help="save residuals and traces")
    parser.add_argument("--top", type=int, default=3,
                        help="how many candidates to refit after the score test (default 3)")
    parser.add_argument("--threshold", type=float, default=10.0,
                        help="BIC drop needed to name an effect (default 10)")
    parser.add_argument("--only", action="append", choices=CANDIDATES, default=None,
                        metavar="EFFECT", help="consider only these effects (repeatable)")
    parser.add_argument("--crop", choices=("slip_end", "none"), default="slip_end",
                        help="start each record at its first slip end (default) or use it "
                        "whole (it must start just after a slip)")
    parser.add_argument("--max-evals", type=int, default=80,
                        help="evaluation budget of the base fit (default 80; it stops earlier "
                        "when converged)")
    parser.add_argument("--learn", action="store_true",
                        help="fit a learned (MLP) correction when no effect explains the data")


def run(args) -> int:
    import sys

    from stickslip_jax.records import read_campaign

    from fitting.discovery import discover
    from fitting.discovery.effects import CANDIDATES

    if args.top < 1:
        raise ValueError(f"--top: must be at least 1, got {args.top}")
    if args.max_evals < 2:
        raise ValueError(f"--max-evals: must be at least 2, got {args.max_evals}")
    if not args.threshold >= 0:
        raise ValueError(f"--threshold: must be >= 0, got {args.threshold}")
    from ..campaign import screen_records

    records = read_campaign(args.records)
    if len(records) < 2:
        raise ValueError("RECORDS: discovery needs at least two records (a campaign)")
    campaign = screen_records(records, strict=args.strict)
    for w in campaign.warnings:
        print("warning: " + w, file=sys.stderr)
    records = campaign.records
    result = discover(records, candidates=tuple(args.only or CANDIDATES), top=args.top,
                      threshold=args.threshold, crop=args.crop, learn=args.learn,
                      max_evals=args.max_evals)
    print(f"effect: {result.effect} (confidence {result.confidence})")
    print(result.explanation)
    print(f"gap (residual RMS): {result.gap_before * 1e3:.3f} um -> "
          f"{result.gap_after * 1e3:.3f} um; noise {result.noise * 1e3:.3f} um")
    print(f"{'candidate':22s} {'score':>10s} {'dBIC':>10s}")
    for c in result.candidates:
        d = "-" if c["delta_criterion"] is None else f"{c['delta_criterion']:.1f}"
        print(f"{c['name']:22s} {c['score']:10.1f} {d:>10s}")
    print(f"{'parameter':22s} {'before':>12s} {'after':>12s}")
    for k, v in result.parameters_after.items():
        b = result.parameters_before.get(k)
        print(f"{k:22s} {'-' if b is None else format(b, '.5g'):>12s} {v:12.5g}")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump({**result.to_json(),
                       "records_screened": [x.to_json() for x in campaign.screening]},
                      fh, indent=2)
    if args.plot:
        from fitting.discovery.plots import plot_discovery

        plot_discovery(result, args.plot)
    return 0
