"""The document of `stickslip mcmc --json` (`mcmc_document`), built from a posterior
sample (`mcmc.McmcResult`), the fit it started from and the screened campaign.

Keys: "model", "parameters" (per parameter the fit's row keys with value = median,
stderr = sd, and the sampler's median, mean, sd, tau_steps, ess), "prior", "objective",
"loss", "interrupted", "likelihood_scale", "walkers", "steps", "burn", "acceptance",
"warnings", "record_names", "records_screened", "notes", and the draws in the layout
`design.posterior.load_samples` reads: "names", "samples" (thinned to at most
`max_draws` rows) and "fixed"; for the microsqueeze law also "given" (eta, surface).
"""

from __future__ import annotations

__all__ = ["JSON_ALIASES", "fixed_misfit", "mcmc_document", "thinned_draws"]

JSON_ALIASES = {"record_names": "records"}
"""JSON keys renamed -> their old names, still written beside them for one release
(`deprecated_keys`): the names of the records sampled were `records`, which in `fit`,
`discover`, `plan` and `pitch` holds one object per record; `records_screened` has
mcmc's objects (the screening of every record given)."""


def thinned_draws(samples, max_draws: int):
    """At most `max_draws` rows of the flat chain, evenly spaced (natural units)."""
    import numpy as np

    samples = np.asarray(samples)
    step = max(1, -(-samples.shape[0] // int(max_draws)))
    return samples[::step]


def fixed_misfit(fit, free) -> list[str]:
    """`stickslip fit`'s warning when fixed values leave the records far from the model
    (median record chi2/n above `FIXED_MISFIT`): the posterior around them means little.
    `free`: the names sampled."""
    from .fit_table import fixed_misfit_warning

    return fixed_misfit_warning([f"{n}={v:g}" for n, v in fit.values.items() if n not in free],
                                fit.record_chi2, "the posterior of the others is not meaningful")


def mcmc_document(res, fit, campaign, *, model: str, truth: dict | None = None,
                  max_draws: int = 2000, extra: dict | None = None) -> dict:
    """The `stickslip mcmc --json` document (module doc) before versioning
    (`versioned(doc, JSON_ALIASES)`): `res` the `McmcResult`, `fit` the `FitResult` it
    sampled around, `campaign` the screened `Campaign`, `model` the law's name, `truth`
    (or None), `extra` the microsqueeze law's {"given": ...}."""
    from ..modes import Objective
    from ..objectives.losses import loss_of

    summary = res.summary()
    names = [f.name for f in fit.features]
    out = {"model": model, "parameters": {
        e.name: {**e.to_json(), **summary[e.name]} for e in res.estimates(truth)},
        "prior": res.prior, "objective": Objective.parse(fit.objective.kind).value,
        "loss": loss_of(fit.objective).spec(),
        "interrupted": res.interrupted,
        "likelihood_scale": res.likelihood_scale, "walkers": res.walkers,
        "steps": res.steps, "burn": res.burn,
        "acceptance": res.acceptance, "warnings": res.warnings,
        "record_names": names,
        "records_screened": [s.to_json() for s in campaign.screening],
        "names": list(res.names), "samples": thinned_draws(res.samples, max_draws).tolist(),
        "fixed": {n: v for n, v in fit.values.items() if n not in res.names},
        "notes": campaign.notes}
    if extra:
        out.update(extra)
    return out
