"""`stickslip mcmc RECORDS...`: posterior of the friction parameters with emcee.

Fits first (as `stickslip fit`, either model), then samples around the optimum (the
command runs `stickslip_fitting.sample`); prints the posterior median, sd, 95 % interval,
autocorrelation time and effective sample size of every parameter and the prior.
`--json OUT` writes the summary and the thinned draws (`report.mcmc_document`), which
`stickslip design --posterior OUT` and `stickslip plan OUT` read; `--chain OUT.nc` the
full chain after burn-in as arviz InferenceData (with arviz installed, its ESS and R-hat
of the walkers are printed, R-hat only indicative); `--plot` the corner plot.
"""

from __future__ import annotations

import argparse
import contextlib

NAME = "mcmc"
HELP = "sample the posterior of the friction parameters (emcee) for a campaign of records"


def add_arguments(parser):
    from .fit import add_campaign_fit_arguments

    parser.add_argument("records", nargs="+", help="record CSV files, directories or globs")
    add_campaign_fit_arguments(
        parser, objective_help="the likelihood: the cycle features (default), every sample "
        "of the traces (exact simulator restarted per cycle), both, or whole records "
        "(smoothed simulator); all but features are tempered to the cluster-robust intervals",
        strict_help="refuse the campaign when any record has no usable stick-slip (default: "
                    "sample with the records that have it, list the others)")
    parser.add_argument("--walkers", type=int, default=32, help="ensemble size (default 32)")
    parser.add_argument("--steps", type=int, default=3000, help="steps per walker (default 3000)")
    parser.add_argument("--burn", type=int, default=None, help="steps discarded (default steps/4)")
    parser.add_argument("--seed", type=int, default=0,
                        help="random seed of the walkers' start and moves (0 to 2**32 - 1)")
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


SAMPLER_KEYWORDS = ("seed", "draws", "steps", "walkers", "burn")
"""Keywords of `stickslip_fitting.sample` whose errors name the command's option."""


def posterior(args, outputs: dict | None = None):
    """`stickslip_fitting.sample` around the fit of `stickslip fit` (`fit.fit_from_args`:
    `api.campaign.fit_campaign`, its one data step checking `outputs` {option: path}
    against the records read), the sampler's settings checked before the fit (errors
    name the command's options)."""
    from ..api.posterior import check_sampler, sample
    from .fit import check_model_options, fit_from_args

    settings = dict(steps=args.steps, walkers=args.walkers, burn=args.burn, seed=args.seed,
                    draws=args.draws)
    with _options_named():
        check_sampler(**settings, free=6 - len(check_model_options(args)))
    fitted = fit_from_args(args, objective=args.objective, outputs=outputs)
    with _options_named():
        return sample(fitted, **settings, progress=not (args.quiet or args.no_progress))


@contextlib.contextmanager
def _options_named():
    """A sampler keyword's ValueError ("seed: ...") as the command's option ("--seed: ...")."""
    try:
        yield
    except ValueError as err:
        head, colon, rest = str(err).partition(":")
        if head not in SAMPLER_KEYWORDS:
            raise
        raise ValueError(f"--{head}{colon}{rest}") from None


def run(args) -> int:
    import sys

    from ..uncertainty.mcmc import ENSEMBLE_CAVEAT, MissingExtra, import_arviz

    if args.chain == "-":
        raise ValueError("--chain: give a file name such as chain.nc (netCDF is not written "
                         "to stdout)")
    if args.chain:
        import_arviz("--chain")  # before the fit: a one-line error naming the extra
    post = posterior(args, {"--json": args.json, args.plot_option: args.plot,
                            "--chain": args.chain})
    res, report = post.mcmc, post.report
    for w in post.campaign_fit.campaign.warnings:
        print("warning: " + w)
    print(post)
    # the chain file's attributes besides the result's own (likelihood scale, units, ...)
    attrs = {k: report[k] for k in ("model", "objective", "loss", "record_names")}
    attrs.update(seed=args.seed, records=report["record_names"],  # old name, one release
                 fixed=report["fixed"])
    idata = None
    try:
        idata = res.to_inference_data(attrs, report["record_names"])
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
        post.to_json(args.json)  # the document with its renamed keys' old names
        if args.json != "-":
            print(f"wrote {args.json}")
    if args.chain:
        res.save_chain(args.chain, idata=idata)
        print(f"wrote {args.chain}")
    if args.plot:
        from stickslip_jax.logs import logger

        logger.info("drawing the corner plot...")
        from ..report.plots import interruptible

        interruptible(post.plot, args.plot)
        print(f"wrote {args.plot}")
    if res.interrupted:
        print("stickslip mcmc: interrupted; the chain so far is summarised above"
              + (f" and written to {args.json}" if args.json not in (None, "-") else ""),
              file=sys.stderr)
        return 130
    return 0
