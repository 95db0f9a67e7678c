"""The sensor's output filter: the digital low-pass most MEMS parts apply before decimating,
which shapes the white noise (../shared/DESIGN.md, ``output_filter``)."""

from typing import ClassVar

import jax.numpy as jnp
import numpy as np

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ._base import NoiseTerm, moving_average


class OutputFilter(NoiseTerm):
    """The white noise leaves the sensor through (1 + F z^-1) / (1 + F): unit gain at low
    frequency (N stays the noise density the Allan curve reads), less power near Nyquist.
    F (dimensionless, in (-1, 1)) is its parameter; this term is the lag-one part of the
    filtered white noise, weight N^2 a b with (a, b) = (1, F) / (1 + F). The ADIS16405's
    output, for one, has a lag-1 autocorrelation of 0.17; left out, a model explains the fall
    of the spectrum toward Nyquist with flicker or quantization."""

    name: ClassVar[str] = "output_filter"
    explanation: ClassVar[str] = (
        "The sensor low-pass filters its output before decimating: the white noise is "
        "smoothed, its spectrum falls toward the Nyquist frequency and neighbouring samples "
        "are positively correlated."
    )
    located_by: ClassVar[str] = "spectrum_bands"
    parameter: ClassVar[str] = "F"
    long_memory: ClassVar[bool] = False

    @staticmethod
    def unit(channel_unit: str) -> str:
        return "1"  # the filter's coefficient is a pure number

    @staticmethod
    def taps(F):
        """The filter's taps (a, b) = (1, F) / (1 + F)."""
        return 1.0 / (1.0 + F), F / (1.0 + F)

    @staticmethod
    def weight(N, taps):
        """Weight of the component: N^2 a b, (a, b) = :meth:`taps`."""
        a, b = taps
        return N**2 * a * b

    @staticmethod
    def spectrum(nu, rate_hz):
        return 8 * jnp.sin(jnp.pi * nu) ** 2 * jnp.cos(2 * jnp.pi * nu) * rate_hz

    @staticmethod
    def autocovariance(lags, rate_hz):
        return rate_hz * moving_average(lags, (-2.0, 2.0, -1.0))

    @staticmethod
    def block_covariance(start, stop, rate_hz):
        """Pairs of neighbouring samples two blocks share: 2 (m - 1) within a block, one across
        a block boundary."""
        size = (stop - start).astype(float)
        touching = np.equal.outer(stop, start) | np.equal.outer(start, stop)
        return rate_hz * (np.diag(2.0 * (size - 1)) + touching) / np.outer(size, size)

    @staticmethod
    def allan_variance(tau, N, F, rate_hz):
        """3 N^2 b (b - 1) / (fs tau^2), b = F / (1 + F): the filter's change to the white
        noise's Allan variance, which dies out as 1 / tau^2."""
        lag = F / (1.0 + F)
        return 3 * N**2 * lag * (lag - 1) / (rate_hz * tau**2)
