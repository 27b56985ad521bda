r"""The objective interface and the least-squares verb over any parameter pytree.

Every objective of the package is an `AbstractResiduals` (an `eqx.Module`):
`residuals(params)`, the whitened residual vector (sum of squares = $-2\log$ likelihood
up to a constant; a Gaussian prior enters as extra residuals); `blocks()`, named lengths
of that vector in order (`split(r)` cuts by them, so reports never slice by position);
`dof()`, the (weighted) number of residuals that carry data. Final objectives: the
campaign objectives (`objectives.combined.AbstractObjective`), `solve.pitch.PitchObjective`
and `design.experiment.SteadyObservables`.

An objective is also the residual function of the one least-squares verb,
`stickslip_jax.lsq.least_squares` (re-exported here with `LeastSquaresSolution` and
`free_filter`), which minimises it over the leaves `free` selects (a `where` function like
`eqx.tree_at`'s, a boolean filter spec, or None: every array leaf); `linearise=True` also
returns the residuals and Jacobian at the optimum. `solve.fit.fit_objective` adds
multi-start and reweighting rounds around it.

```python
sol = least_squares(PitchObjective(template, batch, scale), params, spec)
sol.params, sol.result          # fitted pytree, optimistix result code
```
"""

from __future__ import annotations

import abc

import equinox as eqx
import numpy as np
from jaxtyping import Array, Float

from stickslip_jax.lsq import LeastSquaresSolution, free_filter, least_squares

__all__ = ["AbstractResiduals", "LeastSquaresSolution", "free_filter", "least_squares"]


class AbstractResiduals(eqx.Module):
    """An objective: whitened residuals of a parameter pytree (module doc)."""

    def __call__(self, params, args=None) -> Float[Array, " N"]:
        """The residuals: an objective is the residual function of `least_squares`."""
        return self.residuals(params)

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

