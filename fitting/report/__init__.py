"""What a fit says: one row per estimated parameter (`rows`), the fit's table and JSON
document (`fit_table`), the posterior's document (`mcmc_document`), discovery's answer
and document (`discovery_text`) and the figures (`plots`, `posterior_plots`)."""
