r"""Posterior sampling of the friction parameters with emcee (affine-invariant ensemble).

The log-posterior is the fit's objective (`fitting.combined`: features, trace or
both) as a Gaussian likelihood, $\log L = -\tfrac12 \sum r^2 / s$ ($s = \max(1, \chi^2/\mathrm{dof})$ at
the optimum, the same widening as the Laplace intervals), plus the **prior**: uniform
in the logarithm of each free parameter inside `PRIOR_BOUNDS` (a scale-free prior
for positive quantities), with $\mu_s > \mu_d$; gauge offsets (when fitted) flat.

It is written for emcee's `vectorize=True`: one call evaluates the whole ensemble,
a `jax.vmap` of the residuals inside one `jax.jit`, over a flat (walkers, dim) array
of (log parameters, offsets); the flattening happens only here, at the sampler
boundary. Walkers start in a small ball around the least-squares optimum, shaped by
the Laplace covariance. The integrated autocorrelation time $\tau$ of every
parameter and the effective sample size $N_\mathrm{walkers} (N_\mathrm{steps} -
\mathrm{burn}) / \tau$ are reported, with a warning when the chain is shorter than
50 $\tau$ (emcee's rule of thumb) or the estimate is unreliable.
"""

from __future__ import annotations

import dataclasses

import emcee
import jax
import jax.numpy as jnp
import numpy as np

from .fit import FitResult
from .params import NAMES, CampaignParams
from .uncertainty import _from_logs, laplace

__all__ = ["PRIOR_BOUNDS", "McmcResult", "log_posterior", "run_mcmc", "prior_text"]

PRIOR_BOUNDS = {
    "mu_s": (1e-3, 2.0), "mu_d": (1e-3, 2.0), "gamma": (1e-4, 1e3), "m": (0.02, 5.0),
    "delta": (1e-3, 1e5), "n": (0.02, 5.0),
}
"""Support of the log-uniform prior of each parameter (natural units)."""


def prior_text(free_names) -> str:
    parts = [f"log-uniform {n} in [{PRIOR_BOUNDS[n][0]:g}, {PRIOR_BOUNDS[n][1]:g}]"
             for n in free_names]
    return "; ".join(parts) + "; mu_s > mu_d; gauge offsets flat"


def log_posterior(fit: FitResult):
    """(logp, theta0, free_names, n_offsets): jitted vectorised log-posterior of a fit.

    `logp(theta)` takes (walkers, dim) and returns (walkers,); theta = (log of the free
    friction parameters in NAMES order, free gauge offsets in mm).
    """
    p = fit.params
    logs0 = p.friction.log_values()
    leaf = ("log_gap", "log_mu_d", "log_gamma", "log_m", "log_delta", "log_n")
    free = np.array([bool(getattr(fit.spec.friction, lf)) for lf in leaf])
    idx = jnp.asarray(np.flatnonzero(free))
    k = int(free.sum())
    fit_off = bool(fit.spec.offset)
    lo = jnp.log(jnp.asarray([PRIOR_BOUNDS[n][0] for n in NAMES]))
    hi = jnp.log(jnp.asarray([PRIOR_BOUNDS[n][1] for n in NAMES]))
    scale = max(1.0, fit.reduced_chi2)

    def one(theta, objective):
        logs = logs0.at[idx].set(theta[:k])
        off = theta[k:] if fit_off else p.offset
        inside = jnp.all((logs >= lo) & (logs <= hi)) & (logs[0] > logs[1])
        safe = jnp.where(inside, logs, logs0)
        params = CampaignParams(_from_logs(safe, p.friction), off)
        r = objective.residuals(params)
        ll = -0.5 * jnp.sum(r * r) / scale
        return jnp.where(inside & jnp.isfinite(ll), ll, -jnp.inf)

    batched = jax.jit(jax.vmap(one, in_axes=(0, None)))
    objective = fit.objective

    def logp(theta):
        return batched(theta, objective)

    theta0 = np.concatenate([np.asarray(logs0)[free], np.asarray(p.offset) if fit_off else []])
    names = [n for n, f in zip(NAMES, free) if f]
    return logp, theta0, names, (p.offset.size if fit_off else 0)


@dataclasses.dataclass(frozen=True)
class McmcResult:
    """Posterior samples (natural units, `names` order), diagnostics and the prior used."""

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

    def summary(self) -> dict:
        out = {}
        for i, n in enumerate(self.names):
            s = self.samples[:, i]
            q = np.percentile(s, [2.5, 50, 97.5])
            out[n] = {"median": float(q[1]), "mean": float(s.mean()), "sd": float(s.std()),
                      "ci95": [float(q[0]), float(q[2])], "tau_steps": float(self.tau[i]),
                      "ess": float(self.ess[i])}
        return out


def run_mcmc(
    fit: FitResult,
    *,
    walkers: int = 32,
    steps: int = 2000,
    burn: int | None = None,
    seed: int = 0,
    progress: bool = False,
) -> McmcResult:
    """Sample the posterior of a fit's free parameters with emcee (module doc).

    `burn` steps (default steps // 4) are discarded; `progress` shows emcee's bar.
    """
    logp, theta0, names, n_off = log_posterior(fit)
    dim = theta0.size
    if walkers < 2 * dim:
        raise ValueError(f"--walkers: need at least {2 * dim} walkers (twice the {dim} "
                         f"parameters), got {walkers}")
    if steps < 10:
        raise ValueError(f"--steps: need at least 10 steps, got {steps}")
    burn = steps // 4 if burn is None else int(burn)
    unc = laplace(fit)
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
    sampler.run_mcmc(p0, steps, progress=progress)
    chain = sampler.get_chain(discard=burn, flat=True)
    tau = np.asarray(sampler.get_autocorr_time(discard=burn, tol=0), dtype=float)
    kept = steps - burn
    ess = walkers * kept / np.maximum(tau, 1.0)
    warnings = []
    if np.any(kept < 50 * tau):
        warnings.append(
            f"the chain is too short to trust: {kept} steps after burn-in, less than 50 "
            f"autocorrelation times (max tau = {tau.max():.3g} steps); run more --steps."
        )
    logs = chain[:, : len(names)]
    values = np.exp(logs)
    return McmcResult(
        names=names, samples=values, tau=tau[: len(names)], ess=ess[: len(names)],
        acceptance=float(np.mean(sampler.acceptance_fraction)), walkers=walkers, steps=steps,
        burn=burn, prior=prior_text(names), warnings=warnings,
    )
