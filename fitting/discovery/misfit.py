r"""The misfit a discovery's final model leaves, said by its phase and its form.

When the final model leaves more than `LEFT` x the noise, its residual is split by the
phase of the model's cycle: the **stick** (up to the last `TAIL` of the stick time), the
**breakaway** (that last part, and whatever the model still sticks after the record's
breakaway: a wrong breakaway time or a creep shows there) and the **slip** (from the
model's slip start). The phase with the largest share of the excess sum of squares over
the noise is described by three forms fitted one after another (weighted least squares):

1. a **level** per cycle (the phase's mean residual differs from cycle to cycle);
2. a **ramp** per cycle, linear in the phase's own time (the time since the last slip in
   the stick, the time since the record's breakaway at the breakaway, negative before
   it, the time since the model's breakaway in the slip; mm/s);
3. an **oscillation**: the sinusoid in time (its amplitude and phase per record) at the
   frequency of a grid (`FREQUENCIES`, Hz) that lowers the sum of squares most.

Each form's share is the part of the phase's excess it removes; the words name the phase,
the largest form and those worth at least `WORTH`, with their sizes, and what the three
leave. At the breakaway they also give the model's **breakaway delay** per cycle (ms; the
deflection v dt and static friction k v dt / W it stands for): a delay that changes sign
from cycle to cycle is a scattering breakaway level mu_0, which no smooth law follows.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .sparse import coordinates

__all__ = ["LEFT", "MisfitLeft", "misfit_left"]

LEFT = 2.0
"""The final gap over the noise above which the misfit left is described."""
TAIL = 0.1
"""The breakaway phase: the stick's last share of its stick time."""
WORTH = 0.1
"""A form's share of the phase's excess from which the words name it."""
FREQUENCIES = np.geomspace(0.5, 200.0, 160)
"""Hz: the oscillation's grid."""
_CLOCK = {"stick": "the time since the last slip",
          "breakaway": "the time since the record's breakaway",
          "slip": "the time since the breakaway"}


@dataclasses.dataclass(frozen=True)
class MisfitLeft:
    """The misfit left (module doc): the `phase` described, every phase's RMS (mm) and
    share of the excess, the `forms` fitted, the `words`, the breakaway `delay`; `profile`:
    the phase's clock (s), residual and fit (mm) and cycle, for the figure."""

    phase: str
    rms: dict
    shares: dict
    forms: tuple
    words: str
    delay: dict
    profile: dict = dataclasses.field(repr=False, default_factory=dict)

    def to_json(self) -> dict:
        return {"phase": self.phase, "rms_mm": self.rms, "excess_share": self.shares,
                "forms": list(self.forms), "breakaway_delay": self.delay, "words": self.words,
                "method": "per cycle level, per cycle ramp in the phase's time, then the "
                          "best sinusoid in time (weighted least squares, one after "
                          "another), each form's share of the phase's excess sum of "
                          "squares over the noise"}


def _fit(A, e, w) -> np.ndarray:
    """The weighted least-squares fit of e on the columns A (weights w)."""
    sw = np.sqrt(w)
    beta = np.linalg.lstsq(A * sw[:, None], e * sw, rcond=None)[0]
    return A @ beta


def _oscillation(t, rec, e, w) -> tuple[float, np.ndarray]:
    """The grid frequency (Hz) whose sinusoid (per record) fits e best, and that fit."""
    best = (np.inf, 0.0, np.zeros_like(e))
    onehot = rec[:, None] == np.unique(rec)[None, :]
    for f in FREQUENCIES:
        q = 2 * np.pi * f * t
        A = np.hstack([onehot * np.sin(q)[:, None], onehot * np.cos(q)[:, None]])
        fit = _fit(A, e, w)
        ss = float(np.sum(w * (e - fit) ** 2))
        if ss < best[0]:
            best = (ss, float(f), fit)
    return best[1], best[2]


def _forms(clock, win, t, rec, e, w, excess) -> tuple[list, np.ndarray]:
    """The three forms one after another (module doc): their dicts and the total fit."""
    cycles = np.unique(win)
    onehot = (win[:, None] == cycles[None, :]).astype(float)
    level = _fit(onehot, e, w)
    ramp = _fit(np.hstack([onehot, onehot * clock[:, None]]), e, w)
    freq, wave = _oscillation(t, rec, e - ramp, w)

    def share(a, b):  # the sum of squares from a to b, over the excess
        return float((np.sum(w * a ** 2) - np.sum(w * b ** 2)) / max(excess, 1e-300))

    lv = np.array([np.average(level[win == c], weights=w[win == c]) for c in cycles])
    slopes = []
    for c in cycles:
        on = win == c
        if np.ptp(clock[on]) > 0:
            slopes.append(np.polyfit(clock[on], (ramp - level)[on], 1)[0])
    slopes = np.array(slopes) if slopes else np.zeros(1)
    amp = np.sqrt(2.0 * np.average(wave ** 2, weights=w))
    forms = [
        {"name": "level", "share": share(e, e - level),
         "rms_between_cycles_um": float(1e3 * np.std(lv)),
         "range_um": [float(1e3 * lv.min()), float(1e3 * lv.max())]},
        {"name": "ramp", "share": share(e - level, e - ramp),
         "slope_median_um_s": float(1e3 * np.median(slopes)),
         "slope_quartiles_um_s": [float(1e3 * q) for q in np.percentile(slopes, (25, 75))],
         "same_sign": float(max(np.mean(slopes > 0), np.mean(slopes < 0)))},
        {"name": "oscillation", "share": share(e - ramp, e - ramp - wave),
         "frequency_hz": freq, "amplitude_um": float(1e3 * amp)}]
    return forms, ramp + wave


def _delay(c) -> dict:
    """The model's breakaway delay per cycle (module doc); a window in which the model
    does not slip counts its end as the breakaway (a lower bound; `no_slip` of them)."""
    first = c["slip"] & ~np.r_[False, c["slip"][:-1]]
    win = c["window"]
    t1 = np.full(int(win.max()) + 1, np.inf)
    np.minimum.at(t1, win[first], (c["t"] - c["start_time"])[first])
    at = np.flatnonzero(np.r_[True, win[1:] != win[:-1]])  # each window's first sample
    end = np.zeros_like(t1)
    np.maximum.at(end, win, c["t"] - c["start_time"])
    stuck = ~np.isfinite(t1[win[at]])  # no slip of the model in the window: its end, at least
    if not at.size:
        return {}
    dt = np.where(stuck, end[win[at]], t1[win[at]]) - c["stick_time"][at]
    climb = c["speed"][at] * dt  # mm
    return {"quartiles_ms": [float(1e3 * q) for q in np.percentile(dt, (25, 50, 75))],
            "late": float(np.mean(dt > 0)), "deflection_um": float(1e3 * np.median(climb)),
            "mu_0": float(np.median(c["stiffness"][at] * climb / c["weight"][at])),
            "cycles": int(dt.size), "no_slip": int(stuck.sum())}


def _words(phase, share, forms, rest, delay) -> str:
    """The phase and its forms in words (module doc)."""
    said = {
        "level": lambda f: (f"a level that differs from cycle to cycle (RMS "
                            f"{f['rms_between_cycles_um']:.3g} um between cycles, from "
                            f"{f['range_um'][0]:.3g} to {f['range_um'][1]:.3g} um)"),
        "ramp": lambda f: (f"a residual linear in {_CLOCK[phase]} within each cycle "
                           f"(slope {f['slope_median_um_s']:.3g} um/s, median; quartiles "
                           f"{f['slope_quartiles_um_s'][0]:.3g} to "
                           f"{f['slope_quartiles_um_s'][1]:.3g} um/s; one sign in "
                           f"{100 * f['same_sign']:.0f} % of the cycles)"),
        "oscillation": lambda f: (f"an oscillation at {f['frequency_hz']:.3g} Hz (amplitude "
                                  f"{f['amplitude_um']:.3g} um)")}
    top = max(forms, key=lambda f: f["share"])
    named = [top] + [f for f in forms if f is not top and f["share"] >= WORTH]
    q = delay.get("quartiles_ms")
    late = ("" if phase != "breakaway" or not q else
            f"; the model breaks away later than the record in {100 * delay['late']:.0f} % "
            f"of the {delay['cycles']} cycles, {delay['no_slip']} of them not within the "
            f"window (counted at its end) (delay {q[1]:.3g} ms, median; quartiles "
            f"{q[0]:.3g} to {q[2]:.3g} ms; at the drive speed {delay['deflection_um']:.3g} um "
            f"of deflection, a static friction mu_0 off by {delay['mu_0']:.2g})")
    return (f"The misfit left sits in the {phase} phases ({100 * share:.0f} % of the excess "
            f"over the noise{late}): mostly " + "; then ".join(
                f"{said[f['name']](f)}, {100 * f['share']:.0f} % of it" for f in named)
            + f"; {100 * max(rest, 0.0):.0f} % is left by these forms"
            + (" (irregular from cycle to cycle or shaped within the phase)."
               if rest >= WORTH else "."))


def misfit_left(model, z, r, sd, noise: float, use, samples=None, shape=None,
                sensor: bool = False) -> MisfitLeft:
    """The misfit the model leaves at `z` (whitened residuals `r`, standard errors `sd` mm,
    over `use`; `samples`: what each stands for), by phase and form (module doc)."""
    c = coordinates(model, z, r, sd, shape, sensor)
    o = c["order"]
    e = (np.asarray(r) * np.asarray(sd))[o]
    w = (np.ones(e.size) if samples is None else np.asarray(samples.count, float)[o])
    w = w * np.asarray(use, bool)[o]
    s = c["t"] - c["start_time"]
    to_break = c["stick_time"] - s
    tail = c["stick"] & (to_break <= TAIL * c["stick_time"])  # and past it, stuck on
    since = c["t"] - c["t"][np.maximum.accumulate(np.where(
        c["slip"] & ~np.r_[False, c["slip"][:-1]], np.arange(e.size), 0))]
    phases = {"stick": (c["stick"] & ~tail, s), "breakaway": (tail, -to_break),
              "slip": (~c["stick"], since)}
    ex = {k: max(float(np.sum(w[on] * e[on] ** 2) - np.sum(w[on]) * noise ** 2), 0.0)
          for k, (on, _) in phases.items()}
    total = max(sum(ex.values()), 1e-300)
    rms = {k: float(np.sqrt(np.sum(w[on] * e[on] ** 2) / max(np.sum(w[on]), 1e-300)))
           for k, (on, _) in phases.items()}
    phase = max(ex, key=ex.get)
    on, clock = phases[phase]
    on = on & (w > 0)
    forms, fit = _forms(clock[on], c["window"][on], c["t"][on], c["record"][on], e[on],
                        w[on], ex[phase])
    rest, delay = 1.0 - sum(f["share"] for f in forms), _delay(c)
    return MisfitLeft(phase=phase, rms=rms, shares={k: v / total for k, v in ex.items()},
                      forms=tuple(forms), delay=delay,
                      words=_words(phase, ex[phase] / total, forms, rest, delay),
                      profile={"clock": clock[on], "residual": e[on], "fit": fit,
                               "cycle": c["window"][on], "clock_words": _CLOCK[phase]})
