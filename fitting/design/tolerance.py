r"""Design to a tolerance: which springs keep the stick-slip amplitude below a bound, for
every friction parameter set a posterior allows.

The amplitude is the time-domain limit cycle's (`stickslip_jax.limit_cycle`: the fixed
point of the one-cycle map, equal to the exact simulator's settled cycle, re-slips
included), not eq (6)'s with eq (12)'s cut-off, which calls a small stick-slip above
$v_c$ "none".

- `meet_probability(sample, W, k, v, max_amplitude)`: over the posterior draws
  (`posterior.load_samples`, a `Friction` with leaves of shape (S,)), the probability
  that the amplitude stays at or below `max_amplitude` (mm), at every point of the
  broadcast W (kgf), k (kgf/mm), v (mm/s).
- `required_stiffness(sample, W, v, max_amplitude, meet=0.95)`: the inverse design, the
  stiffness at which the `meet` quantile of the draws' amplitudes equals the tolerance
  (Newton's method in log k on a smooth quantile of the draws, with gradients through the
  fixed point by the implicit function theorem); a stiffer spring meets it with at least
  that probability (the amplitude falls with k: about W/k times a friction drop that
  shrinks with T1). Returns k (kgf/mm), the probability met there, and the solver result.
- `design_front(sample, weights, v, max_amplitude, meet=0.95)`: the inverse design over
  (W, k): the required stiffness at every weight of a grid (one vmapped solve), the
  Pareto front of the pairs (a heavier slide with a softer drive is better on both
  counts: pair i is dominated if another has W >= W_i and k <= k_i, one of them
  strictly) and the pair with the smallest product k W. Every pair meets the tolerance
  with probability `meet` (a slide lighter than the grid's lightest is not searched).
  In the paper's model W and k enter only through k/W (the mass is W/g and every
  deflection mu W/k), so the required stiffness is proportional to W and every pair is on
  the front: the answer is a stiffness per weight (tested); the front matters once the
  friction depends on W (a contact law).
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from stickslip_jax import Friction
from stickslip_jax.limit_cycle import limit_cycle

from .points import positive
from .uncertainty import sample_size

__all__ = ["ToleranceDesign", "ToleranceFront", "design_front", "meet_probability",
           "required_stiffness"]


def _amplitudes(sample: Friction, weight, stiffness, speed):
    """Limit-cycle amplitude (mm) of every draw at one design point, shape (S,)."""
    return jax.vmap(lambda f: limit_cycle(f, weight, stiffness, speed).amplitude)(sample)


def _checked(sample, max_amplitude, meet=0.5) -> int:
    """The sample's number of draws, once `max_amplitude` (> 0) and `meet` (in (0, 1))
    are checked."""
    if not 0 < meet < 1:
        raise ValueError(f"--meet: must lie between 0 and 1, e.g. 0.95, got {meet}")
    if not max_amplitude > 0:
        raise ValueError(f"--max-amplitude: must be positive, got {max_amplitude}")
    return sample_size(sample)


@eqx.filter_jit
def _meet_grid(sample, w, k, v, max_amplitude):
    def one(w, k, v):
        # a count, divided on the host in float64: a float32 mean reported 380 of 400
        # draws as 0.94999999, which reads as missing a 0.95 target it meets exactly
        return jnp.sum(_amplitudes(sample, w, k, v) <= max_amplitude)

    return jax.vmap(one)(w, k, v)


def meet_probability(sample: Friction, weight, stiffness, speed, max_amplitude: float):
    """P(amplitude <= `max_amplitude`) over the draws at every broadcast point (module
    doc); a NumPy array of the broadcast shape."""
    size = _checked(sample, max_amplitude)
    w, k, v = np.broadcast_arrays(*positive(weight, stiffness, speed))
    p = _meet_grid(sample, jnp.asarray(w.ravel()), jnp.asarray(k.ravel()),
                   jnp.asarray(v.ravel()), jnp.asarray(float(max_amplitude)))
    return (np.asarray(p, dtype=float) / size).reshape(w.shape)


@dataclasses.dataclass(frozen=True)
class ToleranceDesign:
    """`stiffness` k (kgf/mm) where the `meet` quantile of the amplitude equals the
    tolerance, `probability` met there (fraction of draws), `converged`."""

    weight: float
    speed: float
    max_amplitude: float
    meet: float
    stiffness: float
    probability: float
    converged: bool


@eqx.filter_jit
def _solve_stiffness(sample, weight, speed, max_amplitude, meet, k0):
    def residual(log_k, args):
        sample, w, v, tol, q = args
        a = _amplitudes(sample, w, jnp.exp(log_k), v)
        # the q quantile interpolates the sorted draws linearly: piecewise smooth, so
        # Newton's method and its gradient see a slope
        return jnp.log(jnp.quantile(a, q)) - jnp.log(tol)

    sol = optx.root_find(residual, optx.Newton(rtol=1e-10, atol=1e-10), jnp.log(k0),
                         args=(sample, weight, speed, max_amplitude, meet), max_steps=100,
                         throw=False)
    k = jnp.exp(sol.value)
    met = jnp.sum(_amplitudes(sample, weight, k, speed) <= max_amplitude * (1 + 1e-9))
    return k, met, sol.result  # a count of draws (`_meet_grid`)


def required_stiffness(sample: Friction, weight: float, speed: float, max_amplitude: float, *,
                       meet: float = 0.95, start: float = 100.0) -> ToleranceDesign:
    """The inverse design of the module doc at one (W kgf, v mm/s); `start`: the first
    stiffness tried (kgf/mm)."""
    size = _checked(sample, max_amplitude, meet)
    k, met, result = _solve_stiffness(sample, jnp.asarray(float(weight)), jnp.asarray(float(speed)),
                                      jnp.asarray(float(max_amplitude)), jnp.asarray(meet),
                                      jnp.asarray(float(start)))
    return ToleranceDesign(float(weight), float(speed), float(max_amplitude), float(meet),
                           float(k), float(met) / size,
                           bool(result == optx.RESULTS.successful) and bool(np.isfinite(k)))


@dataclasses.dataclass(frozen=True)
class ToleranceFront:
    """The inverse design over (W, k) at one speed (`design_front`): per weight of the
    grid (kgf) the required `stiffness` (kgf/mm; NaN where not found), the `probability`
    met there, `converged`; `pareto`: not dominated (module doc); `best_product`: the
    index of the converged pair with the smallest k W (kgf^2/mm)."""

    weight: np.ndarray
    speed: float
    max_amplitude: float
    meet: float
    stiffness: np.ndarray
    probability: np.ndarray
    converged: np.ndarray
    pareto: np.ndarray
    best_product: int

    def pairs(self) -> list[tuple[float, float]]:
        """The Pareto pairs (W kgf, k kgf/mm), lightest first."""
        return [(float(w), float(k)) for w, k, p in
                zip(self.weight, self.stiffness, self.pareto) if p]


def _pareto(weight, stiffness, ok):
    """Non-dominated pairs among `ok`: none other with W >= and k <= (one strictly)."""
    keep = np.zeros(weight.size, bool)
    for i in np.flatnonzero(ok):
        other = ok & (weight >= weight[i]) & (stiffness <= stiffness[i]) \
            & ((weight > weight[i]) | (stiffness < stiffness[i]))
        keep[i] = not other.any()
    return keep


def design_front(sample: Friction, weights, speed: float, max_amplitude: float, *,
                 meet: float = 0.95, start: float = 100.0) -> ToleranceFront:
    """The inverse design over (W, k) of the module doc at drive speed `speed` (mm/s),
    `weights` a 1-D grid (kgf); `start`: the first stiffness tried (kgf/mm)."""
    size = _checked(sample, max_amplitude, meet)
    w = np.asarray(weights, dtype=float)
    if w.ndim != 1 or not w.size or not np.all(np.isfinite(w) & (w > 0)):
        raise ValueError("weights must be a 1-D grid of positive, finite weights (kgf)")
    solve = jax.vmap(_solve_stiffness, in_axes=(None, 0, None, None, None, None))
    k, prob, result = solve(sample, jnp.asarray(w), jnp.asarray(float(speed)),
                            jnp.asarray(float(max_amplitude)), jnp.asarray(meet),
                            jnp.asarray(float(start)))
    k, prob = np.asarray(k), np.asarray(prob, dtype=float) / size
    ok = np.asarray(result == optx.RESULTS.successful) & np.isfinite(k)
    k = np.where(ok, k, np.nan)
    product = np.where(ok, k * w, np.inf)
    return ToleranceFront(w, float(speed), float(max_amplitude), float(meet), k, prob, ok,
                          _pareto(w, k, ok), int(np.argmin(product)))
