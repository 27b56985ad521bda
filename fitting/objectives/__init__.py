"""Objectives: whitened residuals of the campaign parameters (cycle features, every
sample through the exact or the smoothed simulator, their weighted sums) and the robust
losses that transform them."""
