r"""One call for a campaign's posterior: `stickslip_fitting.sample(records, ...)` ->
`CampaignPosterior`.

```python
import stickslip_fitting as sf

post = sf.sample("data/examples/*.csv", steps=3000, walkers=32, seed=0)
print(post.summary())        # pandas DataFrame: median, 95 % interval, unit, sd, tau, ESS
post.plot("corner.png")      # the corner plot of `stickslip mcmc --plot`
post.to_json("mcmc.json")    # the document of `stickslip mcmc --json`
```

The call runs `stickslip mcmc`'s steps: `stickslip_fitting.fit`, `mcmc.run_mcmc` around
its optimum, `report.mcmc_document`. A `CampaignFit` given in place of the records is
sampled around without fitting again.
"""

from __future__ import annotations

import dataclasses
import os
from typing import TYPE_CHECKING

from .campaign import CampaignFit, RecordsSpec
from .results import ResultDocument, pandas_module
from ..report.mcmc_document import JSON_ALIASES as MCMC_ALIASES

if TYPE_CHECKING:
    import pandas
    from matplotlib.figure import Figure

    from ..uncertainty.mcmc import McmcResult

__all__ = ["POSTERIOR_COLUMNS", "CampaignPosterior", "check_sampler", "sample"]

POSTERIOR_COLUMNS = ("median", "low", "high", "unit", "sd", "mean", "tau_steps", "ess")
"""The columns of `CampaignPosterior.summary()` (low, high: the central 95 % interval;
tau_steps: the integrated autocorrelation time in steps; ess: the effective sample size)."""


@dataclasses.dataclass(frozen=True)
class CampaignPosterior(ResultDocument):
    """The result of `sample`: posterior draws of the campaign's free friction parameters.
    `summary()` (pandas, `POSTERIOR_COLUMNS`), `plot(path)` (`stickslip mcmc --plot`),
    `to_json(path)` / `to_dict()` (`stickslip mcmc --json`, with the thinned draws that
    `design --posterior` and `plan` read), `str(result)` (the table the command prints).
    Parts: `mcmc` (`uncertainty.mcmc.McmcResult`), `campaign_fit` (the `CampaignFit` the
    chain started from), `report` (the JSON document) and `truth` (or None).
    """

    report: dict
    mcmc: McmcResult
    campaign_fit: CampaignFit
    truth: dict | None = None

    JSON_ALIASES = MCMC_ALIASES

    @property
    def inputs(self) -> tuple[str, ...]:
        """The record files read (an output may not overwrite one of them)."""
        return self.campaign_fit.inputs

    @property
    def names(self) -> list[str]:
        """The sampled parameters, in the law's order (the fixed ones are in `fixed`)."""
        return list(self.mcmc.names)

    @property
    def fixed(self) -> dict[str, float]:
        """{name: value} of the parameters held fixed (not sampled)."""
        return dict(self.report["fixed"])

    @property
    def acceptance(self) -> float:
        """The mean acceptance fraction of the walkers' moves."""
        return float(self.mcmc.acceptance)

    @property
    def warnings(self) -> list[str]:
        """The sampler's warnings (a chain too short for its autocorrelation time, ...)."""
        return list(self.mcmc.warnings)

    def summary(self) -> pandas.DataFrame:
        """One row per sampled parameter (`POSTERIOR_COLUMNS`, internal units);
        `attrs["acceptance"]` holds the acceptance fraction. Needs pandas."""
        pd = pandas_module("CampaignPosterior.summary()")
        rows = {}
        for name, p in self.report["parameters"].items():
            low, high = p["ci95"]
            rows[name] = (float(p["median"]), float(low), float(high), p["unit"], float(p["sd"]),
                          float(p["mean"]), float(p["tau_steps"]), float(p["ess"]))
        frame = pd.DataFrame.from_dict(rows, orient="index", columns=list(POSTERIOR_COLUMNS))
        frame.index.name = "parameter"
        frame.attrs["acceptance"] = self.acceptance
        return frame

    def plot(self, path: str | os.PathLike[str] | None = None) -> Figure:
        """The corner plot of `stickslip mcmc --plot` (`report.posterior_plots.corner_plot`):
        returned, and saved to `path` (closed then) when given. Needs `corner`."""
        from ..report.posterior_plots import corner_plot

        return corner_plot(self.mcmc.samples, self.mcmc.names, self.output_path(path, "plot"),
                           truth=self.truth, units=self.mcmc.units)

    def __str__(self) -> str:
        """The table `stickslip mcmc` prints, then the prior, the given quantities, the
        likelihood, the sampler's settings and its warnings."""
        r, truth = self.report, self.truth
        head = (f"{'parameter':<10}{'median':>12}{'unit':>7}{'sd':>11}{'95 % interval':>26}"
                f"{'tau':>8}{'ESS':>8}" + (f"{'truth':>10}" if truth else ""))
        lines = [head, "-" * len(head)]
        for name, p in r["parameters"].items():
            ci = f"[{p['ci95'][0]:.5g}, {p['ci95'][1]:.5g}]"
            lines.append(f"{name:<10}{p['median']:>12.5g}{p['unit']:>7}{p['sd']:>11.3g}{ci:>26}"
                         f"{p['tau_steps']:>8.1f}{p['ess']:>8.0f}"
                         + (f"{truth[name]:>10.4g}" if truth else ""))
        lines += ["", f"prior: {r['prior']}"]
        if "given" in r:
            g = r["given"]
            lines.append(f"given: eta = {g['eta']['value']:.4g} {g['eta']['unit']}, surface "
                         f"{g['surface']}")
        loss = "" if r["loss"] == "gaussian" else f" under the {r['loss']} loss"
        lines += [f"likelihood: {r['objective']} objective{loss}, chi2 divided by "
                  f"{r['likelihood_scale']:.3g}",
                  f"{r['walkers']} walkers x {r['steps']} steps (burn-in {r['burn']}); "
                  f"acceptance {r['acceptance']:.2f}"]
        return "\n".join(lines + [f"warning: {w}" for w in r["warnings"]]
                         + [f"note: {n}" for n in r.get("notes", [])])

    def __repr__(self) -> str:
        medians = ", ".join(f"{n}={p['median']:.5g}" for n, p in self.report["parameters"].items())
        return (f"CampaignPosterior(walkers={self.mcmc.walkers}, steps={self.mcmc.steps}, "
                f"acceptance={self.acceptance:.2f}, {medians})")


def sample(records: RecordsSpec | CampaignFit, *, steps: int = 3000, walkers: int = 32,
           burn: int | None = None, seed: int = 0, draws: int = 2000, progress: bool = False,
           **fit_options) -> CampaignPosterior:
    """Sample the posterior of the friction parameters of a campaign, as `stickslip
    mcmc` does: fit (`stickslip_fitting.fit` with `fit_options`), then run emcee around
    the optimum (`mcmc.run_mcmc`).

    - `records`: what `stickslip_fitting.fit` reads, or a `CampaignFit` to sample around
      (then without `fit_options`).
    - `steps`, `walkers`, `burn` (default steps // 4), `seed`: as `--steps`, `--walkers`,
      `--burn`, `--seed`; `draws`: at most this many draws in the JSON document (evenly
      thinned); `progress`: emcee's progress bar.

    Every mistake in the options raises ValueError naming the keyword, before the fit.
    """
    given = isinstance(records, CampaignFit)
    free = (sum(not p.get("fixed", False) for p in records.parameters.values()) if given
            else 6 - len(fit_options.get("fix") or {}))
    check_sampler(steps=steps, walkers=walkers, burn=burn, seed=seed, draws=draws, free=free)
    if given:
        if fit_options:
            raise ValueError(f"{', '.join(fit_options)}: the options of the fit given; give "
                             "the records to fit with other options")
        cf = records
    else:
        from .campaign import fit

        cf = fit(records, **fit_options)
    from stickslip_jax.logs import logger

    from ..data.campaign import find_truth
    from ..report.mcmc_document import fixed_misfit, mcmc_document
    from ..uncertainty.mcmc import run_mcmc

    logger.info(f"sampling: {walkers} walkers x {steps} steps (Ctrl-C stops and keeps the "
                "chain so far)")
    try:
        res = run_mcmc(cf.fit, walkers=walkers, steps=steps, burn=burn, seed=seed,
                       progress=progress, uncertainty=cf.uncertainty)
    except ValueError as err:  # the sampler's own checks name the command's options
        raise ValueError(str(err).replace("--walkers", "walkers").replace("--steps", "steps")
                         ) from None
    res.warnings.extend(fixed_misfit(cf.fit, res.names))
    logger.info(f"sampling {'interrupted' if res.interrupted else 'done'}: acceptance "
                f"{res.acceptance:.2f}")
    truth = find_truth(cf.campaign.records, list(cf.fit.values))
    extra = {"given": cf.report["given"]} if "given" in cf.report else None
    doc = mcmc_document(res, cf.fit, cf.campaign, model=cf.model,
                        truth=truth, max_draws=draws, extra=extra)
    return CampaignPosterior(report=doc, mcmc=res, campaign_fit=cf, truth=truth)


def check_sampler(*, steps: int, walkers: int, burn: int | None, seed: int, draws: int,
                  free: int) -> None:
    """The sampler's settings of `sample` checked before any fit: a ValueError naming the
    keyword (`free`: the parameters sampled, half the least number of walkers)."""
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**32:
        raise ValueError(f"seed: an integer in 0 to 2**32 - 1, got {seed!r}")
    if draws < 1:
        raise ValueError(f"draws: need at least 1 draw, got {draws}")
    if steps < 10:
        raise ValueError(f"steps: need at least 10 steps, got {steps}")
    if walkers < 2 * max(free, 1):
        raise ValueError(f"walkers: need at least {2 * max(free, 1)} walkers (twice the "
                         f"{max(free, 1)} free parameters), got {walkers}")
    if burn is not None and not 0 <= burn < steps:
        raise ValueError(f"burn: must lie in [0, steps), got {burn}")
