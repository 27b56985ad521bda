r"""stickslip_fitting (the folder fitting/): parameter identification, design studies and the missing-physics workflow
for stickslip_jax.

One call fits a campaign as `stickslip fit` does (`api`):

```python
import stickslip_fitting as sf
result = sf.fit("data/examples/*.csv")   # -> CampaignFit
result.summary(); result.plot("fit.png"); result.to_json("fit.json")
```

`sample(records)` -> `posterior_api.CampaignPosterior` (as `stickslip mcmc`) and
`discover(records)` -> `discovery_api.CampaignDiscovery` (as `stickslip discover`) have
the same shape: `summary()`, `plot(path)`, `to_json(path)`.

`stickslip_fitting.fit` is also the module of the fit machinery (`fit.fit_features`,
`fit.FitResult`); calling it runs `api.fit`.

Data flow, one way (each step knows only the ones before it):

1. records -> `campaign.load_campaign` (screening) -> `features.record_features` (cycles)
2. -> objective: `combined.AbstractObjective` (features, trace, `WeightedSum`, smooth)
3. -> solve: `solve.least_squares(objective, params, free)`; `fit.fit_features` (multi-start)
4. -> uncertainty: `uncertainty.laplace` (Fisher, cluster sandwich) or `mcmc.run_mcmc`
5. -> report: `report.ParameterEstimate` rows; `commands/` (tables, JSON), `plots` (figures)

In more words: the objectives are `combined.FeaturesObjective` (cycle features),
`combined.TraceObjective` (every sample, exact simulator restarted per cycle),
`combined.WeightedSum` (`--objective both`) and `smooth_objective.SmoothObjective` (whole
records, smoothed simulator), all `solve.AbstractResiduals`, as are
`pitch_fit.PitchObjective` (pitching channels) and `design.experiment.SteadyObservables`
(steady observables of a planned campaign). `solve.least_squares` is the one
Levenberg-Marquardt (`stickslip_jax.lsq`) over any parameter pytree; for campaigns
`fit.fit_features` / `fit.fit_records` / `fit.fit_objective` add multi-start and
reweighting (one result type `FitResult` with a result code). `mcmc.run_mcmc` samples the
same objective (emcee at the edge). Mode options (`--objective`, `--criterion`) are the
str enums of `modes`.

Where new things go:
- a new friction law to fit: a final subclass of `params.AbstractFrictionParams`
  (names, units, leaves, prior support; `from_log_values`, `with_values`, `physical`);
- a new objective: a final subclass of `combined.AbstractObjective` in a module beside
  `trace_objective` / `smooth_objective`, with residuals of `params.CampaignParams`
  whitened by their standard errors (an objective over other parameters: a final
  subclass of `solve.AbstractResiduals`, solved by `solve.least_squares`); to offer it
  as `--objective NAME`, a member of `modes.Objective` and its branch in `fit.fit_features`;
- a new effect for discovery: a family in `discovery.cycle_effects` and its term in
  `discovery.cycle_model`;
- a new mode option: a member of its enum in `modes` (or a new `AbstractMode` there),
  validated once with `.parse` where it enters;
- a new subcommand: a module in `commands/` (NAME, HELP, add_arguments, run) and an
  entry point in the `stickslip.commands` group of pyproject.toml.

Design studies live in `design` (steady maps, exact cycle maps, experiment planning),
pitching fits in `pitch_fit`. Importing this package enables `jax_enable_x64` (through
`stickslip_jax`): every computation here is in float64.
"""

import importlib
import sys
import types
from typing import TYPE_CHECKING

import stickslip_jax  # noqa: F401  (enables x64)

if TYPE_CHECKING:  # for type checkers, `stickslip_fitting.fit(...)` is the one-call fit
    from .api import fit as fit

__all__ = [
    "AbstractFrictionParams",
    "AbstractResiduals",
    "Campaign",
    "CampaignDiscovery",
    "CampaignFit",
    "CampaignParams",
    "CampaignPosterior",
    "Covariance",
    "DesignCriterion",
    "EmpiricalFriction",
    "FitResult",
    "Hold",
    "McmcResult",
    "MicrosqueezeFriction",
    "ModelModes",
    "Objective",
    "Padding",
    "RecordFeatures",
    "SmallSample",
    "SolverOptions",
    "Uncertainty",
    "Weighting",
    "discover",
    "discover_cycles",
    "fit",
    "fit_features",
    "fit_microsqueeze",
    "fit_objective",
    "fit_records",
    "free_spec",
    "laplace",
    "least_squares",
    "load_campaign",
    "record_features",
    "run_mcmc",
    "sample",
]

_HOME = {
    "AbstractFrictionParams": "params", "CampaignParams": "params",
    "EmpiricalFriction": "params", "free_spec": "params", "Hold": "params",
    "MicrosqueezeFriction": "microsqueeze_params", "fit_microsqueeze": "microsqueeze_fit",
    "Campaign": "campaign", "load_campaign": "campaign",
    "RecordFeatures": "features", "record_features": "features",
    "FitResult": "fit", "fit_features": "fit", "fit_objective": "fit", "fit_records": "fit",
    "Uncertainty": "uncertainty", "laplace": "uncertainty",
    "McmcResult": "mcmc", "run_mcmc": "mcmc",
    "discover_cycles": "discovery.cycle_workflow",
    "AbstractResiduals": "solve", "least_squares": "solve",
    "Objective": "modes", "DesignCriterion": "modes", "Covariance": "modes",
    "SmallSample": "modes", "ModelModes": "modes", "Weighting": "modes", "Padding": "modes",
    "SolverOptions": "modes",
    "CampaignFit": "api",
    "CampaignPosterior": "posterior_api", "sample": "posterior_api",
    "CampaignDiscovery": "discovery_api", "discover": "discovery_api",
}


class _FitModule(types.ModuleType):
    """The type of the submodule `stickslip_fitting.fit`: a module (fit_features,
    FitResult, ...) that, called, runs the one-call fit `api.fit`."""

    def __call__(self, records, **options):
        from .api import fit

        return fit(records, **options)

    @property
    def __signature__(self):
        import inspect

        from .api import fit

        return inspect.signature(fit)


class _Package(types.ModuleType):
    """This package's module type: the import system sets each submodule as an attribute
    of the package, and the submodule `fit` gets the type `_FitModule` there."""

    def __setattr__(self, name, value):
        if name == "fit" and type(value) is types.ModuleType:
            value.__class__ = _FitModule
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


def __getattr__(name):
    # imported on first use: building the `stickslip` parser imports this package, and
    # the fit modules pull in the simulators
    if name == "fit":  # the submodule, callable (`_FitModule`)
        return importlib.import_module(".fit", __name__)
    if name in _HOME:
        return getattr(importlib.import_module(f".{_HOME[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
