"""White noise of the rate: angle (gyro) or velocity (accelerometer) random walk, IEEE Std 952's
N. The term every model of a channel holds."""

import math
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ._base import NoiseTerm, moving_average


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
    parameter: ClassVar[str] = "N"
    long_memory: ClassVar[bool] = False

    @staticmethod
    def unit(channel_unit: str) -> str:
        return f"{channel_unit}/sqrt(Hz)"

    @staticmethod
    def weight(N, taps=(1.0, 0.0)):
        """Weight of the component: N^2 (a^2 + b^2), (a, b) the output filter's taps
        (:meth:`OutputFilter.taps`; none by default)."""
        a, b = taps
        return N**2 * (a * a + b * b)

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

    @staticmethod
    def allan_variance(tau, N):
        """N^2 / tau (IEEE Std 952, eq. C.5 squared)."""
        return N**2 / tau

    @staticmethod
    def sample(key, n, rate_hz, N, F=0.0):
        """``n`` samples of white noise of density N through the output filter F."""
        white = jax.random.normal(key, (n + 1,))
        white = (white[1:] + F * white[:-1]) / (1.0 + F)
        return N * math.sqrt(rate_hz) * white
