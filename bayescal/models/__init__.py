"""Layer 3, probabilistic models: each a parameter set whose simulator and likelihood share
it. The stationary noise of a channel (:class:`~bayescal.NoiseModel`, its Whittle likelihood
and the covariance of its block means), the effect catalogue of ../shared/DESIGN.md (one class
per effect in :mod:`.effects`), the composite model discovery grows, and the calibration
models (two-position, multi-position, thermal). Imports :mod:`bayescal.recording` and
:mod:`bayescal.classical` of bayescal, nothing above.

The public names are re-exported by :mod:`bayescal`; this package's modules are private.
"""
