"""The two-position calibration model: each section reads offset ± g_local / scale plus the
stationary noise of :mod:`._noise_model`, whose parameters both sections share.

Given the noise, each section's level is Gaussian (its turn-on level, :mod:`._level`). When
both sections come from one file, the offset may drift between their starts by the noise
model's own slow terms over that time (:func:`offset_drift_variance`); the offset
reported is the one at the start of the up section (the turn-on convention). g_local keeps its
prior: the data cannot tell it from the scale.
"""

from ._terms import TERMS


def offset_drift_variance(gap_s: float, values: dict, rate_hz: float, terms) -> object:
    """Variance of the noise level's change over ``gap_s`` seconds under the noise ``values``
    (parameters by name; arrays broadcast) of ``terms``: each term's
    :meth:`~bayescal.models.effects._base.NoiseTerm.level_change_variance` (K^2 t for the
    random walk, flicker's structure function, nothing for the stationary terms)."""
    return sum(TERMS[name].level_change_variance(gap_s, values, rate_hz) for name in terms)
