"""fitting: parameter identification, design studies and the missing-physics workflow for stickslip_jax.

Gradient fitting (optimistix) and MCMC (emcee) of friction parameters from measured
stick-slip records. Importing it enables `jax_enable_x64` through `stickslip_jax`.
"""

import stickslip_jax  # noqa: F401  (enables x64)
