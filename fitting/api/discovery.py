r"""One call for missing-physics discovery: `stickslip_fitting.discover(records, ...)` ->
`CampaignDiscovery`.

```python
import stickslip_fitting as sf

found = sf.discover("data/examples/*.csv")
print(found.effect, found.confidence)
print(found.summary())          # pandas DataFrame: one row per effect family tested
found.plot("discover.png")      # the figure of `stickslip discover --plot`
found.to_json("discover.json")  # the document of `stickslip discover --json`
```

The call runs `stickslip discover` on its default base (the per-cycle model, `--base
cycle`) with the same functions: the records read as the command reads them (a file that
cannot be read is set aside and listed), `discovery.cycle_workflow.discover_cycles`, the
figure of `discovery.plots.plot_cycle_discovery` and the document of the command's
`json_document`.
"""

from __future__ import annotations

import dataclasses
import os
from typing import TYPE_CHECKING

from stickslip_jax.records import Record

from .campaign import RecordsSpec, as_list, loss_option
from .results import ResultDocument, pandas_module

if TYPE_CHECKING:
    import pandas
    from matplotlib.figure import Figure

    from ..discovery.result import CycleDiscovery
    from ..objectives.losses import AbstractLoss

__all__ = ["FAMILY_COLUMNS", "CampaignDiscovery", "discover"]

FAMILY_COLUMNS = ("shape", "score", "p_value", "family_wise_p_value", "significant",
                  "significant_by", "chi2_drop", "unphysical", "named")
"""The columns of `CampaignDiscovery.summary()`: the family's shape, its robust window
test (statistic F `score`, its `p_value` and the `family_wise_p_value` over every
family-shape test), whether and by which test it is significant, the refit's chi-square
drop (NaN when not refitted), whether the refit left the physical range, and whether the
answer names it."""

def _number(x) -> float:
    return float("nan") if x is None else float(x)


@dataclasses.dataclass(frozen=True)
class CampaignDiscovery(ResultDocument):
    """The result of `discover`: the effect the paper's model misses in a campaign.

    - `effect`, `confidence`, `explanation`: the answer (a family's name, "none" or
      "unexplained"); `named`: the families the answer names (the effect and those the
      records cannot tell from it);
    - `summary()`: a pandas DataFrame indexed by family (`FAMILY_COLUMNS`);
    - `plot(path)`: the figure of `stickslip discover --plot`;
    - `to_json(path)`: the document of `stickslip discover --json`; `to_dict()` the same
      as a dict;
    - `str(result)`: the answer, the gap, the candidate table and the parameters, as the
      command prints them.

    `result` is the workflow's `discovery.result.CycleDiscovery` (fits, residuals by
    phase, the screened campaign, the learned correction).
    """

    result: CycleDiscovery
    loss: str = "gaussian"
    inputs: tuple[str, ...] = ()
    """The record files read (an output may not overwrite one of them)."""

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
        """The families the answer names: the effect, those the records cannot tell
        from it, and the further effects of the sequential search (empty for "none" and
        "unexplained")."""
        names = {c["name"] for c in self.result.candidates}
        joint = [self.result.effect] + [r["name"] for r in self.result.indistinguishable_from]
        joint += [s["effect"] for s in getattr(self.result, "steps", ())
                  if s["kept"] and s["effect"] not in joint]
        return [n for n in joint if n in names]

    def summary(self) -> pandas.DataFrame:
        """One row per effect family tested, indexed by its name (`FAMILY_COLUMNS`), in
        the order of the candidate table. Needs pandas (the `[pandas]` extra)."""
        pd = pandas_module("CampaignDiscovery.summary()")
        named = set(self.named)
        rows = {}
        for c in self.result.candidates:
            rows[c["name"]] = (c.get("shape") or "", _number(c.get("score")),
                               _number(c.get("score_p_value")),
                               _number(c.get("family_wise_p_value")),
                               bool(c.get("significant")), c.get("significant_by") or "",
                               _number(c.get("chi2_drop")), bool(c.get("unphysical")),
                               c["name"] in named)
        frame = pd.DataFrame.from_dict(rows, orient="index", columns=list(FAMILY_COLUMNS))
        frame.index.name = "family"
        return frame

    @property
    def report(self) -> dict:
        """The `stickslip discover --json` document before strict encoding."""
        from ..commands.discover import json_document

        return {**json_document(self.result), "loss": self.loss}

    def plot(self, path: str | os.PathLike[str] | None = None) -> Figure:
        """The figure of `stickslip discover --plot` (`discovery.plots.
        plot_cycle_discovery`: residual RMS by phase before and after, traces and
        residuals of up to four records): returned, and saved to `path` when given."""
        path = self.output_path(path, "plot")
        fig = self.result.figure()
        if path is not None:
            from stickslip_jax.output import save_figure

            save_figure(fig, path, dpi=120)
        return fig

    def __str__(self) -> str:
        from ..commands.discover import answer_text

        return answer_text(self.result)

    def __repr__(self) -> str:
        return (f"CampaignDiscovery(effect={self.effect!r}, confidence={self.confidence!r}, "
                f"families={len(self.result.candidates)})")


def discover(records: RecordsSpec, *, only: tuple[str, ...] | list[str] | None = None, top: int = 3,
             alpha: float = 0.01, max_evals: int = 80, loss: AbstractLoss | str = "gaussian",
             strict: bool = False, learn: bool = False, progress=None,
             max_effects: int = 3) -> CampaignDiscovery:
    """Find the effect the paper's model misses in a campaign, as `stickslip discover`
    does on its default base (the per-cycle model).

    - `records`: a file, a folder (its *.csv), a glob, a list of these, or `Record`
      objects; at least two.
    - `only`: the effect families to consider (`discovery.cycle_effects.FAMILIES`'
      names; default all), as `--only`.
    - `top`: how many significant families to refit; `alpha`: the false-alarm rate of
      the test over all families; `max_evals`: the evaluation budget of the base fit;
      `loss`: the likelihood ("gaussian", "huber:C", "student-t:NU" or an
      `AbstractLoss`); `strict`: refuse the campaign when a record has no usable
      stick-slip; `learn`: fit the learned phase correction whatever the answer;
      `progress`: called with one line per finished stage (e.g. `print`);
      `max_effects`: how many effects may be named one after another, as
      `--max-effects` (1: the single best effect).

    Every mistake in the options raises ValueError naming the keyword, before any fit
    (the checks of `cycle_workflow.CycleBase`).
    """
    from ..discovery.cycle_effects import FAMILIES
    from ..discovery.cycle_workflow import discover_cycles

    if isinstance(only, str):
        only = [only]
    names = [f.name for f in FAMILIES]
    bad = [n for n in only or () if n not in names]
    if bad:
        raise ValueError(f"only: unknown effect families {', '.join(bad)}; the families are "
                         f"{', '.join(names)}")
    loss = loss_option(loss)

    given = as_list(records)
    unreadable: list = []
    inputs: tuple[str, ...] = ()
    if given and isinstance(given[0], Record):
        recs = given
    else:
        from stickslip_jax.records import read_campaign_files

        files = read_campaign_files([os.fspath(g) for g in given])
        recs, unreadable = files.records, list(files.unreadable)
        files.check(strict)
        inputs = tuple([r.source for r in recs if r.source] + [e.path for e in unreadable])
    if len(recs) + len(unreadable) < 2:
        raise ValueError("records: discovery needs at least two records (a campaign)")
    result = discover_cycles(recs, candidates=tuple(only) if only else None, top=top,
                             alpha=alpha, max_evals=max_evals, strict=strict, learn=learn,
                             loss=loss, unreadable=tuple(unreadable), progress=progress,
                             max_effects=max_effects)
    return CampaignDiscovery(result=result, loss=loss.spec(), inputs=inputs)
