"""Stage 3 of the per-cycle discovery, `ranking`: the robust score test of every family
and shape from one Jacobian block each at the base fit, and the family-wise p-values of
the sign flips (`cycle_workflow`, module doc)."""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.stats

from stickslip_jax.logs import logger

from ..cycle_effects import Shape
from ..decision import hotelling, window_scores
from ..flips import family_wise_p
from ..options import DiscoveryOptions
from ..scores import base_basis, project_out
from ..subproblems import with_shape
from .state import Base, Clock, FamilyScore, Prepared, Ranking

__all__ = ["held_p", "held_test", "physical_side", "rank", "relevant_drop", "shape_columns",
           "significance_line"]

_SHAPE_STEPS = {"stribeck": (("vs", 0.05, True), ("p", 0.1, False)),
                "rate_state": (("length", 0.05, True),),
                "drive_periodic_error": (("pitch", 0.01, True),),
                "sensor_lowpass": (("zeta", -0.03, False),)}
"""Per family: its continuous shape parameters (`cycle_effects.Shape` fields), the
finite-difference step of each and whether the step is relative (`shape_columns`)."""


def score_cols(model, f, G) -> np.ndarray:
    """The family's columns in the score test: the first harmonic only of a per-record
    family (dof 2 per record)."""
    cols = model.cols(f)
    return cols.reshape(G, -1)[:, :2].ravel() if f.per_record else cols


def shape_columns(model, z, shape: Shape, sensor: bool, held) -> np.ndarray:
    """The derivatives [n, k] of the residuals at `z` over the continuous shape parameters
    of the named effects `held` (Stribeck speed scale and exponent, rate-and-state slip
    distance, screw pitch, second-order sensor damping ratio; forward differences). A named
    effect's shape was chosen on the records, so it is a nuisance parameter of every later
    test: a family that only fits what the named effect's shape leaves (a rational Stribeck
    drop fitted by the library's nearest shape, the rest taken up by a sensor low-pass and
    load coupling) lies in their span and is no evidence of a further effect."""
    moved = []
    for f in held:
        for field, h, relative in _SHAPE_STEPS.get(f.name, ()):
            if ((field == "p" and not shape.form.has_exponent)
                    or (field == "zeta" and shape.order != 2)):
                continue
            v = getattr(shape, field)
            moved.append((dataclasses.replace(shape, **{field: v * (1.0 + h) if relative
                                                        else v + h}), h))
    if not moved:
        return np.zeros((0, 0))
    r0 = model.residuals(z, shape, sensor)[0]
    cols = [(model.residuals(z, s, sensor)[0] - r0) / h for s, h in moved]
    return np.stack([c for c in cols if np.all(np.isfinite(c))] or [0.0 * r0], axis=1)


def _nuisance(J, model, z, shape, sensor, held, described) -> np.ndarray:
    """The basis of the base columns `J` and the named effects' shape columns
    (`shape_columns`) over the described records."""
    S = shape_columns(model, z, shape, sensor, held)
    return base_basis((np.hstack([J, S]) if S.size else J) * described[:, None])


def physical_side(model, f, G) -> int:
    """The side of family `f`'s one-sided score test (`flips.one_sided`): its physical
    sign where its test has one column and the effect has a sign (damping, a Stribeck
    drop, the sensor's delay), else 0 (two-sided)."""
    return int(f.signs[0]) if score_cols(model, f, G).size == 1 else 0


def _leads(sc: FamilyScore) -> tuple[bool, float]:
    """The order of a family's shapes: the shape that would explain most (its predicted
    chi-square drop), a one-sided family's (damping, Stribeck b, rate-and-state a, the
    sensor) among the shapes whose score step points to its physical side where any
    does. A step to the other side is no evidence for the effect: a Stribeck curve's
    b < 0 is a friction that rises with speed (damping's sign), and its refit from there
    ends unphysical (measured: damping and a Stribeck drop at once, 4 records, the
    Stribeck refits at b -0.015 to -0.10 in every search)."""
    wrong = sc.family.signs[0] > 0 and np.size(sc.step) > 0 and sc.step[0] < 0
    return not wrong, sc.chi2_predicted


def _efficient(Qb, described, Jc) -> np.ndarray:
    """The columns `Jc` over the described records with the base projected out (NaN
    where they are not finite)."""
    Jc = Jc * described[:, None]
    if np.all(np.isfinite(Jc)):
        return project_out(Qb, Jc)
    return np.full(Jc.shape, np.nan)


def _plain_jacobians(model, base: Base, fams, G) -> dict:
    """The families without shapes share one Jacobian call (one tangent per column)."""
    plain = [f for f in fams if f.shapes == (Shape(),) and f.name != "sensor_lowpass"]
    plain_J = {}
    if plain:
        _, J_all, _ = model.evaluate(base.z, np.concatenate([score_cols(model, f, G)
                                                             for f in plain]),
                                     base.shape, base.sensor)
        a = 0
        for f in plain:
            plain_J[f.name] = J_all[:, a:a + score_cols(model, f, G).size]
            a += score_cols(model, f, G).size
    return plain_J


def _sensor_secant(model, base: Base, cols, shape, opts, efficient, r_rank, starts, window_g):
    """The sensor's column: zero first derivative at tau = 0 (module doc of
    `cycle_model`), so the secant to the probe time constant that fits best; every
    probe is a test of the family-wise level (the choice among them is part of the
    look-elsewhere). Returns the column, the probe and its test's index."""
    best_probe = None
    for probe in opts.sensor_probes:
        zp = base.z.copy()
        zp[cols] = probe
        rp = model.residuals(zp, shape, sensor=True)[0]
        if best_probe is None or np.sum(rp ** 2) < best_probe[0]:
            best_probe = (float(np.sum(rp ** 2)), probe, rp, len(window_g))
        window_g.append(window_scores(efficient(((rp - base.r) / probe)[:, None]), r_rank,
                                       starts))
    _, probe, rp, test = best_probe
    return ((rp - base.r) / probe)[:, None], probe, test


def _family_scores(f, model, base, opts, G, plain_J, efficient, r_rank, starts, window_g,
                   sensor_probe, metrics) -> list[FamilyScore]:
    """Every shape's score test of family `f` (appending its window contributions to
    `window_g`, the sensor's probes to `sensor_probe`, and the Gram matrix of a
    per-record family's test to `metrics` by its index: `flips.family_wise_p` weighs its
    score by the information). Each record's columns of a per-record family (the screw's
    first harmonic) see only that record's windows, each at another phase of the effect,
    so its score turns from window to window; a family shared by the records keeps
    Hotelling's weighting (measured: weighed by the information, a friction drift of two
    columns passed the third search after a screw and damping on 5 records of C at
    family-wise p 0.0042 against Hotelling's nominal 0.01, and was named for 0.2 % of
    the gap)."""
    cols = score_cols(model, f, G)
    out = []
    for shape in f.shapes:
        shape = with_shape(base.shape, f, shape)  # the named effects keep theirs
        test = -1
        if f.name == "sensor_lowpass":
            Jc, sensor_probe[shape], test = _sensor_secant(
                model, base, cols, shape, opts, efficient, r_rank, starts, window_g)
        elif f.name in plain_J:
            Jc = plain_J[f.name]
        else:
            _, Jc, _ = model.evaluate(base.z, cols, shape, base.sensor)
        Jp = efficient(Jc)
        finite = np.all(np.isfinite(Jp))
        if not finite:
            logger.warning(f"{f.name} ({shape.label(f)}): its derivative at the base "
                           "fit is not finite; not tested")
        elif f.name != "sensor_lowpass":
            test = len(window_g)
            window_g.append(window_scores(Jp, r_rank, starts))
            if f.per_record and Jp.shape[1] > 1:
                metrics[test] = Jp.T @ Jp
        F, p, dof, step, pred = hotelling(
            Jp, r_rank, starts, window_g[test] if finite and test >= 0 else None,
            side=physical_side(model, f, G))
        out.append(FamilyScore(f, shape, F, p, dof, step, Jp, pred, test=test if finite else -1))
    return out


def held_p(base: Base, starts, fit, z, f, shape, sensor: bool, value, others=()) -> float:
    """The robust window test's p-value of family `f`, one of the effects named, at a
    `fit` (over its free coordinates, full coordinates `z`) that leaves it out: the
    drop-one test of the sequential search (`stages.more`), the ranking's test of one
    family in its named shape (the sensor by its secant to its fitted value `value`),
    the shapes of the effects `others` in the fit free (`shape_columns`)."""
    return held_test(base, starts, fit, z, f, shape, sensor, value, others)[0]


def held_test(base: Base, starts, fit, z, f, shape, sensor: bool, value, others=()
              ) -> tuple[float, float]:
    """`held_p` and the chi-square drop the score step of `f` predicts at that fit."""
    model, described, n = base.model, base.described, base.n
    r = fit.r[:n]
    cols = score_cols(model, f, model.n_records)
    if f.name == "sensor_lowpass":
        zp = np.array(z, float)
        zp[cols] = value
        Jc = ((model.residuals(zp, shape, sensor=True)[0] - r) / value)[:, None]
    else:
        Jc = model.evaluate(z, cols, shape, sensor)[1]
    Qb = _nuisance(fit.J[:n], model, z, shape, sensor, others, described)
    _, p, _, _, predicted = hotelling(_efficient(Qb, described, Jc),
                                      np.where(described, r, 0.0), starts,
                                      side=physical_side(model, f, model.n_records))
    return p, predicted


def relevant_drop(predicted: float, s2: float, dof: int, n_used: int, opts,
                  level: float) -> bool:
    """The ranking's second route of significance: a predicted chi-square drop of at least
    `relevant` of the samples used whose per-sample score test (the drop over the
    residual variance `s2`, chi-square with `dof` degrees of freedom) has p < `level`."""
    return bool(predicted >= opts.relevant * n_used
                and scipy.stats.chi2.sf(predicted / s2, dof) < level)


def significance_line(significant, n_families: int, alpha: float, level: float,
                      n_tests: int) -> str:
    """How many families are significant, and by which test (the count of the candidate
    table's "significant" column)."""
    wise = sum(s.significant_by == "family-wise" for s in significant)
    sample = len(significant) - wise
    return (f"{len(significant)} of {n_families} families significant: {wise} by the "
            f"robust window test (family-wise p < {alpha:g} over {n_tests} tests), "
            f"{sample} by a relevant predicted drop with per-sample p < {level:.2g}")


def rank(prep: Prepared, base: Base, fams, *, opts: DiscoveryOptions, clock: Clock) -> Ranking:
    """The score tests of every family (module doc of `cycle_workflow`, stage 3)."""
    model, described, starts, G = base.model, base.described, prep.starts, prep.G
    alpha, n_used = opts.alpha, base.n_used
    r_rank = np.where(described, base.r, 0.0)
    Qb = _nuisance(base.fit.J, model, base.z, base.shape, base.sensor, base.held, described)
    n_tests = sum(len(f.shapes) * (len(opts.sensor_probes) if f.name == "sensor_lowpass"
                                   else 1) for f in fams)
    level = alpha / n_tests
    if base.sensor:  # every refit runs with the sensor: its program built meanwhile
        # (far from the data a refit with the sensor may come, but the sensor's refit is
        # often not made, `refit.cannot_win`: its program is built when that refit comes)
        prep.warm["evaluate", True].start()
    plain_J = _plain_jacobians(model, base, fams, G)
    scores: list[FamilyScore] = []
    shape_scores: dict[str, list[FamilyScore]] = {}
    sensor_probe: dict[Shape, float] = {}
    window_g: list[np.ndarray] = []  # every test's window contributions (`flips`)
    sides: list[int] = []  # and its side (`physical_side`)
    metrics: dict[int, np.ndarray] = {}  # and a per-record family's test its Gram matrix

    def efficient(Jc):
        return _efficient(Qb, described, Jc)

    for f in fams:
        if f.name == "sensor_lowpass":  # its program compiles while the others are tested
            prep.warm["residuals", True].result()
        shape_scores[f.name] = _family_scores(f, model, base, opts, G, plain_J, efficient,
                                              r_rank, starts, window_g, sensor_probe,
                                              metrics)
        sides += [physical_side(model, f, G)] * (len(window_g) - len(sides))
        best = max(shape_scores[f.name], key=_leads)
        if len(f.shapes) > 1:
            logger.debug(f"{f.name}: predicted chi2 drop by shape: " + ", ".join(
                f"{s_.shape.label(f)} {s_.chi2_predicted:.4g} (p {s_.p_value:.2g})"
                for s_ in shape_scores[f.name]))
        scores.append(best)
    # the family-wise p-value of every family's chosen shape: the share of sign flips of
    # the windows whose smallest p-value over all tests is as small (`flips`; Bonferroni's
    # alpha / n_tests assumed the tests independent, and they are strongly correlated;
    # a per-record family's test weighs its score by the information, `_family_scores`)
    adjusted = family_wise_p(window_g, sides=sides,
                             metrics=[metrics.get(k) for k in range(len(window_g))])
    for sc in scores:
        sc.p_family = float(adjusted[sc.test]) if sc.test >= 0 else float("nan")
    scores.sort(key=lambda s: (np.nan_to_num(s.p_value, nan=1.0), -s.chi2_predicted))
    # significant: the robust (window-level) test, or a relevant predicted drop (at least
    # `relevant` of the chi-square) that the per-sample score test supports: the robust
    # test loses power where a few windows (slow records, whose breakaway timing is most
    # sensitive) carry most of the signal
    s2 = ((float(np.sum(r_rank[described] ** 2)) + base.within) / n_used if described.any()
          else base.fit.rss / base.n)
    for sc in scores:
        sc.p_sample = float(scipy.stats.chi2.sf(sc.chi2_predicted / s2, sc.dof))
        if sc.p_family < alpha:
            sc.significant_by = "family-wise"
        elif relevant_drop(sc.chi2_predicted, s2, sc.dof, n_used, opts, level):
            sc.significant_by = "per-sample"
    significant = [s for s in scores if s.significant_by is not None]
    clock("ranking", significance_line(significant, len(fams), alpha, level, len(window_g))
          + f"; best {scores[0].family.name} p = {scores[0].p_value:.2g} "
            f"(family-wise {scores[0].p_family:.2g})")
    return Ranking(scores=scores, shape_scores=shape_scores, sensor_probe=sensor_probe,
                   significant=significant, n_tests=len(window_g), level=level)
