"""`stickslip simulate`: a synthetic record (exact or smoothed simulator) with its truth."""

from __future__ import annotations

import argparse
import os

from .options import add_slideway_options, quantity

NAME = "simulate"
HELP = ("simulate a run of the slideway (paper's model) and write it as a record CSV "
        "with a '# truth:' header")


def add_arguments(p):
    p.add_argument("--lubricant", default="A", help="paper lubricant of Table 6 (A or C)")
    add_slideway_options(p)
    p.add_argument("--speed", type=quantity("speed", "mm/min"),
                   help="constant drive speed v (mm/min unless a unit is given)")
    p.add_argument("--drive-program", default=None,
                   help="piecewise-constant drive instead of --speed: "
                        "'0 s 1 mm/min; 30 s 0 mm/min; 60 s 1 mm/min'")
    p.add_argument("--duration", type=quantity("time", "s"), required=True,
                   help="record length (s)")
    p.add_argument("--sample-rate", type=float, default=1000.0, help="samples per second")
    p.add_argument("--noise", type=quantity("length", "mm", positive=False), default=0.0,
                   help="white-noise standard deviation of the deflection (mm, or '0.5um')")
    p.add_argument("--seed", type=int, default=0, help="random seed of the noise")
    p.add_argument("--smooth", type=float, default=None, metavar="EPS",
                   help="use the smoothed simulator with smoothing EPS (e.g. 1e-3) "
                        "instead of the exact one")
    p.add_argument("--max-events", type=int, default=None,
                   help="event budget of the exact simulator (default: from the steady T1)")
    p.add_argument("--out", required=True, help="output CSV path")
    p.add_argument("--force", dest="overwrite", action="store_true",
                   help="replace an existing --out file")


def run(args) -> int:
    from ..drives import ConstantSpeed, program_drive
    from ..lubricants import lubricant, lubricants
    from ..output import check_outputs
    from ..records import parse_drive_program, write_record
    from ..slideway import Slideway

    check_outputs({"--out": args.out})
    if not 0 <= args.seed < 2**63:
        raise ValueError(f"--seed: must be between 0 and 2**63 - 1, got {args.seed}")
    from ..simulation.synthetic import synthetic_record

    if args.lubricant not in lubricants(6):
        raise ValueError(f"--lubricant: unknown lubricant {args.lubricant!r}; "
                         f"Table 6 has {', '.join(lubricants(6))}")
    if (args.speed is None) == (args.drive_program is None):
        raise ValueError("--speed / --drive-program: give exactly one of them")
    if not args.sample_rate > 0 or args.sample_rate != args.sample_rate:
        raise ValueError("--sample-rate: must be a positive number of samples per second")
    if args.noise < 0:
        raise ValueError("--noise: must be >= 0")
    if args.smooth is not None and not 0 < args.smooth < 1:
        raise ValueError("--smooth: smoothing must be between 0 and 1 (e.g. 1e-3)")
    if args.duration * args.sample_rate > 5e6:
        raise ValueError("--duration * --sample-rate: more than 5e6 samples; shorten the run")
    if args.speed is not None:
        drive = ConstantSpeed(args.speed)
    else:
        try:
            program = parse_drive_program(args.drive_program)
        except (ValueError, argparse.ArgumentTypeError) as exc:
            raise ValueError(f"--drive-program: {exc}") from None
        drive = program_drive(program)
    if os.path.exists(args.out) and not args.overwrite:  # after the values, before the work
        raise ValueError(f"--out: {args.out} exists; use --force to replace it")
    slideway = Slideway(lubricant(args.lubricant), args.weight, args.stiffness,
                        normal_load=args.normal_load)
    record = synthetic_record(
        slideway, drive, args.duration, args.sample_rate, noise_std=args.noise,
        seed=args.seed, smoothing=args.smooth, max_events=args.max_events,
        lubricant=args.lubricant)
    path = write_record(record, args.out)
    truth = record.truth
    print(f"wrote {path}: {record.time.size} samples, {truth['cycles']} cycles, "
          f"simulator {truth['simulator']['name']}"
          + (", steady sliding" if truth["steady_sliding"] else ""))
    return 0
