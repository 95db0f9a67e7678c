"""White noise of the rate: angle (gyro) or velocity (accelerometer) random walk, IEEE Std 952's
N. The term every model of a channel holds."""

import math
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ...classical._noise import IEEE952_READINGS
from ._base import NoiseTerm, moving_average
from ._parameter import Parameter


class White(NoiseTerm):
    """White noise of density N (unit/√Hz): per-sample variance N² fs; its increments are a
    moving average of order 1. Through the sensor's output filter (:class:`OutputFilter`) the
    samples are ``(w_k + F w_{k-1}) / (1 + F)``; this term keeps the filter's lag-zero part
    and the filter the lag-one part, so that N stays the low-frequency density the Allan
    curve reads (:class:`~bayescal.models.effects.output_filter.OutputFilter`)."""

    name: ClassVar[str] = "white"
    explanation: ClassVar[str] = (
        "White noise of the rate: averaging over tau reduces it as 1/sqrt(tau), the -1/2 slope "
        "of the Allan deviation (angle or velocity random walk)."
    )
    located_by: ClassVar[str] = "allan_deviation"
    band: ClassVar[str] = "high"
    aliases: ClassVar[tuple[str, ...]] = ("n", "arw", "vrw")
    parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter(
            "N",
            "white noise density",
            time_power=0.5,
            datasheet=True,
        ),
    )
    candidate: ClassVar[bool] = False
    filtered: ClassVar[bool] = True
    streams: ClassVar[tuple[int, ...]] = (0,)
    reading: ClassVar[object] = IEEE952_READINGS["N"]
    classical_caveat: ClassVar[str] = (
        "at tau = 1 s the -1/2 line also carries the other terms, which the model separates"
    )
    card_entries: ClassVar[tuple[str, ...]] = (
        "noise_density",
        "angle_random_walk",
        "velocity_random_walk",
    )

    @classmethod
    def components(cls, context) -> tuple:
        return (cls,)

    @classmethod
    def weights(cls, values, components):
        """N^2 (a^2 + b^2), (a, b) the one-tap output filter's taps
        (:meth:`OutputFilter.taps`; (1, 0) without one)."""
        a, b = taps(values.get("F", 0.0))
        return jnp.asarray(values["N"] ** 2 * (a * a + b * b))[..., None]

    @staticmethod
    def spectrum(nu, rate_hz):
        """Two-sided spectrum of the increments per unit weight, per cycle per sample."""
        return 4 * jnp.sin(jnp.pi * nu) ** 2 * rate_hz

    @staticmethod
    def autocovariance(lags, rate_hz):
        return rate_hz * moving_average(lags, (2.0, -1.0))

    @staticmethod
    def block_covariance(start, stop, rate_hz):
        """Block means of white samples: variance fs / m, independent blocks."""
        return np.diag(rate_hz / (stop - start).astype(float))

    @classmethod
    def allan_variance(cls, tau, values, rate_hz):
        """N^2 / tau (IEEE Std 952, eq. C.5 squared)."""
        return values["N"] ** 2 / tau

    @classmethod
    def allan_exponents(cls, tau, values, rate_hz):
        return [(0, cls.allan_variance(tau, values, rate_hz))]

    @classmethod
    def sample(cls, keys, n, rate_hz, values):
        """``n`` samples of white noise of density N through the one-tap output filter F (a
        low-pass shape is applied by the model, which draws twice the samples for it)."""
        F = values.get("F", 0.0)
        white = jax.random.normal(keys[cls.streams[0]], (n + 1,))
        white = (white[1:] + F * white[:-1]) / (1.0 + F)
        return values["N"] * math.sqrt(rate_hz) * white


def taps(F):
    """The one-tap output filter's taps (a, b) = (1, F) / (1 + F): the samples are
    a w_k + b w_{k-1} (:class:`~bayescal.models.effects.output_filter.OutputFilter`)."""
    return 1.0 / (1.0 + F), F / (1.0 + F)
