"""Layer 5, inference: the one MAP + Laplace routine, emcee sampling and the health checks
every posterior passes, priors (weakly informative, or from a sensor card), posterior
summaries and ArviZ data, and the predictive bands a fitted model draws. Imports the layers
below it (recording, classical, models, navigation), nothing above.

The public names are re-exported by :mod:`bayescal`; this package's modules are private.
"""
