r"""How well the fitted model describes the records: chi2 per record and per phase, and
what to do about it, in sentences.

`adequacy(fit)` returns an `Adequacy`: one `PhaseRow` per (record, phase) with the
number of residuals and their chi2/n **in the records' own errors** (before any scaling
to a record's scatter, `solve.fit.RECORD_CHI2`, and before a heavy-tailed loss), the
campaign's chi2/dof, a `verdict` ("describes": no phase of a record beyond chi2/n `GOOD`;
"misses": some beyond `BAD`; "marginal" between; beyond meaning also improbable under
the noise, `LEVEL`) and sentences a user can act on.

Phases (chi2/n of whitened residuals, 1 is "to the noise"): "levels" (plateau levels,
eqs (1) and (3)), "stick_times" (eq (6)), "start_level" (`--offset start` only),
"trace_stick" and "trace_slip" (the trace objective's samples while the fitted slider
sticks or slips). A fit is judged on what it fitted: a trace fit on its samples only, a
combined fit on both. Which phase misses names the likely cause (`PHASE_HINT`).

A base law other than the paper's (`stickslip fit --law`, fitted through whole records by
`solve.laws.fit_law`) is judged on its own objective's residuals only, the whole records'
samples, split by the records' measured phases (`_law_rows`): "stick" (outside the
detected slips) and "slip" (from a detected breakaway to its slip end); the paper's
feature residuals would measure its equations, not the law. Their hints (`LAW_HINT`)
name no equation of the paper.

## The chance of a chi2: correlated residuals

A row's statistic $q = \sum_i x_i^2 = n \cdot \chi^2/n$ over its $n$ whitened residuals
$x_i$ (dimensionless) has, for Gaussian residuals of lag-$k$ correlation $\rho_k$,
$E[q] = n$ and $\mathrm{Var}[q] = 2 n c$, $c = 1 + 2\sum_k (N_k/n)\rho_k^2$ ($N_k$ the
row's pairs $k$ samples apart). `PhaseRow.p_value` takes Satterthwaite's scaled chi2,
$q/c \sim \chi^2_{n/c}$: $n_\mathrm{eff} = n/c$ (`PhaseRow.n_effective`, $c \ge 1$, so a
correlation never makes a row look worse than its independent chi2). The cycle features'
correlations follow from how they are built (levels independent, stick times close to
second differences of slip timings: `STICK_LAGS`); a time series (a trace's samples,
`_trace_rows`, or a law fit's, `_law_rows`) has $\rho_k$ measured on its own residuals
within each contiguous stretch (`effective_samples`: summed up to emcee's `autocorr`
window, each $\rho_k^2$'s chance part $1/N_k$ taken off), $c = \tau(x^2)$; its calibration
on AR(1) noise: docs/identification.md, `tests/test_adequacy_correlated.py`. Not a block
bootstrap: a resampling would judge the residuals against their own spread, not the
records' noise, and a record holds too few cycles (4-20) for cycle blocks.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

__all__ = ["Adequacy", "BAD", "GOOD", "PhaseRow", "TAIL_RATIO", "adequacy",
           "effective_samples", "model_text", "series_row"]

TAIL_RATIO = 2.0
"""Root mean square over normalised median absolute deviation above which a phase's
residuals are called heavy-tailed (1 for Gaussian residuals; at least 8 residuals)."""

GOOD = 2.0
"""chi2/n up to this: the model describes the phase to the record's noise."""

BAD = 5.0
"""chi2/n above this: the model misses the phase (the noise estimate is good to about
10-20 %, so chi2/n of 2 can be the noise estimate's, 5 cannot)."""

PHASE_HINT = {
    "levels": "the plateau levels scatter more than eq (1) allows (irregular slips, a drive "
              "or gauge error)",
    "stick_times": "the stick times do not follow eq (6) (creep before breakaway, a drive "
                   "speed error)",
    "start_level": "the first plateau is not the gauge zero the model assumes",
    "trace_stick": "the stick phase is not the straight ramp of the model (a drive error, "
                   "creep, sensor dynamics)",
    "trace_slip": "the slips' shape differs from the model's half cosine (damping, "
                  "Stribeck, sensor dynamics): `stickslip discover` names the effect"}

LAW_HINT = {
    "stick": "the sticks differ from the law's (creep before breakaway, a drive error, the "
             "breakaway level's dependence on the stick time or the drive speed)",
    "slip": "the slips differ from the law's (their drop, duration or shape: the law's "
            "velocity dependence, damping, sensor dynamics)"}
"""The hints of a law fit's phases (`_law_rows`)."""


@dataclasses.dataclass(frozen=True)
class PhaseRow:
    """chi2/n of one record's residuals in one phase (module doc): `chi2_per_n` is the
    mean square of its `n` residuals, each over its standard error (dimensionless, 1 at
    the noise)."""

    record: str
    phase: str
    n: int
    chi2_per_n: float
    heavy_tailed: bool = False
    """The residuals' root mean square is more than `TAIL_RATIO` times their normalised
    median absolute deviation: a few residuals far out (irregular slips), not a
    systematic misfit of every cycle."""
    lag_correlation: tuple[float, float] = (0.0, 0.0)
    """Correlation of neighbouring residuals (lags 1 and 2): `STICK_LAGS` for the stick
    times, measured on the residuals for a time series (`series_row`), 0 for independent
    residuals."""
    n_effective: float | None = None
    """Independent residuals the row is worth for the chance of its chi2 (module doc:
    n / c, at most `n`). None: from `lag_correlation` as the only correlations."""

    def __post_init__(self):
        if self.n_effective is None:
            rho = np.asarray(self.lag_correlation, float)[:max(self.n - 1, 0)]
            pairs = self.n - np.arange(1, rho.size + 1)
            c = 1.0 + 2.0 * float(np.sum(pairs * rho ** 2)) / max(self.n, 1)
            object.__setattr__(self, "n_effective", self.n / c)

    def to_json(self) -> dict:
        out = dataclasses.asdict(self)
        out["lag_correlation"] = list(self.lag_correlation)
        return out

    def p_value(self) -> float:
        """Probability of a chi2 this large under the noise (module doc): chi2 with
        `n_effective` degrees of freedom at `n_effective` * chi2/n (Satterthwaite's scaled
        chi2; the plain chi2 with `n` degrees of freedom for independent residuals)."""
        from scipy.special import chdtrc  # chi2's survival function, chdtrc(dof, x)

        nu = float(self.n_effective)
        return float(chdtrc(nu, self.chi2_per_n * nu))


@dataclasses.dataclass(frozen=True)
class Adequacy:
    """The model's adequacy (module doc)."""

    reduced_chi2: float
    rows: list[PhaseRow]
    verdict: str
    sentences: list[str]

    def worst(self) -> PhaseRow | None:
        return max(self.rows, key=lambda r: r.chi2_per_n, default=None)

    def to_json(self) -> dict:
        return {"reduced_chi2": self.reduced_chi2, "verdict": self.verdict,
                "good_chi2_per_n": GOOD, "bad_chi2_per_n": BAD,
                "rows": [r.to_json() for r in self.rows], "sentences": list(self.sentences)}


def _heavy_tailed(x: np.ndarray) -> bool:
    """`PhaseRow.heavy_tailed` of the residuals `x` (`TAIL_RATIO`)."""
    mad = 1.4826 * float(np.median(np.abs(x - np.median(x))))
    return bool(x.size >= 8 and math.sqrt(float(np.mean(x**2))) > TAIL_RATIO * mad)


WINDOW = 5.0
"""Sokal's window factor (emcee's `autocorr` `c`): correlations are summed up to the
smallest lag M with M >= WINDOW * c(M) (module doc)."""


def effective_samples(x: np.ndarray, select: np.ndarray) -> tuple[float, tuple[float, float]]:
    r"""Independent residuals that the selected residuals are worth (module doc), and their
    lag-1 and lag-2 correlations.

    `x`: whitened residuals [S, L], one contiguous stretch of samples per row (a cycle
    window, a record); `select`: bool [S, L], the residuals of the phase. Lags are counted
    along a row only: selected samples of different rows are taken as independent. The
    correlation $\rho_k$ is that of the selected residuals about their mean;
    $c = 1 + 2\sum_{k \le M}(N_k/n)(\rho_k^2 - 1/N_k)$, at least 1, returns $n / c$.
    """
    x = np.atleast_2d(np.asarray(x, float))
    w = np.atleast_2d(np.asarray(select, bool)).astype(float)
    n = float(w.sum())
    if n < 3:
        return n, (0.0, 0.0)
    xc = (x - float(np.sum(x * w)) / n) * w
    var = float(np.sum(xc ** 2)) / n
    if not var > 0.0:
        return n, (0.0, 0.0)
    size = 1 << int(2 * x.shape[1] - 1).bit_length()

    def lagged(a):  # sum over rows and t of a[t] a[t + k], k = 0 ... L - 1
        f = np.fft.rfft(a, size, axis=1)
        return np.fft.irfft(f * np.conj(f), size, axis=1)[:, :x.shape[1]].sum(axis=0)

    pairs = np.rint(lagged(w))[1:]
    have = pairs > 0.5
    rho = np.where(have, lagged(xc)[1:] / np.where(have, pairs, 1.0) / var, 0.0)
    terms = np.where(have, pairs * rho ** 2 - 1.0, 0.0) / n  # the chance part 1/N_k off
    c = 1.0 + 2.0 * np.cumsum(terms)
    lags = np.arange(1, c.size + 1)
    ok = lags >= WINDOW * c
    m = int(np.argmax(ok)) if ok.any() else c.size - 1
    c_m = max(float(c[m]), 1.0) if c.size else 1.0
    lag12 = tuple(float(v) for v in np.pad(rho[:2], (0, max(0, 2 - rho[:2].size))))
    return n / c_m, lag12


def series_row(record: str, phase: str, x: np.ndarray, select: np.ndarray) -> PhaseRow:
    """The `PhaseRow` of a time series' whitened residuals `x` [S, L] in the samples
    `select` [S, L] (`effective_samples`: rows are contiguous stretches)."""
    x = np.atleast_2d(np.asarray(x, float))
    select = np.atleast_2d(np.asarray(select, bool))
    sel = x[select]
    n_eff, lags = effective_samples(x, select)
    return PhaseRow(record, phase, int(sel.size), float(np.mean(sel ** 2)),
                    _heavy_tailed(sel), lags, n_eff)


def _features_rows(fit, names, scale) -> list[PhaseRow]:
    from ..objectives.combined import FeaturesObjective
    from ..solve.fit import compiled
    from ..objectives.cycle_features import feature_residuals

    r = np.asarray(compiled(feature_residuals, fit.params, fit.data, fit.slip_time))
    obj = FeaturesObjective(fit.data, fit.slip_time)
    rec, _ = obj.clusters(fit.features)
    parts, recs = obj.split(r), obj.split(rec)
    phase = {"levels": "levels", "stick_times": "stick_times", "start_levels": "start_level"}
    lags = {"stick_times": STICK_LAGS}
    rows = []
    for i, name in enumerate(names):
        for block, label in phase.items():
            sel = recs[block] == i
            if sel.any():
                x = parts[block][sel]
                chi = float(np.mean(x**2)) * scale[i] ** 2
                rows.append(PhaseRow(name, label, int(sel.sum()), chi, _heavy_tailed(x),
                                     lags.get(block, (0.0, 0.0))))
    return rows


def _stretches(values: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """1-D arrays as the rows of a zero-padded [S, L] array, and its mask."""
    L = max((v.size for v in values), default=0)
    out, mask = np.zeros((len(values), L)), np.zeros((len(values), L), bool)
    for i, v in enumerate(values):
        out[i, :v.size], mask[i, :v.size] = v, True
    return out, mask


def _trace_rows(fit, names, td) -> list[PhaseRow]:
    """Rows of the trace samples, per record its samples while the fitted slider sticks
    and while it slips; a cycle window (its rows of `TraceData` joined) is one stretch
    of contiguous samples for the correlation (`series_row`)."""
    from ..solve.fit import compiled
    from ..objectives.trace import trace_residuals_and_flags

    r, _, vel = compiled(trace_residuals_and_flags, fit.params, td, fit.slip_time)
    r = np.asarray(r).reshape(td.mask.shape)
    slip = np.asarray(vel) > 0
    mask = np.asarray(td.mask)
    rec, window = np.asarray(td.record), np.asarray(td.window)
    rows = []
    for i, name in enumerate(names):
        mine = (rec == i) & mask.any(axis=1)
        parts = [window == w for w in dict.fromkeys(window[mine])]  # in order, rows joined
        x, keep = _stretches([r[m][mask[m]] for m in parts])
        moving, _ = _stretches([slip[m][mask[m]].astype(float) for m in parts])
        for label, where in (("trace_stick", moving < 0.5), ("trace_slip", moving > 0.5)):
            sel = keep & where
            if sel.any():
                rows.append(series_row(name, label, x, sel))
    return rows


def _law_rows(fit, names) -> list[PhaseRow]:
    """Rows of a whole-records fit (`objectives.smooth.SmoothObjective`) from its own
    residuals, in the records' own errors: per record its samples inside the detected
    slips (from a breakaway up to its slip end, `RecordFeatures`) and the others, their
    chance with the correlation measured along the record (`series_row`)."""
    from ..solve.fit import compiled

    d = fit.objective.data
    r = np.asarray(compiled(fit.objective.residuals, fit.params)).reshape(d.mask.shape)
    mask, time = np.asarray(d.mask), np.asarray(d.time)
    rows = []
    for i, (name, f) in enumerate(zip(names, fit.features)):
        t = time[i] + float(f.end_time[0])  # the record's own clock (`smooth_data`)
        slip = np.zeros(t.shape, bool)
        for b, e in zip(np.asarray(f.breakaway_time), np.asarray(f.end_time)):
            slip |= (t >= b) & (t < e)
        for label, where in (("stick", ~slip), ("slip", slip)):
            sel = mask[i] & where
            if sel.any():  # a record is one stretch of contiguous samples
                rows.append(series_row(name, label, r[i], sel))
    return rows


LEVEL = 0.01
"""A phase counts as missed or marginal only when its chi2 is also improbable for its
residuals under the noise (`PhaseRow.p_value`: the chi2 distribution over its effective
number of independent residuals, module doc; probability below `LEVEL` over the number
of rows: a record with 4 cycles reaches chi2/n 3 by chance)."""


def _beyond(row: PhaseRow, threshold: float, n_rows: int) -> bool:
    return row.chi2_per_n > threshold and row.p_value() < LEVEL / max(n_rows, 1)


STICK_LAGS = (-2.0 / 3.0, 1.0 / 6.0)
"""Lag-1 and lag-2 correlations of a record's stick-time residuals (eq 6) that their chi2's
chance allows for: each stick time is the difference of two slips' timings and each
residual reads two neighbouring stick times, so the residuals are up to second
differences of independent timing errors (correlations -2/3 and 1/6; first differences,
-1/2 and 0, when only one stick time matters). The heavier-tailed end is taken, so that
chance is never called a miss. Measured on notebook 03's clean synthetic campaign over
7 seeds: pooled lag-1 correlations -0.51 to -0.79; with independent residuals assumed,
2 of the 7 campaigns were called "misses" (one record's stick times at chi2/n 6.4 and
6.8), with these correlations none."""


def _whole_record_law(friction) -> bool:
    """Whether `friction` is a base law other than the paper's (`solve.laws.LAW_PARAMS`):
    fitted through whole records, judged on that objective's own residuals."""
    from ..modes import FrictionLaw
    from ..solve.laws import LAW_PARAMS

    return isinstance(friction, tuple(cls for law, cls in LAW_PARAMS.items()
                                      if law is not FrictionLaw.PAPER))


def model_text(friction) -> str:
    """How the sentences name a fitted law (the fit's friction parameters): the paper's
    eq (1) law (`EmpiricalFriction`) as "The paper's model", its eq (28) law
    (`MicrosqueezeFriction`) as "The paper's microsqueeze model", another law by its
    `MODEL` ("The log_aging law")."""
    from ..params import EmpiricalFriction

    if _whole_record_law(friction):
        return f"The {friction.MODEL} law"
    if isinstance(friction, EmpiricalFriction):
        return "The paper's model"
    return "The paper's microsqueeze model"


def _sentences(rows: list[PhaseRow], reduced_chi2: float, n_records: int,
               heavy_tailed: bool | None = None, name: str = "The paper's model",
               hints: dict[str, str] = PHASE_HINT) -> tuple[str, list]:
    bad = [r for r in rows if _beyond(r, BAD, len(rows))]
    marginal = [r for r in rows if _beyond(r, GOOD, len(rows)) and r not in bad]
    if not bad and not marginal:
        return "describes", [f"{name} describes every record to its noise (no "
                             f"phase of a record beyond chi2/n {GOOD:g} by more than chance; "
                             f"chi2/dof {reduced_chi2:.3g})."]
    out = []
    missed = sorted({r.record for r in bad})
    if bad:
        frac = len(missed) / max(n_records, 1)
        if frac > 0.5:
            out.append(f"{name} does not describe these records: it misses "
                       f"{len(missed)} of {n_records} beyond their noise. The intervals then "
                       "follow the records' scatter (robust covariance); read the values as "
                       "the model's best compromise, not as the slideway's friction law.")
        else:
            out.append(f"The model misses {len(missed)} of {n_records} records beyond their "
                       f"noise ({', '.join(missed)}); the others it describes.")
        for phase, hint in hints.items():
            hit = [r for r in bad if r.phase == phase]
            if hit:
                worst = max(hit, key=lambda r: r.chi2_per_n)
                out.append(f"{phase.replace('_', ' ')}: chi2/n above {BAD:g} in {len(hit)} "
                           f"record(s), worst {worst.record} ({worst.chi2_per_n:.3g}): "
                           f"{hint}.")
    tails = sorted({r.record for r in bad if r.phase == "levels" and r.heavy_tailed})
    if heavy_tailed is False and tails:
        out.append(f"The levels of {', '.join(tails)} are heavy-tailed (a few cycles far "
                   "out, irregular slips): `--loss student-t` discounts those cycles "
                   "instead of the whole record's weight.")
    if marginal and not bad:
        out.append(f"The model describes the records nearly to their noise (chi2/n up to "
                   f"{max(r.chi2_per_n for r in marginal):.3g} in "
                   f"{len({r.record for r in marginal})} record(s)); a noise estimate "
                   "10-20 % low gives as much.")
    return ("misses" if bad else "marginal"), out


def adequacy(fit) -> Adequacy:
    """The adequacy report of a `stickslip_fitting.solve.fit.FitResult` (module doc)."""
    from ..modes import Objective
    from ..objectives.losses import Gaussian, loss_of

    names = [f.name or f"record {i}" for i, f in enumerate(fit.features)]
    scale = (np.ones(len(names)) if fit.record_scale is None
             else np.asarray(fit.record_scale, float))
    name = model_text(fit.params.friction)
    if _whole_record_law(fit.params.friction):  # its own objective's residuals
        rows = _law_rows(fit, names)
        verdict, sentences = _sentences(rows, fit.reduced_chi2, len(names), name=name,
                                        hints=LAW_HINT)
        return Adequacy(fit.reduced_chi2, rows, verdict, sentences)
    # the phases the fit fitted: a trace-only fit is judged on its samples, not on the
    # cycle features, whose stick times are far more precise than the trace determines
    # the parameters (clean records at the trace optimum reach chi2/n 1e4 there)
    trace_only = fit.objective is not None and fit.objective.kind is Objective.TRACE
    rows = [] if trace_only else _features_rows(fit, names, scale)
    td = fit.objective.trace_data() if fit.objective is not None else None
    if td is not None:
        rows += _trace_rows(fit, names, td)
    heavy = fit.objective is not None and not isinstance(loss_of(fit.objective), Gaussian)
    verdict, sentences = _sentences(rows, fit.reduced_chi2, len(names), heavy, name)
    return Adequacy(fit.reduced_chi2, rows, verdict, sentences)
