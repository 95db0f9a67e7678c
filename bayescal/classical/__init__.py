"""Layer 2, classical estimators, array-first: the Allan family with its equivalent degrees of
freedom and intervals, the Student-t interval and its validity, the IEEE Std 952 slope
readings, local gravity, and the least-squares calibrations (two-position, multi-position,
thermal bins). Imports only :mod:`bayescal.recording` of bayescal.

The public names are re-exported by :mod:`bayescal`; this package's modules are private.
"""
