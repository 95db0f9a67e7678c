"""Layer 4, navigation: what a strapdown inertial navigation system computes and how its
errors grow. Frames and the WGS-84 Earth (:mod:`._earth`), rotations (:mod:`._frames`), the
strapdown mechanization (:mod:`._strapdown`), the phi-angle error model (:mod:`._error_model`),
a linear-Gaussian Kalman filter and RTS smoother with its log-likelihood (:mod:`._kalman`),
the fine alignment at rest and the patent's tilt-rate pipeline (:mod:`._alignment`,
:mod:`._tilt_rates`), the strapdown scenario simulator (:mod:`._simulate`), and how soon a
filter's aiding reveals a bias (:mod:`._aiding`). Imports the
layers below it (recording, classical, models), nothing above.

The public names are re-exported by :mod:`bayescal`; this package's modules are private.
"""
