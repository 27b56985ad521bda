"""`stickslip mcmc RECORDS...`: posterior of the friction parameters with emcee.

Fits first (as `stickslip fit`, either model: `--model microsqueeze` samples h_e and Q
in place of gamma and m, with `--eta` and `--surface` given), then samples around the
optimum; prints the posterior
median, standard deviation, 95 % interval, autocorrelation time and effective sample
size of every parameter, the prior used, and a warning when the chain is too short.
`--json OUT` writes the summary ("parameters", "prior", ...) and the posterior draws
("names", "samples": a (draws, parameters) matrix thinned to at most `--draws` rows,
"fixed": the values of parameters held fixed), which `stickslip design --posterior OUT`
and `stickslip plan OUT` read. `--chain OUT.nc` saves the full chain after burn-in as
arviz InferenceData in netCDF (`McmcResult.save_chain`; chain = walker, draw = step),
and with arviz installed (the extra `stickslip-jax[posterior]`) arviz's ESS and R-hat
of the walkers are printed, R-hat only indicative for an ensemble's walkers.
`--plot OUT.png` (or `--corner`) draws the corner plot with the `corner` package.
"""

from __future__ import annotations

import argparse

from ..report.mcmc_document import JSON_ALIASES, thinned_draws  # noqa: F401  (the JSON's renamed keys)

NAME = "mcmc"
HELP = "sample the posterior of the friction parameters (emcee) for a campaign of records"


def add_arguments(parser):
    parser.add_argument("records", nargs="+", help="record CSV files, directories or globs")
    parser.add_argument("--model", choices=("empirical", "microsqueeze"), default="empirical",
                        help="static-friction law: eq (1) (default) or the microsqueeze law")
    parser.add_argument("--walkers", type=int, default=32, help="ensemble size (default 32)")
    parser.add_argument("--steps", type=int, default=3000, help="steps per walker (default 3000)")
    parser.add_argument("--burn", type=int, default=None, help="steps discarded (default steps/4)")
    parser.add_argument("--seed", type=int, default=0,
                        help="random seed of the walkers' start and moves (0 to 2**32 - 1)")
    from .fit import add_gauge_offset_argument, add_objective_argument, add_slip_time_argument

    add_gauge_offset_argument(parser)
    add_slip_time_argument(parser)
    add_objective_argument(
        parser, help="the likelihood: the cycle features (default), every sample of "
                  "the traces (exact simulator restarted per cycle), both, or whole "
                  "records (smoothed simulator); all but features are tempered to the "
                  "cluster-robust intervals")
    parser.add_argument("--strict", action="store_true",
                        help="refuse the campaign when any record has no usable stick-slip "
                        "(default: sample with the records that have it, list the others)")
    from .fit import add_model_arguments

    add_model_arguments(parser)
    from stickslip_jax.commands.options import add_json_option, add_plot_option, add_quiet_option

    add_json_option(parser, "the summary and the (thinned) posterior draws (`stickslip "
                    "design --posterior OUT` reads the draws)")
    parser.add_argument("--draws", type=int, default=2000,
                        help="at most this many draws in --json (evenly thinned; default 2000)")
    parser.add_argument("--chain", metavar="OUT.nc",
                        help="write the full chain after burn-in (every walker and step, "
                        "log-posterior, units, settings) as arviz InferenceData netCDF to "
                        "OUT.nc; needs the extra: pip install \"stickslip-jax[posterior]\"")
    add_plot_option(parser, "the corner plot of the posterior (the corner package: 16/50/84 "
                    "%% quantiles, truths, units)", aliases=("--corner",))
    add_quiet_option(parser)
    # the old opt-out of the bar alone (the stage lines stay): hidden, --quiet is the flag
    parser.add_argument("--no-progress", action="store_true", help=argparse.SUPPRESS)


def _fixed_misfit(fit, free) -> list[str]:
    from ..report.mcmc_document import fixed_misfit

    return fixed_misfit(fit, free)


def run(args) -> int:
    from ..data.campaign import find_truth
    from ..uncertainty.mcmc import run_mcmc
    from .fit import fit_from_args

    if not 0 <= args.seed < 2**32:
        raise ValueError(f"--seed: must lie in 0 to 2**32 - 1, got {args.seed}")
    if args.draws < 1:
        raise ValueError(f"--draws: need at least 1 draw, got {args.draws}")
    if args.steps < 10:
        raise ValueError(f"--steps: need at least 10 steps, got {args.steps}")
    free = 6 - len(set(f.split("=")[0].strip() for f in args.fix))
    if args.walkers < 2 * max(free, 1):  # before the fit (gauge offsets may need more)
        raise ValueError(f"--walkers: need at least {2 * max(free, 1)} walkers (twice the "
                         f"{max(free, 1)} free parameters), got {args.walkers}")
    if args.burn is not None and not 0 <= args.burn < args.steps:
        raise ValueError(f"--burn: must lie in [0, --steps), got {args.burn}")
    from stickslip_jax.output import check_outputs, versioned, write_json
    from stickslip_jax.records import record_paths

    check_outputs({"--json": args.json, args.plot_option: args.plot, "--chain": args.chain},
                  record_paths(args.records))
    if args.chain == "-":
        raise ValueError("--chain: give a file name such as chain.nc (netCDF is not written "
                         "to stdout)")
    from ..uncertainty.mcmc import ENSEMBLE_CAVEAT, MissingExtra, import_arviz

    if args.chain:
        import_arviz("--chain")  # before the fit: a one-line error naming the extra
    fit, campaign, extra = fit_from_args(args, objective=args.objective)
    records = campaign.records
    for w in campaign.warnings:
        print("warning: " + w)
    import sys

    from stickslip_jax.logs import logger

    logger.info(f"sampling: {args.walkers} walkers x {args.steps} steps (Ctrl-C stops and "
                "keeps the chain so far)")
    res = run_mcmc(fit, walkers=args.walkers, steps=args.steps, burn=args.burn, seed=args.seed,
                   progress=not (args.quiet or args.no_progress))
    res.warnings.extend(_fixed_misfit(fit, res.names))
    logger.info(f"sampling {'interrupted' if res.interrupted else 'done'}: acceptance "
                f"{res.acceptance:.2f}")
    summary = res.summary()
    units = res.units
    truth = find_truth(records, list(fit.values))
    head = (f"{'parameter':<10}{'median':>12}{'unit':>7}{'sd':>11}{'95 % interval':>26}"
            f"{'tau':>8}{'ESS':>8}" + (f"{'truth':>10}" if truth else ""))
    print(head)
    print("-" * len(head))
    for name, s in summary.items():
        ci = f"[{s['ci95'][0]:.5g}, {s['ci95'][1]:.5g}]"
        line = (f"{name:<10}{s['median']:>12.5g}{units[name]:>7}{s['sd']:>11.3g}{ci:>26}"
                f"{s['tau_steps']:>8.1f}{s['ess']:>8.0f}")
        if truth:
            line += f"{truth[name]:>10.4g}"
        print(line)
    print(f"\nprior: {res.prior}")
    if extra:
        g = extra["given"]
        print(f"given: eta = {g['eta']['value']:.4g} {g['eta']['unit']}, surface {g['surface']}")
    loss = "" if args.loss == "gaussian" else f" under the {args.loss} loss"
    print(f"likelihood: {args.objective} objective{loss}, chi2 divided by "
          f"{res.likelihood_scale:.3g}")
    print(f"{res.walkers} walkers x {res.steps} steps (burn-in {res.burn}); "
          f"acceptance {res.acceptance:.2f}")
    for w in res.warnings:
        print("warning: " + w)
    from ..objectives.losses import loss_of

    # the chain file's attributes besides the result's own (likelihood scale, units, ...)
    attrs = {"model": args.model, "objective": args.objective,
             "loss": loss_of(fit.objective).spec(), "seed": args.seed,
             "record_names": [f.name for f in fit.features],
             "records": [f.name for f in fit.features],  # old name, one release (JSON)
             "fixed": {n: v for n, v in fit.values.items() if n not in res.names}}
    idata = None
    try:
        idata = res.to_inference_data(attrs, [f.name for f in fit.features])
    except MissingExtra:
        pass  # arviz's summary is optional (`--chain` checked for it above)
    if idata is not None:
        diag = res.arviz_summary(idata)
        print(f"\narviz, walkers as chains ({ENSEMBLE_CAVEAT}):")
        print(f"{'parameter':<10}{'ESS bulk':>10}{'ESS tail':>10}{'R-hat':>8}")
        for name in res.names:
            row = diag.loc[name]
            print(f"{name:<10}{row['ess_bulk']:>10.0f}{row['ess_tail']:>10.0f}"
                  f"{row['r_hat']:>8.3f}")
    if args.json:
        from ..report.mcmc_document import mcmc_document

        out = mcmc_document(res, fit, campaign, model=args.model, objective=args.objective,
                            truth=truth, max_draws=args.draws, extra=extra)
        write_json(args.json, versioned(out, JSON_ALIASES))
        if args.json != "-":
            print(f"wrote {args.json}")
    if args.chain:
        res.save_chain(args.chain, idata=idata)
        print(f"wrote {args.chain}")
    if args.plot:
        from ..report.posterior_plots import corner_plot

        logger.info("drawing the corner plot...")
        corner_plot(res.samples, res.names, args.plot, truth=truth, units=units)
        print(f"wrote {args.plot}")
    if res.interrupted:
        print("stickslip mcmc: interrupted; the chain so far is summarised above"
              + (f" and written to {args.json}" if args.json not in (None, "-") else ""),
              file=sys.stderr)
        return 130
    return 0
