"""Bayesian inference: the likelihood (vectorised over parameter sets), prior overrides, the emcee
driver with checkpoints, and the frozen posterior record with its ArviZ DataTree."""
