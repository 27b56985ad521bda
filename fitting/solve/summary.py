"""The figures of a fit at its optimum that its report prints and writes: the goodness of
fit, the residual levels in mm, what was minimised, and what the fitted model predicts
for the records without stick-slip (`boundary_check`), computed once where the fit is
made (the report then reads values, not the objective or the model)."""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["FitFigures", "boundary_check", "fit_figures"]


@dataclasses.dataclass(frozen=True)
class FitFigures:
    """A fit's figures: `residual_rms_mm` (the rms of the plateau-level residuals, mm, over
    the cycles with a level), `chi2`, `dof`, `reduced_chi2`, `converged`, `objective` (one
    line), `loss` (its spec), `slip_time` (the T2 mode of eq 3); for an objective that
    reads traces (else None): `trace_residual_rms_mm` (mm), `trace_samples`,
    `trace_window_failures` and `trace_windows_after_reslip`; `steady_records`: the
    `boundary_check` of the campaign's records without stick-slip."""

    residual_rms_mm: float
    chi2: float
    dof: int
    reduced_chi2: float
    converged: bool
    objective: str
    loss: str
    slip_time: str
    trace_residual_rms_mm: float | None = None
    trace_samples: int | None = None
    trace_window_failures: int | None = None
    trace_windows_after_reslip: int | None = None
    steady_records: tuple = ()


def fit_figures(fit, campaign) -> FitFigures:
    """The `FitFigures` of a `solve.fit.FitResult` fitted to `campaign` (a
    `data.campaign.Campaign`)."""
    from ..objectives.combined import FeaturesObjective
    from ..objectives.cycle_features import feature_residuals
    from ..objectives.losses import loss_of
    from .fit import compiled

    res = compiled(feature_residuals, fit.params, fit.data, fit.slip_time)
    level_sd = np.asarray(fit.data.trough_sd)
    levels = FeaturesObjective(fit.data).split(res)["levels"].reshape(level_sd.shape) * level_sd
    mask = np.asarray(fit.data.has_end) | np.asarray(fit.data.has_next)  # on the host
    rms = float(np.sqrt(np.mean(levels[mask] ** 2))) if mask.any() else float("nan")
    trace = {}
    td = fit.objective.trace_data()
    if td is not None:
        from ..objectives.trace import reslip_windows, trace_residuals

        rt = np.asarray(compiled(trace_residuals, fit.params, td, fit.slip_time))
        rt = rt.reshape(td.mask.shape)
        rt = rt * np.asarray(td.sigma)[:, None]
        trace = dict(trace_residual_rms_mm=float(np.sqrt(np.mean(rt[np.asarray(td.mask)] ** 2))),
                     trace_samples=td.n_residuals(), trace_window_failures=fit.trace_failures,
                     trace_windows_after_reslip=reslip_windows(fit.features))
    steady = boundary_check(fit.params.friction.friction(), campaign)
    return FitFigures(residual_rms_mm=rms, chi2=fit.chi2, dof=fit.dof,
                      reduced_chi2=fit.reduced_chi2, converged=fit.converged,
                      objective=fit.objective.describe(), loss=loss_of(fit.objective).spec(),
                      slip_time=str(fit.slip_time), steady_records=tuple(steady), **trace)


def boundary_check(friction, campaign) -> list[dict]:
    r"""Records without stick-slip against the fitted model's stick-slip boundary: for
    every record of the `data.campaign.Campaign` with status NO_STICK_SLIP, eq (6)'s
    steady amplitude $a$ of `friction` at the record's W, k, v and eq (12)'s $v_c$. A
    record sliding steadily where the model predicts a swing 2a above five noise standard
    deviations is a misfit (the model misses something there, or the file's drive speed
    is wrong). Units: um, mm/min."""
    from stickslip_jax.steady import steady_state

    from ..data.campaign import NO_STICK_SLIP, UNREADABLE, USED

    # the screening of the records not used, in the order of `not_used` (the unreadable
    # files, listed last, have no record)
    screened = [s for s in campaign.screening if s.status not in (USED, UNREADABLE)]
    out = []
    for s, (rec, f) in zip(screened, campaign.not_used):
        if s.status != NO_STICK_SLIP:
            continue
        st = steady_state(friction, f.weight, f.stiffness, f.drive_speed,
                          normal_load=f.normal_load)
        amp = float(st.amplitude) if bool(st.stick_slip) else 0.0
        visible = 2.0 * amp > 5.0 * float(f.noise)
        v_c = float(st.critical_speed) * 60.0
        if visible:
            text = (f"{f.name}: slides steadily, but the fitted model predicts stick-slip of "
                    f"amplitude {amp * 1e3:.3g} um (eq 6; v = {f.drive_speed * 60:.4g} mm/min "
                    f"is below eq (12)'s v_c = {v_c:.4g} mm/min): a misfit of the model")
        else:
            text = (f"{f.name}: slides steadily, consistent with the fitted model (eq 6 "
                    f"amplitude {amp * 1e3:.3g} um, eq (12) v_c = {v_c:.4g} mm/min)")
        out.append({"name": f.name, "predicted_amplitude_um": amp * 1e3,
                    "critical_speed_mm_per_min": v_c, "misfit": bool(visible),
                    "message": text})
    return out
