"""`stickslip pitch`: pitching and yawing of the slider from a record's spring force (chapter 6).

    stickslip pitch RECORD [RECORD ...] --height H [H ...] [--drive-offset L [L ...]]
                    [--viscosity ETA] [--fit] [--json OUT.json] [--plot OUT.png]

For each record the model of `stickslip_jax.pitching` turns the spring force k x into the
tilt at the drive point (height H, offset L from the centre of gravity; mm unless a unit
is given) and prints, per measuring point, the tilt eps' (signed extreme), the mean and
the variation d_eps over the second half of the record in um, with the measured values
of the channels the record carries (`pitch_N`, `yaw_N`). `--fit` identifies the model
from those channels first (`solve.pitch`); without it the model is `default_model()`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from stickslip_jax.commands.options import (add_json_option, add_plot_option, quantity, viscosity)

NAME = "pitch"
HELP = "pitching/yawing (chapter 6) of the slider from records: tilt, its variation, fit"


def add_arguments(p):
    p.add_argument("records", nargs="+", metavar="RECORD", help="record CSV file(s)")
    p.add_argument("--height", type=quantity("length", "mm", positive=False), nargs="+",
                   help="drive height h above the slide surface (mm; one, or one per record); "
                   "default: the record's '# drive_height:' header")
    p.add_argument("--drive-offset", dest="drive_offset",
                   type=quantity("length", "mm", positive=False), nargs="+",
                   help="drive offset l from the centre of gravity (mm; one, or one per record); "
                   "default: the '# drive_offset:' header, else 0")
    # the old name (`stickslip fit --gauge-offset` is a mode: one name per concept)
    p.add_argument("--offset", dest="drive_offset", type=quantity("length", "mm", positive=False),
                   nargs="+", default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    p.add_argument("--viscosity", type=viscosity(), default=None,
                   help="lubricant viscosity (Pa*s unless a unit is given, e.g. '216 cP' or "
                   "'230 cSt at 870 kg/m^3'; default lubricant A, 0.216 Pa*s)")
    p.add_argument("--fit", action="store_true",
                   help="identify compliance, neutral points and time constants from the "
                   "records' pitch_N/yaw_N channels first")
    add_json_option(p, "the results")
    add_plot_option(p, "the force and displacement traces")


def _per_record(values, n, flag):
    if values is None:
        return [None] * n
    if len(values) == 1:
        return list(values) * n
    if len(values) != n:
        raise ValueError(f"{flag}: give one value or one per record ({n}), got {len(values)}")
    return list(values)


def _um(x):
    from stickslip_jax.units import from_internal

    return float(from_internal(float(x), "um", "length"))


JSON_ALIASES = {
    "drive_height_mm": "height_mm", "drive_offset_mm": "offset_mm",
    "eps_prime_um": "eps_prime", "mean_um": "mean", "d_eps_um": "d_eps",
    "measured_eps_prime_um": "measured_eps_prime", "measured_d_eps_um": "measured_d_eps"}
"""JSON keys renamed to the one convention (`stickslip_jax.output.UNIT_SUFFIXES`) ->
their old names, still written beside them for one release (`deprecated_keys`)."""


def run(args) -> int:
    from stickslip_jax import pitching as pt
    from stickslip_jax.output import check_outputs, versioned, write_json
    from stickslip_jax.records import read_record
    from stickslip_jax.units import from_internal

    from ..solve.pitch import fit_pitching, pitch_run

    paths = [Path(p) for p in args.records]
    for p in paths:
        if not p.is_file():
            raise ValueError(f"RECORD: no such file {str(p)!r}")
    check_outputs({"--json": args.json, "--plot": args.plot}, paths)
    records = [read_record(p) for p in paths]
    heights = _per_record(args.height, len(records), "--height")
    offsets = _per_record(args.drive_offset, len(records), "--drive-offset")
    model = pt.default_model()
    if args.viscosity is not None:
        model = model.with_viscosity(args.viscosity)
    runs = [pitch_run(r, model, h, o) for r, h, o in zip(records, heights, offsets)]
    out = {"model": "fitted" if args.fit else "default", "records": [], "units": {
        "displacement": "um", "height": "mm", "offset": "mm", "viscosity": "Pa*s"}}
    out["viscosity_pa_s"] = float(from_internal(float(model.viscosity), "Pa*s", "viscosity"))
    if args.fit:
        fit = fit_pitching(runs, template=model)
        model = fit.model
        # the reports' typed rows (value, stderr, ci95, unit, fixed, ...) and "free"
        out["parameters"] = {e.name: {**e.to_json(), "free": not e.fixed}
                             for e in fit.estimates()}
        out["residual_rms_um"] = _um(fit.residual_rms_mm)
        out["notes"] = list(fit.notes)
        print(f"fit of {len(runs)} record(s): residual RMS {_um(fit.residual_rms_mm):.4g} um, "
              f"{'converged' if fit.successful else 'NOT converged'}")
        print(f"{'parameter':>18} {'value':>12} {'stderr':>11} {'95% interval':>27}  unit")
        for e in fit.estimates():
            if not e.fixed:
                lo, hi = e.ci95
                print(f"{e.name:>18} {e.value:12.5g} {e.stderr:11.3g} "
                      f"[{lo:11.5g}, {hi:11.5g}]  {e.unit}")
            else:
                print(f"{e.name:>18} {e.value:12.5g} {'fixed':>11} {'':>27}  {e.unit}")
        for note in fit.notes:
            print(f"note: {note}")
    names = model.points.names
    traces = []
    for path, rec, run_ in zip(paths, records, runs):
        tr = pt.tilt_history(model, run_.time, run_.force, run_.drive)
        traces.append(tr)
        pred = pt.window_summary(tr.displacement, run_.time)
        meas = pt.window_summary(run_.displacement, run_.time)
        observed = np.asarray(run_.observed)
        h, o = float(run_.drive.height), float(run_.drive.offset)
        print(f"\n{path.name}: h = {h:g} mm, l = {o:g} mm "
              f"(arms h-h_Mv = {h - float(model.pitch.neutral):.4g} mm, "
              f"l-l_Mh = {o - float(model.yaw.neutral):.4g} mm)")
        print(f"{'point':>8} {'eps_model':>10} {'mean':>9} {'d_eps':>9} "
              f"{'eps_meas':>10} {'d_eps_meas':>11}   [um]")
        rows = []
        for i, name in enumerate(names):
            row = {"point": name, "eps_prime_um": _um(pred.peak[i]),
                   "mean_um": _um(pred.mean[i]), "d_eps_um": _um(pred.variation[i])}
            line = (f"{name:>8} {row['eps_prime_um']:10.4g} {row['mean_um']:9.4g} "
                    f"{row['d_eps_um']:9.4g}")
            if observed[i]:
                row["measured_eps_prime_um"] = _um(meas.peak[i])
                row["measured_d_eps_um"] = _um(meas.variation[i])
                line += (f" {row['measured_eps_prime_um']:10.4g}"
                         f" {row['measured_d_eps_um']:11.4g}")
            print(line)
            rows.append(row)
        out["records"].append({"file": str(path), "drive_height_mm": h, "drive_offset_mm": o,
                               "points": rows})
    if args.json:
        write_json(args.json, versioned(out, JSON_ALIASES))
    if args.plot:
        _plot(args.plot, paths, runs, traces, names)
    return 0


def _plot(out, paths, runs, traces, names):
    """Per record (a column): the spring force, the vertical (pitch) and horizontal (yaw)
    displacements, model lines and measured dots, one colour per point; the legend of
    every point below the panels, where it hides nothing."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    from ..report.plots import finish_figure

    fig, axes = plt.subplots(3, len(runs), figsize=(4.5 * len(runs), 8.4), squeeze=False,
                             sharex="col", layout="constrained")
    for j, (path, run_, tr) in enumerate(zip(paths, runs, traces)):
        t = np.asarray(run_.time)
        axes[0, j].plot(t, np.asarray(run_.force), "k", lw=0.8)
        axes[0, j].set_ylabel("spring force F = kx [kgf]")
        axes[0, j].set_title(path.name, fontsize=9)
        for i, name in enumerate(names):
            ax = axes[1 if name.startswith("pitch") else 2, j]
            ax.plot(t, 1e3 * np.asarray(tr.displacement[:, i]), lw=1.0, color=f"C{i}")
            if bool(run_.observed[i]):
                ax.plot(t, 1e3 * np.asarray(run_.displacement[:, i]), ".", ms=1.5,
                        color=f"C{i}")
        axes[1, j].set_ylabel("vertical displacement [um]")
        axes[2, j].set_ylabel("horizontal displacement [um]")
        axes[2, j].set_xlabel("time [s]")
    handles = [Line2D([], [], lw=1.0, color=f"C{i}", label=name) for i, name in enumerate(names)]
    handles.append(Line2D([], [], ls="none", marker=".", color="0.3", label="measured"))
    fig.legend(handles=handles, loc="outside lower center", ncols=min(len(handles), 3 * len(runs)),
               fontsize=8)
    fig.suptitle("pitching (points 1-3) and yawing (4-5):" + ("\n" if len(runs) == 1 else " ")
                 + "model lines, measured dots")
    finish_figure(fig, out, 110)
