"""The two-position calibration model: each section reads offset ± g_local / scale plus the
stationary noise of :mod:`._noise_model`, whose parameters both sections share.

Given the noise, each section's level is Gaussian (its turn-on level, :mod:`._level`). When
both sections come from one file, the offset may drift between their starts by the noise
model's own random walk and flicker over that time (:func:`offset_drift_weights`); the offset
reported is the one at the start of the up section (the turn-on convention). g_local keeps its
prior: the data cannot tell it from the scale.
"""

import numpy as np

from ._components import SPECTRAL_COMPONENTS
from .effects.bias_instability import BiasInstability


def offset_drift_weights(gap_s: float, rate_hz: float) -> np.ndarray:
    """Variance of the noise level's change over ``gap_s`` seconds per unit weight of each
    spectral component: t for the random walk (K^2 t), flicker's structure function at
    h = t fs samples, nothing for the stationary terms."""
    weights = dict.fromkeys(SPECTRAL_COMPONENTS, 0.0)
    weights["bias_instability"] = BiasInstability.structure_function(gap_s * rate_hz)
    weights["rate_random_walk"] = gap_s
    return np.array([weights[name] for name in SPECTRAL_COMPONENTS])
