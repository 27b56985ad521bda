"""Rates of the per-cycle discovery on campaigns from the independent generator (slow).

One hidden effect per campaign, in forms that differ from the library's (a damping
ratio; a rational Stribeck drop; a lead-screw error with a second harmonic; a
second-order sensor; a drift of mu_s and mu_d), at two sizes, alternating lubricants
A and C; clean campaigns for the false-alarm rate; two effects outside the library (a
hardening spring, creep before breakaway). Every campaign includes records near the
stick-slip boundary (the fast runs of the light, stiff slider).

`python tests/test_cycle_discovery_rates.py [N_CLEAN]` prints the table (rates, power by
effect and size, gap after / noise, time per campaign); the slow test asserts the
targets: named (alone or jointly with its indistinguishable partner) in >= 80 %
of the effect campaigns, gap after within 15 % of the noise when named, false alarms
<= 5 % on clean campaigns, outside effects never named with "high" confidence.
"""

from __future__ import annotations

import json
import os
import sys
import time

import numpy as np
import pytest
import scipy.stats

sys.path.insert(0, os.path.dirname(__file__))
import independent_records as ir  # noqa: E402

P, I = ir.Physics, ir.Imperfections  # noqa: E741
EFFECTS = {
    "viscous_damping": ({"viscous_damping"},
                        (("physics", P(damping_ratio=0.05)), ("physics", P(damping_ratio=0.2)))),
    "stribeck": ({"stribeck", "rate_state"},
                 (("physics", P(stribeck_b=0.004)), ("physics", P(stribeck_b=0.015)))),
    "drive_periodic_error": ({"drive_periodic_error"},
                             (("imp", I(screw_amp_mm=0.0005)), ("imp", I(screw_amp_mm=0.002)))),
    "sensor_lowpass": ({"sensor_lowpass"},
                       (("imp", I(sensor_order=2, sensor_hz=120.0)),
                        ("imp", I(sensor_order=2, sensor_hz=40.0)))),
    "friction_drift": ({"friction_drift"},
                       (("physics", P(drift_mu_s=-2e-5, drift_mu_d=-1e-5)),
                        ("physics", P(drift_mu_s=-1e-4, drift_mu_d=-5e-5)))),
}
OUTSIDE = {"hardening_spring": ("physics", P(hardening=0.1)),
           "stick_creep": ("imp", I(creep_mm=0.003))}
LUBES = (ir.LUBRICANT_A, ir.LUBRICANT_C)
DESIGN = dict(cycles=4.0)


def run_one(kind, seed, lube, **kw):
    from stickslip_fitting.discovery.cycle_workflow import discover_cycles

    recs = ir.campaign(lube, seed=seed, **DESIGN, **kw)
    t = time.perf_counter()
    try:
        # STICKSLIP_RATES_PROGRESS=1: every campaign's stage lines on stderr
        res = discover_cycles(recs, progress=(
            (lambda line: print(f"  {kind}: {line}", file=sys.stderr, flush=True))
            if os.environ.get("STICKSLIP_RATES_PROGRESS") else None))
    except ValueError as e:  # refused with a reason (counted as not named)
        print(f"{kind}: refused: {e}", file=sys.stderr)
        return dict(kind=kind, effect="refused", named={"refused"}, confidence="-",
                    gap_before=float("nan"), gap_after=float("nan"),
                    seconds=time.perf_counter() - t, samples=0, learned_closes=None,
                    silent_failures=[],
                    family_wise=float("nan"))
    named = {res.effect} | {r["name"] for r in res.indistinguishable_from}
    # the campaign's family-wise p-value: the smallest over the families (uniform on
    # clean campaigns when the ranking's false-alarm rate is calibrated)
    family_wise = min((c["family_wise_p_value"] for c in res.candidates
                       if np.isfinite(c["family_wise_p_value"])), default=float("nan"))
    if os.environ.get("STICKSLIP_RATES_LOG"):  # the decision's inputs, one JSON line each
        with open(os.environ["STICKSLIP_RATES_LOG"], "a") as fh:
            fh.write(json.dumps({"kind": kind, "seed": seed, "effect": res.effect,
                                 "confidence": res.confidence,
                                 "gap_before": res.gap_before / res.noise,
                                 "gap_after": res.gap_after / res.noise,
                                 "seconds": time.perf_counter() - t,
                                 "joint": res.indistinguishable_from,
                                 "candidates": [{k: c[k] for k in (
                                     "name", "score_p_value", "family_wise_p_value",
                                     "chi2_drop", "unphysical", "refit_failed",
                                     "direction_cosine", "z_winner")}
                                     for c in res.candidates]}) + "\n")
    # a refit that ended above the base fit says so (`refit_failed`), never a negative
    # "drop" (a failed refit of load coupling would otherwise "lower" chi-square by
    # -1.2e6 to -1.8e7)
    silent = [c["name"] for c in res.candidates if c["chi2_drop"] is not None
              and c["chi2_drop"] < -1.0 and not c["refit_failed"]]
    return dict(kind=kind, effect=res.effect, named=named, confidence=res.confidence,
                silent_failures=silent,
                gap_before=res.gap_before / res.noise, gap_after=res.gap_after / res.noise,
                seconds=time.perf_counter() - t,
                samples=int(res.model.mask.sum()),
                learned_closes=res.learned.closes if res.learned is not None else None,
                family_wise=family_wise)


def campaigns(n_clean: int):
    out = []
    for i, (name, (_, sizes)) in enumerate(EFFECTS.items()):
        for j, (arg, value) in enumerate(sizes):
            out.append((f"{name}/{'small' if j == 0 else 'large'}", 100 + 2 * i + j,
                        LUBES[(i + j) % 2], {arg: value}))
    for i, (name, (arg, value)) in enumerate(OUTSIDE.items()):
        out.append((f"outside/{name}", 200 + i, LUBES[i % 2], {arg: value}))
    for i in range(n_clean):
        out.append(("clean", 300 + i, LUBES[i % 2], {}))
    return out


def summarise(rows):
    eff = [r for r in rows if r["kind"].split("/")[0] in EFFECTS]
    found = [r for r in eff if r["named"] & EFFECTS[r["kind"].split("/")[0]][0]]
    clean = [r for r in rows if r["kind"] == "clean"]
    alarms = [r for r in clean if r["effect"] != "none"]
    outside = [r for r in rows if r["kind"].startswith("outside")]
    # a library name that does not contain the truth, given with high confidence
    wrong_high = [r["kind"] for r in rows if r["confidence"] == "high"
                  and r["effect"] not in ("none", "unexplained")
                  and (r["kind"].split("/")[0] not in EFFECTS
                       or not r["named"] & EFFECTS[r["kind"].split("/")[0]][0])]
    return dict(found=len(found) / max(len(eff), 1), n_effect=len(eff),
                false_alarms=len(alarms) / max(len(clean), 1), n_clean=len(clean),
                found_gap_ok=all(r["gap_after"] <= 1.15 for r in found),
                outside_high=[r["kind"] for r in outside
                              if r["confidence"] == "high" and r["effect"] not in ("none",)],
                # answered by a library family (a low-confidence wrong name still misleads)
                outside_named=[r["kind"] for r in outside
                               if r["effect"] not in ("sparse_form", "unexplained", "none")],
                # an outside effect left unexplained: the learned phase correction must
                # close at least half the gap's excess over the noise
                outside_learned=[(r["kind"], r["learned_closes"]) for r in outside
                                 if r["effect"] == "unexplained"],
                found_rows=found, wrong_high=wrong_high)


def table(rows) -> str:
    lines = [f"{'campaign':34s} {'answer':22s} {'conf':5s} {'gap/noise':>16s} {'s':>6s}"]
    for r in rows:
        lines.append(f"{r['kind']:34s} {'+'.join(sorted(r['named'])):22s} "
                     f"{r['confidence']:5s} {r['gap_before']:7.2f}->{r['gap_after']:5.2f} "
                     f"{r['seconds']:6.1f}")
    s = summarise(rows)
    lines.append(f"named {100 * s['found']:.0f} % of {s['n_effect']} effect campaigns; "
                 f"false alarms {100 * s['false_alarms']:.0f} % of {s['n_clean']} clean; "
                 f"outside effects named with high confidence: {s['outside_high'] or 'none'}; "
                 f"wrong names with high confidence: {s['wrong_high'] or 'none'}; "
                 "learned correction on unexplained outside effects closes "
                 + (", ".join(f"{k.split('/')[-1]} {100 * c:.0f} %"
                              for k, c in s["outside_learned"]) or "-"))
    return "\n".join(lines)


@pytest.fixture(scope="module")
def rows():
    n_clean = int(os.environ.get("STICKSLIP_RATES_CLEAN", "20"))
    out = [run_one(k, s, lube, **kw) for k, s, lube, kw in campaigns(n_clean)]
    print("\n" + table(out))
    return out


@pytest.mark.slow
def test_discovery_rates_do_not_regress(rows):
    """What the workflow achieves (docs): false alarms <= 5 %, outside effects never
    named with high confidence (and, when unexplained, at least half the gap's excess
    closed by the learned phase correction), no wrong name with high confidence, at
    least 60 % of the effect campaigns named (measured on a 2-core x86 machine: 6 of 10
    named, 0 of 20 false alarms, named gaps after <= 1.05x the noise; the four misses,
    a small damping, a small Stribeck drop, a large screw error and a small sensor,
    leave gaps within 1.05x the noise, so floating-point differences between machines
    can tip them either way)."""
    s = summarise(rows)
    assert s["false_alarms"] <= 0.05
    assert not s["outside_high"]
    # the outside effects by their form, not a family's name (measured: the creep
    # sparse_form, 1.58 -> 1.04 x the noise; the 0.1 stiffening load_coupling (low))
    assert len(s["outside_named"]) <= 1, s["outside_named"]
    assert not s["wrong_high"]
    assert s["found"] >= 0.6
    assert not [(r["kind"], r["silent_failures"]) for r in rows if r["silent_failures"]]
    # an unexplained gap (or none) is never "X or Y" (e.g. "unexplained or rate_state"
    # for the creep, a contender whose refined shape came close)
    assert not [r["kind"] for r in rows if r["effect"] in ("none", "unexplained")
                and len(r["named"]) > 1]
    assert all(c is not None and c >= 0.5 for _, c in s["outside_learned"]), s["outside_learned"]
    # the calibration itself: on clean campaigns the family-wise p-value is uniform
    # (measured: Kolmogorov-Smirnov p 0.25 over the 20 clean campaigns; Bonferroni's
    # min(1, K p) would pile up at 1, the unadjusted smallest p near 0)
    clean = [r["family_wise"] for r in rows if r["kind"] == "clean"]
    assert scipy.stats.kstest(clean, "uniform").pvalue > 0.01, sorted(clean)


@pytest.mark.slow
@pytest.mark.targets
def test_discovery_rates_meet_the_targets(rows):
    """The targets at these sizes: >= 80 % named, gap after within 15 % of the noise
    where named. Met at the edge (measured: 8 of 10, gaps after <= 1.06x). Marked
    `targets`: CI runs `-m "slow and not targets"` (one campaign either way decides
    it)."""
    s = summarise(rows)
    assert s["found"] >= 0.8
    assert s["found_gap_ok"]


POWER = {
    "viscous_damping": ("physics", "damping_ratio", (0.02, 0.1, 0.4)),
    "stribeck": ("physics", "stribeck_b", (0.015, 0.04, 0.1)),
    "drive_periodic_error": ("imp", "screw_amp_mm", (0.002, 0.005, 0.02)),
    "sensor_lowpass": ("imp", "sensor_hz", (60.0, 40.0, 20.0)),
    "friction_drift": ("physics", "drift_mu_s", (-1e-4, -5e-4)),
}
"""The power sweep (`python tests/test_cycle_discovery_rates.py --power`): each effect at
growing sizes (the second-order sensor with damping ratio 0.7; friction drift with
mu_d drifting at half mu_s's rate), both lubricants."""


def power_campaigns():
    out = []
    for i, (name, (arg, field, sizes)) in enumerate(POWER.items()):
        for j, size in enumerate(sizes):
            kw = {field: size}
            if field == "sensor_hz":
                kw["sensor_order"] = 2
            if field == "drift_mu_s":
                kw["drift_mu_d"] = 0.5 * size
            value = P(**kw) if arg == "physics" else I(**kw)
            for lube_i, lube in enumerate(LUBES):
                out.append((f"{name}/{field}={size:g}/{'AC'[lube_i]}", 400 + 10 * i + j, lube,
                            {arg: value}))
    return out



CALIBRATED = {
    "viscous_damping": {"A": (P(damping_ratio=0.2), P(damping_ratio=0.6)),
                        "C": (P(damping_ratio=0.3), P(damping_ratio=0.4))},
    "stribeck": {"A": (P(stribeck_b=0.06), P(stribeck_b=0.2)),
                 "C": (P(stribeck_b=0.12), P(stribeck_b=0.16))},
    "drive_periodic_error": {"A": (I(screw_amp_mm=0.002), I(screw_amp_mm=0.015)),
                             "C": (I(screw_amp_mm=0.012), I(screw_amp_mm=0.03))},
    "sensor_lowpass": {"A": (I(sensor_order=2, sensor_hz=20.0), I(sensor_order=2, sensor_hz=7.0)),
                       "C": (I(sensor_order=2, sensor_hz=12.0), I(sensor_order=2, sensor_hz=7.0))},
    "friction_drift": {"A": (P(drift_mu_s=-2e-5, drift_mu_d=-1e-5),
                             P(drift_mu_s=-5e-4, drift_mu_d=-2.5e-4)),
                       "C": (P(drift_mu_s=-1e-4, drift_mu_d=-5e-5),
                             P(drift_mu_s=-1e-3, drift_mu_d=-5e-4))},
}
"""The calibrated sizes, "about 3x and 20x the noise in the traces", per lubricant: the
effect's RMS misfit to the paper's per-cycle model at the generator's own friction
(`tests/effect_sizes.py`; `python tests/effect_sizes.py --calibrated` prints them for
these campaigns). The small size is about 3x; the large one 20x where a physical effect
gets there (a 15 um screw error on A), else the largest that keeps stick-slip in the
campaign: a damping ratio of 0.6 on A (0.5 on C leaves 1 of 12 records slipping), a
Stribeck drop just below mu_d, a 7 Hz sensor, a drift that has saturated, a 30 um screw
on C (about 100 um, the screw's bound, would be needed for 20x there). Measured at seed
500: 2.7/20.7x screw on A, 3.0/6.7x on C (3.9x at 15 um); damping
3.0/4.8x (A), 2.3/2.6x (C); Stribeck 2.9/13.4x (A), 3.2/5.0x (C); sensor 2.6x at 20 Hz
and 9.4x at 7 Hz (A), 2.7x at 12 Hz and 4.7x at 7 Hz (C); drift 3.2/13.7x (A), 3.8/7.5x (C)."""


def calibrated_campaigns():
    out = []
    for i, (name, by_lube) in enumerate(CALIBRATED.items()):
        for lube_i, lube in enumerate(LUBES):
            for j, value in enumerate(by_lube["AC"[lube_i]]):
                arg = "physics" if isinstance(value, P) else "imp"
                out.append((f"{name}/{'3x' if j == 0 else 'large'}/{'AC'[lube_i]}",
                            600 + 10 * i + 2 * lube_i + j, lube, {arg: value}))
    return out


@pytest.fixture(scope="module")
def calibrated_rows():
    out = [run_one(k, s, lube, **kw) for k, s, lube, kw in calibrated_campaigns()]
    print("\n" + power_table(out))
    return out


def _found(rows):
    return [r for r in rows if r["named"] & EFFECTS[r["kind"].split("/")[0]][0]]


@pytest.mark.slow
def test_calibrated_sizes_do_not_regress(calibrated_rows):
    """At the calibrated sizes (CALIBRATED, 20 campaigns): what the workflow achieves
    (measured: 19 of 20 named, alone or jointly, 18 within 1.15x the noise after; the
    damping ratio 0.6 on A, where 10 of 12 records have no stick-slip left, is
    "sensor_lowpass" with low confidence; the 7 Hz sensor on A 1.28x). No library name
    without the truth given with high confidence, and no refit failure passed off as a
    chi-square drop."""
    rows = calibrated_rows
    assert len(_found(rows)) >= 0.85 * len(rows), power_table(rows)
    # named with the gap after within 15 % of the noise (two campaigns of slack)
    assert len([r for r in _found(rows) if r["gap_after"] <= 1.15]) >= 0.8 * len(rows), \
        power_table(rows)
    assert not [r["kind"] for r in rows if r["confidence"] == "high"
                and r["effect"] not in ("none", "unexplained")
                and not r["named"] & EFFECTS[r["kind"].split("/")[0]][0]]
    assert not [(r["kind"], r["silent_failures"]) for r in rows if r["silent_failures"]]


@pytest.mark.slow
@pytest.mark.targets
def test_calibrated_sizes_meet_the_targets(calibrated_rows):
    """The targets at the calibrated sizes: the family named (alone or jointly with its
    indistinguishable partner) and the gap after within 15 % of the noise, in >= 80 % of
    the campaigns (measured: 18 of 20 named within 1.15x). The stricter reading, every
    named campaign within 1.15x, is not met: the 7 Hz sensor on A, 1.28x."""
    rows = calibrated_rows
    found = _found(rows)
    assert len(found) >= 0.8 * len(rows)
    assert len([r for r in found if r["gap_after"] <= 1.15]) >= 0.8 * len(rows), \
        power_table(rows)


@pytest.mark.slow
def test_a_large_stribeck_drop_on_lubricant_c_is_named():
    """The power sweep's Stribeck drop of 0.1 on lubricant C (rational curve, v_s 10
    mm/s): far from the data (base chi2/n 2) the grid shapes let the per-record screw
    (pitch 1.8 mm, amplitudes 3-38 um on records that travel less than a pitch) explain
    more than Stribeck's best grid shape, so the screw would be named; the close
    contenders' shapes are therefore refined before the choice (measured: stribeck
    (low), gap 1.68 -> 1.17x, about 90 s)."""
    (k, s, lube, kw), = [c for c in power_campaigns() if c[0] == "stribeck/stribeck_b=0.1/C"]
    row = run_one(k, s, lube, **kw)
    assert row["named"] & EFFECTS["stribeck"][0], row
    assert row["gap_after"] < 0.8 * row["gap_before"]

def visible(row) -> float:
    """The effect's visible size: the excess RMS of the paper's model over the noise
    (sqrt(gap^2 / noise^2 - 1); what the base model cannot absorb)."""
    return float(np.sqrt(max(row["gap_before"] ** 2 - 1.0, 0.0)))


def power_table(rows) -> str:
    lines = [f"{'effect / size / lubricant':44s} {'answer':30s} {'conf':5s} "
             f"{'visible':>8s} {'gap after':>9s} {'found':>6s}"]
    for r in rows:
        fam = r["kind"].split("/")[0]
        hit = bool(r["named"] & EFFECTS[fam][0])
        lines.append(f"{r['kind']:44s} {'+'.join(sorted(r['named'])):30s} {r['confidence']:5s} "
                     f"{visible(r):8.2f} {r['gap_after']:9.2f} {'yes' if hit else 'no':>6s}")
    return "\n".join(lines)


def main(argv) -> None:
    """`--power [FIRST]` / `--calibrated [FIRST]`: the power sweep or the calibrated sizes
    (from campaign FIRST on), one line per campaign, then the table; `[N_CLEAN]`: the
    rates campaigns with N_CLEAN clean ones."""
    sets = {"--power": power_campaigns, "--calibrated": calibrated_campaigns}
    if argv[:1] and argv[0] in sets:
        out = []
        first = int(argv[1]) if len(argv) > 1 else 0
        for k, s, lube, kw in sets[argv[0]]()[first:]:
            out.append(run_one(k, s, lube, **kw))
            print(power_table(out[-1:]).splitlines()[-1], flush=True)
        print(power_table(out))
        return
    out = []
    for k, s, lube, kw in campaigns(int(argv[0]) if argv else 20):
        out.append(run_one(k, s, lube, **kw))
        r = out[-1]
        print(f"{r['kind']:34s} {'+'.join(sorted(r['named'])):22s} {r['confidence']:5s} "
              f"{r['gap_before']:7.2f}->{r['gap_after']:5.2f} {r['seconds']:6.1f} s "
              f"{r['samples']} samples", flush=True)
    print(table(out))


if __name__ == "__main__":
    main(sys.argv[1:])
