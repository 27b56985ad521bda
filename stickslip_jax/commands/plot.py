"""`stickslip plot RECORD [--plot OUT.png]`: the trace with stick/slip phases and its
phase plane; by default NAME.png in the current folder, never beside the record in its
data folder (NAME: the record's file name without its extension)."""

from __future__ import annotations

from pathlib import Path

NAME = "plot"
HELP = ("save a PNG of a record: deflection vs time with stick and slip phases marked, "
        "and the phase plane x vs xdot/omega0 (Figs 34/35)")


def add_arguments(p):
    from .options import add_plot_option

    p.add_argument("record", help="record file (CSV; the format: docs/records.md)")
    add_plot_option(p, "the figure (default: NAME.png in the current folder, NAME the "
                    "record's file name without its extension)", hidden=("--out",))


def run(args) -> int:
    from ..record_plots import classify_phases, save_record_plot
    from ..records import read_record

    flag = args.plot_option
    if Path(args.record).is_dir():
        raise ValueError(f"{args.record}: is a folder, not a record file; give one of its "
                         "record files")
    out = Path(args.plot) if args.plot else Path(Path(args.record).with_suffix(".png").name)
    if out.suffix.lower() != ".png":
        raise ValueError(f"{flag}: {out} must end in .png")
    if not out.parent.is_dir():
        raise ValueError(f"{flag}: directory {out.parent} does not exist; create it first")
    from ..output import check_outputs

    check_outputs({flag: str(out)}, [args.record])
    record = read_record(args.record)
    phases = classify_phases(record)
    try:
        save_record_plot(record, out, phases)
    except OSError as exc:
        raise ValueError(f"{flag}: cannot write {out}: {exc.strerror or exc}") from None
    n = phases.n_slips
    sliding = "".join(f", {100 * share:.0f} % {name}" for share, name in (
        (phases.pause_fraction, "in pauses within slips"), (phases.sliding_fraction, "sliding"))
        if share >= 0.005)
    print(f"{out}: {record.n_samples} samples, {n} slip{'' if n == 1 else 's'}, "
          f"{100 * phases.stick_fraction:.0f} % of samples in stick{sliding} "
          f"(slip threshold {phases.threshold:.3g} mm/s, window {phases.window} samples)")
    if phases.verdict:
        print(f"note: {args.record}: {phases.verdict}")
    if phases.glitches:
        print(f"note: {args.record}: {phases.glitches} single-sample spike(s) (glitches) left "
              "out of the phase detection")
    if phases.quantum:
        print(f"note: {args.record}: quantised in steps of {phases.quantum:.3g} mm; one step "
              "within the slope window is not counted as a slip")
    return 0
