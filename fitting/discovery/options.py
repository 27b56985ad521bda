"""The tuning of the per-cycle discovery in one place: `DiscoveryOptions` (each field's
comment says what it does and which measurement set it); `DEFAULTS`, the tuning the
README's rates were measured with.
"""

from __future__ import annotations

import dataclasses

__all__ = ["DEFAULTS", "DiscoveryOptions", "at_least"]


def at_least(name: str, value, low) -> None:
    """A ValueError naming the option `name` and its smallest value unless `value` >= `low`
    (the discovery bases check their options with it; the command names them --name)."""
    if not value >= low:
        raise ValueError(f"{name}: must be at least {low}, got {value}")


@dataclasses.dataclass(frozen=True)
class DiscoveryOptions:
    """Thresholds, budgets and starts of the per-cycle discovery (module doc)."""

    # -- the call's choices --
    # how many significant families are refitted first (stage 4)
    top: int = 3
    # family-wise false-alarm rate of the whole ranking (stage 3)
    alpha: float = 0.01
    # Levenberg-Marquardt evaluations of the base fit and continuations (2x for restarts)
    max_evals: int = 30
    # Levenberg-Marquardt evaluations of each family's refit
    refit_evals: int = 15

    # -- base fit (stage 2) --
    # base chi2/n (or gap/noise) above which the base is far from the data: every family refitted
    misfit: float = 1.5
    # range of exponents m, n (eqs 1, 3) at the start (real records: m -> 0, n 1e116, no slip ended)
    exponents: tuple[float, float] = (0.02, 5.0)
    # a restart's mu_d below this x mu_s is lifted (Stribeck 0.2 on A drove mu_d to 1e-13)
    mu_d_floor: float = 0.1
    # ... to this x mu_s (mu_s kept)
    mu_d_lift: float = 0.4
    # record chi2/n above this and this x the median: weighs by its scatter (`fit.RECORD_CHI2`)
    record_chi2: float = 3.0
    # ... above this and this x the median: set aside (2 um screw on C gave chi2/n 3.0: evidence)
    set_aside_chi2: float = 10.0
    # a set-aside record's errors x this x sqrt(chi2/n): it weighs 1/900 of its own scatter
    set_aside: float = 30.0
    # excess chi2/n below which no gap is unexplained (the weights' approximations on clean data)
    small_excess: float = 0.05
    # re-slip share from which all windows are kept (20 Hz sensors: 73-100 %; rates: 1-32 %)
    reslip_systematic: float = 0.9

    # -- ranking (stage 3) --
    # predicted chi2 drop (share of samples) significant on the per-sample score test alone
    relevant: float = 0.01
    # smallest probe time constant of the sensor's secant score (its scale: 1 ms)
    sensor_probe: float = 1.0
    # probe time constants (ms) of the sensor's secant (one short secant misjudged a slow sensor)
    sensor_probes: tuple[float, ...] = (1.0, 2.5, 6.0, 15.0)

    # -- refits (stage 4) --
    # mm: prior sd of screw coefficients (a record under a pitch drew huge opposite coefficients)
    drive_prior: float = 0.01
    # mm: largest screw harmonic amplitude (a 63 um harmonic of noise was named on clean records)
    screw_amplitude_max: float = 0.05
    # largest ratio of the screw error's amplitudes between records (`_one_screw`)
    screw_spread: float = 3.0
    # a one-sided first parameter also starts at these shares of its bound (Stribeck b 0.1)
    large_starts: tuple[float, ...] = (0.1, 0.3)
    # short refits the shape refinement may spend
    refine_fits: int = 12
    # refits whose shapes are refined before the choice (rational Stribeck lost to a screw on C)
    refine_contenders: int = 3
    # a fit leaving a gap above this x the noise is refined, restarted (Stribeck 0.2 on A: 18.5x)
    refine_gap: float = 1.15

    # -- decision (stage 5) --
    # contender's chi2 drop / winner's from which it is comparable, and a later effect must beat
    # it clearly (drifts vs screw: 0.59-0.60; Stribeck vs load coupling: 0.54)
    joint: float = 0.5
    # principal cosine above which two families change the traces in nearly the same way
    collinear: float = 0.9
    # paired z from which the winner beats a contender clearly (p 0.0013; ~1 % over 8 contenders)
    clear: float = 3.0
    # share of the excess chi2 a named effect must remove to explain the gap (else unexplained)
    explained_share: float = 0.5
    # gap after / noise at or below which the named effect explains the gap ("high" confidence)
    explained_gap: float = 1.15
    # a phase's chi2/n (residuals over their own standard errors) above which "none" is "low"
    phase_chi2: float = 2.0

    # share of the excess chi2 a later effect must remove to be named (real records: irrelevant
    # ones removed 0.8 % and 1.8 %; the second effect of 4-record pair campaigns 5.1-44 %)
    later_share: float = 0.03

    # -- re-weighing (stage 6) --
    # continuations of the winner while the records weighed by their scatter weigh fully again
    reweigh_rounds: int = 3
    # a round is kept if the described gap stays within this factor (Stribeck 0.16 on C: +52 %)
    reweigh_tolerance: float = 1.02

    def __post_init__(self):
        at_least("top", self.top, 1)
        at_least("max_evals", self.max_evals, 2)
        if not 0 < self.alpha < 1:
            raise ValueError(f"alpha: must be between 0 and 1, got {self.alpha}")


DEFAULTS = DiscoveryOptions()
