r"""Identify the pitching/yawing model (chapter 6) from records with `pitch_N`/`yaw_N` channels.

What is fitted (per plane, each only if some record carries that plane's channels):

| parameter | unit | stored as |
|---|---|---|
| `compliance_pitch`, `compliance_yaw` $c$ | rad/(kgf mm) | log c |
| `neutral_height` $h_{Mv}$, `neutral_offset` $l_{Mh}$ | mm | value |
| `tau_pitch`, `tau_yaw` (squeeze lag at the model's viscosity) | s | log tau |

The displacement of point i of record r is
$\delta_{ri}(t) = c\,(h_r - h_{Mv})\,(s_i - s_{pivot})\,\tilde F_\tau(t)$ (pitch; yaw alike
with the offset $l_r$), with $\tilde F_\tau$ the record's spring force through the lag.
A single drive height cannot separate $c$ from $h_{Mv}$ (only their product with the arm
is seen), so the neutral point is fitted only when the records span at least two drive
heights (two offsets for $l_{Mh}$); otherwise it stays at the template's value and is
reported as fixed.

The objective, `PitchObjective`, takes every observed channel sample of every record
(padded and stacked into one batch) in units of the data's RMS.

Procedure: (1) start: for each time constant on a log grid the gains
$g_r = c(h_r - h_{Mv})$ follow by linear least squares, and a line through $(h_r, g_r)$
gives $c$ (slope) and $h_{Mv}$ (zero crossing); (2) Levenberg-Marquardt
(`solve.lsq.least_squares`) on all free parameters; (3) the Gauss-Newton covariance
$s^2 (J^T J)^{-1}$ with $s^2$ = RSS/(N - p) (or the given noise); 95 % intervals are
$\pm 1.96$ sd in the stored coordinates (asymmetric for log-stored parameters).
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, Bool, Float

from stickslip_jax.lsq import gauss_newton_covariance

from ..report.rows import ParameterEstimate
from .lsq import AbstractResiduals, least_squares
from stickslip_jax import pitching as pt
from stickslip_jax.units import UnitError, parse_quantity

__all__ = ["PitchFit", "PitchObjective", "PitchParams", "PitchRun", "fit_pitching", "pitch_run",
           "record_drive_point"]

NAMES = ("compliance_pitch", "neutral_height", "tau_pitch",
         "compliance_yaw", "neutral_offset", "tau_yaw")
UNITS = {"compliance_pitch": "rad/(kgf*mm)", "compliance_yaw": "rad/(kgf*mm)",
         "neutral_height": "mm", "neutral_offset": "mm", "tau_pitch": "s", "tau_yaw": "s"}
_LOG = {"compliance_pitch", "compliance_yaw", "tau_pitch", "tau_yaw"}


class PitchRun(eqx.Module):
    """One record prepared for the fit: `time` (s), `force` $F = kx$ (kgf), the `drive`
    point (mm), `displacement` (mm, shape (n, points) in the model's point order) and
    `observed` (bool per point: the record carries that channel)."""

    time: Float[Array, " n"]
    force: Float[Array, " n"]
    drive: pt.DrivePoint
    displacement: Float[Array, "n points"]
    observed: Bool[Array, " points"]


def _header_length(record, key):
    text = record.extra_header.get(key)
    if text is None:
        return None
    try:
        return parse_quantity(text, "length")
    except (UnitError, ValueError) as exc:
        raise ValueError(f"record header {key}: {exc}") from None


def record_drive_point(record, height=None, offset=None) -> pt.DrivePoint:
    """Drive point (mm) of a record: `height`/`offset` if given, else the record's header
    keys `drive_height` and `drive_offset` (e.g. `# drive_height: 45 mm`); the offset
    defaults to 0 (through the centre of gravity)."""
    h = height if height is not None else _header_length(record, "drive_height")
    if h is None:
        raise ValueError(
            "drive height unknown: give --height (mm) or a '# drive_height: 45 mm' header line")
    o = offset if offset is not None else _header_length(record, "drive_offset")
    return pt.DrivePoint(height=float(h), offset=0.0 if o is None else float(o))


def pitch_run(record, model: pt.PitchingModel, height=None, offset=None) -> PitchRun:
    """A `PitchRun` from a `stickslip_jax.records.Record`: force k x (kgf), the channels
    named like the model's points (`pitch_1` ... `yaw_5`, internal unit mm)."""
    names = model.points.names
    n = record.time.shape[0]
    disp = np.zeros((n, len(names)))
    observed = np.zeros(len(names), dtype=bool)
    for i, name in enumerate(names):
        if name in record.channels:
            disp[:, i] = record.channels[name]
            observed[i] = True
    return PitchRun(
        time=jnp.asarray(record.time, dtype=float),
        force=jnp.asarray(record.stiffness * np.asarray(record.deflection), dtype=float),
        drive=record_drive_point(record, height, offset),
        displacement=jnp.asarray(disp),
        observed=jnp.asarray(observed))


class PitchParams(eqx.Module):
    """The fitted parameters in stored coordinates (`stored`, in `NAMES` order: log of the
    compliances and time constants, the neutral points as they are; module table)."""

    stored: tuple

    @classmethod
    def from_model(cls, model: pt.PitchingModel) -> PitchParams:
        p, y = model.pitch, model.yaw
        values = (p.compliance, p.neutral, p.lag.time_constants[0], y.compliance, y.neutral,
                  y.lag.time_constants[0])
        return cls(tuple(jnp.log(v) if n in _LOG else v for n, v in zip(NAMES, values)))

    def _values(self):
        return [jnp.exp(v) if n in _LOG else v for n, v in zip(NAMES, self.stored)]

    def into(self, model: pt.PitchingModel) -> pt.PitchingModel:
        """`model` with these values (single-mode lags; time constants at the reference
        viscosity, i.e. the fitted value divided by the model's viscosity ratio)."""
        c_p, h, tau_p, c_y, o, tau_y = self._values()
        ratio = model.viscosity_ratio
        return eqx.tree_at(
            lambda m: (m.pitch.compliance, m.pitch.neutral, m.pitch.lag.time_constants,
                       m.yaw.compliance, m.yaw.neutral, m.yaw.lag.time_constants),
            model, (c_p, h, tau_p[None] / ratio, c_y, o, tau_y[None] / ratio))

    def natural(self) -> dict[str, float]:
        return {name: float(v) for name, v in zip(NAMES, self._values())}


def _stack(runs) -> dict:
    """Runs padded to one length and stacked (one compiled residual for any number of
    runs): `time`, `force`, `height`, `offset`, `displacement`, `mask`; padding samples
    continue the sampling times, repeat the last force and carry `mask` False."""
    n = max(r.time.shape[0] for r in runs)
    cols = {k: [] for k in ("time", "force", "height", "offset", "displacement", "mask")}
    for r in runs:
        t = np.asarray(r.time, dtype=float)
        k = n - t.shape[0]
        dt = t[-1] - t[-2]
        cols["time"].append(np.concatenate([t, t[-1] + dt * np.arange(1, k + 1)]))
        f = np.asarray(r.force, dtype=float)
        cols["force"].append(np.concatenate([f, np.full(k, f[-1])]))
        cols["height"].append(float(r.drive.height))
        cols["offset"].append(float(r.drive.offset))
        d = np.asarray(r.displacement, dtype=float)
        cols["displacement"].append(np.concatenate([d, np.zeros((k, d.shape[1]))]))
        m = np.zeros(d.shape[:1] + d.shape[1:], dtype=bool) | np.asarray(r.observed)[None, :]
        cols["mask"].append(np.concatenate([m, np.zeros((k, d.shape[1]), dtype=bool)]))
    return {k: jnp.asarray(np.stack(v)) for k, v in cols.items()}


class PitchObjective(AbstractResiduals):
    """The channel displacements of a batch of records against the pitching model with
    `PitchParams` put into `template`; residuals (predicted - measured, 0 on padding and
    unobserved channels) in units of `scale` (mm), record after record."""

    template: pt.PitchingModel
    batch: dict  # `_stack`
    scale: Float[Array, ""] | float = 1.0

    def residuals(self, params: PitchParams) -> Float[Array, " N"]:
        model = params.into(self.template)
        b = self.batch

        def one(t, f, h, o):
            return pt.tilt_history(model, t, f, pt.DrivePoint(h, o)).displacement

        pred = jax.vmap(one)(b["time"], b["force"], b["height"], b["offset"])
        r = jnp.where(b["mask"], pred - b["displacement"], 0.0)
        return r.ravel() / self.scale

    def blocks(self) -> dict[str, int]:
        n_runs, n, points = self.batch["displacement"].shape
        return {f"record {i}": n * points for i in range(n_runs)}

    def dof(self) -> float:
        return float(np.sum(np.asarray(self.batch["mask"])))


@dataclasses.dataclass(frozen=True)
class PitchFit:
    """Result of `fit_pitching`.

    - `model`: the fitted `PitchingModel`;
    - `parameters`: name -> {"value", "stderr", "ci95": (lo, hi), "unit", "free"}
      (stderr and interval are None for fixed parameters);
    - `residual_rms_mm`: RMS of the observed residuals (mm); `sigma_mm`: the noise level
      used for the covariance (mm); `n_data`, `n_free`;
    - `covariance`: in stored coordinates, ordered like `free_names`;
    - `result`: optimistix result code; `notes`: plain-language remarks (what was fixed).
    """

    model: pt.PitchingModel
    parameters: dict
    residual_rms_mm: float
    sigma_mm: float
    n_data: int
    n_free: int
    free_names: tuple
    covariance: np.ndarray
    result: optx.RESULTS
    notes: tuple

    @property
    def successful(self) -> bool:
        return self.result == optx.RESULTS.successful

    def estimates(self) -> list[ParameterEstimate]:
        """The parameters as the reports' typed rows (`stickslip_fitting.report.rows`)."""
        return [ParameterEstimate(
            name=n, unit=p["unit"], value=p["value"], stderr=p["stderr"],
            ci95=None if p["ci95"] is None else (float(p["ci95"][0]), float(p["ci95"][1])),
            fixed=not p["free"]) for n, p in self.parameters.items()]


def _plane_start(template, runs, plane, taus):
    """Grid over tau; per-run linear gains; a line through (position, gain)."""
    idx = [i for i, p in enumerate(template.points.planes) if p == plane]
    tp = template.plane(plane)
    lever = np.asarray(template.points.positions)[idx] - float(tp.pivot)
    best = None
    for tau in taus:
        lag = pt.first_order(tau)
        gains, positions, sse = [], [], 0.0
        for run in runs:
            obs = np.asarray(run.observed)[idx]
            if not obs.any():
                continue
            ft = np.asarray(pt.lag_response(lag, run.force, run.time))
            basis = ft[:, None] * lever[None, obs]
            y = np.asarray(run.displacement)[:, idx][:, obs]
            g = float(np.sum(basis * y) / np.sum(basis * basis))
            sse += float(np.sum((y - g * basis) ** 2))
            gains.append(g)
            positions.append(float(run.drive.height if plane == pt.PITCH else run.drive.offset))
        if best is None or sse < best[0]:
            best = (sse, tau, gains, positions)
    _, tau, gains, positions = best
    positions, gains = np.asarray(positions), np.asarray(gains)
    if np.ptp(positions) > 0:
        slope, icpt = np.polyfit(positions, gains, 1)
        if not slope > 0:
            raise ValueError(
                f"{plane}: the tilt does not grow with the drive "
                f"{'height' if plane == pt.PITCH else 'offset'} (slope {slope:.3g}); check the "
                "sign convention of the channels and the drive positions")
        return slope, -icpt / slope, tau, True
    neutral = float(tp.neutral)
    arm = positions[0] - neutral
    if arm == 0:
        raise ValueError(f"{plane}: the only drive position equals the neutral point; "
                         "the compliance cannot be seen")
    c = gains[0] / arm
    if not c > 0:
        raise ValueError(f"{plane}: fitted compliance is not positive ({c:.3g}); check signs")
    return c, neutral, tau, False


def fit_pitching(runs, template: pt.PitchingModel | None = None, noise=None, taus=None,
                 rtol: float = 1e-10, atol: float = 1e-10, max_steps: int = 200) -> PitchFit:
    """Fit compliance, neutral point and squeeze time constant of each observed plane to
    `runs` (`PitchRun`s, see `pitch_run`; module doc). `template`: geometry and viscosity
    (default `pt.default_model()`);
    `noise`: displacement noise sd in mm (default: estimated from the residuals);
    `taus`: the start grid of time constants (s)."""
    runs = tuple(runs)
    if not runs:
        raise ValueError("fit_pitching needs at least one record")
    template = pt.default_model() if template is None else template
    taus = np.geomspace(0.01, 300.0, 15) if taus is None else np.asarray(taus)
    leaves = dict(zip(NAMES, PitchParams.from_model(template).stored))
    free_flags = {n: False for n in NAMES}
    notes = []
    for plane, c_name, n_name, t_name in (
        (pt.PITCH, "compliance_pitch", "neutral_height", "tau_pitch"),
        (pt.YAW, "compliance_yaw", "neutral_offset", "tau_yaw")):
        idx = [i for i, p in enumerate(template.points.planes) if p == plane]
        if not any(bool(np.asarray(r.observed)[idx].any()) for r in runs):
            notes.append(f"no {plane} channels: {plane} parameters fixed at the template values")
            continue
        c, neutral, tau, neutral_free = _plane_start(template, runs, plane, taus)
        leaves[c_name] = jnp.log(c)
        leaves[n_name] = jnp.asarray(neutral, dtype=float)
        leaves[t_name] = jnp.log(tau)
        free_flags[c_name] = free_flags[t_name] = True
        free_flags[n_name] = neutral_free
        if not neutral_free:
            notes.append(f"{n_name} fixed at {float(neutral):g} mm: the records have a single "
                         f"drive {'height' if plane == pt.PITCH else 'offset'}, so it cannot be "
                         "separated from the compliance")
    params = PitchParams(tuple(jnp.asarray(leaves[n], dtype=float) for n in NAMES))
    spec = PitchParams(tuple(free_flags[n] for n in NAMES))
    free_names = tuple(n for n in NAMES if free_flags[n])
    if not free_names:
        raise ValueError("no record carries pitch_N or yaw_N channels; nothing to fit")

    vals = np.concatenate([np.asarray(r.displacement)[:, np.asarray(r.observed)].ravel()
                           for r in runs])
    scale = float(np.sqrt(np.mean(vals**2)))  # the data's RMS (mm)
    scale = scale if scale > 0 else 1.0
    objective = PitchObjective(template, _stack(runs), jnp.asarray(scale))
    n_data = int(objective.dof())
    sol = least_squares(objective, params, spec, rtol=rtol, atol=atol, max_steps=max_steps,
                        linearise=True)
    fitted = sol.params
    res = np.asarray(sol.residuals) * scale  # mm
    rms = float(np.sqrt(np.sum(res**2) / n_data))
    dof = max(n_data - len(free_names), 1)
    sigma = float(np.sqrt(np.sum(res**2) / dof)) if noise is None else float(noise)
    cov = gauss_newton_covariance(np.asarray(sol.jacobian) * scale, sigma**2)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    stored = dict(zip(NAMES, fitted.stored))
    parameters = {}
    sd_of = dict(zip(free_names, map(float, sd)))
    for name in NAMES:
        row = (ParameterEstimate.from_log if name in _LOG else ParameterEstimate.from_normal)(
            name, UNITS[name], float(stored[name]), sd_of.get(name))
        parameters[name] = {"value": row.value, "unit": row.unit, "free": free_flags[name],
                            "stderr": row.stderr, "ci95": row.ci95}
    return PitchFit(model=fitted.into(template), parameters=parameters, residual_rms_mm=rms,
                    sigma_mm=sigma, n_data=n_data, n_free=len(free_names), free_names=free_names,
                    covariance=cov, result=sol.result, notes=tuple(notes))
