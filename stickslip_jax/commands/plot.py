"""`stickslip plot RECORD [--out PNG]`: the trace with stick/slip phases and its phase plane."""

from __future__ import annotations

from pathlib import Path

NAME = "plot"
HELP = ("save a PNG of a record: deflection vs time with stick and slip phases marked, "
        "and the phase plane x vs xdot/omega0 (Figs 34/35)")


def add_arguments(p):
    p.add_argument("record", help="record file (CSV, see README 'Records')")
    p.add_argument("--out", default=None,
                   help="PNG to write (default: next to the record, NAME.png)")


def run(args) -> int:
    from ..record_plots import classify_phases, save_record_plot
    from ..records import read_record

    out = Path(args.out) if args.out else Path(args.record).with_suffix(".png")
    if out.suffix.lower() != ".png":
        raise ValueError(f"--out: {out} must end in .png")
    if not out.parent.is_dir():
        raise ValueError(f"--out: directory {out.parent} does not exist; create it first")
    from ..output import check_outputs

    check_outputs({"--out": str(out)}, [args.record])
    record = read_record(args.record)
    phases = classify_phases(record)
    try:
        save_record_plot(record, out, phases)
    except OSError as exc:
        raise ValueError(f"--out: cannot write {out}: {exc.strerror or exc}") from None
    print(
        f"{out}: {record.n_samples} samples, {phases.n_slips} slips, "
        f"{100 * phases.stick_fraction:.0f} % of samples in stick "
        f"(slip threshold {phases.threshold:.3g} mm/s, window {phases.window} samples)"
    )
    return 0
