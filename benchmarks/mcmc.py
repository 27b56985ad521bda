"""Benchmark: `stickslip mcmc --objective trace` on the shipped campaign (data/examples).

Ours: the trace fit (features first), then emcee on the vectorised, compiled trace
log-posterior (`stickslip_fitting.uncertainty.mcmc.run_mcmc`), cold (compilation included) and warm. Printed:
every parameter's median, 95 % interval and whether it contains the truth
(data/examples/truth.json), the autocorrelation time and effective sample size, and the
time to reach >= 1000 effective samples of every parameter (target: < 3 min).

Baseline (same process): the same emcee run with the log-likelihood a SciPy user would
write, the NumPy model with the slip in closed form (benchmarks/scipy_reference.py,
`slip="closed_form"`), the same frozen standard errors and tempering, evaluated walker by
walker. Its chain is run for `--baseline-steps` steps only and its time per step
extrapolated to our number of steps (said so in the table): the full chain would take
tens of minutes.

    python benchmarks/mcmc.py [--steps 3000] [--walkers 32] [--baseline-steps 5]
"""

from __future__ import annotations

import argparse
import glob
import os
import pathlib
import sys
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--walkers", type=int, default=32)
    ap.add_argument("--baseline-steps", type=int, default=5)
    args = ap.parse_args()

    import emcee
    import jax
    import jax.numpy as jnp

    from stickslip_fitting.data.campaign import find_truth
    from stickslip_fitting.modes import Objective
    from stickslip_fitting.solve.fit import fit_records
    from stickslip_fitting.uncertainty.mcmc import likelihood_scale, run_mcmc
    from stickslip_fitting.objectives.trace import trace_sd
    from scipy_reference import reference_windows, scipy_trace_residuals
    from stickslip_jax.records import read_record

    paths = sorted(glob.glob(str(HERE.parent / "data" / "examples" / "*.csv")))
    recs = [read_record(p) for p in paths]
    truth = find_truth(recs)

    t0 = time.perf_counter()
    fit = fit_records(recs, objective=Objective.TRACE)
    t_fit = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = run_mcmc(fit, walkers=args.walkers, steps=args.steps, seed=0)
    t_cold = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = run_mcmc(fit, walkers=args.walkers, steps=args.steps, seed=0)
    t_warm = time.perf_counter() - t0

    # baseline: NumPy closed-form log-likelihood, walker by walker (emcee's default)
    obj = fit.objective
    tdata = obj.trace_data()
    windows = reference_windows(tdata)
    sd = np.asarray(trace_sd(fit.params, tdata, jnp.zeros(tdata.mask.shape)))
    scale = likelihood_scale(fit)
    w_t = 1.0  # the trace objective alone (objective "trace")
    names = list(fit.params.friction.NAMES)

    def log_prob(theta):
        v = np.exp(theta)
        if not v[0] > v[1]:
            return -np.inf
        r = scipy_trace_residuals(v, windows, sd, slip="closed_form")
        return -0.5 * w_t * float(r @ r) / scale

    theta0 = np.log(np.asarray(fit.params.friction.values()))
    rng = np.random.default_rng(0)
    p0 = theta0 + 1e-4 * rng.standard_normal((args.walkers, theta0.size))
    sampler = emcee.EnsembleSampler(args.walkers, theta0.size, log_prob)
    t0 = time.perf_counter()
    sampler.run_mcmc(p0, args.baseline_steps)
    t_base_step = (time.perf_counter() - t0) / args.baseline_steps
    t_base = t_base_step * args.steps

    summ = res.summary()
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"campaign: data/examples ({len(recs)} records); trace fit {t_fit:.1f} s incl. "
          f"compilation; {args.walkers} walkers x {args.steps} steps (burn-in {res.burn}); "
          f"likelihood chi2 / {res.likelihood_scale:.3g}; load {load} on {os.cpu_count()} CPUs; "
          f"jax {jax.__version__}")
    head = (f"{'parameter':<10}{'median':>11}{'95 % interval':>26}{'truth':>10}{'in':>5}"
            f"{'tau':>8}{'ESS':>9}")
    print(head)
    print("-" * len(head))
    contained = []
    for n in names:
        if n not in summ:
            continue
        s = summ[n]
        inside = s["ci95"][0] <= truth[n] <= s["ci95"][1]
        contained.append(inside)
        ci = f"[{s['ci95'][0]:.4g}, {s['ci95'][1]:.4g}]"
        print(f"{n:<10}{s['median']:>11.5g}{ci:>26}{truth[n]:>10.4g}"
              f"{'yes' if inside else 'NO':>5}{s['tau_steps']:>8.1f}{s['ess']:>9.0f}")
    ess_min = min(s["ess"] for s in summ.values())
    # time to 1000 effective samples: the chain's cost per step, times the steps that
    # ESS 1000 needs at the measured autocorrelation time (burn-in included)
    per_step_warm = t_warm / args.steps
    need = 1000.0 / ess_min * (args.steps - res.burn) + res.burn
    t_1000 = per_step_warm * need
    print()
    print(f"{'step':<80}{'time [s]':>10}")
    for label, t in [
        ("ours: mcmc incl. compilation (after the fit)", t_cold),
        ("ours: mcmc compiled", t_warm),
        ("ours: fit + mcmc, cold", t_fit + t_cold),
        (f"baseline: NumPy closed-form emcee, {args.baseline_steps} steps measured, "
         f"x {args.steps} (extrapolated)", t_base),
    ]:
        print(f"{label:<80}{t:>10.2f}")
    print(f"ratio baseline / ours: warm {t_base / t_warm:.1f}x, cold "
          f"{t_base / t_cold:.1f}x (baseline extrapolated from {args.baseline_steps} steps)")
    print(f"smallest ESS {ess_min:.0f}; time to >= 1000 effective samples of every parameter "
          f"(warm, at the measured tau): {t_1000:.1f} s; with the fit and compilation: "
          f"{t_fit + t_cold - t_warm + t_1000:.1f} s; target < 180 s: "
          f"{'met' if t_fit + t_cold - t_warm + t_1000 < 180 else 'MISSED'}")
    print(f"95 % intervals containing the truth: {sum(contained)} of {len(contained)}")
    for w in res.warnings:
        print("warning: " + w)


if __name__ == "__main__":
    main()
