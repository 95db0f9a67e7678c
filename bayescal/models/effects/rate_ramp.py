"""Rate ramp: a steady drift of the bias in time, IEEE Std 952's R."""

import math
from typing import ClassVar

import jax.numpy as jnp

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ...classical._noise import LineReading
from ._base import NoiseTerm
from ._parameter import Parameter

RAMP_PRIOR_FACTOR = 10.0
"""The ramp's prior sd, in multiples of the drift that would explain the whole Allan
deviation at the longest tau."""
_RAMP_LINE = LineReading(1.0, 1.0 / math.sqrt(2.0), "+1 line, extrapolated to tau = sqrt(2) s")
"""The ramp's line of the Allan deviation, R tau / sqrt(2) (IEEE Std 952, eq. C.14)."""


class RateRamp(NoiseTerm):
    """The bias changes at a constant rate R (unit/s): it adds R t to the mean, R / fs to the
    mean increment, and R^2 tau^2 / 2 to the Allan variance."""

    name: ClassVar[str] = "rate_ramp"
    explanation: ClassVar[str] = (
        "The bias drifts steadily in time, at a constant rate, independent of the temperature."
    )
    located_by: ClassVar[str] = "residual_time"
    band: ClassVar[str] = "low"
    aliases: ClassVar[tuple[str, ...]] = ("ramp", "r")
    parameters: ClassVar[tuple[Parameter, ...]] = (
        # Normal around zero, its sd RAMP_PRIOR_FACTOR times the Allan curve's bound, sampled
        # in units of that sd.
        Parameter(
            "R",
            "rate ramp",
            time_power=-1.0,
            link="linear",
            span="linear_scale",
            prior=(0.0, 1.0),
            datasheet=True,
        ),
    )
    mean_rate: ClassVar[str] = "R"

    @classmethod
    def reference_scales(cls, allan) -> dict[str, float]:
        """The ramp's prior scale: RAMP_PRIOR_FACTOR times the drift the Allan curve bounds."""
        return {"R": RAMP_PRIOR_FACTOR * _RAMP_LINE.bound(allan)}

    @classmethod
    def allan_variance(cls, tau, values, rate_hz):
        """R^2 tau^2 / 2 (IEEE Std 952, eq. C.14 squared)."""
        return values["R"] ** 2 * tau**2 / 2

    @classmethod
    def allan_exponents(cls, tau, values, rate_hz):
        # A drift counts as a random walk for the EDF (the nearest power law it has).
        return [(-2, cls.allan_variance(tau, values, rate_hz))]

    @classmethod
    def sample(cls, keys, n, rate_hz, values):
        """R times the middle time of each sample period."""
        return values["R"] * (1.0 / rate_hz) * (jnp.arange(n) + 0.5)
