r"""The objective interface and the least-squares verb over any parameter pytree.

Every objective of the package is an `AbstractResiduals` (an `eqx.Module`):

- `residuals(params)`: the whitened residual vector (sum of squares = $-2\log$
  likelihood up to a constant; a Gaussian prior enters as extra residuals);
- `blocks()`: named lengths of the residual vector, in order (`split(r)` cuts a vector
  by them, so reports never slice by position);
- `dof()`: the (weighted) number of residuals that carry data.

Final objectives: the campaign objectives (`stickslip_fitting.combined.AbstractObjective`,
which add the simulations' flags, clusters and trace data the campaign fit needs:
features, trace, weighted sum, smooth, heavy-tailed), `stickslip_fitting.pitch_fit.
PitchObjective` (the pitching/yawing channels) and `stickslip_fitting.design.experiment.
SteadyObservables` (the steady observables of a planned campaign, with its prior).

`least_squares(objective, params, free)` is the one verb that minimises an objective's
residuals over the leaves `free` selects (a function `params -> leaf or tuple of leaves`
like `eqx.tree_at`'s `where`, a boolean filter spec as for `eqx.partition`, or None: every
array leaf), with the project's one solver (`stickslip_jax.lsq.LevenbergMarquardt`)
inside `optimistix.least_squares`; `jacobian(objective, params, free)` is the Jacobian
over the same leaves (for `stickslip_jax.lsq.gauss_newton_covariance`). The campaign fit
(`stickslip_fitting.fit.fit_objective`) adds multi-start and reweighting rounds on top of
the same solver.

```python
sol = least_squares(PitchObjective(template, batch, scale), params, spec)
sol.params, sol.result          # fitted pytree, optimistix result code
```
"""

from __future__ import annotations

import abc

import equinox as eqx
import jax
import numpy as np
import optimistix as optx
from jax.flatten_util import ravel_pytree
from jaxtyping import Array, Float, PyTree

from stickslip_jax.lsq import LevenbergMarquardt

__all__ = ["AbstractResiduals", "LeastSquaresSolution", "free_filter", "jacobian",
           "least_squares"]


class AbstractResiduals(eqx.Module):
    """An objective: whitened residuals of a parameter pytree (module doc)."""

    @abc.abstractmethod
    def residuals(self, params) -> Float[Array, " N"]:
        """Whitened residuals (sum of squares = -2 log likelihood up to a constant)."""

    @abc.abstractmethod
    def blocks(self) -> dict[str, int]:
        """Named blocks of the residual vector and their lengths, in order."""

    @abc.abstractmethod
    def dof(self) -> float:
        """Weighted number of residuals that carry data."""

    def split(self, r) -> dict[str, np.ndarray]:
        """The residual vector `r` cut into its named `blocks()` (for reports: no hand
        slicing by position)."""
        r = np.asarray(r)
        out, start = {}, 0
        for name, n in self.blocks().items():
            out[name] = r[start: start + n]
            start += n
        if start != r.size:
            raise ValueError(f"residual vector of {r.size} entries, blocks of {start}")
        return out


def free_filter(params: PyTree, free=None) -> PyTree:
    """The boolean filter spec of the free leaves: `free` a function `params -> leaf or
    tuple of leaves` (like `eqx.tree_at`'s `where`), a spec already, or None (every leaf)."""
    if free is None:
        return jax.tree_util.tree_map(lambda _: True, params)
    if callable(free):
        none = jax.tree_util.tree_map(lambda _: False, params)
        return eqx.tree_at(free, none, replace_fn=lambda _: True)
    return free


class LeastSquaresSolution(eqx.Module):
    """What `least_squares` returns: the fitted `params` (free leaves at the optimum, the
    others as given), the `result` code (`optimistix.RESULTS`) and the solver's `stats`
    (`num_steps`)."""

    params: PyTree
    result: optx.RESULTS
    stats: dict

    @property
    def successful(self):
        return self.result == optx.RESULTS.successful


@eqx.filter_jit
def _solve(objective, free, static, solver, max_steps, jac):
    return optx.least_squares(lambda f, obj: obj.residuals(eqx.combine(f, static)),
                              solver, free, args=objective, max_steps=max_steps, throw=False,
                              options=dict(jac=jac))


def least_squares(objective: AbstractResiduals, params: PyTree, free=None, *,
                  rtol: float = 1e-10, atol: float = 1e-10, max_steps: int = 200,
                  jac: str = "fwd") -> LeastSquaresSolution:
    """Minimise `objective.residuals` over the leaves of `params` that `free` selects
    (`free_filter`), by `stickslip_jax.lsq.LevenbergMarquardt(rtol, atol)` in one compiled
    `optimistix.least_squares` (jit-compatible). `jac="bwd"` builds the Jacobian by
    reverse mode (residuals through a `jax.custom_vjp`). Never raises on a failed solve:
    read `result`."""
    free_part, static = eqx.partition(params, free_filter(params, free))
    sol = _solve(objective, free_part, static, LevenbergMarquardt(rtol=rtol, atol=atol),
                 max_steps, jac)
    return LeastSquaresSolution(eqx.combine(sol.value, static), sol.result, sol.stats)


@eqx.filter_jit
def jacobian(objective: AbstractResiduals, params: PyTree, free=None) -> Float[Array, "N P"]:
    """Jacobian [N, P] of `objective.residuals` against the free leaves (`free_filter`),
    flattened in leaf order (`jax.flatten_util.ravel_pytree`), by forward mode."""
    free_part, static = eqx.partition(params, free_filter(params, free))
    flat, unravel = ravel_pytree(free_part)
    return jax.jacfwd(lambda x: objective.residuals(eqx.combine(unravel(x), static)))(flat)
