"""`stickslip` subcommands of the fitting package (fit, mcmc, design, plan, discover, pitch)."""
