r"""Experiment design: Fisher information of the friction parameters and D-optimal records.

A planned record is a design point (W kgf, k kgf/mm, v mm/s). From the steady analysis
(eqs 1, 3, 5-7) it yields the observables, per record (averaged over its cycles):

- stick-slip ($v < v_c$): $\log a$ (eq 5), $\log T_1$ (eq 6), $\mu_0$ (eq 1) and
  $\mu_m$ (eq 3), with noise `Noise.log_amplitude`, `Noise.log_stick_time` (relative
  errors) and `Noise.mu_0`, `Noise.mu_m` (absolute);
- smooth sliding: only the kinetic friction, $\mu_m = \mu_d$, with noise `Noise.mu_m`.
  A record counts as smooth above $v_c$ and also where the slider cannot stick again
  after a slip: a slip from rest ends at $x_1 = 2\mu_m W/k - x_2$, and sticking needs
  $k x_1 < \mu_d W$, i.e. $\mu_m - \mu_d < \mu_0 - \mu_m$ (the time-domain model, and a
  real slideway, slide on there although eq (6) has a solution).

The parameters are $u = \log(\mu_s, \mu_d, \gamma, m, \delta, n)$ (order `PARAMETERS`),
so posterior standard deviations of $u$ are relative uncertainties. The Fisher
information of a record is $J^T \Sigma^{-1} J$ with $J = \partial y / \partial u$ from
`jax.jacfwd` through the steady analysis (implicit function theorem of the eq (6) root
find). `greedy_design` adds, one at a time, the candidate record that most increases
$\log\det$ of the posterior precision (prior + records): greedy D-optimal design.
`laplace_fit` fits the observables with a Gaussian prior in $u$ and returns the Laplace
(Gauss-Newton) posterior covariance. Its objective is `SteadyObservables` (an
`stickslip_fitting.solve.lsq.AbstractResiduals`: the whitened observables of every record,
then the prior as residuals), searched through `TanhBounded` (a bounded coordinate
around the prior mean) by `stickslip_fitting.solve.lsq.least_squares`, the project's one
Levenberg-Marquardt.

The design is local: the information is evaluated at an estimate of $u$, and the most
informative records lie near the regime boundaries (v_c, resticking), where a rough
estimate misjudges the regime. Planned in one shot from an estimate 10 % off lubricant
A, six D-optimal records did *worse* than an even spread; planned sequentially
(`sequential_campaign`: a small pilot, then one record at a time from the current
fit, as `stickslip plan` is meant to be used) they did better (tests, notebook 04).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, Float

from stickslip_jax import Friction, steady_state
from stickslip_jax.lsq import JacobianMode, gauss_newton_covariance
from stickslip_jax.steady import STICK_SLIP

from ..modes import DesignCriterion, check_member
from ..params import EmpiricalFriction
from ..solve.lsq import AbstractResiduals, least_squares
from .campaign import Campaign
from .posterior import PARAMETERS, log_params

N_OBS = 4


class Noise(eqx.Module):
    """Standard deviations of one record's observables: relative for a and T1, absolute
    for mu_0 and mu_m (dimensionless)."""

    log_amplitude: float = 0.05
    log_stick_time: float = 0.05
    mu_0: float = 0.01
    mu_m: float = 0.01

    def sigma(self):
        return jnp.array([self.log_amplitude, self.log_stick_time, self.mu_0, self.mu_m])


def friction_of(u: Float[Array, " 6"]) -> Friction:
    """Eq (1) + eq (3) `Friction` from $u = \\log$ parameters (order `PARAMETERS`)."""
    return EmpiricalFriction.from_values(*jnp.exp(u)).friction()


def observables(u, weight, stiffness, speed):
    r"""Observables of one record and their mask: ``(y, mask)`` with
    $y = (\log a, \log T_1, \mu_0, \mu_m)$ and `mask` 1 where the entry is observed."""
    friction = friction_of(u)
    s = steady_state(friction, weight, stiffness, speed)
    stick = s.regime == STICK_SLIP  # stick-slip that ends each slip in a stick
    safe_a = jnp.where(stick, s.amplitude, 1.0)
    safe_t = jnp.where(stick, s.stick_time, 1.0)
    mu_m = jnp.where(stick, s.mu_m, friction.mu_d)
    y = jnp.stack([jnp.log(safe_a), jnp.log(safe_t), s.mu_0, mu_m])
    on = stick.astype(float)
    return y, jnp.stack([on, on, on, jnp.ones_like(on)])


@eqx.filter_jit
def record_information(u, campaign: Campaign, noise: Noise = Noise()):
    """Fisher information (N, 6, 6) of each record of `campaign` about $u$."""

    def one(w, k, v):
        jac, mask = jax.jacfwd(lambda uu: observables(uu, w, k, v), has_aux=True)(u)
        wts = mask / noise.sigma() ** 2
        return jac.T @ (wts[:, None] * jac)

    return jax.vmap(one)(campaign.weight, campaign.stiffness, campaign.speed)


def fisher_information(u, campaign: Campaign, noise: Noise = Noise()):
    """Total Fisher information (6, 6) of a campaign about $u$ (sum over its records)."""
    return jnp.sum(record_information(u, campaign, noise), axis=0)


def prior_precision(prior_sd) -> np.ndarray:
    """Diagonal Gaussian prior precision in $u$ from standard deviations of $\\log$ parameters."""
    sd = np.broadcast_to(np.asarray(prior_sd, dtype=float), (len(PARAMETERS),))
    if not np.all(sd > 0):
        raise ValueError("prior standard deviations must be positive")
    return np.diag(1.0 / sd**2)


def posterior_sd(precision) -> np.ndarray:
    """Standard deviations of $u$ (relative uncertainties) from a precision matrix."""
    return np.sqrt(np.diag(np.linalg.inv(np.asarray(precision))))


class Plan(eqx.Module):
    """Result of `greedy_design`: the chosen records (indices into the candidates, in
    order of choice), their `Campaign`, the criterion after each choice (`log_det`:
    log det of the precision for "D", minus the covariance trace for "A"), and the
    posterior sd of $u$ before and after."""

    indices: np.ndarray
    campaign: Campaign
    log_det: np.ndarray
    sd_before: np.ndarray
    sd_after: np.ndarray


def greedy_design(u, candidates: Campaign, budget: int, *, noise: Noise = Noise(), prior_sd=1.0,
                  existing: Campaign | None = None, repeats: bool = True,
                  criterion: DesignCriterion = DesignCriterion.D) -> Plan:
    """Choose `budget` records from `candidates`, each maximising log det of the
    posterior precision (prior + `existing` records + records chosen so far).

    `u`: the parameter estimate ($\\log$, `log_params`) at which the information is
    evaluated; `prior_sd`: sd of $\\log$ parameters (scalar or 6); `repeats`: allow a
    candidate to be chosen more than once (a repeated record); `criterion`: a
    `stickslip_fitting.modes.DesignCriterion`, D (maximise log det of the precision) or A
    (minimise the trace of the posterior covariance, i.e. the mean posterior variance).
    """
    check_member("criterion", criterion, DesignCriterion)
    if budget < 1:
        raise ValueError(f"budget must be >= 1, got {budget}")
    if not repeats and budget > len(candidates):
        raise ValueError(f"budget {budget} exceeds the {len(candidates)} candidates")
    u = jnp.asarray(u, dtype=float)
    info = np.asarray(record_information(u, candidates, noise))
    prec = prior_precision(prior_sd)
    if existing is not None and len(existing):
        prec = prec + np.asarray(fisher_information(u, existing, noise))
    sd_before = posterior_sd(prec)
    chosen, log_dets = [], []
    available = np.ones(len(candidates), bool)
    for _ in range(budget):
        if criterion is DesignCriterion.D:
            _, ld = np.linalg.slogdet(prec[None] + info)
        else:
            ld = -np.trace(np.linalg.inv(prec[None] + info), axis1=1, axis2=2)
        ld = np.where(available, ld, -np.inf)
        i = int(np.argmax(ld))
        chosen.append(i)
        log_dets.append(float(ld[i]))
        prec = prec + info[i]
        if not repeats:
            available[i] = False
    idx = np.asarray(chosen)
    return Plan(idx, candidates.take(idx), np.asarray(log_dets), sd_before, posterior_sd(prec))


def even_design(candidates: Campaign, budget: int) -> Campaign:
    """The comparison campaign: `budget` speeds evenly spaced in log over the candidates'
    speed range, cycling through the candidates' distinct (W, k) pairs."""
    w, k, v = (np.asarray(x) for x in (candidates.weight, candidates.stiffness, candidates.speed))
    pairs = sorted({(a, b) for a, b in zip(w, k)})
    speeds = np.geomspace(v.min(), v.max(), budget)
    pw, pk = np.array([pairs[i % len(pairs)] for i in range(budget)]).T
    return Campaign(pw, pk, speeds)


def candidate_grid(weights, stiffnesses, speeds) -> Campaign:
    """Every combination of the given W (kgf), k (kgf/mm) and v (mm/s) as a `Campaign`."""
    w, k, v = np.meshgrid(np.asarray(weights, float), np.asarray(stiffnesses, float),
                          np.asarray(speeds, float), indexing="ij")
    return Campaign(w.ravel(), k.ravel(), v.ravel())


@eqx.filter_jit
def simulate_observations(u, campaign: Campaign, noise: Noise, key):
    """Synthetic observations (N, 4) and masks of a campaign at truth $u$, with Gaussian noise."""
    y, mask = jax.vmap(observables, in_axes=(None, 0, 0, 0))(
        u, campaign.weight, campaign.stiffness, campaign.speed)
    eps = jax.random.normal(key, y.shape) * noise.sigma()
    return y + eps * mask, mask


class SteadyObservables(AbstractResiduals):
    r"""Observables `y` (N, 4) with their `mask` of the records of `campaign` against the
    steady analysis at $u$ (`observables`), whitened by `noise`, then the Gaussian prior
    $(u - \bar u)/\sigma_u$ as residuals (`prior_mean`, `prior_sd` in $u$)."""

    y: Float[Array, "N 4"]
    mask: Float[Array, "N 4"]
    campaign: Campaign
    noise: Noise
    prior_mean: Float[Array, " 6"]
    prior_sd: Float[Array, " 6"]

    def residuals(self, u) -> Float[Array, " M"]:
        c = self.campaign
        pred, _m = jax.vmap(observables, in_axes=(None, 0, 0, 0))(
            u, c.weight, c.stiffness, c.speed)
        r = (pred - self.y) / self.noise.sigma() * self.mask
        return jnp.concatenate([r.ravel(), (u - self.prior_mean) / self.prior_sd])

    def blocks(self) -> dict[str, int]:
        return {"observables": int(np.size(self.y)), "prior": int(np.size(self.prior_mean))}

    def dof(self) -> float:
        return float(np.sum(np.asarray(self.mask))) + float(np.size(self.prior_mean))


class TanhBounded(AbstractResiduals):
    r"""`inner` searched in $z$ with $u = c + L\tanh(z/L)$ (`centre` c, `bound` L): every
    trial point of the solver stays within L of c (where, for the steady analysis, its
    derivatives are finite). `to_params(z)` maps a solution back."""

    inner: AbstractResiduals
    centre: Float[Array, " P"]
    bound: Float[Array, " P"]

    def to_params(self, z):
        return self.centre + self.bound * jnp.tanh(z / self.bound)

    def residuals(self, z):
        return self.inner.residuals(self.to_params(z))

    def blocks(self) -> dict[str, int]:
        return self.inner.blocks()

    def dof(self) -> float:
        return self.inner.dof()


class LaplaceFit(eqx.Module):
    """Maximum a posteriori $u$ (`value`), its Laplace covariance and sd, and the result code."""

    value: Float[Array, " 6"]
    covariance: Float[Array, "6 6"]
    sd: Float[Array, " 6"]
    result: optx.RESULTS


@eqx.filter_jit
def _map_estimate(objective: SteadyObservables, max_steps: int):
    """(u at the posterior mode, the Jacobian of the residuals there, the result code),
    one compiled program."""
    # The search runs in z with u = mean + L tanh(z / L): trial steps of the optimiser
    # stay within L = min(3 sd, 2) of the prior mean, where the steady analysis and
    # its derivatives are finite (far outside, e.g. m ~ 100, T1^m overflows).
    bounded = TanhBounded(objective, objective.prior_mean,
                          jnp.minimum(3.0 * objective.prior_sd, 2.0))
    sol = least_squares(bounded, jnp.zeros_like(objective.prior_mean), rtol=1e-10,
                        atol=1e-10, max_steps=max_steps,
                        jac=JacobianMode.REVERSE)
    u_hat = bounded.to_params(sol.params)
    return u_hat, jax.jacfwd(objective.residuals)(u_hat), sol.result


def laplace_fit(y, mask, campaign: Campaign, noise: Noise, prior_mean, prior_sd=1.0,
                max_steps: int = 200) -> LaplaceFit:
    """Fit $u$ to observations `y` (N, 4) by Levenberg-Marquardt with a Gaussian prior
    (mean `prior_mean`, sd `prior_sd` in $u$); Laplace covariance from the Gauss-Newton
    Hessian at the optimum (`stickslip_jax.lsq.gauss_newton_covariance`, the project's one
    covariance)."""
    prior_mean = jnp.asarray(prior_mean, dtype=float)
    psd = jnp.broadcast_to(jnp.asarray(prior_sd, dtype=float), prior_mean.shape)
    objective = SteadyObservables(y, mask, campaign, noise, prior_mean, psd)
    u_hat, jac, result = _map_estimate(objective, max_steps)
    cov = gauss_newton_covariance(jac)
    return LaplaceFit(u_hat, cov, np.sqrt(np.diag(cov)), result)


def sequential_campaign(truth, start, candidates: Campaign, pilot: Campaign, n_next: int, key,
                        *, noise: Noise = Noise(), prior_sd=1.0,
                        criterion: DesignCriterion = DesignCriterion.D
                        ) -> tuple[Campaign, LaplaceFit]:
    """Simulate a sequential campaign on synthetic data (what `stickslip plan` is for).

    Record the `pilot` campaign, then `n_next` times: fit all records so far
    (`laplace_fit`, prior mean `start`, sd `prior_sd`), choose the next record with
    `greedy_design` at the fitted parameters (the records so far as `existing`) and
    record it. Observations are drawn at `truth` ($u$) with `noise`. Returns the final
    campaign and its fit. Rows not yet recorded are carried as masked padding, so the
    fit compiles once.
    """
    check_member("criterion", criterion, DesignCriterion)
    if n_next < 0:
        raise ValueError(f"n_next must be >= 0, got {n_next}")
    n0 = len(pilot)
    if n0 < 1:
        raise ValueError("the pilot campaign needs at least one record")
    total = n0 + n_next
    arrays = [np.full(total, float(np.asarray(x)[0])) for x in
              (pilot.weight, pilot.stiffness, pilot.speed)]
    for a, x in zip(arrays, (pilot.weight, pilot.stiffness, pilot.speed)):
        a[:n0] = np.asarray(x)
    keys = jax.random.split(key, total)
    y_all = np.zeros((total, N_OBS))
    mask_all = np.zeros((total, N_OBS))

    def record(i):
        one = Campaign(*(a[i:i + 1] for a in arrays))
        y, m = simulate_observations(jnp.asarray(truth, dtype=float), one, noise, keys[i])
        y_all[i], mask_all[i] = np.asarray(y)[0], np.asarray(m)[0]

    for i in range(n0):
        record(i)
    for i in range(n0, total):
        fit = laplace_fit(y_all, mask_all, Campaign(*arrays), noise, start, prior_sd)
        done = Campaign(*(a[:i] for a in arrays))
        plan = greedy_design(fit.value, candidates, 1, noise=noise, prior_sd=prior_sd,
                             existing=done, criterion=criterion)
        for a, x in zip(arrays, (plan.campaign.weight, plan.campaign.stiffness,
                                 plan.campaign.speed)):
            a[i] = float(np.asarray(x)[0])
        record(i)
    campaign = Campaign(*arrays)
    return campaign, laplace_fit(y_all, mask_all, campaign, noise, start, prior_sd)
