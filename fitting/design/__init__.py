"""Design studies: maps, devices, uncertainty propagation, inverse and experiment design.

- `design_map(friction, W, k, v)`: steady (or exact time-domain) stick-slip over a
  broadcast grid/sample of friction parameters, W (kgf), k (kgf/mm), v (mm/s);
  chunked, jit+vmap, sharded over all devices (`maps`, `chunks`, `sharding`).
- `propagate(sample, W, k, v)`: probability of stick-slip and credible bands of v_c and
  a from a posterior sample (`uncertainty`, samples read by `posterior.load_samples`).
- `minimum_stiffness`, `maximum_weight`: inverse design by Newton through the steady
  analysis (`inverse`).
- `fisher_information`, `greedy_design`: D-optimal choice of the next records,
  `laplace_fit` (objective `SteadyObservables`) and `sequential_campaign` to check a
  plan on synthetic data (`experiment`).

`method="exact"` maps use `exact.exact_kernel` (the limit cycle of
`stickslip_jax.simulation.simulate_exact`). Units: kgf, mm, s; speeds mm/s.
"""

__all__ = ["Campaign", "LaplaceFit", "Noise", "Plan", "SteadyObservables", "TanhBounded",
           "candidate_grid", "even_design", "fisher_information", "friction_of", "greedy_design",
           "laplace_fit", "log_params", "observables", "posterior_sd", "prior_precision",
           "record_information", "sequential_campaign", "simulate_observations", "PARAMETERS",
           "DesignMap", "DesignPoints", "InverseDesign", "UncertainMap", "batch_mesh", "collect",
           "design_map", "design_points", "friction_from_params", "friction_params",
           "iter_design_map", "load_samples", "map_chunks", "maximum_weight", "minimum_stiffness",
           "outer", "pad_batch", "propagate", "replicate", "samples_from_csv", "samples_from_json",
           "save_samples", "shard_batch", "to_host"]

from .chunks import collect, map_chunks
from .experiment import (Campaign, LaplaceFit, Noise, Plan, SteadyObservables, TanhBounded,
                         candidate_grid, even_design, fisher_information, friction_of,
                         greedy_design, laplace_fit, log_params, observables, posterior_sd,
                         prior_precision, record_information, sequential_campaign,
                         simulate_observations)
from .inverse import InverseDesign, maximum_weight, minimum_stiffness
from .maps import DesignMap, DesignPoints, design_map, design_points, iter_design_map, outer
from .posterior import (PARAMETERS, friction_from_params, friction_params, load_samples,
                        samples_from_csv, samples_from_json, save_samples)
from .sharding import batch_mesh, pad_batch, replicate, shard_batch, to_host
from .uncertainty import UncertainMap, propagate
