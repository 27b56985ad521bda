"""Design studies: maps (`maps`, `chunks`, `sharding`; `design_map`), posterior
propagation (`uncertainty`; `propagate`, samples read by `posterior.load_samples`),
inverse design by Newton through the steady analysis (`inverse`; `minimum_stiffness`,
`maximum_weight`) and experiment design (`experiment`; `greedy_design`,
`sequential_campaign`). Units: kgf, mm, s; speeds mm/s.
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
