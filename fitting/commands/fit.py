"""`stickslip fit RECORDS...`: friction parameters of a campaign, with errors and diagnostics.

Prints a table (value, unit, standard error, 95 % interval; truth and error when the
records carry the truth they were made from), the identifiability warnings, and the
fit quality; `--json OUT` writes the same as JSON, `--plot OUT.png` the diagnostic
figure. Units: mu dimensionless, gamma s^-m, delta s^-n; internal kgf, mm, s.
`--model microsqueeze` fits h_e (mm) and Q (mm^4) in place of gamma and m, with the
viscosity `--eta` and the surface pair `--surface` given (`stickslip_fitting.microsqueeze_fit`).
"""

from __future__ import annotations

import math

import numpy as np

from stickslip_jax.modes import GaugeOffset, SlipTime

from ..modes import ModelModes, Objective

NAME = "fit"
HELP = "fit the friction parameters (eq 1, eq 3) to a campaign of records"


def __getattr__(name):
    # imported where used, so the parser is built without the fitting code; the old
    # module-level names still resolve
    if name in ("find_truth", "load_campaign"):
        from .. import campaign

        return getattr(campaign, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    from stickslip_jax.commands.options import add_json_option, add_plot_option, add_quiet_option

    add_json_option(parser, "the result")
    add_plot_option(parser, "the diagnostic figure")
    add_quiet_option(parser)


def add_campaign_fit_arguments(parser, *, objective_help: str, strict_help: str,
                               old_offset_name: bool = True):
    """The options of one campaign's fit (--model, --gauge-offset, --slip-time,
    --objective, --strict, --fix, --loss, --eta, --surface): shared by `stickslip fit`
    and `fit-batch`, each with its own help for --objective and --strict."""
    parser.add_argument("--model", choices=("empirical", "microsqueeze"), default="empirical",
                        help="static-friction law: eq (1) (default) or the microsqueeze law")
    add_gauge_offset_argument(parser, old_name=old_offset_name)
    add_slip_time_argument(parser)
    add_objective_argument(parser, help=objective_help)
    parser.add_argument("--strict", action="store_true", help=strict_help)
    add_model_arguments(parser)


def add_objective_argument(parser, help: str):
    """--objective (`stickslip_fitting.modes.Objective`'s values, default "features"):
    shared by `fit` and `mcmc`, each with its own help."""
    parser.add_argument("--objective", choices=Objective.choices(),
                        default=Objective.FEATURES.value, help=help)


def add_slip_time_argument(parser):
    """--slip-time (`stickslip_jax.modes.SlipTime`'s values): shared by `fit` and `mcmc`."""
    parser.add_argument("--slip-time", choices=SlipTime.choices(), default=SlipTime.PAPER.value,
                        help="T2 in eq (3): pi/omega0 (eq 7, default) or the actual slip time")


def add_gauge_offset_argument(parser, old_name: bool = True):
    """--gauge-offset (old name --offset, hidden, unless `old_name` is False: a command
    newer than the rename; `stickslip_jax.modes.GaugeOffset`'s values): shared by
    `stickslip fit`, `mcmc` and `fit-batch`."""
    import argparse

    parser.add_argument("--gauge-offset", dest="offset", choices=GaugeOffset.choices(),
                        default=GaugeOffset.ZERO.value,
                        help="gauge offset: trust the zero (default), or read it from the first "
                        "sample of records that start with the spring relaxed")
    if not old_name:
        return
    # the old name (`stickslip pitch --drive-offset` is a length: one name per concept)
    parser.add_argument("--offset", dest="offset", choices=GaugeOffset.choices(),
                        default=argparse.SUPPRESS, help=argparse.SUPPRESS)


def add_model_arguments(parser):
    """--fix, --eta, --surface: shared by `stickslip fit` and `stickslip mcmc`."""
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
    parser.add_argument("--surface", default="S1G1",
                        help="--model microsqueeze: surface pair of Table 10 (default S1G1)")


def fit_from_args(args, *, objective: Objective | str = "features"):
    """Read the campaign of `args.records`, screen it and fit `args.model` to the records
    with usable stick-slip (`stickslip_fitting.campaign`; all of them with `args.strict`).

    Returns (fit, campaign, extra): `extra` is None or the given quantities of the
    microsqueeze model ({"given": {"eta": ..., "surface": ...}}). Every user error is a
    ValueError naming the option or file to fix (checked before any fitting).
    """
    from ..campaign import load_campaign
    from ..fit import fit_features
    from ..losses import parse_loss
    from ..params import Hold

    objective = Objective.parse(objective)
    loss = parse_loss(args.loss)
    modes = ModelModes(offset=GaugeOffset.parse(args.offset, "offset"),
                       slip_time=SlipTime.parse(args.slip_time))
    if args.model == "microsqueeze":
        from stickslip_jax.contact import surface_pair

        from ..microsqueeze_fit import default_eta, fit_microsqueeze
        from ..microsqueeze_params import MicrosqueezeFriction

        fixed = parse_fix(args.fix, MicrosqueezeFriction)
        hold = Hold.named(fixed) if fixed else None
        try:
            pair = surface_pair(args.surface)
        except (KeyError, ValueError) as err:
            raise ValueError(f"--surface: unknown surface pair {args.surface!r} ({err})") from None
        campaign = load_campaign(args.records, strict=getattr(args, "strict", False))
        eta = args.eta if args.eta is not None else default_eta(campaign.records[0].lubricant)
        _say_fitting(args, campaign, objective)
        fit = fit_microsqueeze(campaign.features, eta=eta, pair=pair, hold=hold, modes=modes,
                               objective=objective, records=campaign.records, loss=loss)
        return fit, campaign, {"given": {"eta": {"value": eta, "unit": "kgf*s/mm^2"},
                                        "surface": args.surface}}
    if args.eta is not None:
        raise ValueError("--eta: only used with --model microsqueeze")
    fixed = parse_fix(args.fix)
    campaign = load_campaign(args.records, strict=getattr(args, "strict", False))
    _say_fitting(args, campaign, objective)
    fit = fit_features(campaign.features, hold=Hold.named(fixed) if fixed else None,
                       modes=modes, objective=objective, records=campaign.records, loss=loss)
    return fit, campaign, None


def _say_fitting(args, campaign, objective) -> None:
    """One stage line (the `stickslip` logger: stderr unless --quiet) once the inputs are
    read and checked."""
    from stickslip_jax.logs import logger

    n = sum(s.status == "used" for s in campaign.screening)
    loss = "" if args.loss == "gaussian" else f", loss {args.loss}"
    logger.info(f"fitting {n} records (objective {objective}{loss}, model {args.model})...")


def parse_fix(items, law=None) -> dict[str, float]:
    """{name: value} from `--fix NAME=VALUE` options, checked against the friction law
    `law` (an `AbstractFrictionParams` subclass, default the empirical law): known names,
    each at most once, values inside the law's physical range (its MCMC prior support),
    mu_s > mu_d when both are given, and at least one parameter left to fit."""
    from ..params import EmpiricalFriction

    law = EmpiricalFriction if law is None else law
    names, bounds, units = law.NAMES, law.PRIOR_BOUNDS, law.UNITS
    out = {}
    for item in items:
        name, _, value = item.partition("=")
        name = name.strip()
        if name not in names or not value:
            raise ValueError(f"--fix: expected NAME=VALUE with NAME in {', '.join(names)}, "
                             f"got {item!r}")
        try:
            v = float(value)
        except ValueError:
            raise ValueError(f"--fix {name}: {value!r} is not a number") from None
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"--fix {name}: the value must be positive and finite, got {v}")
        if name in out and out[name] != v:
            raise ValueError(f"--fix {name}: given twice ({out[name]:g} and {v:g}); give it "
                             "once")
        lo, hi = bounds[name]
        if not lo <= v <= hi:
            unit = "" if units[name] == "-" else f" {units[name]}"
            raise ValueError(f"--fix {name}={v:g} lies outside the physical range "
                             f"{lo:g}-{hi:g}{unit} of {name}")
        out[name] = v
    if "mu_s" in out and "mu_d" in out and not out["mu_s"] > out["mu_d"]:
        raise ValueError(f"--fix: mu_s ({out['mu_s']:g}) must exceed mu_d ({out['mu_d']:g})")
    if len(out) == len(names):
        raise ValueError("--fix: every parameter is fixed, nothing is left to fit; leave at "
                         "least one free")
    return out


FIXED_MISFIT = 100.0
"""With fixed values, a median record chi2/n (before any error scaling) above this means
the fixed values do not describe the records: said in a warning."""


def build_report(fit, unc, campaign, *, model="empirical", extra=None) -> dict:
    """The JSON-ready result of a fit (the `--json` contract).

    `records` lists every record given, in order: the used ones with their fitted gauge
    offset, the others with `status` and `reason` (`stickslip_fitting.campaign`);
    `steady_records` compares records without stick-slip with the fitted boundary."""
    from ..campaign import Campaign, boundary_check, find_truth

    if not isinstance(campaign, Campaign):  # a plain list of records: all used
        from ..campaign import screen_records

        campaign = screen_records(list(campaign), min_records=1)
    records = campaign.records
    truth = find_truth(records, fit.params.friction.NAMES)
    bounds = fit.params.friction.PRIOR_BOUNDS  # the support: a value there is "at bound"
    params = {e.name: e.with_bounds(bounds).to_json() for e in unc.estimates(truth)}
    from ..adequacy import adequacy
    from ..combined import FeaturesObjective
    from ..fit import compiled
    from ..losses import loss_of
    from ..objectives import feature_residuals

    res = compiled(feature_residuals, fit.params, fit.data, fit.slip_time)
    level_sd = np.asarray(fit.data.trough_sd)
    levels = FeaturesObjective(fit.data).split(res)["levels"].reshape(level_sd.shape) * level_sd
    mask = np.asarray(fit.data.has_end | fit.data.has_next)
    rms = float(np.sqrt(np.mean(levels[mask] ** 2))) if mask.any() else float("nan")
    out = {
        "model": model,
        "parameters": params,
        "records": _record_rows(fit, campaign),
        "records_not_used": sum(s.status != "used" for s in campaign.screening),
        "steady_records": boundary_check(fit.params.friction.friction(), campaign),
        "residual_rms_mm": rms,
        "chi2": fit.chi2,
        "dof": fit.dof,
        "reduced_chi2": fit.reduced_chi2,
        "converged": fit.converged,
        "objective": fit.objective.describe(),
        "loss": loss_of(fit.objective).spec(),
        "slip_time": str(fit.slip_time),
        "covariance": unc.covariance,
        "covariance_scale": unc.scale,
        "identifiability": {
            "not_identifiable": [n for n, ok in unc.identifiable.items() if not ok],
            "fisher_eigenvalues_log": [float(x) for x in unc.fisher_eigenvalues],
            "weakest_direction": unc.weakest_direction,
            "correlation": [[None if not np.isfinite(x) else float(x) for x in row]
                            for row in unc.corr],
            "warnings": list(unc.warnings) + _fixed_misfit(fit, unc),
        },
        "truth_available": truth is not None,
        "adequacy": adequacy(fit).to_json(),
    }
    td = fit.objective.trace_data()
    if td is not None:
        from ..trace_objective import reslip_windows, trace_residuals

        rt = np.asarray(compiled(trace_residuals, fit.params, td, fit.slip_time))
        rt = rt.reshape(td.mask.shape)
        rt = rt * np.asarray(td.sigma)[:, None]
        out["trace_residual_rms_mm"] = float(np.sqrt(np.mean(rt[np.asarray(td.mask)] ** 2)))
        out["trace_samples"] = td.n_residuals()
        out["trace_window_failures"] = fit.trace_failures
        out["trace_windows_after_reslip"] = reslip_windows(fit.features)
    if extra:
        out.update(extra)
    return out


def fixed_misfit_warning(fixed: list[str], record_chi2, consequence: str) -> list[str]:
    """A warning when the fixed values (`fixed`: "name=value" strings) leave the records
    far from the model (median record chi2/n above `FIXED_MISFIT`); `consequence` says
    what is then not meaningful (shared by `fit` and `mcmc`)."""
    if not fixed or record_chi2 is None:
        return []
    med = float(np.median(record_chi2))
    if med <= FIXED_MISFIT:
        return []
    return [f"with the fixed values ({', '.join(fixed)}) the model misses the records far "
            f"beyond their noise (median record chi2/n {med:.3g} before scaling their errors): "
            f"the fixed values are incompatible with these records, and {consequence}."]


def _fixed_misfit(fit, unc) -> list[str]:
    """A warning when fixed values leave the records far from the model (`FIXED_MISFIT`)."""
    return fixed_misfit_warning([f"{e.name}={e.value:g}" for e in unc.estimates() if e.fixed],
                                fit.record_chi2,
                                "the other estimates and their intervals are not meaningful")


def _record_rows(fit, campaign) -> list[dict]:
    offsets = np.asarray(fit.params.offset)
    used = {f.name: i for i, f in enumerate(fit.features)}
    rows = []
    chi = fit.record_chi2
    scale = fit.record_scale
    for s in campaign.screening:
        row = s.to_json()
        if s.status == "used" and s.name in used:
            i = used[s.name]
            row["gauge_offset_mm"] = float(offsets[i])
            if chi is not None:
                row["features_chi2_per_residual"] = float(chi[i])
                row["error_scale"] = float(scale[i]) if scale is not None else 1.0
        rows.append(row)
    return rows


def format_table(report) -> str:
    """The printed result: one row per parameter (value, unit, standard error, 95 %
    interval; truth and error when the records carry it; a note: fixed, not identifiable
    with the reason, at a bound), then the fit's quality, warnings and notes. A parameter
    the records do not determine shows "-", never its placeholder value."""
    from ..report import note_text, text_table, value_text

    truth = report["truth_available"]
    header = ["parameter", "value", "unit", "std err", "95 % interval"]
    if truth:
        header += ["truth", "error"]
    header.append("note")
    rows = []
    for name, p in report["parameters"].items():
        shown = (p["stderr"] is not None and not p["fixed"] and p["value"] is not None
                 and not p.get("at_bound"))
        row = [name, value_text(p), p["unit"], f"{p['stderr']:.3g}" if shown else "-",
               f"[{p['ci95'][0]:.5g}, {p['ci95'][1]:.5g}]" if shown and p["ci95"] else "-"]
        if truth:
            err = p.get("relative_error")
            row += [f"{p['truth']:.5g}" if p.get("truth") is not None else "-",
                    "-" if err is None else f"{100 * err:.2f}%"]
        row.append(note_text(p))
        rows.append(row)
    align = "lrlrr" + ("rr" if truth else "") + "l"
    if not any(r[-1] for r in rows):  # nothing to note: no empty column
        header, rows, align = header[:-1], [r[:-1] for r in rows], align[:-1]
    lines = text_table(header, rows, align).splitlines()
    lines.append("")
    used = [r for r in report["records"] if r.get("status", "used") == "used"]
    lines.append(
        f"{len(used)} records, "
        f"{sum(r['complete_cycles'] for r in used)} complete cycles; "
        f"residual rms {report['residual_rms_mm'] * 1e3:.3g} um; chi2/dof = "
        f"{report['reduced_chi2']:.3g}; converged: {report['converged']}"
    )
    worst = max((r.get("features_chi2_per_residual", 0.0) for r in used), default=0.0)
    if any(r.get("error_scale", 1.0) > 1.0 for r in used):
        lines[-1] += (f" (after scaling record errors to their scatter; before, chi2/n up to "
                      f"{worst:.3g}: the model does not describe the records to their noise)")
    if "trace_residual_rms_mm" in report:
        lines.append(
            f"objective: {report['objective']}; {report['trace_samples']} samples, trace "
            f"residual rms {report['trace_residual_rms_mm'] * 1e3:.3g} um"
            + (f"; {report['trace_window_failures']} cycle simulations failed"
               if report["trace_window_failures"] else "")
            + (f"; {report['trace_windows_after_reslip']} cycles after a re-slip left out"
               " of the trace (features only)" if report["trace_windows_after_reslip"] else "")
        )
    if report.get("loss", "gaussian") != "gaussian":
        lines.append(f"likelihood: {report['loss']} loss (heavy-tailed; the intervals are "
                     f"the M-estimator's sandwich, covariance {report['covariance']})")
    for sentence in report.get("adequacy", {}).get("sentences", []):
        lines.append("adequacy: " + sentence)
    for w in report["identifiability"]["warnings"]:
        lines.append("warning: " + w)
    for r in report["records"]:
        if r.get("status", "used") != "used":
            lines.append(f"warning: {r['name']}: {r['status'].replace('_', ' ')}, not fitted "
                         f"({r['reason']})")
    scaled = [r for r in used if r.get("error_scale", 1.0) > 1.0]
    if scaled:
        lines.append(
            "warning: the model describes these records worse than their noise; their "
            "feature errors were scaled to their scatter (chi2/n before scaling): "
            + ", ".join(f"{r['name']} ({r['features_chi2_per_residual']:.3g})" for r in scaled))
    for s in report.get("steady_records", []):
        lines.append(("warning: " if s["misfit"] else "note: ") + s["message"])
    return "\n".join(lines)


def run(args) -> int:
    from stickslip_jax.output import check_outputs, versioned, write_json
    from stickslip_jax.records import record_paths

    from ..uncertainty import laplace

    check_outputs({"--json": args.json, "--plot": args.plot}, record_paths(args.records))
    import sys

    from stickslip_jax.logs import logger

    fit, campaign, extra = fit_from_args(args, objective=args.objective)
    logger.info(f"fit {'converged' if fit.converged else 'did not converge'}; intervals...")
    records = campaign.records
    unc = laplace(fit)
    report = build_report(fit, unc, campaign, model=args.model, extra=extra)
    logger.info("report done")
    print(format_table(report))
    for n in campaign.notes:
        print("note: " + n)

    if args.json:
        write_json(args.json, versioned(report))
        if args.json != "-":
            print(f"wrote {args.json}")
    if args.plot:
        from ..plots import fit_figure

        logger.info("drawing the figure...")
        reasons = {s.name: s.reason for s in campaign.screening}
        fit_figure(fit, unc, records, args.plot,
                   not_used=[(r, reasons.get(f.name) or "not used") for r, f in campaign.not_used])
        print(f"wrote {args.plot}")
    if not fit.converged:
        print("stickslip fit: the fit did not converge (see the warnings): the values above "
              "are not an optimum", file=sys.stderr)
        return 3
    return 0
