"""Benchmark: campaign fit (optimistix LM, jitted multi-start) vs SciPy least_squares, and emcee ESS/s.

A 12-record campaign (3 (W, k) pairs x 4 speeds, lubricant A, noise 0.5 um, 1 kHz;
about 0.5 M samples) made by the exact simulator. Timed in one process:
1. features + our fit, including compilation (first call) and again (compiled);
2. `scipy.optimize.least_squares` (trust-region reflective, 2-point finite differences)
   on the same residual function (jitted, so SciPy pays only for its finite differences
   and iterations) from the same starting points, one after the other;
3. the trace objective (every sample through the exact simulator, restarted per cycle):
   our fit (`objective="trace"`, LM from the features optimum, jitted, forward-mode
   Jacobian), including compilation and again, against `scipy.optimize.least_squares`
   (2-point finite differences) on the same jitted trace residuals from the same start;
   and the combined objective ("both");
4. emcee effective samples per second (minimum over parameters), after compilation.

Usage: python benchmarks/fit.py [--small]
"""

import argparse
import time

import numpy as np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--small", action="store_true", help="quick smoke run (fewer samples/steps)")
    args = ap.parse_args()

    import equinox as eqx
    import jax
    import jax.numpy as jnp
    from jax.flatten_util import ravel_pytree
    from scipy.optimize import least_squares

    import stickslip_jax as ss
    from fitting.features import record_features
    from fitting.fit import fit_features, initial_guesses
    from fitting.mcmc import run_mcmc
    from fitting.objectives import feature_data, feature_residuals
    from fitting.params import CampaignParams, free_spec
    from fitting.synthetic import synthetic_campaign, truth_values

    fr = ss.lubricant("A")
    cycles = 3 if args.small else 8
    recs = synthetic_campaign(fr, speed_fractions=(0.02, 0.05, 0.15, 0.4), cycles=cycles, seed=0)
    n_samples = sum(r.n_samples for r in recs)

    t0 = time.perf_counter()
    feats = [record_features(r) for r in recs]
    t_feat = time.perf_counter() - t0
    t0 = time.perf_counter()
    fit = fit_features(feats)
    t_fit_first = time.perf_counter() - t0
    t0 = time.perf_counter()
    fit = fit_features(feats)
    t_fit_again = time.perf_counter() - t0

    # SciPy on the same residuals, same starts
    data = feature_data(feats)
    starts = initial_guesses(feats)
    p0 = CampaignParams(starts[0], jnp.zeros(len(feats)))
    spec = free_spec(p0)
    _, static = eqx.partition(p0, spec)
    flat0, unravel = ravel_pytree(eqx.partition(p0, spec)[0])
    res_fn = jax.jit(lambda v: feature_residuals(eqx.combine(unravel(v), static), data))
    res_fn(flat0).block_until_ready()
    t0 = time.perf_counter()
    best = None
    nfev = 0
    for s in starts:
        v0 = np.asarray(ravel_pytree(eqx.partition(CampaignParams(s, jnp.zeros(len(feats))),
                                                    spec)[0])[0])
        out = least_squares(lambda v: np.asarray(res_fn(jnp.asarray(v))), v0, method="trf",
                            jac="2-point", x_scale="jac", xtol=1e-10, ftol=1e-10, max_nfev=4000)
        nfev += out.nfev
        if best is None or out.cost < best.cost:
            best = out
    t_scipy = time.perf_counter() - t0
    scipy_chi2 = 2 * best.cost

    # trace objective: ours vs SciPy finite differences on the same residuals
    from fitting.trace_objective import trace_data, trace_residuals

    t0 = time.perf_counter()
    tfit = fit_features(feats, objective="trace", records=recs)
    t_tr_first = time.perf_counter() - t0
    t0 = time.perf_counter()
    tfit = fit_features(feats, objective="trace", records=recs)
    t_tr_again = time.perf_counter() - t0
    t0 = time.perf_counter()
    bfit = fit_features(feats, objective="both", records=recs)
    t_both_first = time.perf_counter() - t0
    tdata = trace_data(recs, feats)
    free0, tstatic = eqx.partition(fit.params, fit.spec)  # start: the features optimum
    tflat0, tunravel = ravel_pytree(free0)
    tres = jax.jit(lambda v: trace_residuals(eqx.combine(tunravel(v), tstatic), tdata))
    t0 = time.perf_counter()
    tres(tflat0).block_until_ready()
    t_tr_compile = time.perf_counter() - t0
    t0 = time.perf_counter()
    tres(tflat0).block_until_ready()
    t_tr_eval = time.perf_counter() - t0
    t0 = time.perf_counter()
    tout = least_squares(lambda v: np.asarray(tres(jnp.asarray(v))), np.asarray(tflat0),
                         method="trf", jac="2-point", x_scale="jac", xtol=1e-8, ftol=1e-8,
                         max_nfev=2000)
    t_tr_scipy = time.perf_counter() - t0

    steps = 400 if args.small else 6000
    run_mcmc(fit, walkers=32, steps=20)  # compile
    t0 = time.perf_counter()
    mc = run_mcmc(fit, walkers=32, steps=steps)
    t_mc = time.perf_counter() - t0

    truth = truth_values(fr)
    print(f"campaign: {len(recs)} records, {n_samples} samples, "
          f"{sum(f.n_complete for f in feats)} complete cycles")
    print(f"{'step':<48}{'time [s]':>10}")
    print(f"{'feature extraction (NumPy)':<48}{t_feat:>10.2f}")
    print(f"{'optimistix LM, 12 starts, incl. compilation':<48}{t_fit_first:>10.2f}")
    print(f"{'optimistix LM, 12 starts, compiled':<48}{t_fit_again:>10.3f}")
    print(f"{'SciPy least_squares FD, 12 starts':<48}{t_scipy:>10.2f}  ({nfev} evaluations)")
    print(f"ratio SciPy / ours (incl. compilation): {t_scipy / t_fit_first:.1f}x; "
          f"compiled: {t_scipy / t_fit_again:.0f}x")
    print(f"chi2: ours {fit.chi2:.3f}, SciPy {scipy_chi2:.3f}")
    print("recovered:", ", ".join(f"{k}={v:.4g} (truth {truth[k]:g})" for k, v in fit.values.items()))
    print(f"trace objective: {tdata.n_residuals()} samples in {int(np.asarray(tdata.mask).any(1).sum())} "
          f"cycle windows (padded to {tdata.time.shape[0]} x {tdata.time.shape[1]})")
    print(f"{'optimistix LM, trace, incl. features fit + compilation':<56}{t_tr_first:>10.2f}")
    print(f"{'optimistix LM, trace, compiled (features fit included)':<56}{t_tr_again:>10.2f}")
    print(f"{'optimistix LM, both, incl. compilation':<56}{t_both_first:>10.2f}")
    print(f"{'SciPy least_squares FD on the trace (after its':<56}{t_tr_scipy:>10.2f}  "
          f"({tout.nfev} evaluations + {tout.njev} FD Jacobians, {t_tr_eval * 1e3:.0f} ms per evaluation;")
    print(f"{'   residual compiled in ' + f'{t_tr_compile:.1f} s)':<56}")
    print(f"ratio SciPy / ours, trace (ours incl. compilation): {t_tr_scipy / t_tr_first:.2f}x; "
          f"(SciPy + its compilation) / ours: {(t_tr_scipy + t_tr_compile) / t_tr_first:.2f}x; "
          f"compiled: {t_tr_scipy / t_tr_again:.1f}x")
    print(f"trace chi2: ours {tfit.chi2:.2f} (converged {tfit.converged}), SciPy "
          f"{2 * tout.cost:.2f} (status {tout.status}); both: chi2/dof {bfit.reduced_chi2:.3f}")
    print("trace fit:", ", ".join(f"{k}={v:.4g}" for k, v in tfit.values.items()))
    ess = mc.ess.min()
    print(f"emcee: 32 walkers x {steps} steps in {t_mc:.1f} s; min ESS {ess:.0f} "
          f"({ess / t_mc:.1f} effective samples/s; max tau {mc.tau.max():.0f} steps)")
    if mc.warnings:
        print("emcee warning:", mc.warnings[0])


if __name__ == "__main__":
    main()
