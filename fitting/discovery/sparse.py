r"""Effects outside the library, named by their form: a sparse model of the residual.

When a gap remains that no effect family explains, the per-cycle base (`cycle_model`)
gets a few terms from a library of forms in the cycle's physical coordinates (`TERMS`),
fitted jointly with the base parameters:

- **stick** (a displacement of the deflection before the breakaway, mm, carried by the
  model itself, `cycle_effects.stick_terms`): a constant, powers of the deflection $x$
  and of the time since the last slip $s$ (in s, and as $s/T_1$), the approach to the
  breakaway $e^{-(T_1 - s)/\tau}$ (creep) and a lost motion of the drive taken up over
  its first $L$ of travel, $\min(v s, L)/L$ (backlash);
- **pre-slide** (linear, outside the model): the slider creeps by $c\,e^{-(t_b - t)/\tau}$
  before it breaks away while the breakaway stays where the stick line alone reaches
  static friction (eq 1), so the slip starts from the crept deflection:
  $c\cos\omega_0(t - t_b)$ during the slip, held after it ($t_b$ the model's breakaway,
  `_breakaways`; the independent generator's creep);
- **slip** (a force on the slider, in units of its weight W): powers of the reduced
  deflection $\xi = k x/W$, the sign and powers of the slider velocity $\dot y$ (over
  $V = $ `V_REF`), a drift in time; a force $f(t)$ moves the slider by
  $\delta y(t) = (g/\omega_0)\int_{t_b}^{t}\sin\omega_0(t - t')\,f(t')\,dt'$
  (its first-order response during the slip, held after the slider stops);
- **drift**: the reading's drift over the record.

The terms are chosen by `select_terms` (sequentially thresholded least squares, SINDy's
regression, along a path of thresholds, and a forward selection) on the base residuals
with the base Jacobian projected out (a stick term's column is the model's own, the
breakaway's move included); the support of least chi-square plus `TERM_COST` per term
wins, at most `MAX_TERMS`; creep terms (`SAME_SIGN`) are kept together only with one
sign. The form is refitted with the model's parameters (`fit_sparse_form`,
Levenberg-Marquardt on the model's coordinates, the linear terms solved at every point)
and found when it closes at least `FOUND_SHARE` of the gap's excess over the noise.
Selection and refit hold every window's restart level free (`_levels`, linear, one per
window), and again as measured: the measured level is a plateau's mean, and a form that
bends the stick (a creep) biases it (measured: creep of 3 um over 50 ms, lubricant A,
seed 0: the fastest records' sticks 0.5-2 um above the model at the true friction and
creep; with the levels free the linear fit leaves the noise); with free levels the terms
must also close `FOUND_SHARE` of what the levels alone leave, and the levels alone at
most `LEVELS_MOST` of the excess (`_beyond_levels`). A form must also outdo a breakaway
that scatters from cycle to cycle (`_scattered`: each window's static friction free,
the other coordinates at the base point): a law of the stick or the slip has one size in every cycle,
and its terms must close `FOUND_SHARE` of what the scattered breakaways alone leave
(`_beyond_scatter`). Units: mm, s, kgf.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from stickslip_jax.units import G_MM_S2

from .cycle_effects import STICK_SCALE, STICK_TAUS, STICK_TERMS, STICK_TRAVELS, stick_terms
from .cycle_model import per_sample

__all__ = ["FOUND_SHARE", "MAX_TERMS", "SparseForm", "TERMS", "Term", "coordinates",
           "fit_sparse_form", "library", "select_terms", "significant_terms"]

MAX_TERMS = 3
"""A form of more than three terms is a fit, not a form."""
TERM_COST = 0.03
"""Each term must lower chi-square by this share of the excess over the samples' count."""
FOUND_SHARE = 0.5
"""The share of the gap's excess over the noise a form must close to be reported."""
LEVELS_MOST = 0.7
"""With free restart levels, the largest share of the excess the levels alone may close
for the terms to be found (`_beyond_levels`; measured: creep 3 um on A, seeds 0-3,
22-44 %; a 0.5 um screw 100 %, a 0.1 stiffening 85 %)."""
MIN_T = 2.0
"""A refitted term is reported when its coefficient is at least this many standard errors
from zero (`significant_terms`)."""
V_REF = 10.0
"""mm/s: the slider velocity the velocity powers are measured in (a slip's peak speed)."""
MU_S = 1
"""The base coordinate of the static friction's rise over the kinetic (log(mu_s - mu_d),
`cycle_model`): per window, the breakaway's scatter (`_scattered`)."""
SCATTER_SHIFTS = np.r_[0.0, np.outer([1.0, -1.0], [0.0025, 0.005, 0.0075, 0.01, 0.0125, 0.015,
                                                   0.02, 0.03, 0.04, 0.06, 0.08]).T.ravel()]
"""Relative shifts of mu_s tried for each window (`_scattered`): steps of a quarter of a
1 % scatter, then up to 8 % for a heavy tail's sporadic slips."""
PRESLIDE_TAUS = STICK_TAUS
"""s: time constants of the pre-slide terms (creep that leaves the breakaway where the
stick line alone puts it)."""


@dataclasses.dataclass(frozen=True)
class Term:
    """One candidate form: its `phase`, `variable`, `symbol`, the coefficient's `unit` and
    what it does in `words`."""

    name: str
    phase: str
    variable: str
    symbol: str
    unit: str
    words: str


def _terms() -> tuple[Term, ...]:
    out = [Term("stick_level", "stick", "-", "c", "mm",
                "the reading during the stick is offset from the stick line")]
    out += [Term(f"stick_x{p}", "stick", "deflection", f"c x^{p}", f"mm^{1 - p}",
                 f"the reading during the stick changes with the deflection^{p}")
            for p in (1, 2, 3)]
    out += [Term(f"stick_s{p}", "stick", "time since the last slip", f"c s^{p}",
                 f"mm/s^{p}", f"the reading during the stick changes with (time since "
                 f"the last slip)^{p}") for p in (1, 2)]
    out += [Term(f"stick_phase{p}", "stick", "time since the last slip",
                 f"c (s/T1)^{p}", "mm", f"the reading during the stick changes with (time "
                 f"since the last slip / stick time)^{p}") for p in (1, 2, 4, 8)]
    out += [Term(f"stick_creep{int(tau * 1e3)}ms", "stick", "time to the breakaway",
                 f"c exp(-(T1 - s)/{tau * 1e3:g} ms)", "mm",
                 "the slider creeps before it breaks away (the reading changes just "
                 "before the breakaway)") for tau in STICK_TAUS]
    out += [Term(f"stick_lost{int(L * 1e3)}um", "stick", "drive travel since the last slip",
                 f"c min(v s, {L * 1e3:g} um)/{L * 1e3:g} um", "mm",
                 "the drive loses motion after each slip (backlash): the spring's far end "
                 f"lags by the coefficient, taken up over {L * 1e3:g} um of drive travel "
                 "since the last slip") for L in STICK_TRAVELS]
    out += [Term(f"stick_preslide{int(tau * 1e3)}ms", "stick", "time to the breakaway",
                 f"c exp(-(T1 - s)/{tau * 1e3:g} ms)", "mm",
                 "the slider creeps before it breaks away, the breakaway where the stick "
                 "line alone reaches static friction (the slip starts from the crept "
                 "deflection)") for tau in PRESLIDE_TAUS]
    out += [Term(f"slip_xi{p}", "slip", "deflection", f"c W (k x/W)^{p}", "-",
                 f"a force on the slider during the slip grows with the deflection^{p}"
                 + (" (a spring that stiffens with deflection)" if p == 3 else ""))
            for p in (1, 2, 3)]
    out += [Term("slip_sign", "slip", "sign of the slider velocity", "c W sign(ydot)", "-",
                 "a force along the slip (a kinetic friction offset)")]
    out += [Term(f"slip_v{p}", "slip", "slider velocity", f"c W (ydot/{V_REF:g} mm/s)^{p}",
                 "-", f"a force on the slider during the slip grows with the slider "
                 f"velocity^{p}") for p in (1, 2, 3)]
    out += [Term("slip_drift", "slip", "time", "c W (t - t_mid)", "1/s",
                 "a force during the slip drifts over the record"),
            Term("drift", "record", "time", "c (t - t_mid)", "mm/s",
                 "the reading drifts over the record")]
    return tuple(out)


TERMS = _terms()

_CREEPS = [j for j, t in enumerate(TERMS) if t.variable == "time to the breakaway"]
SAME_SIGN = tuple((i, j) for i in _CREEPS for j in _CREEPS if i < j)
"""Pairs of terms (indices into `TERMS`) of one creep: the creep terms, which move the
breakaway, and the pre-slide terms, which leave it, at every time constant. A slider
creeps one way, toward the breakaway, so their coefficients share the creep's sign. Of
opposite signs two of them nearly cancel in the stick and act as a breakaway moved
against the creep, which no creep does (measured: 3 um over 50 ms on A, seed 1, the
levels as measured: -5.54 and +3.58 um over 30 ms, then, the same time constant
paired, -2.73 um over 30 ms and +1.12 um over 10 ms)."""

LIBRARY_FORMS = {"slip_v1": ("viscous_damping", "stribeck", "rate_state"),
                 "slip_xi1": ("load_coupling",), "slip_drift": ("friction_drift",),
                 "drift": ("gauge_drift",)}
"""Terms whose form is a library family's own: a force along the slider velocity is the
first order of any speed-dependent friction (a dashpot, a Stribeck curve, rate-and-state
friction); one along the deflection, a normal load coupled to the spring force; a force
or a reading drifting over the record, the friction's or the gauge's drift. A sparse form
that holds the family named does not replace it (`stages.form`)."""


def coordinates(model, z, r, sd, shape=None, sensor: bool = False) -> dict:
    """The cycle's coordinates per masked sample at the model's trace, sorted window by
    window in time (`order`)."""
    data, mask = model.data, np.asarray(model.data.mask)
    fields = ("record", "window", "start_time", "stick_time", "speed", "stiffness", "weight")
    row = dict(zip(fields, per_sample(data, *fields)))
    t_all = np.asarray(data.time)
    dt = np.broadcast_to((t_all[:, 1] - t_all[:, 0])[:, None], mask.shape)[mask]
    t = t_all[mask]
    offset = (np.asarray(z) * model.scales)[6:model.n_base]
    x = np.asarray(data.deflection)[mask] - r * sd - offset[row["record"]]
    _, yd, _ = (model.residuals(z) if shape is None else
                model.residuals(z, shape, sensor))
    yd = np.asarray(yd)[mask]
    order = np.lexsort((t, row["window"]))
    c = {k: v[order] for k, v in row.items()}
    c.update(t=t[order], dt=np.abs(dt[order]), x=x[order], yd=yd[order], order=order)
    win, slip = c["window"], c["yd"] > 0
    first = np.r_[True, win[1:] != win[:-1]]
    start_idx = np.maximum.accumulate(np.where(first, np.arange(win.size), 0))
    cum = np.cumsum(slip)
    seen = (cum - np.r_[0, cum][start_idx]) > 0
    c.update(slip=slip, stick=~seen, after=seen & ~slip, start_idx=start_idx)
    t_mid = np.zeros(int(c["record"].max()) + 1)
    for g in np.unique(c["record"]):
        tt = c["t"][c["record"] == g]
        t_mid[g] = 0.5 * (tt.min() + tt.max())
    c["t_rel"] = c["t"] - t_mid[c["record"]]
    return c


def _slip_response(c: dict, f: np.ndarray) -> np.ndarray:
    """The reading's change (mm) under a force W f during the slips (module doc)."""
    w0 = np.sqrt(c["stiffness"] * G_MM_S2 / c["weight"])
    tau = c["t"] - c["t"][c["start_idx"]]
    fj = np.where(c["slip"], f, 0.0) * c["dt"]
    parts = []
    for trig in (np.cos, np.sin):
        cum = np.cumsum(fj * trig(w0 * tau))
        parts.append(cum - np.r_[0.0, cum][c["start_idx"]])
    dy = G_MM_S2 / w0 * (np.sin(w0 * tau) * parts[0] - np.cos(w0 * tau) * parts[1])
    last = np.maximum.accumulate(np.where(c["slip"], np.arange(f.size), 0))
    dy = np.where(c["after"], dy[last], np.where(c["stick"], 0.0, dy))
    return -dy


def _breakaways(c: dict) -> np.ndarray:
    r"""The model's breakaway per sample (s): the half sine $a\sin\omega_0(t - t_b)$ fitted
    to the slider velocity of its window's slip (least squares, linear in $a\cos$ and
    $a\sin\omega_0 t_b$); the measured one (start + stick time) where the window has
    no slip."""
    w0 = np.sqrt(c["stiffness"] * G_MM_S2 / c["weight"])
    _, win = np.unique(c["window"], return_inverse=True)
    ph = w0 * (c["t"] - c["start_time"])
    sn, cs, v = np.sin(ph), np.cos(ph), np.where(c["slip"], c["yd"], 0.0)
    on = c["slip"].astype(float)

    def total(a):
        return np.bincount(win, a * on)

    ss, sc, cc, vs, vc = (total(sn * sn), total(sn * cs), total(cs * cs), total(v * sn),
                          total(v * cs))
    det = ss * cc - sc * sc
    ok = (total(np.ones_like(v)) >= 3) & (np.abs(det) > 1e-12 * np.maximum(ss * cc, 1e-300))
    det = np.where(ok, det, 1.0)
    p_, q_ = (vs * cc - vc * sc) / det, (vc * ss - vs * sc) / det  # v = p sin + q cos
    # w0 (t_b - start) = atan2(-q, p) modulo 2 pi: the branch nearest the measured breakaway
    off = np.angle(np.exp(1j * (np.arctan2(-q_, p_)[win] - w0 * c["stick_time"])))
    return c["start_time"] + c["stick_time"] + np.where(ok[win], off / w0, 0.0)


def _start_response(c: dict, t_b: np.ndarray) -> np.ndarray:
    r"""The reading's change (mm) per mm added to the deflection the slip starts from (the
    kinetic friction unchanged): $\cos\omega_0(t - t_b)$ during the slip from the
    model's breakaway t_b, held after the slider stops; 0 in the stick."""
    w0 = np.sqrt(c["stiffness"] * G_MM_S2 / c["weight"])
    dx = np.where(c["slip"], np.cos(w0 * (c["t"] - t_b)), 0.0)
    last = np.maximum.accumulate(np.where(c["slip"], np.arange(dx.size), 0))
    return np.where(c["after"], dx[last], dx)


def library(model, z, r, sd) -> np.ndarray:
    """The columns of `TERMS` (mm per unit coefficient) at the model's trace at z."""
    c = coordinates(model, z, r, sd)
    stick, s, x = c["stick"], c["t"] - c["start_time"], c["x"]
    xi, v = c["stiffness"] * x / c["weight"], np.maximum(c["yd"], 0.0) / V_REF
    cols = dict(zip(STICK_TERMS, np.moveaxis(np.asarray(
        stick_terms(s, c["stick_time"], x, c["speed"])), -1, 0)))
    t_b = _breakaways(c)
    start = _start_response(c, t_b)
    for tau in PRESLIDE_TAUS:  # the stick's creep, and the slip from the crept deflection
        creep = np.exp(-np.maximum(t_b - c["t"], 0.0) / tau)
        cols[f"stick_preslide{int(tau * 1e3)}ms"] = np.where(stick, creep, start)
    cols["drift"] = c["t_rel"]
    force = {f"slip_xi{p}": xi ** p for p in (1, 2, 3)}
    force.update({f"slip_v{p}": v ** p for p in (1, 2, 3)})
    force.update(slip_sign=np.ones_like(x), slip_drift=c["t_rel"])
    out = np.empty((x.size, len(TERMS)))
    for j, term in enumerate(TERMS):
        if term.phase == "slip":
            col = _slip_response(c, force[term.name])
        elif term.name in STICK_TERMS:
            col = cols[term.name] * stick
        else:
            col = cols[term.name]
        out[c["order"], j] = col
    return out


def select_terms(base: np.ndarray, b: np.ndarray, C: np.ndarray, *,
                 same_sign=()) -> tuple[np.ndarray, float]:
    """The terms of the sparse form: sequentially thresholded least squares of b on the
    whitened columns C, `base` projected out: at each threshold of a path (a share of the
    excess chi-square each standardised coefficient must explain) and along a forward
    selection, the support (at most `MAX_TERMS`) of least chi-square + a cost per term
    (`TERM_COST` of the excess, at least 2 ln n); a support holding both columns
    of a pair of `same_sign` with coefficients of opposite signs is not a form (`SAME_SIGN`).
    Returns the support (column indices) and its chi-square."""
    n = b.size
    Q = np.linalg.qr(base)[0] if base.size else np.zeros((n, 0))
    Cp, bp = C - Q @ (Q.T @ C), b - Q @ (Q.T @ b)
    norm = np.linalg.norm(Cp, axis=0)
    live = norm > 1e-9 * max(norm.max(), 1e-300)
    Cs = np.where(live, Cp / np.where(live, norm, 1.0), 0.0)
    rss0 = float(bp @ bp)
    excess = max(rss0 - n, 0.0)
    cost = max(TERM_COST * excess, 2.0 * np.log(n))

    def rss_of(S):
        if not S.size:
            return rss0, np.zeros(0)
        beta = np.linalg.lstsq(Cs[:, S], bp, rcond=None)[0]
        res = bp - Cs[:, S] @ beta
        pos = dict(zip(S.tolist(), beta))
        if any(pos[i] * pos[j] < 0 for i, j in same_sign if i in pos and j in pos):
            return np.inf, beta
        return float(res @ res), beta

    best, best_score = np.zeros(0, int), rss0
    for share in (0.5, 0.3, 0.2, 0.1, 0.05, 0.02, 0.01, 0.005):
        S = np.flatnonzero(live)
        for _ in range(20):
            _, beta = rss_of(S)
            keep = np.abs(beta) >= np.sqrt(share * excess)
            if keep.sum() > MAX_TERMS:  # the largest standardised coefficients
                keep = np.isin(np.arange(S.size), np.argsort(-np.abs(beta))[:MAX_TERMS])
            if keep.all():
                break
            S = S[keep]
        rss, _ = rss_of(S)
        if rss + cost * S.size < best_score:
            best, best_score = S, rss + cost * S.size
    S = np.zeros(0, int)
    for _ in range(MAX_TERMS):  # and forward selection: strongly collinear columns (creep
        # terms of neighbouring time constants) split their coefficients under the joint
        # fit, so that every threshold dropped them all
        rest = np.setdiff1d(np.flatnonzero(live), S)
        if not rest.size:
            break
        scores = [rss_of(np.r_[S, j])[0] for j in rest]
        S = np.r_[S, rest[int(np.argmin(scores))]]
        if min(scores) + cost * S.size < best_score:
            best, best_score = S, min(scores) + cost * S.size
    return best, rss_of(best)[0]


@dataclasses.dataclass(frozen=True)
class SparseForm:
    """The sparse form of the residual (module doc): its `terms` (the most significant
    first), the gaps (mm) before and after its refit, the `noise` (mm), whether it was
    `found`, and the refit's coordinates `z` and whitened residuals `r`."""

    terms: tuple
    gap_before: float
    gap_after: float
    noise: float
    found: bool
    z: np.ndarray = dataclasses.field(repr=False)
    r: np.ndarray = dataclasses.field(repr=False)
    gap_levels: float = float("nan")  # the base with the windows' restart levels free alone
    gap_scatter: float = float("nan")  # the base with every window's static friction free
    selected: tuple = ()  # the names of every term the selection chose, reported or not

    @property
    def closes(self) -> float:
        excess = self.gap_before - self.noise
        return float((self.gap_before - self.gap_after) / excess) if excess > 0 else 0.0

    @property
    def closes_beyond_levels(self) -> float:
        """The share of the excess left by the free restart levels alone that the terms
        close (`gap_levels`)."""
        excess = self.gap_levels - self.noise
        return float((self.gap_levels - self.gap_after) / excess) if excess > 0 else 0.0

    @property
    def closes_beyond_scatter(self) -> float:
        """The share of the excess left by a breakaway scattering from cycle to cycle
        (`gap_scatter`) that the terms close."""
        excess = self.gap_scatter - self.noise
        return float((self.gap_scatter - self.gap_after) / excess) if excess > 0 else 0.0

    @property
    def formula(self) -> str:
        """The terms in words and symbols."""
        return "; ".join(f"{t['phase']}: {t['words']}, {t['coefficient']:+.3g} "
                         f"{t['symbol'][2:]} (c in {t['unit']})" for t in self.terms) or "-"

    def to_json(self) -> dict:
        return {"found": self.found, "formula": self.formula, "terms": list(self.terms),
                "gap_before": self.gap_before, "gap_after": self.gap_after,
                "gap_levels_alone": self.gap_levels,
                "closes_beyond_levels": self.closes_beyond_levels,
                "gap_scattered_breakaways_alone": self.gap_scatter,
                "closes_beyond_scattered_breakaways": self.closes_beyond_scatter,
                "noise": self.noise, "gap_unit": "mm", "closes": self.closes,
                "library": [t.name for t in TERMS],
                "method": "sequentially thresholded least squares over the library, "
                          f"at most {MAX_TERMS} terms, each worth {TERM_COST:g} of the "
                          "excess chi-square; refitted with the base parameters and every "
                          "window's restart level"}


def _gap(r, sd, use) -> float:
    return float(np.sqrt(np.mean((r * sd)[use] ** 2)))


def _levels(model, sd):
    r"""The windows' restart levels as free parameters: J (whitened, base columns first)
    -> [n, windows] the whitened reading change per mm added to each window's restart
    level, $1/s + \partial r/\partial o_g$ on its rows ($o_g$ its record's gauge offset:
    the offset lowers the restart level and raises the reading by as much)."""
    rec, win = per_sample(model.data, "record", "window")
    _, wid = np.unique(win, return_inverse=True)
    rows = np.arange(rec.size)

    def columns(J):
        out = np.zeros((rec.size, wid.max() + 1))
        out[rows, wid] = 1.0 / sd + np.asarray(J)[rows, 6 + rec]
        return out
    return columns


def _scattered(model, z, use) -> np.ndarray:
    r"""The whitened residuals at z with every window's static friction at the best of
    `SCATTER_SHIFTS` for its own rows ($\mu_s \to \mu_s(1 + e)$, $\mu_d$ held: a window's
    rows depend on its own cycle's friction only): a breakaway that scatters from cycle
    to cycle, fitted window by window on a grid (its first order does not follow a
    heavy-tailed scatter: mu_s scattering as Student-t, 3 dof, 1 % on C, seed 761, 5.89
    -> 5.02 x the noise with each window's column of the base Jacobian, 2.49 on the
    grid). A shift at which a window does not break away or end its slip is skipped."""
    z = np.asarray(z, float)
    scale, (log_mu_d, log_gap) = model.scales[MU_S], z[:2] * model.scales[:2]
    mu_d, rise = np.exp(log_mu_d), np.exp(log_gap)
    _, win = per_sample(model.data, "record", "window")
    _, wid = np.unique(win, return_inverse=True)
    w = np.asarray(use, float)
    best, best_chi2 = None, None
    for e in SCATTER_SHIFTS:
        if rise + e * (mu_d + rise) <= 0.0:
            continue
        z_e = z.copy()
        z_e[MU_S] = np.log(rise + e * (mu_d + rise)) / scale
        r_e, _, ok = model.evaluate(z_e, np.array([MU_S]))
        r_e = np.asarray(r_e, float)
        if not (ok and np.isfinite(r_e).all()):
            continue
        chi2 = np.bincount(wid, (r_e * w) ** 2, wid.max() + 1)
        if best is None:
            best, best_chi2 = r_e, chi2
            continue
        best = np.where((chi2 < best_chi2)[wid], r_e, best)
        best_chi2 = np.minimum(chi2, best_chi2)
    return best


def fit_sparse_form(model, z, r, J, noise: float, use=None, *, gap=None,
                    iterations: int = 30, levels: bool | None = None) -> SparseForm:
    """The sparse form (`_fit_form`) with the windows' restart levels free and held as
    measured (`levels` None: both, the one that leaves the smaller gap): free levels
    are nearly collinear with a lost motion of the drive, whose large breakaway moves
    their linear columns do not follow (backlash of 5 um on A, seed 0: 1.49 -> 1.47 x
    the noise with them, 1.03 without), and a creep needs them (above)."""
    frees = (True, False) if levels is None else (levels,)
    forms = [_fit_form(model, z, r, J, noise, use, gap=gap, iterations=iterations,
                       levels=free) for free in frees]
    if any(f.found for f in forms):  # and against a breakaway scattering from cycle to cycle
        sd = np.asarray(model.sd).ravel()[model.mask]
        use = np.ones(r.size, bool) if use is None else np.asarray(use, bool)
        gap_of, w = gap if gap is not None else (lambda rr: _gap(rr, sd, use)), use.astype(float)
        r_s, J = _scattered(model, z, use), np.asarray(J, float)
        for i, (form, free) in enumerate(zip(forms, frees)):
            if form.found and r_s is not None:  # the other coordinates free, linear
                B = np.hstack([J, _levels(model, sd)(J)]) if free else J
                b = np.linalg.lstsq(B * w[:, None], r_s * w, rcond=None)[0]
                form = dataclasses.replace(form, gap_scatter=gap_of(r_s - B @ b))
                forms[i] = dataclasses.replace(form, found=_beyond_scatter(form))
    found = [f for f in forms if f.found] or forms
    return min(found, key=lambda f: f.gap_after)


def _fit_form(model, z, r, J, noise: float, use=None, *, gap=None, iterations: int = 30,
              levels: bool = True) -> SparseForm:
    """Choose the sparse form of the whitened residual `r` at z (base Jacobian J) and
    refit it with the base by Levenberg-Marquardt steps through `model` (the linear
    terms, and with `levels` the windows' restart levels, solved at every point; a step
    that does not lower chi-square damped more) until a step lowers the excess
    chi-square by less than 0.2 %; `use`: the residuals the regression and gaps use;
    `gap`: the gap (mm) of whitened residuals (default the RMS over `use`)."""
    sd = np.asarray(model.sd).ravel()[model.mask]
    use = np.ones(r.size, bool) if use is None else np.asarray(use, bool)
    gap_of = gap if gap is not None else (lambda rr: _gap(rr, sd, use))
    Cw = library(model, z, r, sd) / sd[:, None]
    stick = np.array([t.name in STICK_TERMS for t in TERMS])  # carried by the model
    scols = model.layout.stick_cols()  # TERMS begin with the stick terms, in their order
    _, Js, _ = model.evaluate(z, scols)
    Cw[:, stick] = -np.asarray(Js) / STICK_SCALE  # per mm of coefficient
    w = use.astype(float)
    level = _levels(model, sd) if levels else None
    J = np.asarray(J, float)
    S, _ = select_terms(np.hstack([J, level(J)]) * w[:, None] if levels else J * w[:, None],
                        r * w, Cw * w[:, None], same_sign=SAME_SIGN)
    inside, add = S[stick[S]], S[~stick[S]]
    cols = np.r_[np.arange(model.n_base), scols[inside]]
    z_k, r_k = np.array(z, float), np.asarray(r, float)
    Jk = np.hstack([J, -Cw[:, inside] * STICK_SCALE])
    best = (gap_of(r), z_k, r_k, {}, {})
    # the added terms and, with `levels`, the windows' restart levels (at the base point,
    # as the library's columns)
    lin = np.hstack([Cw[:, add]] + ([level(J)] if levels else []))
    gap_levels = best[0]
    if levels:  # what the free levels alone do (linear, at the base point)
        B = np.hstack([J, lin[:, add.size:]])
        gap_levels = gap_of(r - B @ np.linalg.lstsq(B * w[:, None], r * w, rcond=None)[0])

    def linear(r_k):  # their coefficients at the model's point (least squares)
        coef = (np.linalg.lstsq(lin * w[:, None], r_k * w, rcond=None)[0] if lin.shape[1]
                else np.zeros(0))
        return r_k - lin @ coef, coef[:add.size]

    at, lam = (z_k, r_k, Jk), 1e-3  # the best point's residuals and Jacobian; the damping
    best_chi2 = float(np.sum((r * w) ** 2))
    for _ in range(iterations if S.size else 0):
        z_k, r_k, Jk = at
        A = np.hstack([Jk, lin]) * w[:, None]
        # Levenberg-Marquardt on the model's coordinates (the linear ones undamped): the
        # breakaways make the friction's steps far from linear
        d = np.zeros(A.shape[1])
        d[:cols.size] = np.sqrt(lam * np.maximum(np.sum(A[:, :cols.size] ** 2, axis=0), 1e-30))
        beta, *_ = np.linalg.lstsq(np.vstack([A, np.diag(d)]), np.r_[r_k * w, np.zeros(d.size)],
                                   rcond=None)
        z_k = z_k.copy()
        z_k[cols] -= beta[:cols.size]
        r_k, Jk, ok = model.evaluate(z_k, cols)
        r_k, Jk = np.asarray(r_k), np.asarray(Jk)
        r_new, coef_add = linear(r_k)
        chi2 = (float(np.sum((r_new * w) ** 2)) if np.all(ok) and np.isfinite(r_new).all()
                else np.inf)
        if not chi2 < best_chi2:  # a step too long for the breakaways' nonlinearity: damp more
            lam *= 8.0
            continue
        A = np.hstack([Jk, Cw[:, add]]) * w[:, None]
        cov = np.linalg.pinv(A.T @ A) * max(float(np.sum((r_new * w) ** 2))
                                            / max(w.sum() - A.shape[1], 1.0), 1.0)
        se = np.sqrt(np.clip(np.diag(cov), 0.0, None))[model.n_base:]
        values = np.r_[z_k[scols[inside]] * STICK_SCALE, coef_add]
        se = np.r_[se[:inside.size] * STICK_SCALE, se[inside.size:]]
        order = np.r_[inside, add]
        small = best_chi2 - chi2 < 0.002 * max(best_chi2 - w.sum(), 0.0)
        best_chi2 = chi2
        best, at = (gap_of(r_new), z_k, r_new, dict(zip(order, values)), dict(zip(order, se))), (
            z_k, r_k, Jk)
        lam = max(lam / 4.0, 1e-6)
        if small:
            break
    gap_after, z_after, r_after, coef, se = best
    terms = tuple({"name": TERMS[j].name, "phase": TERMS[j].phase,
                   "variable": TERMS[j].variable, "symbol": TERMS[j].symbol,
                   "coefficient": float(coef[j]), "stderr": float(se[j]),
                   "unit": TERMS[j].unit, "words": TERMS[j].words}
                  for j in significant_terms(S, coef, se))
    gap_before = gap_of(r)
    closes = (gap_before - gap_after) / max(gap_before - noise, 1e-300)
    form = SparseForm(terms=terms, gap_before=gap_before, gap_after=gap_after,
                      noise=float(noise), found=bool(terms) and closes >= FOUND_SHARE,
                      z=z_after, r=r_after, gap_levels=gap_levels,
                      selected=tuple(TERMS[j].name for j in S))
    return dataclasses.replace(form, found=form.found and (not levels or _beyond_levels(form)))


def significant_terms(S, coef: dict, se: dict) -> list[int]:
    """The terms of the support `S` that the refit keeps, the most significant first: a
    term whose refitted coefficient is within `MIN_T` standard errors of zero describes
    nothing the others do not, and its words would name a phase and a variable the
    records do not show (measured on `data/real/`: a creep term refitted to -4e-10 +-
    1e-3 mm beside a slip term of -2.69 +- 0.03)."""
    def t(j):
        return abs(coef[j]) / se[j] if se.get(j) else np.inf
    return sorted((j for j in S if j in coef and t(j) >= MIN_T), key=lambda j: -t(j))


def _beyond_levels(form: SparseForm) -> bool:
    """With free restart levels, whether the terms themselves are found: the levels alone
    close at most `LEVELS_MOST` of the excess (else the gap is the measured levels', a
    slow drive error they absorb by themselves: a 0.5 um screw on A, seed 104, 1.21 ->
    1.00 x the noise with the levels alone, and a drift term stood in for the screw), and
    the terms close `FOUND_SHARE` of the excess the levels leave, not of the whole excess:
    a creep lowers the measured levels, so the levels take a part of its own gap (3 um over 50 ms on A, seed 1: the levels alone 1.54 -> 1.31 x
    the noise, with the terms 1.06, 82 % of what the levels leave but 46 % of the whole
    excess)."""
    excess = form.gap_before - form.noise
    levels_share = (form.gap_before - form.gap_levels) / excess if excess > 0 else 1.0
    return levels_share <= LEVELS_MOST and form.closes_beyond_levels >= FOUND_SHARE


def _beyond_scatter(form: SparseForm) -> bool:
    """Whether the terms outdo a breakaway scattering from cycle to cycle (`_scattered`):
    they close `FOUND_SHARE` of the excess the scattered breakaways alone leave. A
    breakaway that scatters leaves before each slip a residual that a creep's shape
    fits, of one sign in nearly every cycle, so the sign and size of the form's
    coefficient window by window do not tell the two apart (measured, irregular slips
    on C: mu_s scattering 1 % per cycle, seed 751, a creep before breakaway of +1.15 um over 10 ms
    and a stick-phase ramp, 3.08 -> 1.88 x the noise, the scattered breakaways alone
    1.09; Student-t, 3 dof, seed 761, a creep of +3.37 um over 10 ms, 5.89 -> 2.21, the
    breakaways alone 2.49, 19 % of their excess closed. Creep of 3 um over 50 ms, A seed
    0 and C seed 201: 83 % and 88 %)."""
    return form.closes_beyond_scatter >= FOUND_SHARE
