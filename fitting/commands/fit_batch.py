"""`stickslip fit-batch CAMPAIGN...`: fit many campaigns, one per folder or glob, on one
machine or spread over processes and hosts (`jax.distributed`).

Every CAMPAIGN is fitted as `stickslip fit CAMPAIGN` would, with the same options; one
that cannot be fitted is listed with the reason and the others go on (`solve.batch`).
Prints one row per campaign; `--json`, `--csv`, `--plot` write every report, a long
table and the parameters side by side. Across processes: the same command on every
process with `--coordinator HOST:PORT --num-processes N --process-id I`; process 0
prints and writes. Exit 0 when every campaign fitted and converged, 3 when some did not.
"""

from __future__ import annotations

import argparse
import os
import sys

NAME = "fit-batch"
HELP = "fit many campaigns (one per folder or glob), across processes with jax.distributed"


def add_arguments(parser):
    from stickslip_jax.commands.options import (add_json_option, add_plot_option,
                                                add_quiet_option)

    from .fit import add_campaign_fit_arguments

    parser.add_argument("campaigns", nargs="+", metavar="CAMPAIGN",
                        help="one campaign per argument: a folder of record CSV files or a "
                        "quoted glob ('runs/A_*.csv')")
    add_campaign_fit_arguments(
        parser, old_offset_name=False,
        objective_help="what each campaign's fit matches (as in stickslip fit): the cycle "
                       "features (default, fast), every sample of the traces, both, or whole "
                       "records through the smoothed simulator",
        strict_help="fail a campaign when any of its records has no usable stick-slip "
                    "(default: fit the records that have it)")
    add_json_option(parser, "every campaign's fit report")
    parser.add_argument("--csv", metavar="OUT.csv",
                        help="write the results as a long-format CSV: one row per campaign "
                        "and parameter (status, value, unit, standard error, 95 %% interval)")
    add_plot_option(parser, "the parameters of every campaign side by side")
    add_quiet_option(parser)
    group = parser.add_argument_group(
        "across processes (jax.distributed; give all three on every process)")
    group.add_argument("--coordinator", metavar="HOST:PORT",
                       help="address of process 0, e.g. localhost:12345 or node01:12345")
    group.add_argument("--num-processes", type=int, metavar="N",
                       help="number of processes that share the batch")
    group.add_argument("--process-id", type=int, metavar="I",
                       help="this process's index, 0 ... N-1 (process 0 writes the outputs)")
    group.add_argument("--join-timeout", type=float, default=None, metavar="SECONDS",
                       help="how long to wait for every process to join (default 120 s, at "
                       f"most {MAX_JOIN_S:g})")


MAX_JOIN_S = 290.0
"""Longest --join-timeout: JAX itself ends the process (abort, no message) after 300 s."""


def _join(args) -> None:
    """Join the `jax.distributed` job the three options describe (before any JAX work)."""
    given = [args.coordinator is not None, args.num_processes is not None,
             args.process_id is not None]
    if not any(given):
        if args.join_timeout is not None:
            raise ValueError("--join-timeout: only used with --coordinator, --num-processes "
                             "and --process-id")
        return
    if not all(given):
        raise ValueError("--coordinator, --num-processes and --process-id: give all three "
                         "(the same coordinator and count on every process) or none")
    if args.join_timeout is None:
        args.join_timeout = 120.0
    if not 0 < args.join_timeout <= MAX_JOIN_S:
        raise ValueError(f"--join-timeout: must lie in (0, {MAX_JOIN_S:g}] s, got "
                         f"{args.join_timeout:g}")
    import threading

    from stickslip_jax.distributed import initialize

    print(f"stickslip fit-batch: process {args.process_id} of {args.num_processes} waiting "
          f"for the others at {args.coordinator} (up to {args.join_timeout:g} s)...",
          file=sys.stderr, flush=True)
    joined = threading.Event()

    def give_up():  # JAX's own timeout aborts the process without a word
        if not joined.wait(args.join_timeout):
            print(f"stickslip fit-batch: error: --coordinator {args.coordinator}: not all "
                  f"{args.num_processes} processes joined within {args.join_timeout:g} s; "
                  "start the same command with every --process-id 0 ... "
                  f"{args.num_processes - 1} (or raise --join-timeout)",
                  file=sys.stderr, flush=True)
            os._exit(2)

    threading.Thread(target=give_up, daemon=True).start()
    try:
        initialize(args.coordinator, args.num_processes, args.process_id)
    except ValueError as exc:
        raise ValueError(f"--coordinator/--num-processes/--process-id: {exc}") from None
    except RuntimeError as exc:  # JAX was already in use, or the coordinator is unreachable
        raise ValueError(f"--coordinator {args.coordinator}: cannot join the job ({exc})") \
            from None
    finally:
        joined.set()


def _fit_one(args):
    """fit_one(spec) of `stickslip_fitting.solve.batch.fit_batch`: `stickslip fit`'s path."""
    from .fit import fit_from_args

    def fit_one(spec) -> dict:
        one = argparse.Namespace(**{**vars(args), "records": [spec]})
        result = fit_from_args(one, objective=args.objective)
        report = result.report
        report["notes"] = result.notes
        return report

    return fit_one


def run(args) -> int:
    from stickslip_jax.logs import logger
    from stickslip_jax.output import versioned, write_json, write_text

    from ..report.fit_table import batch_csv, batch_table
    from ..solve.batch import ERROR, fit_batch
    from .fit import check_model_options

    check_model_options(args)  # a bad --fix is the command's error, not every campaign's
    _join(args)
    import jax

    from ..objectives.losses import parse_loss

    parse_loss(args.loss)  # after joining: it starts JAX

    lead = jax.process_index() == 0
    batch = fit_batch(args.campaigns, _fit_one(args), progress=logger.info,
                      outputs={"--json": args.json, "--csv": args.csv,
                               args.plot_option: args.plot})
    errors = batch.count(ERROR) > 0
    code = 1 if errors else 0 if batch.all_fitted else 3
    if not lead:  # every process ends with the batch and its exit code; one writes
        return code
    print(batch_table(batch))
    for e in batch.entries:
        for note in (e.report or {}).get("notes", []):
            print(f"note: {e.name}: {note}")
    if args.json:
        write_json(args.json, versioned({
            "processes": batch.processes, "wall_time_s": batch.seconds,
            "campaigns": [e.to_json() for e in batch.entries]}))
        if args.json != "-":
            print(f"wrote {args.json}")
    if args.csv:
        write_text(args.csv, batch_csv(batch))
        print(f"wrote {args.csv}")
    if args.plot:
        from ..report.plots import batch_figure, interruptible

        interruptible(batch_figure, batch, args.plot)
        print(f"wrote {args.plot}")
    if errors:
        print("stickslip fit-batch: internal errors in some campaigns (see the table); run "
              "one of them with `stickslip --debug fit` for the traceback", file=sys.stderr)
    return code
