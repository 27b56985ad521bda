"""The report of a campaign fit: the `--json` document of `stickslip fit` (`build_report`)
and its printed table (`format_table`), for the command, `stickslip_fitting.fit` and
`fit-batch` (whose table and long CSV are `batch_table` and `batch_csv`)."""

from __future__ import annotations

import numpy as np

__all__ = ["FIXED_MISFIT", "batch_csv", "batch_table", "build_report", "fit_text",
           "fixed_misfit_warning", "format_table"]

FIXED_MISFIT = 100.0
"""With fixed values, a median record chi2/n (before any error scaling) above this means
the fixed values do not describe the records: said in a warning."""


def build_report(fit, unc, campaign, *, extra=None, truth=None, figures=None, estimates=None,
                 checks=None, screening=None) -> dict:
    """The JSON-ready result of a fit (the `--json` contract), from the values the steps
    before it handed on: `fit` (`solve.fit.FitResult`), `unc`
    (`uncertainty.laplace.Uncertainty`), `campaign` (`data.campaign.Campaign`), `truth`
    (the records' parameters, `data.campaign.find_truth`), `figures`
    (`solve.summary.FitFigures`), `estimates` (`unc.estimates(truth)`), `checks` (the
    JSON of `uncertainty.adequacy.adequacy`) and `screening` (the JSON of each record's
    `RecordStatus`); "model" names the fitted law (its `MODEL`). A call without
    `figures` (a notebook's, with the fit alone) finds them here.

    `records` lists every record given, in order: the used ones with their fitted gauge
    offset, the others with `status` and `reason` (`stickslip_fitting.data.campaign`);
    `steady_records` compares records without stick-slip with the fitted boundary
    (`solve.summary.boundary_check`)."""
    from ..data.campaign import ONE_RECORD_HOLDS, Campaign

    if not isinstance(campaign, Campaign):  # a plain list of records: all used
        from ..data.campaign import screen_records

        campaign = screen_records(list(campaign), min_records=1)
    if figures is None:  # the fit alone: what the steps before the report give
        from ..data.campaign import find_truth
        from ..solve.summary import fit_figures
        from ..uncertainty.adequacy import adequacy

        truth = find_truth(campaign.records, fit.params.friction.NAMES)
        figures, estimates = fit_figures(fit, campaign), unc.estimates(truth)
        checks, screening = adequacy(fit).to_json(), [s.to_json() for s in campaign.screening]
    records = campaign.records
    bounds = fit.params.friction.PRIOR_BOUNDS  # the support: a value there is "at bound"
    params = {e.name: e.with_bounds(bounds).to_json() for e in estimates}
    held = [n for n in ONE_RECORD_HOLDS if len(records) == 1 and params.get(n, {}).get("fixed")]
    for n in held:  # fixed at a value one record cannot check: said with the reason
        params[n].update(identifiable=False, reason="not identifiable from one record: "
                         + ONE_RECORD_HOLDS[n])
    steady = list(figures.steady_records)
    unknown = [n for n, ok in unc.identifiable.items() if not ok]
    if unknown:  # the boundary of a model the records do not determine predicts nothing
        steady = [dict(s, predicted_amplitude_um=None, critical_speed_mm_per_min=None,
                       misfit=None, message=f"{s['name']}: slides steadily; not compared with "
                       f"the fitted model ({', '.join(unknown)} not identifiable)")
                  for s in steady]
    out = {"model": fit.params.friction.MODEL, "parameters": params, "records": _record_rows(fit, campaign, screening),
           "records_not_used": sum(s.status != "used" for s in campaign.screening),
           "steady_records": steady,
           "residual_rms_mm": figures.residual_rms_mm, "chi2": figures.chi2,
           "dof": figures.dof, "reduced_chi2": figures.reduced_chi2,
           "converged": figures.converged, "objective": figures.objective,
           "loss": figures.loss, "slip_time": figures.slip_time, "covariance": unc.covariance,
           "covariance_scale": unc.scale,
           "identifiability": {
               "not_identifiable": [n for n, ok in unc.identifiable.items()
                                    if not ok or n in held],
               "fisher_eigenvalues_log": [float(x) for x in unc.fisher_eigenvalues],
               "weakest_direction": unc.weakest_direction,
               "correlation": [[None if not np.isfinite(x) else float(x) for x in row]
                               for row in unc.corr],
               "warnings": list(unc.warnings) + fixed_misfit_warning(
                   [f"{e.name}={e.value:g}" for e in estimates if e.fixed],
                   fit.record_chi2, "the other estimates and their intervals are not "
                   "meaningful")},
           "truth_available": truth is not None,
           "adequacy": checks}
    if figures.trace_samples is not None:
        out.update(trace_residual_rms_mm=figures.trace_residual_rms_mm,
                   trace_samples=figures.trace_samples,
                   trace_window_failures=figures.trace_window_failures,
                   trace_windows_after_reslip=figures.trace_windows_after_reslip)
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


def _record_rows(fit, campaign, screening) -> list[dict]:
    offsets = np.asarray(fit.params.offset)
    used = {f.name: i for i, f in enumerate(fit.features)}
    rows = []
    chi = fit.record_chi2
    scale = fit.record_scale
    for s, row in zip(campaign.screening, screening):
        row = dict(row)
        if s.status == "used" and s.name in used:
            i = used[s.name]
            row["gauge_offset_mm"] = float(offsets[i])
            if chi is not None:
                row["features_chi2_per_residual"] = float(chi[i])
                row["error_scale"] = float(scale[i]) if scale is not None else 1.0
        if "friction_radius_mm" in row:  # a rotational rig: its lengths as angles too
            row.update({k[:-3] + "_rad": row[k] / row["friction_radius_mm"]
                        for k in ("noise_mm", "gauge_offset_mm") if k in row})
        rows.append(row)
    return rows


def format_table(report) -> str:
    """The printed result: one row per parameter (value, unit, standard error, 95 %
    interval; truth and error when the records carry it; a note: fixed, not identifiable
    with the reason, at a bound), then the fit's quality, warnings and notes. A parameter
    the records do not determine shows "-", never its placeholder value."""
    from .rows import note_text, text_table, value_text

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
    lines.append(f"{len(used)} records, "
                 f"{sum(r['complete_cycles'] for r in used)} complete cycles; "
                 f"residual rms {report['residual_rms_mm'] * 1e3:.3g} um; chi2/dof = "
                 f"{report['reduced_chi2']:.3g}; converged: {report['converged']}")
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
               " of the trace (features only)" if report["trace_windows_after_reslip"] else ""))
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


def fit_text(report, notes) -> str:
    """What `stickslip fit` prints: the table (`format_table`), then the campaign's notes."""
    return "\n".join([format_table(report)] + [f"note: {n}" for n in notes])


def batch_table(batch) -> str:
    """The table `stickslip fit-batch` prints of a `solve.batch.BatchResult`: one row per
    campaign (status, records used, parameter values headed with their units, chi2/dof,
    time). A parameter the campaign does not determine shows "-", with the reason below
    the table; a fixed value or one at a bound says so in its cell; a campaign not fitted
    has "-" everywhere and its message below."""
    from .rows import note_text, text_table, value_text

    names = list(dict.fromkeys(p for e in batch.entries if e.report
                               for p in e.report["parameters"]))
    units = {}
    for e in batch.entries:
        for n, p in (e.report or {}).get("parameters", {}).items():
            units.setdefault(n, p.get("unit", "-"))
    header = (["campaign", "status", "records"]
              + [n if units[n] in ("-", "") else f"{n} [{units[n]}]" for n in names]
              + ["chi2/dof", "s"])
    rows, below = [], []
    for e in batch.entries:
        row = [e.name, e.status.replace("_", " ")]
        if e.report is None:
            rows.append(row + ["-"] * (len(header) - 3) + [f"{e.seconds:.1f}"])
            below.append(f"{e.name}: {e.status.replace('_', ' ')}: {e.message}")
            continue
        used = sum(r.get("status", "used") == "used" for r in e.report["records"])
        row.append(str(used))
        unknown: dict[str, list[str]] = {}
        for n in names:
            p = e.report["parameters"].get(n)
            if p is None:
                row.append("-")
                continue
            cell, note = value_text(p), note_text(p)
            if p.get("value") is None:
                unknown.setdefault(note.removeprefix("not identifiable: "), []).append(n)
            elif note:
                cell += " (fixed)" if p.get("fixed") else " (at bound)"
            row.append(cell)
        rows.append(row + [f"{e.report['reduced_chi2']:.3g}", f"{e.seconds:.1f}"])
        for reason, which in unknown.items():
            below.append(f"{e.name}: {', '.join(which)} not identifiable (-): {reason}")
    lines = text_table(header, rows, "ll" + "r" * (len(header) - 2)).splitlines()
    lines += [""] + below if below else []
    n = len(batch.entries)
    lines.append("")
    lines.append(f"{batch.count('fitted')} of {n} campaigns fitted"
                 + (f", {batch.count('not_converged')} did not converge"
                    if batch.count("not_converged") else "")
                 + (f", {batch.count('failed') + batch.count('error')} could not be fitted"
                    if batch.count("failed") + batch.count("error") else "")
                 + f"; {batch.processes} process{'es' if batch.processes > 1 else ''}, "
                 f"{batch.seconds:.1f} s")
    return "\n".join(lines)


def _num(x) -> str:
    """A number for the CSV: full precision, empty when there is none."""
    return "" if x is None else repr(float(x))


def batch_csv(batch) -> str:
    """CSV text, one row per campaign and parameter (a campaign not fitted: one row with
    its message). A parameter the campaign does not determine has an empty value and its
    reason in `message` ("not identifiable: ..."), as has a value at a bound."""
    import csv
    import io

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["campaign", "status", "parameter", "value", "unit", "stderr", "ci95_low",
                "ci95_high", "fixed", "reduced_chi2", "message"])
    for e in batch.entries:
        if e.report is None:
            w.writerow([e.name, e.status, "", "", "", "", "", "", "", "", e.message])
            continue
        for name, p in e.report["parameters"].items():
            ci = p.get("ci95") or [None, None]
            w.writerow([e.name, e.status, name, _num(p["value"]), p["unit"],
                        _num(p.get("stderr")), _num(ci[0]), _num(ci[1]), bool(p["fixed"]),
                        _num(e.report["reduced_chi2"]), p.get("reason") or ""])
    return buf.getvalue()
