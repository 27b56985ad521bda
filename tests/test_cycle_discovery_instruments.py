"""False alarms of the per-cycle discovery on clean physics read through imperfect
instruments (slow): campaigns of the independent generator with *no* missing physics,
each with one imperfection of the logger or the slider that a real record has and that
is not an effect to name: quantisation, spikes, a noisier gauge, a jittered clock (the
stamps resampled on reading), irregular slips (mu_s drawn per cycle, Gaussian or
heavy-tailed), and all of the instrument ones at once; both lubricants.

What counts: a library effect named is a false alarm (any confidence); "unexplained" is
an honest answer for irregular slips (the paper's model has one mu_s) but a false alarm
for the instrument imperfections, which the workflow is built to absorb (the spike
filter, the noise estimate, the resampling).

`python tests/test_cycle_discovery_instruments.py [--instrument | --slider] [FIRST]` prints
the table (answer, confidence, gap before -> after in units of the noise, seconds) and
the rates. The slow test (CI) runs the instrument set; the irregular slips (about 4 min
a campaign) are under the `targets` marker.
"""

from __future__ import annotations

import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))
import independent_records as ir  # noqa: E402
from test_cycle_discovery_rates import LUBES, run_one  # noqa: E402

I = ir.Imperfections  # noqa: E741
NOISE = ir.Imperfections().noise_mm

INSTRUMENT = {
    "quantised_1um": I(quantum_mm=2 * NOISE),
    "spikes": I(spike_rate=0.002, spike_mm=0.03),
    "noisy_2um": I(noise_mm=4 * NOISE),
    "clock_jitter_4pct": I(clock_jitter=0.04),
    "all_instrument": I(quantum_mm=NOISE, spike_rate=0.001, spike_mm=0.02, clock_jitter=0.03),
}
"""Imperfections of the measurement chain: the answer must be "none"."""

SLIDER = {
    "irregular_slips_1pct": I(mu_s_jitter=0.01),
    "irregular_slips_t3": I(mu_s_jitter=0.01, mu_s_jitter_df=3.0),
}
"""Irregular slips (a real slideway's scatter of mu_s from cycle to cycle): no library
effect may be named; "none" or "unexplained" are both honest."""


P = ir.Physics
IMPERFECT = INSTRUMENT["all_instrument"]
EFFECTS = {
    "viscous_damping": ("physics", P(damping_ratio=0.2)),
    "stribeck": ("physics", P(stribeck_b=0.06)),
    "drive_periodic_error": ("imp", {"screw_amp_mm": 0.015}),
    "sensor_lowpass": ("imp", {"sensor_order": 2, "sensor_hz": 20.0}),
    "friction_drift": ("physics", P(drift_mu_s=-5e-4, drift_mu_d=-2.5e-4)),
}
"""The power under an imperfect instrument (`--effects`, measured, not asserted): the
calibrated set's lubricant A campaigns (`test_cycle_discovery_rates.CALIBRATED`: the 3x
sizes, the 15 um screw and the saturated drift) read through `IMPERFECT`."""


def effect_campaigns():
    import dataclasses

    from test_cycle_discovery_rates import EFFECTS as NAMES

    out = []
    for i, (name, (arg, value)) in enumerate(EFFECTS.items()):
        kw = ({"physics": value, "imp": IMPERFECT} if arg == "physics"
              else {"imp": dataclasses.replace(IMPERFECT, **value)})
        out.append((f"{name}/imperfect/A", 800 + i, LUBES[0], kw, NAMES[name][0]))
    return out


def campaigns(which=None):
    """(kind, seed, lubricant, generator arguments) of every campaign, or of the sets
    named in `which` (INSTRUMENT, SLIDER)."""
    sets = which or (INSTRUMENT, SLIDER)
    out = []
    for i, (name, imp) in enumerate({**INSTRUMENT, **SLIDER}.items()):
        if not any(name in group for group in sets):
            continue
        for j, lube in enumerate(LUBES):
            out.append((f"{name}/{'AC'[j]}", 700 + 10 * i + j, lube, {"imp": imp}))
    return out


def false_alarm(row) -> bool:
    kind = row["kind"].split("/")[0]
    allowed = ("none",) if kind in INSTRUMENT else ("none", "unexplained")
    return row["effect"] not in allowed


def table(rows) -> str:
    lines = [f"{'campaign':28s} {'answer':34s} {'conf':5s} {'gap/noise':>13s} {'s':>6s}"]
    for r in rows:
        lines.append(f"{r['kind']:28s} {'+'.join(sorted(r['named'])):34s} {r['confidence']:5s} "
                     f"{r['gap_before']:6.2f}->{r['gap_after']:5.2f} {r['seconds']:6.1f}"
                     + ("  FALSE ALARM" if false_alarm(r) else ""))
    inst = [r for r in rows if r["kind"].split("/")[0] in INSTRUMENT]
    sl = [r for r in rows if r["kind"].split("/")[0] in SLIDER]
    lines.append(f"false alarms: instrument {sum(map(false_alarm, inst))} of {len(inst)}, "
                 f"irregular slips {sum(map(false_alarm, sl))} of {len(sl)}; "
                 f"refused: {[r['kind'] for r in rows if r['effect'] == 'refused'] or 'none'}")
    return "\n".join(lines)


def _rows(which):
    out = [run_one(k, s, lube, **kw) for k, s, lube, kw in campaigns(which)]
    print("\n" + table(out))
    return out


@pytest.mark.slow
def test_imperfect_instruments_raise_no_false_alarm():
    """No library effect named, and nothing "unexplained", on clean physics read through
    an imperfect instrument; a campaign is never refused for its instrument, a 4 % clock
    jitter included (measured: 10 of 10 "none (high)", gaps 0.91-1.06x the noise, 6-52 s
    a campaign)."""
    rows = _rows((INSTRUMENT,))
    assert not [r["kind"] for r in rows if r["effect"] == "refused"], table(rows)
    assert not [r["kind"] for r in rows if false_alarm(r)], table(rows)


@pytest.mark.slow
@pytest.mark.targets
def test_irregular_slips_raise_no_false_alarm():
    """Irregular slips (mu_s scattering 1 % from cycle to cycle): "none" or "unexplained",
    never a library name, nor a sparse form: on C the scattered breakaway leaves a
    residual of a creep's shape before each slip, and the form that fits it (3.08 ->
    1.88 and 5.89 -> 2.21 x the noise) does not outdo every window's own mu_s (1.09 and
    2.49, `sparse._beyond_scatter`). Marked `targets` (about 4 min a campaign, beyond
    CI's budget)."""
    rows = _rows((SLIDER,))
    assert not [r["kind"] for r in rows if false_alarm(r)], table(rows)


def main(argv) -> None:
    """`[--instrument | --slider] [FIRST]`: one set (default both), from campaign FIRST on;
    `--effects`: the effect campaigns read through an imperfect instrument."""
    if argv[:1] == ["--effects"]:
        rows = []
        for k, s, lube, kw, truth in effect_campaigns():
            r = run_one(k, s, lube, **kw)
            r["found"] = bool(r["named"] & truth)
            rows.append(r)
            print(f"{k:34s} {'+'.join(sorted(r['named'])):40s} {r['confidence']:5s} "
                  f"{r['gap_before']:6.2f}->{r['gap_after']:5.2f} {r['seconds']:6.1f} s "
                  f"{'found' if r['found'] else 'MISSED'}", flush=True)
        print(f"named {sum(r['found'] for r in rows)} of {len(rows)}; within 1.15x the "
              f"noise after: {sum(r['found'] and r['gap_after'] <= 1.15 for r in rows)}")
        return
    which = {"--instrument": (INSTRUMENT,), "--slider": (SLIDER,)}.get(argv[0]) if argv else None
    argv = argv[1:] if which else argv
    out = []
    for k, s, lube, kw in campaigns(which)[int(argv[0]) if argv else 0:]:
        out.append(run_one(k, s, lube, **kw))
        print(table(out[-1:]).splitlines()[1], flush=True)
    print(table(out))


if __name__ == "__main__":
    main(sys.argv[1:])
