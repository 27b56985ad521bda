r"""One call for missing-physics discovery: `stickslip_fitting.discover(records, ...)` ->
`CampaignDiscovery`.

```python
import stickslip_fitting as sf

found = sf.discover("data/examples/*.csv")
print(found.effect, found.confidence)
print(found.summary())          # pandas DataFrame: one row per effect tested
found.plot("discover.png")      # the figure of `stickslip discover --plot`
found.to_json("discover.json")  # the document of `stickslip discover --json`

smooth = sf.discover("data/examples", base=sf.SmoothBase(top=2, crop=sf.Crop.SLIP_END))  # --base smooth
laws = sf.discover("data/examples", compare_laws=True).laws  # --compare-laws
```

`stickslip discover` is this call: the records read, `discovery.engine.discover` on the
base, the base friction laws compared where asked (`discovery.laws.compare_laws`), its
figure, and the answer text and JSON document of `report.discovery_text`.
"""

from __future__ import annotations

import dataclasses
import os
from typing import TYPE_CHECKING

from stickslip_jax.records import Record

from ..modes import DiscoveryBase, When
from ..report.discovery_text import answer_text, json_document, named_effects
from .campaign import RecordsSpec, as_list, loss_option, parameter_frame
from .results import ResultDocument, pandas_module

if TYPE_CHECKING:
    import pandas
    from matplotlib.figure import Figure

    from ..discovery.cycle_workflow import CycleBase
    from ..discovery.laws import LawComparison
    from ..discovery.result import Discovery
    from ..discovery.workflow import SmoothBase
    from ..objectives.losses import AbstractLoss

__all__ = ["FAMILY_COLUMNS", "SMOOTH_COLUMNS", "CampaignDiscovery", "discover", "named_effects"]

FAMILY_COLUMNS = ("shape", "score", "p_value", "family_wise_p_value", "significant",
                  "significant_by", "chi2_drop", "unphysical", "named")
"""The columns of `CampaignDiscovery.summary()` on the per-cycle base: the family's shape,
its robust window test (F `score`, `p_value`, `family_wise_p_value`), whether and by which
test it is significant, the refit's chi-square drop (NaN: not refitted), whether the refit
left the physical range, and whether the answer names it."""

SMOOTH_COLUMNS = ("score", "p_value", "dof", "delta_bic", "lr_p_value", "unphysical", "named")
"""The columns of `summary()` on the smoothed base (`SmoothBase`): the score test
(statistic, p-value, dof), the refit's BIC change and likelihood-ratio p-value (NaN: not
refitted), whether the score step or the refit was unphysical, and whether it is named."""


@dataclasses.dataclass(frozen=True)
class CampaignDiscovery(ResultDocument):
    """The result of `discover`: the effect the paper's model misses in a campaign
    (`effect`: a name, "none" or "unexplained"), its tables (`summary()`,
    `parameters(when)`), figure (`plot`), `stickslip discover --json` document
    (`to_json`, `to_dict`) and, as `str`, what the command prints. `result` is the
    pipeline's `discovery.result.Discovery` (fits, residuals by phase, the campaign);
    `laws` the base friction laws compared on the records it used (`compare_laws=True`;
    JSON key "laws"), else None."""

    result: Discovery
    loss: str = "gaussian"
    inputs: tuple[str, ...] = ()
    """The record files read (an output may not overwrite one of them)."""
    laws: LawComparison | None = None

    @property
    def effect(self) -> str:
        return self.result.effect

    @property
    def confidence(self) -> str:
        return self.result.confidence

    @property
    def explanation(self) -> str:
        return self.result.explanation

    @property
    def named(self) -> list[str]:
        """The effects the answer names: the effect, those the records cannot tell from
        it, and the further effects of the sequential search (empty for "none" and
        "unexplained")."""
        names = {c["name"] for c in self.result.candidates}
        joint, further = named_effects(self.result)
        return [n for n in joint + [n for n in further if n not in joint] if n in names]

    def summary(self) -> pandas.DataFrame:
        """One row per effect tested, in the candidate table's order: `FAMILY_COLUMNS`
        (index "family") or `SMOOTH_COLUMNS` (index "effect"). Needs pandas."""
        pd = pandas_module("CampaignDiscovery.summary()")
        cycle = self.result.BASE is DiscoveryBase.CYCLE
        columns = FAMILY_COLUMNS if cycle else SMOOTH_COLUMNS
        keys = {"p_value": "score_p_value", "delta_bic": "delta_criterion"}
        kinds = dict(shape=str, significant_by=str, dof=int, significant=bool,
                     unphysical=bool, named=bool)
        named = set(self.named)

        def cell(c, k):  # None: NaN for a number, "" for a text, False for a flag
            v = c["name"] in named if k == "named" else c.get(keys.get(k, k))
            kind = kinds.get(k, float)
            return float("nan") if v is None and kind is float else kind(v or kind())

        rows = {c["name"]: [cell(c, k) for k in columns] for c in self.result.candidates}
        frame = pd.DataFrame.from_dict(rows, orient="index", columns=list(columns))
        frame.index.name = "family" if cycle else "effect"
        return frame

    def parameters(self, when: When | str = When.AFTER) -> pandas.DataFrame:
        """The friction parameters (and the named effects' as "effect.name") `When.BEFORE`
        or `When.AFTER` the named effects (or its string, "before", "after"), with the
        columns of `CampaignFit.summary()` (NaN with the reason where the records do not
        determine a value). Needs pandas."""
        when = When.parse(when)
        return parameter_frame(self.report[f"estimates_{when.value}"],
                               "CampaignDiscovery.parameters()")

    @property
    def report(self) -> dict:
        """The `stickslip discover --json` document before strict encoding."""
        loss = {"loss": self.loss} if self.result.BASE is DiscoveryBase.CYCLE else {}
        laws = {} if self.laws is None else {"laws": self.laws.to_json()}
        return {**json_document(self.result), **loss, **laws}

    def plot(self, path: str | os.PathLike[str] | None = None) -> Figure:
        """The figure of `stickslip discover --plot`, saved to `path` when given."""
        path = self.output_path(path, "plot")
        fig = self.result.figure()
        if path is not None:
            from stickslip_jax.output import save_figure

            save_figure(fig, path, dpi=120)
        return fig

    def __str__(self) -> str:
        return answer_text(self.result) + ("" if self.laws is None else "\n" + self.laws.message)

    def __repr__(self) -> str:
        return (f"CampaignDiscovery(effect={self.effect!r}, confidence={self.confidence!r}, "
                f"base={self.result.BASE.value!r}, effects={len(self.result.candidates)})")


def discover(records: RecordsSpec, *, base: CycleBase | SmoothBase | None = None,
             only: tuple[str, ...] | list[str] | None = None, top: int = 3,
             alpha: float = 0.01, max_evals: int = 80, loss: AbstractLoss | str = "gaussian",
             strict: bool = False, learn: bool = False, progress=None,
             max_effects: int = 3, compare_laws: bool = False,
             outputs: dict[str, str | None] | None = None) -> CampaignDiscovery:
    """Find the effect the paper's model misses in a campaign, as `stickslip discover`.

    - `records`: a file, a folder (its *.csv), a glob, a list of these, or `Record`s;
      at least two.
    - `base`: None for the per-cycle base built from the keywords below (`--base
      cycle`), or `CycleBase(...)` / `SmoothBase(...)` carrying its own options (the
      keywords then keep their defaults).
    - `only`, `top`, `alpha`, `max_evals`, `strict`, `learn`, `max_effects`: as the
      command's options; `loss`: "gaussian", "huber:C", "student-t:NU" or an
      `AbstractLoss`; `progress`: called with one line per finished stage.
    - `compare_laws`: also fit the base friction laws (the paper's, rate-and-state with
      aging, logarithmic aging) to the records discovery used (`CampaignDiscovery.laws`;
      minutes on the smoothed simulator).
    - `outputs`: {option: path} of files to be written, checked against the files read
      before any fit (an output never overwrites an input).

    A mistake in the options raises ValueError naming the keyword, before any fit.
    """
    from ..discovery.cycle_workflow import CycleBase
    from ..discovery.engine import AbstractBaseModel
    from ..discovery.engine import discover as run

    if base is None:  # CycleBase checks the options and names the keyword
        base = CycleBase.tuned(only=only, top=top, alpha=alpha, max_evals=max_evals,
                               strict=strict, learn=learn, loss=loss_option(loss),
                               max_effects=max_effects)
    elif not isinstance(base, AbstractBaseModel):
        raise ValueError(f"base: a CycleBase or SmoothBase (from stickslip_fitting), got "
                         f"{base!r}")
    else:
        keywords = dict(only=only, top=top, alpha=alpha, max_evals=max_evals, loss=loss,
                        strict=strict, learn=learn, max_effects=max_effects)
        defaults = discover.__kwdefaults__ or {}
        set_ = [k for k, v in keywords.items() if v != defaults[k]]
        if set_:
            raise ValueError(f"{', '.join(set_)}: with base given, set it as a field of "
                             f"{type(base).__name__} (or leave base out)")

    given = as_list(records)
    unreadable: list = []
    inputs: tuple[str, ...] = ()
    if given and isinstance(given[0], Record):
        recs: list[Record] = given
    else:
        from stickslip_jax.records import read_campaign_files

        files = read_campaign_files([os.fspath(g) for g in given])
        recs, unreadable = files.records, list(files.unreadable)
        files.check(base.strict)
        inputs = tuple([r.source for r in recs if r.source] + [e.path for e in unreadable])
    if outputs:
        from stickslip_jax.output import check_outputs

        check_outputs(outputs, inputs)
    if len(recs) + len(unreadable) < 2:
        raise ValueError("records: discovery needs at least two records (a campaign)")
    from stickslip_jax.logs import logger

    logger.info(f"discovery on {len(recs)} records (base {base.NAME})...")
    result = run(recs, dataclasses.replace(base, unreadable=tuple(unreadable)),
                 progress=progress)
    used = base.loss if isinstance(base, CycleBase) else None
    return CampaignDiscovery(result=result, loss=used.spec() if used else "gaussian",
                             inputs=inputs, laws=_compare_laws(result.campaign)
                             if compare_laws else None)


def _compare_laws(campaign) -> LawComparison:
    """The base friction laws fitted to the records discovery used (`compare_laws`)."""
    from stickslip_jax.logs import logger

    from ..discovery.laws import compare_laws
    from ..modes import FrictionLaw

    logger.info("comparing the base friction laws on the smoothed simulator (minutes)...")
    return compare_laws(campaign.records, (FrictionLaw.PAPER, FrictionLaw.RATE_STATE_AGING,
                                           FrictionLaw.LOG_AGING), features=campaign.features)
