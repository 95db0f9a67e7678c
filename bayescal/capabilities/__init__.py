"""Layer 6, capabilities: one function per thing a user does — fit a channel's noise,
calibrate an accelerometer (two-position, multi-position), fit and update a thermal
calibration and update it from a strapdown system's own alignment, discover what a model left
out — each returning one typed, immutable result. Imports the layers below it (recording,
classical, models, navigation, inference), nothing above.

The public names are re-exported by :mod:`bayescal`; this package's modules are private.
"""
