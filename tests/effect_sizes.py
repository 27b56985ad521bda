"""How large a hidden effect is in the traces: the target sizes, "about 3x and 20x the
noise".

An effect's size in the traces is what the paper's model cannot reproduce when it is
given the generator's own friction: the per-cycle model (every cycle restarted from its
measured slip end, as discovery fits it) is run at the true friction of
`independent_records`, only the records' offsets fitted, and the residual RMS of the
campaign with the effect is compared with the same seed's campaign without it:

    size = sqrt(rms_effect^2 - rms_clean^2) / noise

(0 for an invisible effect, 3 for an effect whose misfit is three times the noise RMS).
Measured with the package's per-cycle model because "visible in the traces" means visible
to the model discovery fits; the records themselves come from the independent generator.

`python tests/effect_sizes.py` prints the sizes of the rates campaigns' effects.
"""

from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
import independent_records as ir  # noqa: E402


def trace_rms(records, friction: ir.Friction) -> float:
    """Residual RMS (mm) of the per-cycle model at `friction` (offsets fitted) over the
    cycle windows it reproduces."""
    import equinox as eqx
    import jax

    from stickslip_fitting.data.campaign import screen_records
    from stickslip_fitting.discovery.cycle_model import CycleModel, drift_origins
    from stickslip_fitting.discovery.subproblems import SubProblem
    from stickslip_fitting.params import EmpiricalFriction
    from stickslip_fitting.objectives.trace import trace_data

    campaign = screen_records(list(records))
    recs, feats = campaign.records, campaign.features
    data = trace_data(recs, feats, drive_fix=False, keep_reslips=True)
    G = len(recs)
    model = CycleModel(data, drift_origins(recs), np.ones(np.asarray(data.mask).shape), G)
    f = friction
    z = model.z0(EmpiricalFriction.from_values(f.mu_s, f.mu_d, f.gamma, f.m, f.delta, f.n),
                 np.zeros(G))
    # windows the model cannot reproduce at this friction (no breakaway, a slip that
    # does not end) are left out, as discovery leaves them out
    _, _, ok = model.residuals(z)
    mask = np.asarray(data.mask) & np.asarray(ok)[:, None]
    data = eqx.tree_at(lambda d: d.mask, data, jax.device_put(mask))
    model = CycleModel(data, model.tref, np.ones(mask.shape), G)
    cols = np.arange(6, model.n_base)  # the offsets only
    sub = SubProblem(model, z, cols)
    fit = sub.solve(z[cols], max_evals=10)
    r, _, ok = model.residuals(sub.full(fit.z))
    mask = np.asarray(data.mask)
    row = np.broadcast_to(np.arange(mask.shape[0])[:, None], mask.shape).ravel()[mask.ravel()]
    good = np.asarray(ok)[row] & np.isfinite(r)
    return float(np.sqrt(np.mean(r[good] ** 2)))


def in_trace_size(lube: ir.Friction, seed: int, design: dict, **kw) -> float:
    """The effect's size in the traces, in units of the noise (module doc)."""
    noise = kw.get("imp", ir.Imperfections()).noise_mm
    rms = trace_rms(ir.campaign(lube, seed=seed, **design, **kw), lube)
    rms0 = trace_rms(ir.campaign(lube, seed=seed, **design), lube)
    return float(np.sqrt(max(rms ** 2 - rms0 ** 2, 0.0)) / noise)


if __name__ == "__main__":
    import test_cycle_discovery_rates as rates

    sets = rates.calibrated_campaigns() if "--calibrated" in sys.argv else rates.campaigns(0)
    for kind, seed, lube, kw in sets:
        print(f"{kind:40s} {'AC'[rates.LUBES.index(lube)]} "
              f"{in_trace_size(lube, seed, rates.DESIGN, **kw):7.2f}", flush=True)
