"""Rate ramp: a steady drift of the bias in time, IEEE Std 952's R."""

from typing import ClassVar

import jax.numpy as jnp

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ._base import SlotTerm


class RateRamp(SlotTerm):
    """The bias changes at a constant rate R (unit/s): it adds R t to the mean, R / fs to the
    mean increment, and R^2 tau^2 / 2 to the Allan variance."""

    name: ClassVar[str] = "rate_ramp"
    explanation: ClassVar[str] = (
        "The bias drifts steadily in time, at a constant rate, independent of the temperature."
    )
    located_by: ClassVar[str] = "residual_time"
    band: ClassVar[str] = "low"
    parameter: ClassVar[str] = "R"

    @staticmethod
    def unit(channel_unit: str) -> str:
        per_second = {"deg/s": "deg/s^2", "rad/s": "rad/s^2", "m/s^2": "m/s^3"}
        return per_second.get(channel_unit, f"{channel_unit}/s")

    @staticmethod
    def allan_variance(tau, R):
        """R^2 tau^2 / 2 (IEEE Std 952, eq. C.14 squared)."""
        return R**2 * tau**2 / 2

    @staticmethod
    def sample(n, rate_hz, R):
        """R times the middle time of each sample period."""
        return R * (1.0 / rate_hz) * (jnp.arange(n) + 0.5)
