r"""Posterior sampling of the friction parameters with emcee (affine-invariant ensemble).

The log-posterior is the fit's objective (`objectives.combined`: features, trace or both)
as a Gaussian likelihood, $\log L = -\tfrac12 \sum r^2 / s$ ($s = \max(1,
\chi^2/\mathrm{dof})$ at the optimum, as for the Laplace intervals), plus a prior uniform
in the logarithm of each free parameter inside `PRIOR_BOUNDS`, with $\mu_s > \mu_d$;
gauge offsets flat. The microsqueeze law adds its physical region to the support
($C_3 < \mu_s < C_1$, $\mu_d$ above the film-only friction, $h_e > t_b + a_d$:
`MicrosqueezeFriction.physical`).

Where the samples of one stick phase share errors (trace and combined objectives, and
features fits the model does not describe to their noise) the likelihood is tempered:
$s$ is multiplied by the largest ratio over the free parameters of the cluster-robust to
the scaled Fisher variance (`likelihood_scale`, reported), so no posterior is narrower
than its robust Laplace interval (`uncertainty.laplace`).

Written for emcee's `vectorize=True`: one compiled `jax.vmap` of the residuals evaluates
the whole ensemble over a flat (walkers, dim) array of (log parameters, offsets). Walkers
start in a small ball around the optimum, shaped by the Laplace covariance. The
integrated autocorrelation time $\tau$ and the effective sample size
$N_\mathrm{walkers}(N_\mathrm{steps} - \mathrm{burn})/\tau$ are reported, with a
warning under 50 $\tau$ (emcee's rule of thumb).

The chain after burn-in converts to an arviz `InferenceData` (`to_inference_data`,
netCDF by `save_chain`; the extra `stickslip-jax[posterior]`). `arviz_summary` gives ESS
and R-hat with the walkers as chains, only indicative (`ENSEMBLE_CAVEAT`).
"""

from __future__ import annotations

import dataclasses
import json
import warnings

import emcee
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..solve.fit import COMPILER_OPTIONS, FitResult
from ..microsqueeze_params import MicrosqueezeFriction
from ..modes import Covariance
from ..params import AbstractFrictionParams, CampaignParams, EmpiricalFriction, free_mask
from ..report.rows import ParameterEstimate
from .laplace import Uncertainty, laplace

__all__ = ["PRIOR_BOUNDS", "MissingExtra", "McmcResult", "import_arviz", "import_extra",
           "likelihood_scale", "log_posterior", "run_mcmc", "prior_text"]

POSTERIOR_EXTRA = 'pip install "stickslip-jax[posterior]"'
"""How to install arviz (and its netCDF writer) for the chain file and arviz summaries."""

ENSEMBLE_CAVEAT = ("the walkers of an affine-invariant ensemble are not independent chains: "
                   "R-hat across walkers is only indicative")
"""Said wherever arviz's across-chain diagnostics of the walkers are shown."""


class MissingExtra(ImportError, ValueError):
    """An optional dependency is missing: an ImportError for library callers, a one-line
    error (exit 2) for the command line, which reports ValueErrors so."""


def import_extra(module: str, extra: str, option: str | None = None):
    """The optional `module`, or `MissingExtra` naming how to install it (`extra`),
    prefixed by the command-line `option` that needs it. Silences FutureWarnings on import."""
    import importlib

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)
            return importlib.import_module(module)
    except ImportError:
        what = f"{option}: " if option else ""
        raise MissingExtra(f"{what}needs {module}, which is not installed: {extra}") from None


def import_arviz(option: str | None = None):
    """The arviz module, or `MissingExtra` naming `POSTERIOR_EXTRA` (`import_extra`)."""
    return import_extra("arviz", POSTERIOR_EXTRA, option)


PRIOR_BOUNDS = {**EmpiricalFriction.PRIOR_BOUNDS, **MicrosqueezeFriction.PRIOR_BOUNDS}
"""Support of the log-uniform prior of each parameter of both laws (natural units: h_e
mm, Q mm^4); each law's own is its `PRIOR_BOUNDS` class variable."""


def prior_text(friction: AbstractFrictionParams, free_names) -> str:
    """The prior of the law `friction` belongs to, in words, for `free_names`."""
    bounds, units = friction.PRIOR_BOUNDS, friction.UNITS

    def unit(n):
        return "" if units[n] == "-" else f" {units[n]}"

    parts = [f"log-uniform {n} in [{bounds[n][0]:g}, {bounds[n][1]:g}]{unit(n)}"
             for n in free_names]
    text = "; ".join(parts) + "; mu_s > mu_d"
    if friction.REGION:
        text += f"; {friction.MODEL} physical region ({friction.REGION})"
    return text + "; gauge offsets flat"


@eqx.filter_jit(compiler_options=COMPILER_OPTIONS)
def _batched_log_posterior(theta, logs0, idx, lo, hi, template, offset0, objective, scale,
                           fit_off: bool):
    """log posterior of every row of theta (walkers, dim); module level so that it compiles
    once per campaign layout (see `log_posterior`)."""
    k = idx.size

    def one(th):
        logs = logs0.at[idx].set(th[:k])
        off = th[k:] if fit_off else offset0
        inside = jnp.all((logs >= lo) & (logs <= hi)) & (logs[0] > logs[1])
        safe = jnp.where(inside, logs, logs0)
        friction = template.from_log_values(safe)
        # the law's physical region (microsqueeze: no clipping, the logs round-trip)
        inside = inside & friction.physical() & jnp.all(
            jnp.abs(friction.log_values() - safe) < 1e-7)
        r = objective.residuals(CampaignParams(friction, off))
        ll = -0.5 * jnp.sum(r * r) / scale
        return jnp.where(inside & jnp.isfinite(ll), ll, -jnp.inf)

    return jax.vmap(one)(theta)


def likelihood_scale(fit: FitResult, robust=None) -> float:
    """The factor s dividing chi2 in the log-likelihood (module doc): max(1, chi2/dof),
    times the largest robust-to-Fisher variance ratio of the free friction parameters
    when the fit's Laplace covariance is not Fisher's. `robust`: `laplace(fit)` when
    already computed."""
    base = max(1.0, fit.reduced_chi2)
    robust = laplace(fit) if robust is None else robust
    if robust.covariance is Covariance.FISHER:
        return base
    fisher = laplace(fit, covariance=Covariance.FISHER)
    free = robust.free
    ratio = np.diag(robust.cov_log)[free] / np.diag(fisher.cov_log)[free]
    ratio = ratio[np.isfinite(ratio)]
    return base * max(1.0, float(ratio.max()) if ratio.size else 1.0)


def log_posterior(fit: FitResult, scale: float | None = None):
    """(logp, theta0, free_names, n_offsets): jitted vectorised log-posterior of a fit.

    `logp(theta)` takes (walkers, dim) and returns (walkers,); theta = (log of the free
    friction parameters in the model's NAMES order, free gauge offsets in mm). `scale`:
    the likelihood's chi2 divisor (default `max(1, chi2/dof)`; `run_mcmc` passes
    `likelihood_scale(fit)`).
    """
    p = fit.params
    all_names = p.friction.NAMES
    logs0 = p.friction.log_values()
    free = free_mask(fit.spec)
    idx = jnp.asarray(np.flatnonzero(free))
    fit_off = bool(fit.spec.offset)
    bounds = p.friction.PRIOR_BOUNDS
    lo = jnp.log(jnp.asarray([bounds[n][0] for n in all_names]))
    hi = jnp.log(jnp.asarray([bounds[n][1] for n in all_names]))
    scale = max(1.0, fit.reduced_chi2) if scale is None else float(scale)
    scale = jnp.asarray(scale)  # an array: no recompilation per value
    args = (logs0, idx, lo, hi, p.friction, p.offset, fit.objective, scale)

    def logp(theta):
        return _batched_log_posterior(theta, *args, fit_off)

    theta0 = np.concatenate([np.asarray(logs0)[free], np.asarray(p.offset) if fit_off else []])
    names = [n for n, f in zip(all_names, free) if f]
    return logp, theta0, names, (p.offset.size if fit_off else 0)


@dataclasses.dataclass(frozen=True)
class McmcResult:
    """Posterior samples (natural units, `names` order), diagnostics and the prior used.

    `samples` is the flat chain after burn-in (steps x walkers rows); `chain` the same
    as (walkers, steps, parameters), `log_prob` the log-posterior (walkers, steps),
    `offsets` the sampled gauge offsets in mm (walkers, steps, records) or None."""

    names: list
    samples: np.ndarray
    tau: np.ndarray
    ess: np.ndarray
    acceptance: float
    walkers: int
    steps: int
    burn: int
    prior: str
    warnings: list
    units: dict | None = None
    likelihood_scale: float = 1.0
    interrupted: bool = False
    chain: np.ndarray | None = None
    log_prob: np.ndarray | None = None
    offsets: np.ndarray | None = None

    def to_inference_data(self, attrs: dict | None = None, records=None):
        """The chain after burn-in as an arviz `InferenceData`: chain = walker, draw = step
        (numbered from the burn-in), one variable per parameter in natural units with a
        `units` attribute, `gauge_offset` (mm) over `record` (names: `records`),
        sample_stats `lp`. `attrs` (objective, loss, model, seed...) join the result's own
        on every group, as JSON text unless numbers or strings. `MissingExtra` without
        arviz."""
        az = import_arviz()
        if self.chain is None:
            raise ValueError("this result keeps no chain (made without run_mcmc)")
        draws = np.arange(self.burn, self.burn + self.chain.shape[1])
        posterior = {n: self.chain[:, :, i] for i, n in enumerate(self.names)}
        coords, dims = {"draw": draws}, {}
        if self.offsets is not None and self.offsets.shape[-1]:
            n_rec = self.offsets.shape[-1]
            posterior["gauge_offset"] = self.offsets
            coords["record"] = list(records) if records is not None else list(range(n_rec))
            dims["gauge_offset"] = ["record"]
        stats = {"lp": self.log_prob} if self.log_prob is not None else None
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)
            # the layout is (walker, step) by construction, also with fewer steps than walkers
            warnings.filterwarnings("ignore", "More chains", UserWarning)
            idata = az.from_dict(posterior=posterior, sample_stats=stats, coords=coords,
                                 dims=dims)
        units = {**(self.units or {}), **({"gauge_offset": "mm"} if dims else {})}
        for name, var in idata.posterior.data_vars.items():
            var.attrs["units"] = units.get(name, "-")
        meta = {"sampler": "emcee EnsembleSampler (affine-invariant stretch move)",
                "likelihood_scale": self.likelihood_scale, "units": units,
                "walkers": self.walkers, "steps": self.steps, "burn": self.burn,
                "acceptance": self.acceptance, "prior": self.prior,
                "interrupted": self.interrupted, "warnings": self.warnings,
                "note": ENSEMBLE_CAVEAT, **(attrs or {})}
        meta = {k: v if isinstance(v, (str, int, float)) and not isinstance(v, bool)
                else json.dumps(v) for k, v in meta.items()}
        for group in idata.groups():
            getattr(idata, group).attrs.update(meta)
        return idata

    def save_chain(self, path: str, attrs: dict | None = None, records=None,
                   idata=None) -> None:
        """Write `to_inference_data(attrs, records)` (or `idata`, already made from it) as
        netCDF to `path`, atomically. Read it back with `arviz.from_netcdf`."""
        from stickslip_jax.output import write_atomic

        idata = self.to_inference_data(attrs, records) if idata is None else idata
        write_atomic(str(path), lambda tmp: idata.to_netcdf(tmp), suffix=".nc")

    def arviz_summary(self, idata=None):
        """arviz's diagnostics of the walkers as chains (a pandas DataFrame, one row per
        parameter: ess_bulk, ess_tail, r_hat, mcse_*; R-hat only indicative)."""
        az = import_arviz()
        idata = self.to_inference_data() if idata is None else idata
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return az.summary(idata, var_names=list(self.names), kind="diagnostics")

    def estimates(self, truth: dict | None = None) -> list[ParameterEstimate]:
        """One `ParameterEstimate` per sampled parameter: the posterior median, its
        standard deviation as the standard error, the central 95 % interval."""
        summ = self.summary()
        return [ParameterEstimate(name=n, unit=(self.units or {}).get(n, "-"),
                                  value=s["median"], stderr=s["sd"],
                                  ci95=(s["ci95"][0], s["ci95"][1])).with_truth(truth)
                for n, s in summ.items()]

    def summary(self) -> dict:
        out = {}
        for i, n in enumerate(self.names):
            s = self.samples[:, i]
            q = np.percentile(s, [2.5, 50, 97.5])
            out[n] = {"median": float(q[1]), "mean": float(s.mean()), "sd": float(s.std()),
                      "ci95": [float(q[0]), float(q[2])], "tau_steps": float(self.tau[i]),
                      "ess": float(self.ess[i])}
        return out


def _sample(sampler, p0, steps: int, progress: bool) -> bool:
    """Run the sampler; a Ctrl-C ends it after the current step instead of inside the
    log-posterior (where emcee would print a traceback), a second at once. True when it
    was interrupted. Off the main thread (no signal handler) it goes through as usual."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        sampler.run_mcmc(p0, steps, progress=progress)
        return False
    stop = []

    def on_sigint(signum, frame):
        if stop:  # the second Ctrl-C: now
            raise KeyboardInterrupt
        stop.append(True)

    previous = signal.signal(signal.SIGINT, on_sigint)
    try:
        for _ in sampler.sample(p0, iterations=steps, progress=progress):
            if stop:
                break
    finally:
        signal.signal(signal.SIGINT, previous)
    return bool(stop)


MIN_KEPT = 10
"""Steps a chain interrupted by Ctrl-C must have to be kept (fewer: the interrupt goes on)."""


def run_mcmc(fit: FitResult, *, walkers: int = 32, steps: int = 2000, burn: int | None = None,
             seed: int = 0, progress: bool = False,
             uncertainty: Uncertainty | None = None) -> McmcResult:
    """Sample the posterior of a fit's free parameters with emcee (module doc).

    `burn` steps (default steps // 4) are discarded; `progress` shows emcee's bar;
    `uncertainty`: the fit's `laplace(fit)`, when already computed. A Ctrl-C
    (KeyboardInterrupt) during sampling keeps the chain so far (at least `MIN_KEPT` steps;
    burn-in at most a quarter of it): the result says `interrupted`.
    """
    unc = laplace(fit) if uncertainty is None else uncertainty
    scale = likelihood_scale(fit, unc)
    logp, theta0, names, n_off = log_posterior(fit, scale)
    dim = theta0.size
    if walkers < 2 * dim:
        raise ValueError(f"--walkers: need at least {2 * dim} walkers (twice the {dim} "
                         f"parameters), got {walkers}")
    if steps < 10:
        raise ValueError(f"--steps: need at least 10 steps, got {steps}")
    burn = steps // 4 if burn is None else int(burn)
    if not 0 <= burn < steps:
        raise ValueError(f"--burn: must lie in [0, --steps), got {burn}")
    rng = np.random.default_rng(seed)
    sd = np.sqrt(np.clip(np.diag(unc.cov_log)[unc.free], 1e-14, 1e-2))
    sd = np.concatenate([sd, np.full(n_off, 1e-6)])
    p0 = theta0 + 0.1 * sd * rng.standard_normal((walkers, dim))
    lp0 = np.asarray(logp(jnp.asarray(p0)))
    p0[~np.isfinite(lp0)] = theta0  # pragma: no cover (only at a prior boundary)

    def log_prob(theta):
        return np.asarray(logp(jnp.asarray(theta)))

    sampler = emcee.EnsembleSampler(walkers, dim, log_prob, vectorize=True)
    sampler.random_state = np.random.RandomState(seed).get_state()
    try:
        interrupted = _sample(sampler, p0, steps, progress)
    except ValueError as exc:
        if "condition number" not in str(exc):
            raise
        # emcee refuses walkers that start (nearly) on one line: the fit's covariance is
        # degenerate, e.g. a --fix value the records contradict
        raise ValueError(
            "the walkers cannot start: around the fit's optimum they are not linearly "
            "independent (the fit's covariance is degenerate: parameters not identifiable "
            "or at a bound, or --fix values the records contradict); check `stickslip fit` "
            "with the same records and options, and fix fewer parameters or add records") from None
    if interrupted:
        done = int(sampler.iteration)
        if done < MIN_KEPT:
            raise KeyboardInterrupt
        steps = done
        burn = min(burn, done // 4)
    chain = sampler.get_chain(discard=burn, flat=True)
    full = sampler.get_chain(discard=burn)  # (steps, walkers, dim)
    log_prob = np.asarray(sampler.get_log_prob(discard=burn)).T
    tau = np.asarray(sampler.get_autocorr_time(discard=burn, tol=0), dtype=float)
    kept = steps - burn
    ess = walkers * kept / np.maximum(tau, 1.0)
    warnings = []
    if interrupted:
        warnings.append(f"interrupted after {steps} steps: the posterior is from the chain so "
                        f"far (burn-in {burn})")
    if np.any(kept < 50 * tau):
        warnings.append(
            f"the chain is too short to trust: {kept} steps after burn-in, less than 50 "
            f"autocorrelation times (max tau = {tau.max():.3g} steps); run more --steps.")
    logs = chain[:, : len(names)]
    values = np.exp(logs)
    return McmcResult(
        names=names, samples=values, tau=tau[: len(names)], ess=ess[: len(names)],
        acceptance=float(np.mean(sampler.acceptance_fraction)), walkers=walkers, steps=steps,
        burn=burn, prior=prior_text(fit.params.friction, names), warnings=warnings,
        units=dict(fit.params.friction.UNITS), likelihood_scale=scale, interrupted=interrupted,
        chain=np.exp(np.transpose(full[:, :, : len(names)], (1, 0, 2))), log_prob=log_prob,
        offsets=np.transpose(full[:, :, len(names):], (1, 0, 2)) if n_off else None)
