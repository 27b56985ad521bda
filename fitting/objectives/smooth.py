r"""The smoothed-simulator objective: every sample of whole records against the
differentiable smoothed simulator (`stickslip_jax.simulation.simulate_smooth`), run once
per record (`stickslip fit --objective smooth`).

Each record is simulated from its first measured slip end (the slider at rest, stick
time 0, deflection the measured trough there less the gauge offset) to its last sample,
driven at its constant speed or, for a measured drive or a `drive_program`, by its drive
interpolated linearly between `KNOTS` knots (a 6 um lead-screw error on a 2 mm pitch to
within 0.0062 um at 10 mm/min over 60 s). The residuals are
$(x_i - c - x_\mathrm{sim}(t_i)) / \sigma$ ($\sigma$ the record's noise, $c$ its gauge
offset). Unlike the trace objective (restarted at every measured slip end) the model runs
freely over the record, so it tests whether it reproduces the whole oscillogram, the
timing of every slip included; an error of the period accumulates over the cycles, so
the robust covariance treats each record as one cluster.

Settings (`SmoothObjective` fields): `formulation` (default "latch": not stiff,
gradients verified against finite differences for smoothing 1e-4 ... 1e-2 at rtol <=
1e-9), `smoothing` (default 1e-4: at 1e-3 the smoothed slips of a slow record drift from
exact ones by several noise standard deviations), `rtol`/`atol` (mm, mm/s; default
1e-9, 1e-11), `max_steps`. Jacobians by forward mode through the solver. Cost: one
simulation per record per parameter direction; `max_samples` in `smooth_data` caps each
record.
"""

from __future__ import annotations

from typing import ClassVar

import diffrax as dfx
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

import stickslip_jax as ss
from stickslip_jax.drives import ConstantSpeed, MeasuredDrive
from stickslip_jax.modes import Formulation, SlipTime
from stickslip_jax.simulation import simulate_smooth
from stickslip_jax.simulation.trace import pad_series

from .combined import AbstractObjective
from ..modes import Objective

__all__ = ["KNOTS", "SmoothData", "SmoothObjective", "drive_knots", "pack_records", "record_drive",
           "smooth_data"]

KNOTS = 512
"""Knots of a record's piecewise-linear drive when it is not a constant speed (module doc)."""


class SmoothData(eqx.Module):
    """Whole records for the smoothed objective (module doc): `time` [R, N] (s, from each
    record's first slip end), `deflection` [R, N] (mm), `mask` [R, N] (False on padding);
    per record `weight` W and `normal_load` N (kgf), `stiffness` (kgf/mm), `speed` (mm/s),
    `start_level` (the measured reading at the start, mm) and `sigma` (noise sd, mm);
    `drive_knots` [R, KNOTS + 1, 2] (times s, drive positions mm; None when every record
    is driven at a constant speed)."""

    time: Float[Array, "R N"]
    deflection: Float[Array, "R N"]
    mask: Bool[Array, "R N"]
    weight: Float[Array, " R"]
    normal_load: Float[Array, " R"]
    stiffness: Float[Array, " R"]
    speed: Float[Array, " R"]
    start_level: Float[Array, " R"]
    sigma: Float[Array, " R"]
    drive_knots: Float[Array, "R K 2"] | None = None

    def n_residuals(self) -> int:
        return int(np.asarray(self.mask).sum())


def smooth_data(records, features) -> SmoothData:
    """`SmoothData` of `records` with their `RecordFeatures` (the first slip end and its
    trough level start each simulation). ValueError naming the record when it has no
    slip to start from."""
    if len(records) != len(features):
        raise ValueError("smooth_data: one RecordFeatures per record")
    times, xs, starts, x1, sig = [], [], [], [], []
    for rec, f in zip(records, features):
        name = rec.name or "record"
        if not f.stick_slip or len(f.end_time) == 0 or not np.isfinite(f.trough[0]):
            raise ValueError(f"{name}: --objective smooth needs a slip to start from "
                             f"({f.message or 'no slip end found'})")
        t_e = float(f.end_time[0])
        keep = np.asarray(rec.time) >= t_e
        t = np.asarray(rec.time, float)[keep] - t_e
        x = np.asarray(rec.deflection, float)[keep]
        if t.size < 16:
            raise ValueError(f"{name}: fewer than 16 samples after the first slip end")
        times.append(t)
        xs.append(x)
        starts.append(t_e)
        x1.append(float(f.trough[0]))
        sig.append(float(f.noise))  # floored at sticks.NOISE_FLOOR
    return pack_records(records, times, xs, starts, x1, sig)


def pack_records(records, times, xs, starts, start_level, sigma) -> SmoothData:
    """`SmoothData` of `records`' samples, padded: `times` (s, each from its record's
    time `starts`) and readings `xs` (mm), with each record's `start_level` and noise
    `sigma` (mm), its weight, load, stiffness and speed and, unless every record is
    driven at a constant speed, its drive knots from its start (`drive_knots`)."""
    ts, data, mask = pad_series(times, xs)

    def arr(a):
        return jnp.asarray(np.asarray(a, float))

    def per(name):
        return arr([getattr(rec, name) for rec in records])

    steady = all(rec.drive_source == "speed" for rec in records)
    knots = None if steady else arr([drive_knots(rec, t0, t[-1])
                                     for rec, t0, t in zip(records, starts, times)])
    return SmoothData(time=ts, deflection=data, mask=mask, weight=per("weight"),
                      normal_load=per("load"), stiffness=per("stiffness"),
                      speed=per("nominal_drive_speed"), start_level=arr(start_level),
                      sigma=arr(sigma), drive_knots=knots)


def drive_knots(rec, t_e: float, span: float) -> np.ndarray:
    """[KNOTS + 1, 2] knots (s, mm) of `rec`'s drive from its time `t_e` on, origin there:
    `KNOTS` over `span` (s), one far beyond on the last slope."""
    tk = np.linspace(0.0, span, KNOTS)
    uk = (rec.drive_speed * tk if rec.drive_source == "speed"
          else rec.drive_position(tk + t_e) - rec.drive_position([t_e])[0])
    far = 1e3 * max(span, 1.0)
    slope = (uk[-1] - uk[-2]) / (tk[-1] - tk[-2])
    return np.stack([np.append(tk, far), np.append(uk, uk[-1] + slope * (far - tk[-1]))], 1)


def record_drive(speed, knots):
    """A record's drive: its constant `speed` (mm/s), or its `knots` (s, mm; `drive_knots`)."""
    return ConstantSpeed(speed) if knots is None else MeasuredDrive(knots[:, 0], knots[:, 1])


class SmoothObjective(AbstractObjective):
    """Whole records against the smoothed simulator (module doc)."""

    data: SmoothData
    smoothing: float = eqx.field(static=True, default=1e-4)
    rtol: float = eqx.field(static=True, default=1e-9)
    atol: float = eqx.field(static=True, default=1e-11)
    max_steps: int = eqx.field(static=True, default=16384)
    formulation: Formulation = eqx.field(static=True, default=Formulation.LATCH,
                                         converter=Formulation.parse)
    slip_time: SlipTime = eqx.field(static=True, default=SlipTime.PAPER,
                                    converter=SlipTime.parse)
    kind: ClassVar[Objective] = Objective.SMOOTH
    robust: ClassVar[bool] = True

    def simulate(self, params):
        """Model deflection [R, N] (mm, without the gauge offset) and success flags [R]."""
        fr = params.friction.friction()
        d = self.data
        x0 = d.start_level - params.offset

        def one(args):
            w, n, k, v, x_start, t, m, kn = args
            tr = simulate_smooth(ss.Slideway(fr, w, k, n), record_drive(v, kn), t,
                                 smoothing=self.smoothing, slip_time=self.slip_time,
                                 rtol=self.rtol, atol=self.atol, max_steps=self.max_steps,
                                 initial_deflection=x_start, mask=m,
                                 adjoint=dfx.ForwardMode(), formulation=self.formulation)
            return tr.deflection, tr.result == ss.simulation.SimulationResult.successful

        return jax.lax.map(one, (d.weight, d.normal_load, d.stiffness, d.speed, x0, d.time,
                                 d.mask, d.drive_knots))

    def residuals_and_aux(self, params, weights_at=None, slider_velocity=None):
        x, ok = self.simulate(params)
        d = self.data
        r = (d.deflection - params.offset[:, None] - x) / d.sigma[:, None]
        return jnp.where(d.mask, r, 0.0).ravel(), (ok, None)

    def dof(self) -> float:
        return float(self.data.n_residuals())

    def blocks(self) -> dict[str, int]:
        return {"smooth": int(np.prod(self.data.mask.shape))}

    def clusters(self, features):
        mask = np.asarray(self.data.mask)
        R = mask.shape[0]
        rec = np.where(mask, np.arange(R)[:, None], -1).ravel()
        return rec, np.where(mask, 0, -1).ravel()

    def describe(self) -> str:
        return (f"whole records, smoothed simulator from the first slip end "
                f"({self.formulation}, smoothing {self.smoothing:g})")

    def failures(self, ok) -> int:
        return int(np.count_nonzero(~np.asarray(ok, bool)))
