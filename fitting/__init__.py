r"""stickslip_fitting (the folder fitting/): parameter identification, design studies and the missing-physics workflow
for stickslip_jax.

One call fits a campaign as `stickslip fit` does (`api.campaign`):

```python
import stickslip_fitting as sf
result = sf.fit("data/examples/*.csv")   # -> CampaignFit
result.summary(); result.plot("fit.png"); result.to_json("fit.json")
```

`sample(records)` -> `api.posterior.CampaignPosterior` (as `stickslip mcmc`),
`discover(records)` -> `api.discovery.CampaignDiscovery` (as `stickslip discover`) and
`design_map(weight, stiffness, speed)` -> `api.design.DesignStudy` (as `stickslip design`)
have the same shape: `summary()`, `plot(path)`, `to_json(path)`;
`plan_records(sources, weights, stiffnesses, speeds)` -> `api.plan.RecordPlan` (as
`stickslip plan`) prints its table and has `to_json(path)`.

The subpackages follow the data flow, one way (each knows only the ones before it):

1. `data`: records -> `data.campaign.load_campaign` (screening) -> `data.features` (cycles)
2. `objectives`: `objectives.combined.AbstractObjective` (features, trace, `WeightedSum`, smooth)
3. `solve`: `solve.lsq.least_squares(objective, params, free)`; `solve.fit` (multi-start)
4. `uncertainty`: `uncertainty.laplace` (Fisher, cluster sandwich), `uncertainty.mcmc`
5. `report`: `report.rows.ParameterEstimate`, `report.fit_table`, `report.plots`;
   `commands/` parse, call one verb and print; `api/` returns the result objects.

Beside them: `params` and `modes` (the vocabulary every step shares), `discovery/`
(missing physics, in stages) and `design/` (steady maps, exact cycle maps, experiment
planning, tolerances).

Where a new friction law, objective, effect family, option or command goes:
docs/architecture.md ("Where new things go").

Importing this package enables `jax_enable_x64` (through `stickslip_jax`): every
computation here is in float64.
"""

import importlib
from typing import TYPE_CHECKING

import stickslip_jax  # noqa: F401  (enables x64)

if TYPE_CHECKING:  # for type checkers, `stickslip_fitting.fit(...)` is the one-call fit
    from .api.campaign import fit as fit

_HOME = {"AbstractFrictionParams": "params", "CampaignParams": "params",
         "EmpiricalFriction": "params", "free_spec": "params", "Hold": "params",
         "MicrosqueezeFriction": "microsqueeze_params", "fit_microsqueeze": "solve.microsqueeze",
         "Campaign": "data.campaign", "load_campaign": "data.campaign",
         "RecordFeatures": "data.features", "record_features": "data.features",
         "FitResult": "solve.fit", "fit_features": "solve.fit", "fit_objective": "solve.fit",
         "fit_records": "solve.fit",
         "Uncertainty": "uncertainty.laplace", "laplace": "uncertainty.laplace",
         "McmcResult": "uncertainty.mcmc", "run_mcmc": "uncertainty.mcmc",
         "discover_cycles": "discovery.cycle_workflow", "CycleBase": "discovery.cycle_workflow",
         "SmoothBase": "discovery.workflow",
         "AbstractResiduals": "solve.lsq", "least_squares": "solve.lsq",
         "Objective": "modes", "Crop": "modes", "DesignCriterion": "modes", "Covariance": "modes",
         "SmallSample": "modes", "ModelModes": "modes", "Weighting": "modes", "Padding": "modes",
         "SolverOptions": "modes", "When": "modes", "CampaignFit": "api.campaign",
         "fit": "api.campaign",
         "CampaignPosterior": "api.posterior", "sample": "api.posterior",
         "CampaignDiscovery": "api.discovery", "discover": "api.discovery",
         "DesignStudy": "api.design", "design_map": "api.design",
         "RecordPlan": "api.plan", "plan_records": "api.plan"}
__all__ = sorted(_HOME)


def __getattr__(name):
    # imported on first use: building the `stickslip` parser imports this package, and
    # the fit modules pull in the simulators
    if name in _HOME:
        return getattr(importlib.import_module(f".{_HOME[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
