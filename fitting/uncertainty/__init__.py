"""How sure a fit is: Laplace covariance and identifiability (`laplace`), posterior
sampling with emcee (`mcmc`) and the adequacy of the fitted model (`adequacy`)."""
