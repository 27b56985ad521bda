"""What the stages of the per-cycle discovery hand on (`cycle_workflow`): each stage is a
function of the states before it and returns its own, frozen.

`Clock` times the stages and reports each line to `progress`; `Prepared` is the campaign
and its cycle windows (`prepare`), `Base` the paper's model fitted to them (`base_fit`),
`Ranking` the score tests (`rank`), `Fits` what every refit needs (the states so far and
the options), `Refitted` the refits (`refit`, `sharpen`), `Choice` the winner and the
decision (`decide`), `Reweighed` the winner with the records tried at full weight
(`reweigh`), `Decided` the two with the sequential search's steps."""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable

import numpy as np

from stickslip_jax.lsq import LeastSquaresSolution as Solution
from stickslip_jax.lsq import gauss_newton_decrease

from ...data.campaign import Campaign
from ..cycle_effects import Family, Shape
from ..cycle_model import CycleModel
from ..decision import Decision
from ..options import DiscoveryOptions
from ..result import effect_rows
from ..subproblems import SubProblem
from ..thinning import Samples

__all__ = ["SIGNIFICANT_BY", "Base", "Choice", "Clock", "Decided", "Fits", "Prepared",
           "Ranking", "Refitted", "Reweighed", "Step"]


@dataclasses.dataclass
class Clock:
    """Stage timings (s, by stage name; a stage reported twice keeps its last time) and the
    progress lines ("name: line (t s)")."""

    progress: Callable[[str], object] | None = None
    timings: dict = dataclasses.field(default_factory=dict)
    last: float = dataclasses.field(default_factory=time.perf_counter)
    suffix: str = ""  # added to every stage name (the later effects' stages: ", effect 2")

    def __call__(self, name: str, line: str) -> None:
        now = time.perf_counter()
        name += self.suffix
        self.timings[name] = now - self.last
        self.last = now
        if self.progress is not None:
            self.progress(f"{name}: {line} ({self.timings[name]:.1f} s)")

    def say(self, line: str) -> None:
        """A progress line that is not a stage."""
        if self.progress is not None:
            self.progress(line)


@dataclasses.dataclass(frozen=True, eq=False)
class Prepared:
    """The screened campaign, its cycle windows (`trace_data`, windows the model cannot
    start set aside) and the model weighted at the features fit's friction."""

    campaign: Campaign
    data: object  # `trace_objective.TraceData`
    warm: dict  # the model's programs compiling in the background (`CycleModel.warm`)
    model: CycleModel
    z_start: np.ndarray  # the base fit's start (`plausible_start` of the features fit)
    t2_of: np.ndarray  # per window: the slip time pi / omega_0 (s)
    starts: np.ndarray  # index of every window's first sample (samples are window by window)
    windows_set_aside: list
    n_complete: int  # complete cycle windows
    n_reslip: int  # of them, those following a re-slip
    keep_reslips: bool
    samples: Samples | None = None  # [N, L]: what each entry of `data` stands for (`thinning`)

    @property
    def recs(self):
        return self.campaign.records

    @property
    def feats(self):
        return self.campaign.features

    @property
    def G(self) -> int:
        return len(self.campaign.records)


@dataclasses.dataclass(frozen=True, eq=False)
class Base:
    """The paper's model fitted to the windows, with the records it describes worse than
    their noise weighed by their scatter (`scaled`) or set aside (`aside`); with the
    effects already named (`held`, in the order named; their coordinates are base
    columns, `cols`, and their shape settings and sensor flag are `shape`, `sensor`)."""

    model: CycleModel  # weighted as at the base optimum (records scaled by `factor`)
    fit: Solution
    z: np.ndarray  # the model's coordinates at the base fit
    sd_plain: np.ndarray  # [N, L] standard errors before the records' scaling
    rec_of: np.ndarray  # per residual: its record
    median_chi2: float  # the campaign's median record chi2/n
    scaled: dict  # record -> chi2/n: weighed by its scatter
    aside: dict  # record -> chi2/n: set aside (a subset of `scaled`)
    scaled_notes: list  # `records_scaled`
    described: np.ndarray  # per residual: its record is not set aside
    n_used: int  # residuals of the described records
    sd: np.ndarray  # per residual: standard error (mm)
    noise: float  # the campaign's noise level (mm)
    gap_before: float
    gap_all_before: float
    slipping: np.ndarray  # per residual: in a slip
    misfit: bool  # far from the data (chi2/n or gap over `misfit`)
    samples: Samples | None = None  # per residual: the samples it stands for (`thinning`)
    within: float = 0.0  # chi-square of the binned sticks' scatter (described records):
    # the samples' chi-square is the residuals' (`fit.rss`) plus this
    held: tuple = ()  # the `Family`s named so far, part of the base
    shape: Shape = Shape()  # their shape settings (`subproblems.with_shape`)
    sensor: bool = False  # the sensor low-pass is one of them

    @property
    def cols(self) -> np.ndarray:
        """The base's model columns: friction, offsets, then the held effects'; `fit.J`
        and `fit.z` are over these."""
        return np.concatenate([np.arange(self.model.n_base)]
                              + [self.model.cols(f) for f in self.held])

    @functools.cached_property
    def own_decrease(self) -> float:
        """The Gauss-Newton decrease of the base fit over its own columns (NaN where its
        derivatives are not finite): once for a base fit, read by every family's
        `refit.cannot_win`."""
        J, r = np.asarray(self.fit.J), np.asarray(self.fit.r)
        with np.errstate(over="ignore", invalid="ignore"):
            A, g = J.T @ J, J.T @ r
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(g))):
            return float("nan")
        try:
            return float(gauss_newton_decrease(A, g, xp=np))
        except np.linalg.LinAlgError:
            return float("nan")

    @property
    def r(self) -> np.ndarray:
        return self.fit.r

    @property
    def n(self) -> int:
        return self.fit.r.size


@dataclasses.dataclass
class FamilyScore:
    family: Family
    shape: Shape
    statistic: float  # F statistic (Hotelling T^2, small-sample corrected)
    p_value: float
    dof: int
    step: np.ndarray  # Gauss-Newton step of the family's coordinates (scaled)
    direction: np.ndarray  # efficient-score columns (for collinearity)
    chi2_predicted: float  # chi-square drop the Gauss-Newton step predicts
    test: int = -1  # index of its test among all family-shape tests (`flips`)
    p_family: float = float("nan")  # family-wise p-value over all tests (`flips`)
    p_sample: float = float("nan")  # per-sample score test's p-value (chi-square, dof)
    significant_by: str | None = None  # which test made it significant (`SIGNIFICANT_BY`)


SIGNIFICANT_BY = {
    "family-wise": "the robust window test, family-wise p below alpha",
    "per-sample": "a relevant predicted chi-square drop whose per-sample score test has p "
                  "below alpha / (number of tests)",
}
"""The two ways a family is significant (`rank`): its key in `FamilyScore.significant_by`
and what it means."""


@dataclasses.dataclass(frozen=True, eq=False)
class Ranking:
    """The score tests: every family's best shape (`scores`, ordered by p-value), every
    shape's test (`shape_scores`), the sensor's probe per kernel, the significant ones."""

    scores: list
    shape_scores: dict
    sensor_probe: dict
    significant: list
    n_tests: int  # family-shape tests counted in the family-wise p-values
    level: float = float("nan")  # the per-sample test's level (alpha / tests, Bonferroni)


@dataclasses.dataclass
class FamilyRefit:
    family: Family
    shape: Shape
    fit: Solution
    drop: float  # chi-square drop against the base fit
    values: np.ndarray  # natural values of the family's parameters
    stderr: np.ndarray
    unphysical: str | None
    sensor: bool
    sub: SubProblem  # the refit's problem (to continue it)
    failed: str | None = None  # why the refit is not a result (it ended above the base)


@dataclasses.dataclass(frozen=True, eq=False)
class Fits:
    """What a refit needs: the options, the campaign, the base and the ranking (None
    before `rank`)."""

    opts: DiscoveryOptions
    prep: Prepared
    base: Base
    ranking: Ranking | None = None


@dataclasses.dataclass(frozen=True, eq=False)
class Refitted:
    """The refits in the order they were made; `eligible`: the families the calibrated
    test let through (the winner is one of them); `shaped`: families whose shape the
    refinement before the decision already searched."""

    refits: list
    eligible: frozenset
    shaped: frozenset = frozenset()


@dataclasses.dataclass(frozen=True, eq=False)
class Choice:
    """The winner (None: no physical refit that lowers chi-square) after its polish and
    shape refinement, the decision against the other refits and its chi-square drop as
    decided."""

    chosen: FamilyRefit | None
    decision: Decision | None
    rivals: list  # `indistinguishable_from`
    compared: dict  # family name -> `Contender`
    decided_drop: float
    judged: tuple = ()  # the refits as decided (a per-record screw as one screw: `one_screw`)


@dataclasses.dataclass(frozen=True, eq=False)
class Reweighed:
    """The winner after the records weighed by their scatter were tried at full weight,
    the standard errors of its last fit, and the records that weigh fully again."""

    chosen: FamilyRefit | None
    sd_after: np.ndarray
    reweighed: list


@dataclasses.dataclass(frozen=True, eq=False)
class Decided:
    """What the decision hands on: the choice of the final model (`more_effects`), the
    winner tried with the records at full weight (`reweigh`) and the sequential search's
    steps (`settled`)."""

    choice: Choice
    after: Reweighed
    steps: list


@dataclasses.dataclass(frozen=True, eq=False)
class Step:
    """One effect of the sequential search (`stages.more`): its family and shape, its
    values and standard errors (natural units; in the final model, all named effects
    fitted together, where it is kept), the gap (mm) with it and the effects before it,
    its family-wise p-value in its ranking, its confidence, its chi-square drop, the
    families its records cannot tell it from, the effects named before it that its
    drop-one test removed (`dropped`), and whether it is in the final model."""

    family: Family
    shape: Shape
    values: np.ndarray
    stderr: np.ndarray
    gap_after: float
    p_family: float
    confidence: str
    drop: float
    rivals: list
    dropped: tuple = ()
    kept: bool = True

    def to_json(self, G: int) -> dict:
        """The step's entry of the JSON's "steps": a value the records do not determine
        is null in "values" and "stderr", with its reason in "estimates" (the
        parameter-entry keys of `stickslip fit`)."""
        rows = {e.name: e.to_json() for e in effect_rows(self, G)}
        return {"effect": self.family.name, "shape": self.shape.label(self.family),
                "values": {n: e["value"] for n, e in rows.items()},
                "stderr": {n: e["stderr"] if e["value"] is not None else None
                           for n, e in rows.items()},
                "units": {n: e["unit"] for n, e in rows.items()}, "estimates": rows,
                "gap_after": self.gap_after,
                "p_family": self.p_family, "confidence": self.confidence,
                "chi2_drop": self.drop, "indistinguishable_from": self.rivals,
                "dropped": list(self.dropped), "kept": self.kept}
