"""The tuning of the per-cycle discovery (`cycle_workflow.discover_cycles`) in one place.

`DiscoveryOptions` holds every threshold, budget and start of the stages; `DEFAULTS` is
the tuning the README's rates were measured with. Each field's comment says what it does
and which measurement set it. The module-level upper-case names are the same values
(`MISFIT`, `JOINT`, ...), for the documentation and doctests that quote them.
"""

from __future__ import annotations

import dataclasses

__all__ = ["DEFAULTS", "DiscoveryOptions"]


@dataclasses.dataclass(frozen=True)
class DiscoveryOptions:
    """Thresholds, budgets and starts of `discover_cycles` (module doc)."""

    # -- the call's choices (`discover_cycles` keywords) --
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
    # contender's chi2 drop / winner's from which it is comparable (drifts vs screw: 0.59-0.60)
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

    # -- re-weighing (stage 6) --
    # continuations of the winner while the records weighed by their scatter weigh fully again
    reweigh_rounds: int = 3
    # a round is kept if the described gap stays within this factor (Stribeck 0.16 on C: +52 %)
    reweigh_tolerance: float = 1.02


DEFAULTS = DiscoveryOptions()

MISFIT = DEFAULTS.misfit
"""Base chi2/n above which every family is refitted (`discover_cycles`, stage 4)."""
RELEVANT = DEFAULTS.relevant
"""A family whose predicted chi-square drop is at least this fraction of the samples is
significant on the per-sample score test alone (`discover_cycles`, stage 3)."""
DRIVE_PRIOR = DEFAULTS.drive_prior
"""mm: prior standard deviation of every screw-error coefficient (a lead screw's error is
microns; a record that travels less than a pitch cannot bound its coefficients alone,
and without the prior draws a smooth curve with huge coefficients of opposite sign)."""
SCREW_AMPLITUDE_MAX = DEFAULTS.screw_amplitude_max
"""mm: largest amplitude of either harmonic of the screw error in any record (a record
shorter than a pitch cannot separate its coefficients; on a clean campaign of the
independent generator a 63 um second harmonic there made a screw error out of noise,
named with high confidence, when only long records were bounded)."""
SCREW_SPREAD = DEFAULTS.screw_spread
"""Largest ratio of the screw error's amplitudes between records (`_one_screw`)."""
SENSOR_PROBE = DEFAULTS.sensor_probe
"""Smallest probe time constant of the sensor's secant score, in its scale (1 ms)."""
SENSOR_PROBES = DEFAULTS.sensor_probes
"""Probe time constants (ms) of the sensor's secant score: the sensor changes the traces
at second order in tau and its kernels ring, so one short secant misjudges a slow
sensor; the probe that lowers chi-square most at the base parameters gives the secant,
and its refit starts there (the look-elsewhere is counted in the Bonferroni level)."""
EXPONENTS = DEFAULTS.exponents
"""Range of the exponents m and n (eqs 1 and 3) at the base fit's start."""
MU_D_FLOOR, MU_D_LIFT = DEFAULTS.mu_d_floor, DEFAULTS.mu_d_lift
"""A restart's kinetic friction mu_d below MU_D_FLOOR x mu_s starts at MU_D_LIFT x mu_s
(`lift_mu_d`)."""
RECORD_CHI2 = DEFAULTS.record_chi2
"""A record whose base chi2/n exceeds this and 3x the campaign's median weighs by its own
scatter (its standard errors scaled by sqrt(chi2/n)), or beyond SET_ASIDE_CHI2 is set
aside; reported in `records_scaled`."""
SET_ASIDE_CHI2 = DEFAULTS.set_aside_chi2
"""A record whose base chi2/n exceeds this and this times the campaign's median (its
residual RMS over 3x the noise) is set aside from the base fit, the gaps and the tests;
one between RECORD_CHI2 and this weighs by its own scatter and stays in the tests (a
2 um screw error on lubricant C made its fastest record chi2/n 3.0: the evidence)."""
SET_ASIDE = DEFAULTS.set_aside
"""A record set aside (SET_ASIDE_CHI2) has its standard errors scaled by this times
sqrt(chi2/n): it weighs 1/900 of its own scatter (it stays in the arrays, and the
re-weighing after a named effect tries it at full weight again)."""
SMALL_EXCESS = DEFAULTS.small_excess
"""Excess chi2/n of the base fit below which no unexplained residual is reported."""
JOINT = DEFAULTS.joint
"""A contender whose refit lowers chi-square by at least this fraction of the winner's
drop explains a comparable share of the residual (`decide`). Measured on the independent
campaigns (README): the drift families that share one direction with the screw error
(cosine 0.97-0.998) lower it by 0.59-0.60 of the winner's drop; the slip-shape families
on the Stribeck campaign by 0.54-0.78 of the sensor's."""
COLLINEAR = DEFAULTS.collinear
"""Principal cosine of the efficient-score directions above which two families change
the traces in nearly the same way (`decide`)."""
CLEAR = DEFAULTS.clear
"""The winner beats a contender clearly when its advantage in the paired window test
(`paired_z`) is at least this many standard errors (one-sided p 0.0013 each: over the
up to 8 contenders of a campaign, a chance "clear" win over an equally good family
stays near 1 %)."""
REFINE_GAP = DEFAULTS.refine_gap
"""Far from the data, a named family whose refit leaves a gap above this many times the
noise gets its shape refined (`cycle_effects.neighbour_shapes`)."""
REWEIGH_ROUNDS = DEFAULTS.reweigh_rounds
"""Continuations of the winner's fit while records weighed by their scatter at the base
are tried at full weight (`discover_cycles`)."""
REWEIGH_TOLERANCE = DEFAULTS.reweigh_tolerance
"""A re-weighing round is kept only if the gap over the records of the gap before (those
not set aside at the base) stays within this factor: a record that the named effect does
not describe bends the shared parameters away from the others when it weighs fully
(measured: a Stribeck drop of 0.16 on C named rate_state, and re-weighing a record set
aside raised that gap 0.604 -> 0.92 um). Records weighed by their scatter count in that
gap: re-weighed, a 15 um screw error on A went 1.63 -> 1.16x the noise while the records
weighed fully throughout rose 14 % in chi-square."""
REFINE_FITS = DEFAULTS.refine_fits
"""Short refits (`refit_evals` evaluations each) the shape refinement may spend."""
REFINE_CONTENDERS = DEFAULTS.refine_contenders
"""Far from the data, the physical refits (best first) whose shapes are refined before
the choice when they explain at least `joint` of the best one's chi-square drop."""
RESLIP_SYSTEMATIC = DEFAULTS.reslip_systematic
"""Fraction of the complete cycle windows flagged as following a re-slip
(`RecordFeatures.slipped_on`) from which the flag is taken as a systematic lengthening of
the slips (a slow gauge, damping) and every window is kept (`discover_cycles`). Measured
on the independent generator: 1-32 % flagged on the rates and large-effect campaigns,
71 % under stick-phase creep (keeping them took its base gap from 1.6 to 32x the noise),
73 % and 100 % under 20 Hz sensors (the second was refused for want of windows)."""
PHASE_CHI2 = DEFAULTS.phase_chi2
"""A phase (stick, slip) whose residuals over their own standard errors have a chi2/n
above this is not explained: "none" is then given with "low" confidence."""
LARGE_STARTS = DEFAULTS.large_starts
"""Far from the data (a misfit base), the refit of a family whose first parameter is
one-sided (damping c, Stribeck b, rate-and-state a) also starts with that parameter at
these fractions of its bound: from zero, a large effect's refit ran out of evaluations
near zero (measured: a Stribeck drop b = 0.1 of the independent generator, refitted to
b = -3e-6 from zero and to 0.10 from 0.05)."""
