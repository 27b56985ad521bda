r"""One call for a campaign's fit: `stickslip_fitting.fit(records, ...)` -> `CampaignFit`.

```python
import stickslip_fitting as sf

result = sf.fit("data/examples/*.csv")   # a glob, a folder, a list of paths or Records
print(result.summary())                  # pandas DataFrame, one row per parameter
result.plot("fit.png")                   # the diagnostic figure
result.to_json("fit.json")               # the document of `stickslip fit --json`
```

The call runs `stickslip fit`'s one verb (`fit_campaign`), so it gives the same numbers,
document and text. The options are the command's, each the object it names
(`Objective.TRACE`, `{"n": 1.0}`, `Huber(2.0)`, `EmpiricalFriction`) or its string.

Units are the internal ones (kgf, mm, s; mu dimensionless, gamma s^-m, delta s^-n). A
parameter the records do not determine has no value: NaN in `summary()`, null with a
reason in the JSON.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any, Union

from stickslip_jax.modes import GaugeOffset, SlipTime
from stickslip_jax.records import Record

from ..modes import ModelModes, Objective
from .results import ResultDocument, pandas_module

if TYPE_CHECKING:
    import pandas
    from matplotlib.figure import Figure

    from ..data.campaign import Campaign, FitCampaign
    from ..solve.fit import FitResult
    from ..objectives.losses import AbstractLoss
    from ..params import AbstractFrictionParams
    from ..uncertainty.laplace import Uncertainty

__all__ = ["CampaignFit", "RecordsSpec", "SUMMARY_COLUMNS", "fit", "loss_option"]

RecordsSpec = Union[str, "os.PathLike[str]", Record, Iterable[Union[str, "os.PathLike[str]", Record]]]
"""What `fit` reads: a file, a folder (its *.csv), a glob, or a list of these; or
`Record` objects (one or a list)."""

SUMMARY_COLUMNS = ("value", "std_err", "low", "high", "unit", "identifiable", "reason")
"""The columns of `CampaignFit.summary()` (low, high: the 95 % interval)."""

def parameter_rows(entries: dict) -> dict[str, tuple]:
    """{name: (value, std_err, low, high, unit, identifiable, reason)} (`SUMMARY_COLUMNS`)
    of a report's parameter entries ({name: entry}, the `--json` parameter keys)."""
    nan = math.nan
    rows = {}
    for name, p in entries.items():
        fixed = bool(p.get("fixed", False))
        known = bool(p.get("identifiable", True)) or fixed
        value = p.get("value")
        value = nan if value is None or not known else float(value)
        reason = p.get("reason")
        if not known and not reason:
            reason = "not identifiable: the records do not determine it"
        if fixed and not reason:
            reason = "fixed (given, not fitted)"
        interval = p.get("ci95")
        shown = (known and not fixed and not p.get("at_bound", False)
                 and p.get("stderr") is not None and interval is not None)
        rows[name] = (value,
                      float(p["stderr"]) if shown else nan,
                      float(interval[0]) if shown else nan,
                      float(interval[1]) if shown else nan,
                      p["unit"], bool(p.get("identifiable", True)), reason or "")
    return rows


def parameter_frame(entries: dict, owner: str) -> pandas.DataFrame:
    """`parameter_rows` as a DataFrame indexed by "parameter"; `owner` names the call in
    the error when pandas is missing."""
    pd = pandas_module(owner)
    frame = pd.DataFrame.from_dict(parameter_rows(entries), orient="index",
                                   columns=list(SUMMARY_COLUMNS))
    frame.index.name = "parameter"
    return frame


@dataclasses.dataclass(frozen=True)
class CampaignFit(ResultDocument):
    """The result of `fit`: the campaign's friction parameters with their intervals.
    `summary()` (pandas, `SUMMARY_COLUMNS`), `plot(path)` (`stickslip fit --plot`),
    `to_json(path)` / `to_dict()` (`stickslip fit --json`), `str(result)` (`text`, the table
    the command prints). Parts: `report` (the JSON document), `fit` (`solve.fit.FitResult`),
    `uncertainty` (`uncertainty.laplace.Uncertainty`), `campaign` (`data.campaign.Campaign`)
    and `notes` (what reading and cycle extraction did to each record, `Campaign.notes`);
    `model` is the report's ("empirical", "microsqueeze" or another base law's name);
    `run_mcmc(result.fit)` for the posterior.
    """

    report: dict
    fit: FitResult
    uncertainty: Uncertainty
    campaign: Campaign
    notes: list[str] = dataclasses.field(default_factory=list)

    @property
    def model(self) -> str:
        """The friction law fitted, as the report names it."""
        return self.report["model"]

    @property
    def inputs(self) -> tuple[str, ...]:
        """The record files read (an output may not overwrite one of them)."""
        return self.campaign.inputs

    @property
    def text(self) -> str:
        """The table `stickslip fit` prints, then the campaign's notes
        (`report.fit_table.fit_text`)."""
        from ..report.fit_table import fit_text

        return fit_text(self.report, self.notes)

    @property
    def converged(self) -> bool:
        """True when the optimiser reached an optimum (the CLI exits 3 otherwise)."""
        return bool(self.report["converged"])

    @property
    def parameters(self) -> dict[str, dict]:
        """{name: entry} of the JSON document (value, stderr, ci95, unit, identifiable,
        fixed, ...), in the law's order."""
        return self.report["parameters"]

    @property
    def values(self) -> dict[str, float]:
        """{name: value}; NaN for a parameter the records do not determine."""
        return {name: row[0] for name, row in parameter_rows(self.report["parameters"]).items()}

    def summary(self) -> pandas.DataFrame:
        """One row per parameter (`SUMMARY_COLUMNS`, internal units); `reason` says why a
        parameter is fixed, at a bound or not identifiable (value NaN then). Needs
        pandas."""
        return parameter_frame(self.report["parameters"], "CampaignFit.summary()")

    def plot(self, path: str | os.PathLike[str] | None = None) -> Figure:
        """The diagnostic figure of `stickslip fit --plot` (`report.plots.fit_figure`):
        returned, and saved to `path` (closed then) when given."""
        from ..report.plots import campaign_fit_figure

        path = self.output_path(path, "plot")
        return campaign_fit_figure(self.fit, self.uncertainty, self.campaign, path)

    def __str__(self) -> str:
        return self.text

    def __repr__(self) -> str:
        used = sum(s.status == "used" for s in self.campaign.screening)
        values = ", ".join(f"{n}={v:.5g}" for n, v in self.values.items())
        return (f"CampaignFit(model={self.model!r}, records={used}, converged="
                f"{self.converged}, {values})")


def fit(records: RecordsSpec, *, model: str | type[AbstractFrictionParams] = "empirical",
        objective: Objective | str = Objective.FEATURES, fix: Mapping[str, float] | None = None,
        loss: AbstractLoss | str = "gaussian", gauge_offset: GaugeOffset | str = GaugeOffset.ZERO,
        slip_time: SlipTime | str = SlipTime.PAPER, strict: bool = False,
        eta: float | str | None = None, surface: str = "S1G1") -> CampaignFit:
    """Fit the friction parameters to a campaign of records, as `stickslip fit` does.

    - `records`: a `RecordsSpec`.
    - `model`: `EmpiricalFriction` (eq (1), "empirical", the default) or
      `MicrosqueezeFriction` ("microsqueeze": h_e and Q in place of gamma and m).
    - `objective`: an `Objective` (or its value); `fix`: {name: value} held fixed.
    - `loss`: an `objectives.losses.AbstractLoss` or its spec ("huber:1.345").
    - `gauge_offset`: a `GaugeOffset` (ZERO or START); `slip_time`: a `SlipTime` (PAPER,
      pi/omega0 of eq 7, or SELF_CONSISTENT).
    - `strict`: refuse the campaign when a record has no usable stick-slip (default: fit
      the others, listed in the report).
    - `eta`: microsqueeze only: the viscosity, a number in Pa*s or a string with its unit
      ("216 cP"); default the records' lubricant in Table 11. `surface`: the surface pair
      of Table 10.

    Every mistake in the options or the records raises ValueError naming what to fix
    (a glob that matches no file names the pattern), before any fitting. A fit that does
    not converge gives a RuntimeWarning (`CampaignFit.converged` is then False).
    """
    goal = Objective.parse(objective)
    modes = ModelModes(offset=GaugeOffset.parse(gauge_offset, "gauge_offset"),
                       slip_time=SlipTime.parse(slip_time))
    from ..params import EmpiricalFriction

    law = _law(model)
    loss = loss_option(loss)
    fixed = _fixed(fix, law)
    pair = eta_value = None
    if not issubclass(law, EmpiricalFriction):  # the microsqueeze law
        pair = surface_option(surface)
        eta_value = None if eta is None else _viscosity(eta)
    elif eta is not None:
        raise ValueError("eta: only used with model='microsqueeze'")
    out = fit_campaign(as_list(records), law, fixed, objective=goal, loss=loss, modes=modes,
                       strict=strict, eta=eta_value, pair=pair, surface=surface,
                       check=lambda held: _fixed(held, law))
    if not out.converged:
        warnings.warn("the fit did not converge (see str(result) for the warnings): its "
                      "values are not an optimum", RuntimeWarning, stacklevel=2)
    return out


def fit_campaign(records: list, law, fixed: dict[str, float], *, objective: Objective,
                 loss: AbstractLoss, modes: ModelModes, strict: bool = False,
                 eta: float | None = None, pair=None, surface: str = "S1G1",
                 check=None, outputs=None) -> CampaignFit:
    """`stickslip fit`'s steps, each once in the order the data flows: `records` read and
    screened (`data.campaign`; the command's `outputs` checked against the files read,
    `_read`), `law` fitted with `fixed` {name: value} held (`solve.fit`,
    `solve.microsqueeze`; a single record holds `one_record_holds` too, the merged holds
    checked by `check`), the intervals and checks (`uncertainty`), the report
    (`report.fit_table`). `eta` (kgf*s/mm^2; None: the records' lubricant's) and `pair`:
    the microsqueeze law's givens."""
    from ..objectives.losses import Gaussian
    from ..params import EmpiricalFriction, Hold

    micro = not issubclass(law, EmpiricalFriction)  # the other law it takes: microsqueeze
    what = f"objective {objective}" + ("" if isinstance(loss, Gaussian)
                                       else f", loss {loss.spec()}")
    data = _read(records, law, one_record=not micro, strict=strict, outputs=outputs, what=what)
    if data.holds:
        fixed = {**data.holds, **fixed}
        fixed = fixed if check is None else check(fixed)
    kw: dict[str, Any] = dict(hold=Hold.named(fixed) if fixed else None, modes=modes,
                              objective=objective, records=data.campaign.records, loss=loss)
    if not micro:
        from ..solve.fit import fit_features

        result, extra = fit_features(data.campaign.features, **kw), None
    else:
        from ..solve.microsqueeze import default_eta, fit_microsqueeze

        eta = default_eta(data.campaign.records[0].lubricant) if eta is None else eta
        result = fit_microsqueeze(data.campaign.features, eta=eta, pair=pair, **kw)
        extra = {"given": {"eta": {"value": eta, "unit": "kgf*s/mm^2"}, "surface": surface}}
    return _conclude(result, data, extra)


def fit_law_campaign(records: list, law, fixed: dict[str, float], *, modes: ModelModes,
                     strict: bool = False, outputs=None) -> CampaignFit:
    """`fit_campaign` for a base law other than the paper's (a `FrictionLaw`, fitted through
    whole records by `solve.laws.fit_law`), `fixed` held."""
    from ..params import Hold
    from ..solve.laws import LAW_PARAMS, fit_law

    data = _read(records, LAW_PARAMS[law], one_record=False, strict=strict, outputs=outputs,
                 what=f"objective {Objective.SMOOTH}")
    result = fit_law(data.campaign.features, data.campaign.records, law,
                     hold=Hold.named(fixed) if fixed else None, modes=modes)
    return _conclude(result, data, None)


def _read(records: list, law, *, one_record: bool, strict: bool, outputs, what: str
          ) -> FitCampaign:
    """The data step of a campaign fit (`data.campaign.read_fit_campaign` for `law`'s
    parameters), then the command's `outputs` ({option: path}) checked against the files
    read, before any fitting; `what` the fit says it runs."""
    from stickslip_jax.logs import logger

    from ..data.campaign import read_fit_campaign

    data = read_fit_campaign(records, law.NAMES, one_record=one_record, strict=strict)
    if outputs:
        from stickslip_jax.output import check_outputs

        check_outputs(outputs, data.campaign.inputs)
    logger.info(f"fitting {len(data.campaign.records)} records ({what}, model {law.MODEL})...")
    return data


def _conclude(result: FitResult, data: FitCampaign, extra) -> CampaignFit:
    """A fit's figures and its boundary at the records without stick-slip
    (`solve.summary`), Laplace intervals and adequacy checks (`uncertainty`), then its
    report (`report.fit_table`), from what the data step gave (`data`)."""
    from stickslip_jax.logs import logger

    from ..report.fit_table import build_report
    from ..solve.summary import fit_figures
    from ..uncertainty.adequacy import adequacy
    from ..uncertainty.laplace import laplace

    figures = fit_figures(result, data.campaign)
    logger.info(f"fit {'converged' if figures.converged else 'did not converge'}; "
                "intervals...")
    unc = laplace(result)
    estimates, checks = unc.estimates(data.truth), adequacy(result).to_json()
    report = build_report(result, unc, data.campaign, extra=extra, truth=data.truth,
                          figures=figures, estimates=estimates, checks=checks,
                          screening=data.screening)
    logger.info("report done")
    return CampaignFit(report=report, fit=result, uncertainty=unc, campaign=data.campaign,
                       notes=list(data.notes))


def as_list(records) -> list:
    """`records` as a list of specs or of `Record`s (a single one in a list); a list that
    mixes the two is refused."""
    if isinstance(records, (str, os.PathLike, Record)):
        return [records]
    if not isinstance(records, Iterable):
        raise ValueError(f"records: a path, a folder, a glob, a Record or a list of them, "
                         f"got {records!r}")
    out = list(records)
    if any(isinstance(r, Record) for r in out) and not all(isinstance(r, Record) for r in out):
        raise ValueError("records: give paths (files, folders, globs) or Record objects, "
                         "not both in one campaign")
    return out


def _law(model) -> type[AbstractFrictionParams]:
    """The law class of `model` (a class or its name)."""
    from ..microsqueeze_params import MicrosqueezeFriction
    from ..params import EmpiricalFriction

    laws = {"empirical": EmpiricalFriction, "microsqueeze": MicrosqueezeFriction}
    for name, law in laws.items():
        if model is law or model == name:
            return law
    raise ValueError(f"model must be one of {tuple(laws)} (or EmpiricalFriction, "
                     f"MicrosqueezeFriction), got {model!r}")


def _keyword(err: ValueError, option: str) -> ValueError:
    """The command's message with its option written as the keyword."""
    return ValueError(str(err).replace(f"--{option}", option))


def loss_option(loss) -> AbstractLoss:
    """The `loss` keyword of `fit`, `sample` and `discover`: an `AbstractLoss` as it is,
    a spec ("huber:1.345") parsed, a ValueError naming the keyword otherwise."""
    from ..objectives.losses import AbstractLoss, parse_loss

    if isinstance(loss, AbstractLoss):
        return loss
    try:
        return parse_loss(loss)
    except ValueError as err:
        raise _keyword(err, "loss") from None


def _fixed(fix, law) -> dict[str, float]:
    """{name: value} held, checked by `params.parse_fix` (names, ranges, one free)."""
    from ..params import parse_fix

    if fix is None:
        fix = {}
    if not isinstance(fix, Mapping):
        raise ValueError(f"fix: a mapping {{name: value}}, e.g. {{'n': 1.0}}, got {fix!r}")
    items = []
    for name, value in fix.items():
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"fix {name}: {value!r} is not a number") from None
        items.append(f"{name}={number!r}")
    try:
        return parse_fix(items, law)
    except ValueError as err:
        raise _keyword(err, "fix") from None


def surface_option(name: str, option: str = "surface"):
    """The `SurfacePair` of Table 10 named `name`; a ValueError naming `option` otherwise."""
    from stickslip_jax.contact import surface_pair

    try:
        return surface_pair(name)
    except (KeyError, ValueError) as err:
        raise ValueError(f"{option}: unknown surface pair {name!r} ({err})") from None


def _viscosity(eta) -> float:
    """`eta` in kgf*s/mm^2 from a number in Pa*s or a string with its unit (the command's
    parser)."""
    import argparse

    from stickslip_jax.commands.options import viscosity

    if isinstance(eta, bool) or not isinstance(eta, (int, float, str)):
        raise ValueError(f"eta: a number in Pa*s or a string with its unit, got {eta!r}")
    try:
        return float(viscosity()(eta if isinstance(eta, str) else repr(float(eta))))
    except (argparse.ArgumentTypeError, ValueError) as err:
        raise ValueError(f"eta: {err}") from None
