r"""Which base friction law describes a campaign: the paper's eqs (1), (3) against the other
laws (`stickslip_fitting.modes.FrictionLaw`) on the same records.

`compare_laws(records, laws)` fits every law through whole records (`solve.laws.fit_law`,
simulators below) on the earlier part of each record (up to `1 -
hold_out` of it) and scores it by $\mathrm{AIC} = \chi^2 + 2k$ and $\mathrm{BIC} = \chi^2 +
k\ln n$ of the fitted residuals and by $\chi^2/n$ of the held-out cycles, the model run
on past the fitted part (a law that only bends to the fitted cycles drifts off there).

Each record is compared over its first `CYCLES` cycles after its first slip end (later
cycles add cost, not evidence: a rate-and-state law with a small direct effect takes
about 3000 solver steps per cycle, and 30 cycles of a real record outran the step budget;
4 cost 20-120 CPU s for two records, once 550). The preferred law has the lowest BIC; a law
that cannot be fitted (no start simulates through the records, or the fit fails from every
start it refines) scores an infinite chi-square, with the `reason`. The paper's law is the
wrong base when another beats it by `BIC_MARGIN` (a Bayes factor above 150) and is not
worse on the held-out cycles.

The paper's law runs through the exact simulator (`ExactRecords`: events in closed form),
the others through the smoothed one. A slip that ends above $\mu_d W$ slips on from rest
with $\mu_d$ (a re-slip, eqs (1), (3) at $T_1 = 0$); the exact simulator does so, the
smoothed one's latch does not (measured on records of the paper's law that re-slip after
every slip: the true parameters at chi2/n 1.00 through the exact simulator, 150-310
through the latch, whose slider creeps on with the drive where it should slip again; the
fit through the latch settles at chi2/n 134, mu_s 0.368 against 0.415, delta 21 against 37). Each
record starts where its slider came to rest after its first slip (`at_rest`): after a
re-slip up to one slip later than the end the features time (from a single slip's
duration).
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import numpy as np

from ..modes import FrictionLaw, ModelModes, SolverOptions
from ..objectives.smooth import SmoothObjective, record_drive

__all__ = ["BIC_MARGIN", "ExactRecords", "LawComparison", "LawScore", "at_rest",
           "compare_laws"]

BIC_MARGIN = 10.0
"""BIC difference above which one law is preferred with strong evidence."""
CYCLES = 4
"""Cycles of each record (after its first slip end) the laws are compared over."""
LAW_TOLERANCES = dict(rtol=1e-7, atol=1e-9, max_steps=32768)
"""The solve of a law other than the paper's (mm, mm/s; steps): 100 x looser than the
latch's 1e-9 (1e-8 mm on a 0.1 mm deflection, far below any noise), twice its budget."""


REST_SIGMAS = 3.0
"""A re-slip's tail: samples whose 3-sample mean lies this many noise sd (of one sample)
or more above the stick line after it (`at_rest`)."""


class ExactRecords(SmoothObjective):
    """`SmoothObjective` on the same data through the exact simulator
    (`stickslip_jax.simulation.simulate_exact`, module doc): the paper's law only.
    `max_events`: stick and slip phases per record (a re-slip costs two more).

    Record by record (`lax.map`), not `simulate_exact_campaign`: that gives the same
    values (to 2e-13 mm) and, once compiled, comparisons 4 times faster, but compiles
    about 3 times longer; one comparison on the example campaign (the paper's law) took
    14 instead of 7 s of CPU time (load 10-12)."""

    max_events: int = eqx.field(static=True, default=64)

    def simulate(self, params):
        import stickslip_jax as ss
        from stickslip_jax.simulation import SimulationResult, simulate_exact

        fr = params.friction.friction()
        d = self.data

        def one(args):
            w, n, k, v, x_start, t, m, kn = args
            tr = simulate_exact(ss.Slideway(fr, w, k, n), record_drive(v, kn), t,
                                slip_time=self.slip_time, initial_deflection=x_start,
                                start_time=0.0, mask=m, max_events=self.max_events,
                                cycle_table=False, check=False)
            return tr.deflection, tr.result == SimulationResult.successful

        return jax.lax.map(one, (d.weight, d.normal_load, d.stiffness, d.speed,
                                 d.start_level - params.offset, d.time, d.mask, d.drive_knots))

    def describe(self) -> str:
        return "whole records, exact simulator from the slider's first rest"


def at_rest(record, features):
    """`features` with its first slip end moved to where the slider came to rest (module
    doc) when that slip lasted longer than a single slip (`RecordFeatures.slipped_on`):
    past the last sample whose 3-sample mean lies `REST_SIGMAS` noise sd above the stick
    line after it (the trough, moving with the drive), within two single slips' durations,
    by the time a half cosine of half the largest excess there takes from that level to
    rest; the trough moves along that line. Others are returned unchanged."""
    f = features
    if not len(f.end_time) or not bool(np.asarray(f.slipped_on)[0]):
        return f
    t = np.asarray(record.time, float)
    y = np.asarray(record.deflection if f.deflection_used is None else f.deflection_used, float)
    t_e, x1 = float(f.end_time[0]), float(f.trough[0])
    win = np.flatnonzero((t >= t_e) & (t <= t_e + 2.0 * np.pi / f.omega0))
    if win.size < 4:
        return f
    u = record.drive_position(t[win])
    excess = (y[win] - x1 - (u - record.drive_position([t_e])[0])) / f.noise
    high = np.flatnonzero(np.convolve(excess, np.ones(3) / 3.0, "same") >= REST_SIGMAS)
    if not high.size:
        return f
    # the slip's last swing, a half cosine of half the largest excess, comes to rest
    # arccos(1 - level / half) / omega0 after it passes the level
    half = 0.5 * float(np.max(excess))
    late = np.arccos(1.0 - min(REST_SIGMAS / half, 2.0)) / f.omega0
    j = int(np.searchsorted(t, t[win[high[-1]]] + late))
    if j >= win[-1]:
        return f
    end = np.array(f.end_time, float)
    trough = np.array(f.trough, float)
    trough[0] += float(record.drive_position([t[j]])[0] - record.drive_position([t_e])[0])
    end[0] = t[j]
    return dataclasses.replace(f, end_time=end, trough=trough)


@dataclasses.dataclass(frozen=True)
class LawScore:
    """One law's fit (module doc): `chi2` of the `n` fitted residuals, `k` free
    parameters, `held_out` chi2/n, `values` (natural units), `reason` for no finite score."""

    law: FrictionLaw
    chi2: float
    n: int
    k: int
    held_out: float
    converged: bool
    values: dict
    reason: str = ""

    @property
    def aic(self) -> float:
        return self.chi2 + 2.0 * self.k

    @property
    def bic(self) -> float:
        return self.chi2 + self.k * float(np.log(max(self.n, 1)))


@dataclasses.dataclass(frozen=True)
class LawComparison:
    """The scores of every law in the order given, the `preferred` one, `paper_wrong_base`
    (module doc) and a one-paragraph `message`."""

    scores: tuple[LawScore, ...]
    preferred: FrictionLaw
    paper_wrong_base: bool
    message: str

    def score(self, law: FrictionLaw) -> LawScore:
        return next(s for s in self.scores if s.law is law)

    def to_json(self) -> dict:
        return {"preferred": self.preferred.value, "paper_wrong_base": self.paper_wrong_base,
                "message": self.message, "laws": [
                    {"law": s.law.value, "chi2": s.chi2, "n": s.n, "k": s.k, "aic": s.aic,
                     "bic": s.bic, "held_out_chi2_per_sample": s.held_out,
                     "converged": s.converged, "values": s.values, "reason": s.reason}
                    for s in self.scores]}


def _verdict(scores) -> tuple[FrictionLaw, bool, str]:
    best = min(scores, key=lambda s: s.bic)
    paper = next((s for s in scores if s.law is FrictionLaw.PAPER), None)
    lines = [f"{s.law.value}: BIC {s.bic:.1f}, held-out chi2/n {s.held_out:.3g}"
             + (f" ({s.reason})" if s.reason else "" if s.converged else
                " (its fit not converged within its step budget)") for s in scores]
    if paper is None or best is paper:
        return best.law, False, f"preferred: {best.law.value} ({'; '.join(lines)})"
    wrong = paper.bic - best.bic >= BIC_MARGIN and best.held_out <= paper.held_out
    verdict = ("the paper's law is the wrong base" if wrong else
               "the evidence against the paper's law is not strong")
    return best.law, wrong, (f"preferred: {best.law.value}, BIC lower by "
                             f"{paper.bic - best.bic:.1f}; {verdict} ({'; '.join(lines)})")


def _crop(d, features, cycles):
    """`SmoothData` d cut after the `cycles`-th slip end following each record's first."""
    import jax.numpy as jnp

    t = np.asarray(d.time)
    ends = [np.asarray(f.end_time, float) for f in features]
    cut = np.array([e[cycles] - e[0] if e.size > cycles else np.inf for e in ends])
    keep = t <= cut[:, None]
    last = np.maximum(keep.sum(1) - 1, 0)
    n = int(last.max()) + 1
    j = np.minimum(np.arange(n)[None, :], last[:, None])

    def take(a):
        return jnp.asarray(np.take_along_axis(np.asarray(a), j, 1))

    return dataclasses.replace(d, time=take(d.time), deflection=take(d.deflection),
                               mask=jnp.asarray(np.asarray(d.mask)[:, :n] & keep[:, :n]))


def compare_laws(records, laws=tuple(FrictionLaw), *, hold_out: float = 1 / 3,
                 features=None, modes: ModelModes = ModelModes(),
                 solver: SolverOptions = SolverOptions(), pad_to: int = 0,
                 cycles: int | None = CYCLES) -> LawComparison:
    """Fit and score each of `laws` (`FrictionLaw` members) on `records` (module doc).

    `hold_out`: the fraction of each record kept out of the fit (0 to 0.8); `features`:
    the records' `RecordFeatures` (None: extracted); `modes`, `solver` as in
    `fit_features`; `pad_to`: samples per record at least (other lengths reuse the
    compiled fit); `cycles`: per record (None: whole records).
    """
    import jax.numpy as jnp

    from ..data.features import record_features
    from ..objectives.smooth import smooth_data
    from ..solve.laws import fit_law

    if not 0.0 <= hold_out <= 0.8:
        raise ValueError(f"hold_out: a fraction in [0, 0.8], got {hold_out}")
    features = [record_features(r) for r in records] if features is None else features
    rest = [at_rest(r, f) for r, f in zip(records, features)]
    d = smooth_data(records, rest)
    d = _crop(d, rest, cycles) if cycles is not None else d
    extra = max(pad_to - d.time.shape[1], 0)
    if extra:
        def pad(a):
            return jnp.concatenate([a, jnp.repeat(a[:, -1:], extra, axis=1)], axis=1)

        d = dataclasses.replace(d, time=pad(d.time), deflection=pad(d.deflection),
                                mask=jnp.pad(d.mask, ((0, 0), (0, extra))))
    # stick and slip per cycle, and a re-slip's two more, twice over
    events = 8 * ((cycles if cycles is not None else max(len(f.end_time) for f in rest)) + 2)

    def objective(law, data):
        if law is FrictionLaw.PAPER:
            return ExactRecords(data, slip_time=modes.slip_time, max_events=events)
        return SmoothObjective(data, slip_time=modes.slip_time, **LAW_TOLERANCES)

    cut = (1.0 - hold_out) * jnp.max(jnp.where(d.mask, d.time, 0.0), axis=1, keepdims=True)
    train = d.mask & (d.time <= cut)
    held = np.asarray(d.mask & ~train).ravel()
    n = int(np.count_nonzero(np.asarray(train)))
    scores = []
    for law in laws:
        obj = objective(law, dataclasses.replace(d, mask=train))
        try:
            fit = fit_law(features, records, law, modes=modes, solver=solver, objective=obj)
        except ValueError as err:  # the law cannot be fitted to these records
            scores.append(LawScore(law, float("inf"), n, 0, float("inf"), False, {},
                                   reason=str(err)))
            continue
        r = np.asarray(objective(law, d).residuals(fit.params))
        k = n - fit.dof  # free parameters
        held_out = float(np.mean(r[held] ** 2)) if held.any() else float("nan")
        budget = (f"{obj.max_events} events" if law is FrictionLaw.PAPER
                  else f"{obj.max_steps} solver steps")
        scores.append(LawScore(
            law=law, chi2=float(fit.chi2), n=n, k=k, held_out=held_out,
            converged=bool(fit.converged), values=fit.values,
            reason="" if np.isfinite(fit.chi2) and not np.isinf(held_out) else
            f"the fitted law's simulation did not reach the records' end within {budget}"))
    preferred, wrong, message = _verdict(scores)
    return LawComparison(tuple(scores), preferred, wrong, message)
