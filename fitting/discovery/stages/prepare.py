"""Stage 1 of the per-cycle discovery, `prepare`: screening, the features fit (the start)
and the cycle windows with the model weighted at the start (`cycle_workflow`)."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from stickslip_jax.units import G_MM_S2

from ...data.campaign import screen_records
from ...solve.fit import fit_features
from ...params import CampaignParams, EmpiricalFriction
from ...objectives.trace import cycle_windows, reslip_windows, trace_data, trace_sd
from ..cycle_model import CycleModel, drift_origins
from ..options import DiscoveryOptions
from ..starts import plausible_start
from ..thinning import Samples, thin_windows
from .state import Clock, Prepared

__all__ = ["prepare", "sd_at"]


@eqx.filter_jit
def _sd_at(logs, data, slider_velocity, count):
    """`trace_sd` (mm, [N, L]) at the friction of the six `EmpiricalFriction` logs, of
    the means of `count` samples, compiled once (run eagerly, each of its small
    operations compiled a program of its own: 3.7 s of a cold 16 s preparation)."""
    friction = EmpiricalFriction(*[logs[i] for i in range(6)])
    return (trace_sd(CampaignParams(friction, jnp.zeros(1)), data, slider_velocity)
            / jnp.sqrt(count))


def sd_at(z, data, slider_velocity, samples: Samples) -> np.ndarray:
    """`_sd_at` at the first six coordinates of z (the friction logs), for the entries of
    `data` standing for `samples` ([N, L], `thinning`)."""
    return np.asarray(_sd_at(jax.device_put(np.asarray(z, float)[:6]), data,
                             jax.device_put(np.asarray(slider_velocity, float)),
                             jax.device_put(samples.count)))


def _cancel(warm: dict):
    """Cancel the warm-up jobs (`CycleModel.warm`) that have not started (a campaign
    refused after the warm-up began: its programs are not needed)."""
    for f in warm.values():
        f.cancel()


def _windows(recs, feats, opts: DiscoveryOptions):
    """The cycle windows (`trace_data`, the drive error left in the data), and the counts
    of complete windows and re-slips and whether the re-slips are kept."""
    # slips measured longer than a single slip are left out as re-slips (their restart
    # state is not measured); when nearly all are, the lengthening is systematic: a slow
    # gauge or a damped slip, the very effects sought, so every window is kept (measured:
    # a 20 Hz second-order sensor made 94 of 94 windows "re-slips" and the campaign was
    # refused)
    n_complete = cycle_windows(feats)
    n_reslip = reslip_windows(feats)
    keep_reslips = n_reslip > 0 and n_reslip >= opts.reslip_systematic * n_complete
    try:
        data = trace_data(recs, feats, drive_fix=False, keep_reslips=keep_reslips)
    except ValueError as e:  # said in discovery's words (the trace objective's advice,
        # "use --objective features", is not an option here)
        raise ValueError("discovery needs complete stick-slip cycles whose restart state is "
                         "measured: " + str(e).replace("; use --objective features", "")
                         .replace("trace objective: ", "") + "; the per-cycle model has "
                         "nothing to fit (check the records: a sensor ringing at the "
                         "slideway's own frequency or slips that never re-stick)") from None
    return data, n_complete, n_reslip, keep_reslips


def _set_aside_windows(data, model, recs, warm, z_start, ok):
    """The windows the paper's model cannot reproduce at the start (`ok` False: no
    breakaway, or a slip that does not end within 2.5 pi/omega_0, e.g. a strong Stribeck
    drop) masked out and listed; one such window must not stop the campaign. Returns the
    data, the model, the velocities at the start, the notes and the count."""
    has = np.asarray(data.mask).any(1)
    failed = np.unique(np.asarray(data.window)[has & ~np.asarray(ok)])
    notes = []
    if not failed.size:
        return data, model, None, notes, 0
    keep = ~np.isin(np.asarray(data.window), failed)
    if not np.any(keep & has):
        _cancel(warm)
        raise ValueError("the paper's model reproduces none of the campaign's cycle "
                         "windows at the features' parameters (no breakaway, or slips "
                         "that do not end); check the records' stick-slip")
    rec_of_window = {int(w): int(r) for w, r in zip(np.asarray(data.window),
                                                    np.asarray(data.record))}
    for g in sorted({rec_of_window[int(w)] for w in failed}):
        n_w = sum(1 for w in failed if rec_of_window[int(w)] == g)
        notes.append(
            f"{recs[g].note or recs[g].source or f'record {g}'}: {n_w} cycle window(s) "
            "set aside (the paper's model at the start finds no breakaway or a slip "
            "that does not end)")
    data = eqx.tree_at(lambda d: d.mask, data,
                       jax.device_put(np.asarray(data.mask) & keep[:, None]))
    model = CycleModel(data, model.tref, np.ones(np.asarray(data.mask).shape), len(recs))
    _, yd, _ = model.residuals(z_start)
    return data, model, yd, notes, int(failed.size)


def prepare(records, *, strict: bool, unreadable, opts: DiscoveryOptions,
            clock: Clock) -> Prepared:
    """Screen the records, fit the features (the start), cut the cycle windows and weight
    the model at the start (module doc of `cycle_workflow`, stage 1)."""
    campaign = screen_records(list(records), strict=strict, unreadable=unreadable)
    recs, feats = campaign.records, campaign.features
    data, n_complete, n_reslip, keep_reslips = _windows(recs, feats, opts)
    data, samples = thin_windows(data)  # the sticks binned: the cost is per window
    G = len(recs)
    # the per-cycle model's programs compile in a background thread meanwhile
    warm = CycleModel(data, drift_origins(recs), np.ones(np.asarray(data.mask).shape),
                      G).warm()
    try:
        start = fit_features(feats)
    except BaseException:  # the jobs not yet started are not compiled for nothing
        _cancel(warm)
        raise
    # weights (effective variance) at the start, refreshed once at the base optimum
    model = CycleModel(data, drift_origins(recs),
                       np.ones(np.asarray(data.mask).shape), G)
    z_features = model.z0(start.params.friction, np.asarray(start.params.offset))
    z_start = z_features.copy()
    t2_of = np.pi / np.sqrt(np.asarray(data.stiffness) * G_MM_S2 / np.asarray(data.weight))
    z_start[:6] = plausible_start(z_start[:6], np.asarray(data.stick_time), t2_of)
    warm["residuals", False].result()
    _, yd, ok = model.residuals(z_start)
    data, model, yd_kept, windows_set_aside, n_failed = _set_aside_windows(
        data, model, recs, warm, z_start, ok)
    yd = yd if yd_kept is None else yd_kept
    window = np.broadcast_to(np.asarray(data.window)[:, None], data.mask.shape)
    window = np.asarray(window).ravel()[np.asarray(data.mask).ravel()]
    if np.any(np.diff(window) < 0):
        raise RuntimeError("trace_data rows are not in window order")
    starts = np.flatnonzero(np.r_[True, np.diff(window) != 0])
    model = CycleModel(data, model.tref, sd_at(z_features, data, yd, samples), G)
    clock("prepare", f"{G} records used, {len(campaign.not_used)} set aside, "
                     f"{starts.size} cycle windows, {samples.flat(model.mask).n} samples "
                     f"({model.mask.sum()} with the sticks binned)"
                     + (f"; {n_failed} windows set aside" if n_failed else ""))
    return Prepared(campaign=campaign, data=data, warm=warm, model=model, z_start=z_start,
                    t2_of=t2_of, starts=starts, windows_set_aside=windows_set_aside,
                    samples=samples,
                    n_complete=n_complete, n_reslip=n_reslip, keep_reslips=keep_reslips)
