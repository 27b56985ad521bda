"""Benchmark: campaign fit (optimistix Levenberg-Marquardt) vs SciPy least_squares with finite
differences (on the same residuals, and on a NumPy/SciPy model of the trace), and emcee
effective samples per second.

Campaign: 12 records like the simulators benchmark (3 (W, k) pairs x 4 drive speeds,
lubricant A, exact simulator, noise 0.5 um, 1 kHz) but with three different k/W (Table 1's
pairs share one k/W, so n would not be identifiable), 15 cycles each: about 0.5 M samples.

What is timed, in one process (every "incl. compilation" figure starts from empty JAX
caches, `jax.clear_caches()`, no persistent compilation cache; best of `--repeat`
rounds because the machine is shared):

1. the features fit: our 12-start fit (`fit_features`), and SciPy `least_squares`
   (trust-region reflective, 2-point finite differences, `x_scale="jac"`) on the same
   jitted residual function from the same 12 starts, with the same reweighting rounds
   (effective-variance weights frozen per round at the previous optimum) and tolerances
   of the same size (SciPy xtol = ftol = gtol = 1e-10; ours rtol = atol = 1e-10 on the
   step and on the change of every residual; the criteria differ, the optima agree);
2. the trace fit (every sample through the exact simulator, restarted per cycle): ours
   (`Objective.TRACE`: features fit first, then LM on the trace) and SciPy on the same
   jitted trace residuals from the same start (our features optimum), same rounds,
   tolerances 1e-8 (ours: root mean square of the step and of the residual change);
   then the SciPy-native trace part: the same SciPy `least_squares` on residuals of a
   NumPy/SciPy model (`benchmarks/scipy_reference.py`: brentq for the breakaway,
   solve_ivp DOP853 rtol 1e-12 for each slip, every cycle window simulated once), same start,
   rounds and tolerances, the weights of each round from our `trace_sd` (outside the
   residual function); then the same again with the slips in closed form
   (`slip="closed_form"`: NumPy, no ODE solver, brentq for the breakaway); plus the
   combined objective ("both"), ours only; what the cold trace fit compiles (its programs
   and the seconds of tracing, lowering and XLA compilation, from JAX's monitoring
   events: `compile_census`);
3. the same fits from the cache folder of the `stickslip` command (on by default: JAX's
   persistent compilation cache and the stored programs, `stickslip_jax.stored_programs`):
   the folder filled once, then the in-memory caches and loaded programs dropped and the
   fits timed again: loading the stored programs, no tracing and no XLA compilation (a
   later process on a campaign of the same layout);
4. the main job, `stickslip fit -q data/examples/*.csv` in a new process (imports
   included): from an empty cache folder, then again from the filled one (`--no-cli`
   leaves it out);
5. emcee (`stickslip_fitting.uncertainty.mcmc.run_mcmc`, 32 walkers): minimum effective sample size over the
   parameters per second, after compilation.

Three SciPy baselines. The strict one: SciPy's residual functions are jitted JAX (the
same model and residuals, compiled with the XLA options of our solves,
`stickslip_fitting.solve.fit.COMPILER_OPTIONS`, so the comparison is optimiser + derivatives); their
compilation is reported separately and included in the "SciPy incl. compilation"
figures. The SciPy-native one (trace part): what a SciPy user would write for a general
slip law, the model in NumPy/SciPy (it agrees with the exact simulator to about 1e-13 mm, see
tests/test_scipy_reference.py); its whole trace fit is the strict SciPy features fit
plus the SciPy-native trace part (the features residual is tiny). The SciPy
closed-form one: the SciPy-native model with the slip's closed form instead of solve_ivp,
a fast NumPy version of this model (the exact simulator uses the same closed form);
its whole trace fit is again the strict features fit plus its trace part. The chi2 and
parameters of the optima are printed so that it can be seen they solve the same problem.

Usage: python benchmarks/fit.py [--small] [--repeat N] [--no-cli] [--no-native]
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from functools import partial

import numpy as np


class Timed(float):
    """A wall time [s] with the CPU time [s] of this process (every thread) beside it, `cpu`:
    on a machine shared with other jobs the CPU time varies less than the wall time."""

    def __new__(cls, wall, cpu):
        t = super().__new__(cls, wall)
        t.cpu = cpu
        return t


def best_of(fn, repeat, clear=False):
    """(best wall time as a `Timed`, last result) of `repeat` calls; `clear`: empty JAX's
    caches first."""
    import jax

    times, out = [], None
    for _ in range(repeat):
        if clear:
            jax.clear_caches()
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        times.append(Timed(time.perf_counter() - t0, time.process_time() - c0))
    return min(times), out


COMPILE_EVENTS = {"/jax/core/compile/jaxpr_trace_duration": "tracing",
                  "/jax/core/compile/jaxpr_to_mlir_module_duration": "lowering",
                  "/jax/core/compile/backend_compile_duration": "XLA"}
"""JAX's monitoring events of a compilation and the step each times."""


def compile_census(fn, repeat):
    """`best_of(fn, repeat, clear=True)` and what one of those runs compiles, from JAX's
    monitoring events (wall times): (time, result, [(program, XLA seconds)] in order,
    {step: seconds} of tracing, lowering to StableHLO and XLA's compilation); programs
    and seconds per run (the mean over the `repeat` runs)."""
    from jax import monitoring

    events = []

    def listen(event, secs, fun_name="?", **_):
        if event in COMPILE_EVENTS and events is not None:
            events.append((COMPILE_EVENTS[event], fun_name, secs))

    monitoring.register_event_duration_secs_listener(listen)
    t, out = best_of(fn, repeat, clear=True)
    found, events = events, None  # the listener stays registered, silent from here
    per_run = len([e for e in found if e[0] == "XLA"]) // repeat
    programs = [(name, secs) for step, name, secs in found if step == "XLA"][:per_run]
    steps = {step: sum(s for k, _, s in found if k == step) / repeat
             for step in COMPILE_EVENTS.values()}
    return t, out, programs, steps


def scipy_rounds(res_fn, aux_fn, y0, ref0, vel0, tol, max_rounds, round_tol, max_nfev=4000,
                 first_round=0):
    """SciPy least_squares (2-point finite differences) with the reweighting rounds of
    `stickslip_fitting.solve.fit._solve_rounds`: the weights are frozen at `ref` (and the trace's slider
    velocity `vel`) for one solve, then moved to its optimum; `max_nfev`: iterations per
    round at most (SciPy does not count the finite-difference evaluations there);
    `first_round`: rounds already done (stopping needs a second round). Returns
    (optimum, chi2, function evaluations, rounds)."""
    from scipy.optimize import least_squares

    y, ref, vel, nfev = np.asarray(y0), np.asarray(ref0), vel0, 0
    for k in range(first_round, first_round + max_rounds):
        out = least_squares(lambda v: np.asarray(res_fn(v, ref, vel)), y, method="trf",
                            jac="2-point", x_scale="jac", xtol=tol, ftol=tol, gtol=tol,
                            max_nfev=max_nfev)
        nfev += out.nfev + out.njev * y.size
        move = float(np.max(np.abs(out.x - ref)))
        y, ref, vel = out.x, out.x, aux_fn(out.x)
        if k > 0 and move < round_tol:
            break
    return y, 2.0 * out.cost, nfev, k + 1


def cached_fits(features_fit, trace_fit, repeat):
    """(features fit, trace fit) times [s] from the cache folder of the `stickslip`
    command (JAX's persistent compilation cache and the stored programs,
    `stickslip_jax.stored_programs`): a temporary folder filled by one run of each, then
    every in-memory cache and loaded program dropped before each timed run (loading
    remains, as in a later process); both are turned off again afterwards."""
    import jax
    from jax.experimental.compilation_cache import compilation_cache

    from stickslip_jax import stored_programs

    def later_process(fit):
        def run():
            stored_programs.use(os.path.join(folder, "programs"))  # drops the loaded ones
            return fit()
        return run

    with tempfile.TemporaryDirectory() as folder:
        jax.config.update("jax_compilation_cache_dir", folder)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
        compilation_cache.reset_cache()
        jax.clear_caches()
        later_process(trace_fit)()  # fills it (the trace fit starts with the features solve)
        t_feat, _ = best_of(later_process(features_fit), repeat, clear=True)
        t_trace, _ = best_of(later_process(trace_fit), repeat, clear=True)
        stored_programs.use(None)
        jax.config.update("jax_compilation_cache_dir", None)
        compilation_cache.reset_cache()
    return t_feat, t_trace


def cli_main_job():
    """Times [s] of `stickslip fit -q data/examples/*.csv` in new processes (`Timed`: wall
    and the process's CPU time): from an empty persistent cache folder, then from the
    filled one (best of two)."""
    import resource
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    files = sorted(os.path.join(root, "data", "examples", f)
                   for f in os.listdir(os.path.join(root, "data", "examples"))
                   if f.endswith(".csv"))
    cmd = [sys.executable, "-m", "stickslip_jax.cli", "fit", "-q", *files]
    times = []
    with tempfile.TemporaryDirectory() as folder:
        env = dict(os.environ, STICKSLIP_CACHE_DIR=folder)
        for _ in range(3):
            t0 = time.perf_counter()
            c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            subprocess.run(cmd, env=env, check=True, capture_output=True)
            c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            times.append(Timed(time.perf_counter() - t0, c1.ru_utime - c0.ru_utime
                               + c1.ru_stime - c0.ru_stime))
    return times[0], min(times[1:])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--small", action="store_true", help="quick smoke run (fewer samples/steps)")
    ap.add_argument("--repeat", type=int, default=2, help="rounds per timing (best counts)")
    ap.add_argument("--no-cli", action="store_true", help="leave out the stickslip fit runs")
    ap.add_argument("--no-native", action="store_true",
                    help="leave out the SciPy-native (solve_ivp) trace fit, the slowest part")
    args = ap.parse_args()

    import equinox as eqx
    import jax
    import jax.numpy as jnp
    from jax.flatten_util import ravel_pytree

    import stickslip_jax as ss
    from stickslip_fitting.solve import fit as fit_module
    from stickslip_fitting.data.features import record_features
    from stickslip_fitting.solve.fit import fit_features, initial_guesses
    from stickslip_fitting.uncertainty.mcmc import run_mcmc
    from stickslip_fitting.modes import Objective
    from stickslip_fitting.objectives.cycle_features import feature_residuals
    from stickslip_fitting.params import CampaignParams, free_spec
    from stickslip_fitting.data.synthetic import synthetic_campaign, truth_values
    from stickslip_fitting.objectives.trace import trace_data, trace_residuals_and_flags

    fr = ss.lubricant("A")
    cycles = 3 if args.small else 15
    recs = synthetic_campaign(fr, speed_fractions=(0.02, 0.05, 0.15, 0.4), cycles=cycles, seed=0)
    n_samples = sum(r.n_samples for r in recs)
    R = args.repeat

    t_feat, feats = best_of(lambda: [record_features(r) for r in recs], R)

    # 1. features fit: ours vs SciPy, same starts, same rounds
    t_fit_first, fit = best_of(lambda: fit_features(feats), R, clear=True)
    t_fit_again, fit = best_of(lambda: fit_features(feats), max(R, 3))
    data = fit.data
    starts = [CampaignParams(s, jnp.zeros(len(feats))) for s in initial_guesses(feats)]
    spec = free_spec(starts[0])
    _, static = eqx.partition(starts[0], spec)
    _, unravel = ravel_pytree(eqx.partition(starts[0], spec)[0])

    def params_of(v):
        return eqx.combine(unravel(v), static)

    # the data go in as arguments (closed-over arrays would be constant-folded by XLA)
    # compiled with the options of our solves (fit_module.COMPILER_OPTIONS): the same
    # machine code for the residuals on both sides
    fres_jit = jax.jit(lambda v, ref, data: feature_residuals(params_of(v), data,
                                                              weights_at=params_of(ref)),
                       compiler_options=fit_module.COMPILER_OPTIONS)

    def fres(v, ref):
        return fres_jit(v, ref, data)

    flat_starts = [np.asarray(ravel_pytree(eqx.partition(p, spec)[0])[0]) for p in starts]

    def scipy_features():
        # our multi-start strategy (`stickslip_fitting.solve.fit._solve_rounds`): every start screened
        # for SCREEN_ROUNDS rounds of at most SCREEN_STEPS iterations, then the
        # POLISH_STARTS best polished with the full budget
        res = (lambda v, ref, _: fres(v, ref))
        screened, nfev = [], 0
        for v0 in flat_starts:
            try:
                y, chi2, n, _ = scipy_rounds(res, lambda v: None, v0, v0, None, 1e-10,
                                             fit_module.SCREEN_ROUNDS, np.inf,
                                             max_nfev=fit_module.SCREEN_STEPS, first_round=-1)
            except ValueError:  # a round starts where a residual is not finite: SciPy
                continue        # stops there (ours screens such a start out)
            screened.append((chi2, y))
            nfev += n
        best = None
        for chi2, y0 in sorted(screened, key=lambda c: c[0])[:fit_module.POLISH_STARTS]:
            y, chi2, n, rounds = scipy_rounds(res, lambda v: None, y0, y0, None, 1e-10,
                                              fit_module.MAX_ROUNDS, fit_module.ROUND_TOL,
                                              first_round=fit_module.SCREEN_ROUNDS)
            nfev += n
            if best is None or chi2 < best[1]:
                best = (y, chi2, rounds)
        return best, nfev

    def compile_features():
        fres(flat_starts[0], flat_starts[0]).block_until_ready()

    t_sp_feat_compile, _ = best_of(compile_features, R, clear=True)
    t_sp_feat, ((sp_y, sp_chi2, sp_rounds), sp_nfev) = best_of(scipy_features, R)
    sp_vals = np.asarray(params_of(sp_y).friction.values())
    feat_dev = float(np.max(np.abs(sp_vals / np.asarray(fit.params.friction.values()) - 1)))

    # 2. trace fit: ours (features first + trace) vs SciPy from the same start
    trace, both = (dict(objective=o, records=recs) for o in (Objective.TRACE, Objective.BOTH))
    t_tr_first, tfit, tr_programs, tr_steps = compile_census(
        lambda: fit_features(feats, **trace), R)
    t_tr_again, tfit = best_of(lambda: fit_features(feats, **trace), max(R, 3))
    t_both_first, bfit = best_of(lambda: fit_features(feats, **both), 1, clear=True)
    t_fit_cached, t_tr_cached = cached_fits(lambda: fit_features(feats),
                                            lambda: fit_features(feats, **trace), R)
    tdata = trace_data(recs, feats)
    tstart = np.asarray(ravel_pytree(eqx.partition(fit.params, fit.spec)[0])[0])

    @partial(jax.jit, compiler_options=fit_module.COMPILER_OPTIONS)
    def tjit_data(v, ref, vel, tdata):
        r, _, vel_v = trace_residuals_and_flags(params_of(v), tdata, weights_at=params_of(ref),
                                                slider_velocity=vel)
        return r, vel_v

    def tjit(v, ref, vel):
        return tjit_data(v, ref, vel, tdata)

    vel0 = jnp.zeros(tdata.mask.shape)

    def tres(v, ref, vel):  # residuals (the slider velocity stays on the device)
        return tjit(v, ref, vel)[0]

    def tvel(v):  # slider velocity at v, for the next round's weights
        return tjit(v, v, vel0)[1]

    def compile_trace():
        tres(tstart, tstart, vel0).block_until_ready()

    t_sp_tr_compile, _ = best_of(compile_trace, R, clear=True)
    t_eval, _ = best_of(lambda: tres(tstart, tstart, vel0).block_until_ready(), 5)
    t_sp_tr, (sp_ty, sp_tchi2, sp_tn, sp_trounds) = best_of(
        lambda: scipy_rounds(tres, tvel, tstart, tstart, vel0, 1e-8, fit_module.MAX_ROUNDS,
                             fit_module.ROUND_TOL), R)
    sp_tvals = np.asarray(params_of(sp_ty).friction.values())
    tr_dev = float(np.max(np.abs(sp_tvals / np.asarray(tfit.params.friction.values()) - 1)))

    # 2b. SciPy-native trace part: least_squares on residuals of the NumPy/SciPy model
    # (scipy_reference.py: brentq + solve_ivp, each cycle window simulated once), same
    # start, rounds and tolerances; the weights are frozen per round by our trace_sd at the
    # previous optimum (its slider velocity from the SciPy model; the first round: 0)
    from stickslip_fitting.objectives.trace import trace_sd
    from scipy_reference import (reference_windows, scipy_trace_residuals,
                                 scipy_trace_simulation, values_from_free)

    if tstart.size != 6:
        raise ValueError("the SciPy-native trace fit expects the 6 friction parameters free")
    windows = reference_windows(tdata)  # converted to NumPy once

    def native_fit(slip):
        """SciPy least_squares on the NumPy/SciPy model with slips by `slip` ("ode" or
        "closed_form"): (time, evaluation time, (optimum, chi2, evaluations, rounds),
        largest relative parameter difference to ours)."""
        def native_sd(v, velocity=None):  # once per round: JAX allowed
            if velocity is None:
                velocity = scipy_trace_simulation(values_from_free(v), windows, slip=slip)[1]
            return np.asarray(trace_sd(params_of(jnp.asarray(v)), tdata,
                                       jnp.asarray(velocity)))

        def native_res(v, ref, sd):  # NumPy/SciPy only
            return scipy_trace_residuals(values_from_free(v), windows, sd, slip=slip)

        sd0 = native_sd(tstart, np.zeros(tdata.mask.shape))
        t_eval, _ = best_of(lambda: native_res(tstart, tstart, sd0), 3)
        t, out = best_of(lambda: scipy_rounds(native_res, native_sd, tstart, tstart, sd0, 1e-8,
                                              fit_module.MAX_ROUNDS, fit_module.ROUND_TOL), R)
        dev = float(np.max(np.abs(values_from_free(out[0])
                                  / np.asarray(tfit.params.friction.values()) - 1)))
        return t, t_eval, out, dev

    nan = float("nan")  # --no-native: the solve_ivp fit (minutes) left out
    t_nat, t_nat_eval, (_, nat_chi2, nat_n, nat_rounds), nat_dev = (
        (nan, nan, (None, nan, 0, 0), nan) if args.no_native else native_fit("ode"))
    t_cf, t_cf_eval, (_, cf_chi2, cf_n, cf_rounds), cf_dev = native_fit("closed_form")
    # our trace part alone: the whole trace fit minus the features fit it starts with
    t_tr_only_first = t_tr_first - t_fit_first
    t_tr_only_again = t_tr_again - t_fit_again

    truth = truth_values(fr)
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"campaign: {len(recs)} records, {n_samples} samples, "
          f"{sum(f.n_complete for f in feats)} complete cycles; load average {load} on "
          f"{os.cpu_count()} CPUs; best of {R} rounds")
    print(f"{'step':<58}{'time [s]':>10}{'CPU [s]':>10}")
    rows = [
        ("feature extraction (NumPy)", t_feat),
        ("features fit, ours: 12 starts, incl. compilation", t_fit_first),
        ("features fit, ours: compiled", t_fit_again),
        ("features fit, SciPy FD: 12 starts", t_sp_feat),
        ("   its residual's compilation", t_sp_feat_compile),
        ("trace fit, ours: features + trace, incl. compilation", t_tr_first),
        ("trace fit, ours: features + trace, compiled", t_tr_again),
        ("   trace part alone, incl. compilation", t_tr_only_first),
        ("   trace part alone, compiled", t_tr_only_again),
        ("trace part, SciPy FD from the same start", t_sp_tr),
        ("   its residual's compilation", t_sp_tr_compile),
        ("trace part, SciPy-native (NumPy/SciPy model), same start", t_nat),
        ("trace part, SciPy closed-form (NumPy model), same start", t_cf),
        ("both objectives, ours: incl. compilation", t_both_first),
        ("features fit, ours: from the cache folder", t_fit_cached),
        ("trace fit, ours: features + trace, from the cache folder", t_tr_cached),
    ]
    for name, t in rows:
        print(f"{name:<58}{t:>10.3f}{getattr(t, 'cpu', float('nan')):>10.3f}")
    print(f"features: ours {fit.n_steps} LM steps in {fit.n_rounds} rounds (best start), "
          f"chi2 {fit.chi2:.4f}; SciPy {sp_nfev} residual evaluations (12 starts), "
          f"{sp_rounds} rounds (best start), chi2 {sp_chi2:.4f}; "
          f"largest parameter difference {feat_dev:.1e}")
    print(f"trace: {tdata.n_residuals()} samples in {int(np.unique(np.asarray(tdata.window)).size)}"
          f" cycle windows, {tdata.mask.shape[0]} rows of {tdata.mask.shape[1]} "
          f"({tdata.mask.size / tdata.n_residuals():.2f}x padding); one evaluation "
          f"{t_eval * 1e3:.1f} ms")
    print(f"cold trace fit compiles {len(tr_programs)} programs ("
          + ", ".join(f"{n} {s:.2f} s" for n, s in tr_programs)
          + " in XLA): " + ", ".join(f"{k} {v:.2f} s" for k, v in tr_steps.items())
          + f" of its {t_tr_first:.2f} s (wall)")
    print(f"trace: ours {tfit.n_steps} LM steps in {tfit.n_rounds} rounds, chi2 {tfit.chi2:.3f}"
          f" (converged {tfit.converged}); SciPy {sp_tn} residual evaluations in "
          f"{sp_trounds} rounds, chi2 {sp_tchi2:.3f}; largest parameter difference "
          f"{tr_dev:.1e}; both: chi2/dof {bfit.reduced_chi2:.3f}")
    print(f"trace, SciPy-native: {nat_n} residual evaluations in {nat_rounds} rounds, one "
          f"evaluation {t_nat_eval * 1e3:.0f} ms, chi2 {nat_chi2:.3f}; largest parameter "
          f"difference to ours {nat_dev:.1e}")
    print(f"trace, SciPy closed-form: {cf_n} residual evaluations in {cf_rounds} rounds, one "
          f"evaluation {t_cf_eval * 1e3:.0f} ms, chi2 {cf_chi2:.3f}; largest parameter "
          f"difference to ours {cf_dev:.1e}")
    whole_ours, whole_ours_c = t_tr_first, t_tr_again
    whole_sp = t_sp_feat + t_sp_tr
    whole_sp_c = whole_sp + t_sp_feat_compile + t_sp_tr_compile
    print("ratios SciPy / ours (> 1: ours faster):")
    print(f"  features fit: incl. compilation (both) {(t_sp_feat + t_sp_feat_compile) / t_fit_first:.2f}x"
          f", ours incl. vs SciPy without {t_sp_feat / t_fit_first:.2f}x, "
          f"compiled {t_sp_feat / t_fit_again:.1f}x")
    print(f"  trace part: incl. compilation (both) "
          f"{(t_sp_tr + t_sp_tr_compile) / t_tr_only_first:.2f}x, compiled "
          f"{t_sp_tr / t_tr_only_again:.1f}x")
    print(f"  whole trace fit (features + trace): incl. compilation (both) "
          f"{whole_sp_c / whole_ours:.2f}x, compiled {whole_sp / whole_ours_c:.1f}x")
    print(f"  trace part vs SciPy-native: compiled {t_nat / t_tr_only_again:.1f}x, incl. our "
          f"compilation {t_nat / t_tr_only_first:.1f}x")
    print(f"  whole trace fit vs SciPy-native (SciPy FD features + SciPy-native trace): "
          f"compiled {(t_sp_feat + t_nat) / whole_ours_c:.1f}x, incl. our compilation "
          f"{(t_sp_feat + t_nat) / whole_ours:.1f}x")
    print(f"  trace part vs SciPy closed-form: compiled {t_cf / t_tr_only_again:.1f}x, incl. our "
          f"compilation {t_cf / t_tr_only_first:.1f}x")
    print(f"  whole trace fit vs SciPy closed-form (SciPy FD features + closed-form trace): "
          f"compiled {(t_sp_feat + t_cf) / whole_ours_c:.1f}x, incl. our compilation "
          f"{(t_sp_feat + t_cf) / whole_ours:.1f}x")
    sp_cpu = t_sp_feat.cpu + t_cf.cpu
    print(f"  the same in CPU time (SciPy {sp_cpu:.2f} s): compiled "
          f"{sp_cpu / whole_ours_c.cpu:.1f}x, incl. our compilation "
          f"{sp_cpu / whole_ours.cpu:.2f}x, ours from the cache folder "
          f"{sp_cpu / t_tr_cached.cpu:.2f}x")
    print(f"  whole trace fit vs SciPy closed-form, ours from the cache folder (stored "
          f"programs loaded, a later process): {(t_sp_feat + t_cf) / t_tr_cached:.1f}x; vs "
          f"SciPy strict incl. its compilation {whole_sp_c / t_tr_cached:.1f}x")
    print(f"target: a converged 6-parameter fit in < 30 s incl. compilation: "
          f"{max(t_fit_first, t_tr_first) < 30} (features {t_fit_first:.1f} s, trace "
          f"{t_tr_first:.1f} s)")
    print(">= 10x faster than the SciPy FD fit (whole trace fit), met (compiled / incl. our "
          "compilation) against:")
    for name, t_sp, t_sp_c in (
            ("SciPy-native (solve_ivp slips)", t_sp_feat + t_nat, t_sp_feat + t_nat),
            ("SciPy closed-form (NumPy slips)", t_sp_feat + t_cf, t_sp_feat + t_cf),
            ("SciPy strict (our compiled residuals)", whole_sp, whole_sp_c)):
        print(f"  {name:<40} {t_sp / whole_ours_c >= 10} / {t_sp_c / whole_ours >= 10}"
              f"  ({t_sp / whole_ours_c:.1f}x / {t_sp_c / whole_ours:.1f}x)")
    print("recovered (features):", ", ".join(f"{k}={v:.4g} (truth {truth[k]:g})"
                                            for k, v in fit.values.items()))
    print("recovered (trace):   ", ", ".join(f"{k}={v:.4g}" for k, v in tfit.values.items()))
    print(">= 3x faster than the SciPy closed-form fit (whole trace fit) incl. our "
          f"compilation: empty caches {(t_sp_feat + t_cf) / whole_ours >= 3} "
          f"({(t_sp_feat + t_cf) / whole_ours:.1f}x), from the cache folder "
          f"{(t_sp_feat + t_cf) / t_tr_cached >= 3} ({(t_sp_feat + t_cf) / t_tr_cached:.1f}x)")
    if not args.no_cli:
        t_cli_cold, t_cli_warm = cli_main_job()
        print(f"stickslip fit -q data/examples/*.csv (new process): {t_cli_cold:.1f} s wall "
              f"({t_cli_cold.cpu:.1f} s CPU) from an empty cache, {t_cli_warm:.1f} s wall "
              f"({t_cli_warm.cpu:.1f} s CPU) from the filled cache (target < 3 s: "
              f"{t_cli_warm < 3} wall, {t_cli_warm.cpu < 3} CPU); load average "
              + ", ".join(f"{x:.1f}" for x in os.getloadavg()))
    # 5. emcee (after the fit figures are printed)
    steps = 400 if args.small else 6000
    run_mcmc(fit, walkers=32, steps=20)  # compile
    t_mc, mc = best_of(lambda: run_mcmc(fit, walkers=32, steps=steps), 1)

    ess = mc.ess.min()
    print(f"emcee: 32 walkers x {steps} steps in {t_mc:.1f} s; min ESS {ess:.0f} "
          f"({ess / t_mc:.1f} effective samples/s; max tau {mc.tau.max():.0f} steps); "
          f"1000 effective samples of every parameter in {1000 / (ess / t_mc):.0f} s "
          "(target < 300 s)")
    if mc.warnings:
        print("emcee warning:", mc.warnings[0])


if __name__ == "__main__":
    main()
