r"""Discovery on the per-cycle model: which effect is the paper's model missing?

```python
from stickslip_jax.records import read_campaign
from stickslip_fitting.discovery.cycle_workflow import discover_cycles

result = discover_cycles(read_campaign("records/*.csv"))
result.effect, result.confidence, result.gap_before, result.gap_after
```

Stages (each timed in `result.timings`, reported to `progress` as it finishes):

1. `prepare`: screening (records without usable stick-slip set aside and listed), the
   features fit (start), the cycle windows (the drive error left in the data).
2. `base_fit`: the paper's model on every window (`cycle_model`, all effects zero), the
   objective of `stickslip fit --objective trace` (friction + one gauge offset per
   record), weights refreshed once at the optimum. A record described much worse than
   the others (chi2/n above `record_chi2` x the median: a marginal record) weighs by its
   own scatter (`records_scaled`); the gaps and tests are over the other records (its
   structured residuals would be "explained" a little by every family).
3. `ranking`: a **robust score test** of every family and shape (`cycle_effects`) from
   one Jacobian block each at the base fit: the efficient score (the family's columns
   with the base parameters projected out) is summed per cycle window, $g_w$, and
   Hotelling's $T^2$ tests its mean zero, $F = \frac{n - p}{p(n-1)} T^2 \sim F(p, n - p)$
   ($n$ windows, $p$ parameters): residuals within a window share the errors of its
   measured restart, so a per-sample test would raise false alarms on clean data.
   A family is significant when its best shape's **family-wise** p-value is below
   `alpha` (`flips`: Westfall-Young min-p over sign flips of the windows, which keeps the
   tests' strong correlations; Bonferroni assumed them independent and lost power), or
   when its predicted chi-square drop is at least `relevant` of the samples and the
   per-sample score test passes Bonferroni's level (the window test loses power when a
   few windows carry most of the signal).
4. `refit`: the `top` significant families, each refitted from the score step with its
   best shape (the sensor with both kernel orders). A fit beyond a family's physical
   bounds or signs, or one whose traces do not change with its parameters (a zero
   Jacobian: e.g. a damping that stops every slip), is unphysical and never named. Far
   from the data (base chi2/n > `misfit`), the physical refits that explain at least
   `joint` of the best one's drop have their continuous shape parameters refined
   (`refine_contenders`; the grid shapes alone let a per-record screw beat a rational
   Stribeck curve on lubricant C). When none of the `top` refits is physical, the other
   significant families are refitted too.
5. `decision`: every other family with nominal evidence (robust p < `alpha`) is refitted
   as a contender. The physical refit with the largest chi-square drop net of its
   parameters' price (ln n each, `stages.decide.price`) wins; each other refit is
   compared with it by the **paired window test** (`paired_z`) and the principal cosine
   of their efficient-score directions (`decide`). A contender not clearly beaten
   (z < `clear`) that is physical and nearly collinear (cosine >= `collinear`) is named
   jointly (`indistinguishable_from`: "X or Y: these records cannot tell them apart"),
   unless the winner is still needed given it (`stages.decide.told_apart`).
   Far from the data, a named fit that leaves more than `refine_gap` x the noise is run
   again from the base fit's starting friction (the base bent its friction to absorb the
   effect). Confidence is "high" only when the answer explains the gap (residual RMS
   within 15 % of the noise) and no contender that explains a comparable share (drop >=
   `joint` of the winner's) is unbeaten; a gap that no family explains (less than half
   of the excess chi-square removed) is "unexplained", with the residual pattern and a
   learned correction over the cycle phase (`cycle_learned`). The explanation names every
   phase left above the noise; "none" is "low" when a phase's chi2/n exceeds `phase_chi2`.
6. `more`: the sequential search (`stages.more`, whose module doc justifies the stopping
   rule): the named effect joins the base and stages 3-5 run again over the families not
   yet in it, until none is significant or `max_effects` are named; each earlier effect
   is tested again given the new one and dropped when no longer significant.
   `result.steps` is the staircase, `result.effect` the first effect kept. The records
   weighed by their scatter are tried at full weight (`reweigh`) on the final model.

Gaps are residual RMS in mm; `noise` is the RMS of the records' robust noise estimates.
The stages are the functions of `discovery.stages`; the lower-case names above are the
fields of `options.DiscoveryOptions`.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

from ..objectives.losses import AbstractLoss
from .cycle_effects import FAMILIES, family
from .cycle_model import per_sample
from .engine import AbstractBaseModel, discover
from .options import DEFAULTS, DiscoveryOptions, at_least
from .result import CycleDiscovery, friction_rows
from .stages import (Clock, Fits, Prepared, Refitted, base_fit, choose, conclude, more_effects,
                     prepare, rank, refit, reweigh, settled, sharpen)
from .stages.state import Decided

__all__ = ["CycleBase", "CycleDiscovery", "DiscoveryOptions", "discover_cycles"]


@dataclasses.dataclass(frozen=True)
class CycleBase(AbstractBaseModel):
    """The per-cycle base (module doc) and its options.

    `candidates`: family names (default all of `cycle_effects.FAMILIES`; `only` of
    `tuned`, of `stickslip_fitting.discover` and of `--only`); `opts`: the
    tuning (`options.DiscoveryOptions`); `strict`: refuse the campaign when a record has
    no usable stick-slip; `learn`: fit the learned phase correction (`cycle_learned`)
    whatever the answer (always for "unexplained"); `loss`: a heavy-tailed likelihood
    (`objectives.losses`, `--loss`) whose weights at the base fit are held fixed (None or
    Gaussian: least squares); `unreadable`: the errors of the files that could not be
    read, listed in the screening; `max_effects`: how many effects the sequential search
    may name (stage 6; 1: the first search's answer alone).
    """

    candidates: tuple[str, ...] | None = None
    opts: DiscoveryOptions = DEFAULTS
    strict: bool = False
    learn: bool = False
    loss: AbstractLoss | None = None
    unreadable: tuple = ()
    max_effects: int = 3
    NAME: ClassVar[str] = "cycle"

    def __post_init__(self):
        """The one check of the options (`opts` checks its own); an error names the option
        as `tuned` and `stickslip_fitting.discover` spell it (the command adds "--")."""
        at_least("max_effects", self.max_effects, 1)
        names = [f.name for f in FAMILIES]
        bad = [n for n in self.candidates or () if n not in names]
        if bad:
            raise ValueError(f"only: unknown effect families {', '.join(bad)}; the families "
                             f"are {', '.join(names)}")

    @classmethod
    def tuned(cls, *, only=None, **options) -> CycleBase:
        """The base of `only` the families named (a name or names; None or empty: all)
        from `options`, the fields of `CycleBase` and of its tuning `DiscoveryOptions` (over
        `DEFAULTS`)."""
        tuning = {k: options.pop(k) for k in list(options)
                  if k in DiscoveryOptions.__dataclass_fields__}
        if isinstance(only, str):
            only = (only,)
        if only:
            options["candidates"] = tuple(only)
        return cls(opts=dataclasses.replace(DEFAULTS, **tuning), **options)

    @property
    def families(self) -> list:
        return [family(n) for n in self.candidates] if self.candidates else list(FAMILIES)

    def prepare(self, records, clock: Clock) -> Prepared:
        return prepare(records, strict=self.strict, unreadable=self.unreadable,
                       opts=self.opts, clock=clock)

    def base_fit(self, prepared: Prepared, clock: Clock) -> Fits:
        base = base_fit(prepared, loss=self.loss, opts=self.opts, clock=clock)
        return Fits(opts=self.opts, prep=prepared, base=base)

    def rank(self, fitted: Fits, clock: Clock) -> Fits:
        return dataclasses.replace(fitted, ranking=rank(fitted.prep, fitted.base,
                                                        self.families, opts=self.opts,
                                                        clock=clock))

    def refit(self, ranked: Fits, clock: Clock) -> Refitted:
        return sharpen(ranked, refit(ranked, clock=clock), clock=clock)

    def decide(self, ranked: Fits, refitted: Refitted, clock: Clock) -> Decided:
        last, choice, steps = more_effects(ranked, choose(ranked, refitted, clock=clock),
                                           self.families, max_effects=self.max_effects,
                                           clock=clock)
        after = reweigh(last, choice, clock=clock)
        return Decided(choice=choice, after=after, steps=settled(last, after.chosen, steps))

    def conclude(self, ranked: Fits, refitted: Refitted, decided: Decided,
                 clock: Clock) -> CycleDiscovery:
        result = conclude(ranked, refitted, decided.choice, decided.after, learn=self.learn,
                          clock=clock, steps=decided.steps)
        return with_uncertainty(result, ranked.base)


def with_uncertainty(result: CycleDiscovery, base) -> CycleDiscovery:
    """The friction rows before and after with their standard errors and identifiability
    (`result.friction_rows`, one cluster per cycle window). Without a refit of its own (no
    effect, or a form outside the library) the final friction is the base's: a value the
    form moved keeps the base's verdict and has no standard error."""
    clusters = per_sample(result.model.data, "record", "window")

    def rows(fit):
        return friction_rows(fit, result.campaign.features, clusters,
                             chi2=fit.rss + base.within, dof=base.n_used - fit.z.size)

    before = rows(result.base_fit)
    after = (rows(result.final_fit) if result.final_fit is not result.base_fit else
             [b if b.value == a.value else dataclasses.replace(b, value=a.value, stderr=None,
                                                                ci95=None)
              for b, a in zip(before, result.estimates_after)])
    return dataclasses.replace(result, estimates_before=before, estimates_after=after)


def discover_cycles(records, *, progress=None, **options) -> CycleDiscovery:
    """Run the workflow (module doc) on `records` (a campaign of `Record`s) with the
    `options` of `CycleBase.tuned`; `progress` is called with one line per finished stage."""
    return discover(records, CycleBase.tuned(**options), progress=progress)
