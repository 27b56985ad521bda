r"""One call for the next records to measure: `plan_records(sources, weights, stiffnesses,
speeds, ...)` -> `RecordPlan`, the plan `stickslip plan` prints and writes.

```python
import numpy as np
import stickslip_fitting as sf

plan = sf.plan_records(["A"], [11.3, 36.0, 53.2], [27.3, 86.9, 128.5],
                       np.geomspace(0.0022, 92.0, 12) / 60.0, budget=2)
print(plan)                  # the table `stickslip plan` prints
plan.to_json("plan.json")    # the document of `stickslip plan --json`
```

The candidate axes are numbers in the package's units (kgf, kgf/mm, mm/s); the sources
are `design.posterior.plan_sources`' (a lubricant name, a prior or posterior file, records
already measured)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import ClassVar

import numpy as np

from ..modes import DesignCriterion
from ..report.rows import ParameterEstimate
from .design import JSON_ALIASES
from .results import ResultDocument

__all__ = ["MAX_BUDGET", "PlannedRecord", "RecordPlan", "plan_records"]

MAX_BUDGET = 1000
"""Most records one plan proposes (the greedy design adds them one at a time)."""


@dataclasses.dataclass(frozen=True)
class PlannedRecord:
    """A proposed record: its conditions and whether the steady analysis expects
    stick-slip there (the document's "records" rows)."""

    weight_kgf: float
    stiffness_kgf_per_mm: float
    drive_speed_mm_per_min: float
    stick_slip_expected: bool


@dataclasses.dataclass(frozen=True)
class RecordPlan(ResultDocument):
    """The plan: the `records` proposed, from `source` (what the estimate came from) by
    `criterion` among `n_candidates` records, and each parameter's estimate with its
    relative sd `before` and `after` them (`report.rows.ParameterEstimate`)."""

    source: str
    criterion: DesignCriterion
    n_candidates: int
    records: tuple[PlannedRecord, ...]
    before: tuple[ParameterEstimate, ...]
    after: tuple[ParameterEstimate, ...]
    inputs: tuple[str, ...] = ()

    JSON_ALIASES: ClassVar[dict[str, str]] = JSON_ALIASES

    @property
    def report(self) -> dict:
        """The `stickslip plan --json` document before versioning."""
        return {"source": self.source, "criterion": self.criterion.value,
                "estimate": {e.name: e.value for e in self.before},
                "relative_sd_before": {e.name: e.log_sd for e in self.before},
                "relative_sd_after": {e.name: e.log_sd for e in self.after},
                "records": [dataclasses.asdict(r) for r in self.records]}

    def __str__(self) -> str:
        lines = [f"plan from {self.source}: {len(self.records)} record(s), "
                 f"{self.criterion.value}-optimal, {self.n_candidates} candidates",
                 f"{'#':>3} {'W [kgf]':>9} {'k [kgf/mm]':>11} {'v [mm/min]':>11}  regime"]
        for i, r in enumerate(self.records, 1):
            regime = "stick-slip" if r.stick_slip_expected else "smooth"
            lines.append(f"{i:>3} {r.weight_kgf:>9.4g} {r.stiffness_kgf_per_mm:>11.4g} "
                         f"{r.drive_speed_mm_per_min:>11.4g}  {regime}")
        lines.append("relative sd of the parameters (sd of log), before -> after:")
        lines += [f"  {b.name:>6}: {b.log_sd:.3g} -> {a.log_sd:.3g}"
                  for b, a in zip(self.before, self.after)]
        lines.append("note: the design is local to the estimate; record one or two "
                     "proposals, re-fit, and plan again (see "
                     "stickslip_fitting.design.sequential_campaign)")
        return "\n".join(lines)


def plan_records(sources, weights, stiffnesses, speeds, *, budget: int = 4, table: int = 6,
                 prior_sd: float = 0.5, noise=None,
                 criterion: DesignCriterion | str = DesignCriterion.D,
                 repeats: bool = True) -> RecordPlan:
    """The `budget` records among the candidates `weights` x `stiffnesses` x `speeds`
    (kgf, kgf/mm, mm/s) that best identify the friction parameters at the estimate of
    `sources` (`design.posterior.plan_sources`, with `table` and `prior_sd`), by the greedy
    `criterion`-optimal design (`design.experiment.greedy_design`; `noise` a
    `design.Noise`, default its own; `repeats`: may propose a record twice; `criterion` a
    `DesignCriterion` or its value). A mistake raises ValueError naming the keyword."""
    from stickslip_jax.logs import logger
    from stickslip_jax.output import check_memory

    from ..design import PARAMETERS, Noise, candidate_grid, greedy_design, observables
    from ..design.posterior import plan_sources
    from ..params import UNITS

    noise = Noise() if noise is None else noise
    criterion = DesignCriterion.parse(criterion, "criterion")
    if not 1 <= budget <= MAX_BUDGET:
        raise ValueError(f"budget: must lie in 1-{MAX_BUDGET} records (a plan proposes "
                         f"records one at a time), got {budget}")
    if not all(x > 0 for x in (noise.log_amplitude, noise.log_stick_time, noise.mu_0,
                               noise.mu_m)):
        raise ValueError("noise: every noise level must be positive")
    u, sd, existing, desc = plan_sources(sources, table, prior_sd)
    axes = (weights, stiffnesses, speeds)
    # the Fisher matrix of every candidate (6 x 6) and its observables, per greedy step;
    # checked before the grid of candidates is built (3000^3 of them died building it)
    n_cands = float(np.prod([np.size(a) for a in axes], dtype=float))
    check_memory(f"{' x '.join(str(np.size(a)) for a in axes)} = {n_cands:.3g} candidate "
                 "records", "weights/stiffnesses/speeds", n_cands * 64 * 8)
    cands = candidate_grid(*axes)
    if not repeats and budget > len(cands):
        raise ValueError(f"budget: {budget} exceeds the {len(cands)} candidates")
    logger.info(f"choosing {budget} of {len(cands)} candidate records "
                f"({criterion.value}-optimal)...")
    plan = greedy_design(u, cands, budget, noise=noise, prior_sd=sd, existing=existing,
                         repeats=repeats, criterion=criterion)
    logger.info("plan done")
    rows = []
    for i in range(budget):
        w, k, v = (float(np.asarray(x)[i]) for x in
                   (plan.campaign.weight, plan.campaign.stiffness, plan.campaign.speed))
        _, mask = observables(u, w, k, v)
        rows.append(PlannedRecord(w, k, v * 60.0, bool(np.asarray(mask)[0] > 0)))
    # the estimate (log coordinates) with its sd before and after
    before, after = (tuple(ParameterEstimate.from_log(p, UNITS[p], x, s)
                           for p, x, s in zip(PARAMETERS, u, sds))
                     for sds in (plan.sd_before, plan.sd_after))
    return RecordPlan(desc, criterion, len(cands), tuple(rows), before, after,
                      inputs=tuple(str(s) for s in sources if Path(s).exists()))
