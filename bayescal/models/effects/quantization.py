"""Quantization noise: white angle (or velocity) noise, IEEE Std 952's Q."""

import math
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ...classical._noise import IEEE952_READINGS
from ._base import NoiseTerm, moving_average
from ._parameter import Parameter


class Quantization(NoiseTerm):
    """White noise of the integrated signal (the angle or velocity increment) of variance Q^2
    per sample, Q in unit·s: each rate sample carries the difference of two such errors over
    its period, so its increments are a moving average of order 2 and the Allan variance
    falls as 3 Q^2 / tau^2."""

    name: ClassVar[str] = "quantization"
    explanation: ClassVar[str] = (
        "The output is rounded to the converter's resolution (LSB): the samples sit on "
        "discrete levels, and the rounding adds white noise of LSB/sqrt(12) per sample; white "
        "angle (velocity) noise beyond it, IEEE 952's Q, makes the spectrum rise toward "
        "Nyquist and the Allan deviation fall as 1/tau at short tau."
    )
    located_by: ClassVar[str] = "discrete_levels"
    band: ClassVar[str] = "high"
    aliases: ClassVar[tuple[str, ...]] = ("q", "white_angle")
    parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter(
            "Q",
            "quantization (white angle noise)",
            time_power=1.0,
            datasheet=True,
        ),
    )
    streams: ClassVar[tuple[int, ...]] = (4,)
    reading: ClassVar[object] = IEEE952_READINGS["Q"]
    classical_caveat: ClassVar[str] = "the -1 stretch of the Allan curve also carries white noise"
    lsb: float = 0.0
    """The grid the samples sit on, when discovery named it from the samples themselves (its
    rounding, LSB^2 / 12 per sample, is then a known white floor of every model); zero for
    the white angle noise Q, the slot term."""

    def describe(self, finding, posterior, search) -> dict:
        """The grid's LSB and what its rounding adds (white, per sample and as a density), or
        the white angle noise Q beyond it."""
        if self.lsb == 0:
            return super().describe(finding, posterior, search)
        unit, rate = search.data.unit, search.data.rate_hz
        return {
            "lsb": {"value": self.lsb, "unit": unit},
            "rounding_sd": {"value": self.lsb / math.sqrt(12.0), "unit": unit},
            "rounding_density": {
                "value": self.lsb / math.sqrt(12.0 * rate),
                "unit": f"{unit}/sqrt(Hz)",
            },
        }

    @property
    def decided_before_search(self) -> bool:
        return self.lsb > 0  # the grid's step, read from the samples

    @classmethod
    def components(cls, context) -> tuple:
        return (cls,)

    @classmethod
    def weights(cls, values, components):
        """Q^2."""
        return jnp.asarray(values["Q"] ** 2)[..., None]

    @staticmethod
    def spectrum(nu, rate_hz):
        sin2 = jnp.sin(jnp.pi * nu) ** 2
        return 16 * sin2 * sin2 * rate_hz**2

    @staticmethod
    def autocovariance(lags, rate_hz):
        return rate_hz**2 * moving_average(lags, (6.0, -4.0, 1.0))

    @staticmethod
    def block_covariance(start, stop, rate_hz):
        """The block mean of (e_{k+1} - e_k) / period over [a, b) is (e_b - e_a) / (m period):
        Q^2 fs^2 / (m_i m_j) at each block end two blocks share."""
        size = (stop - start).astype(float)
        shared = (
            np.equal.outer(stop, stop).astype(float)
            - np.equal.outer(stop, start)
            - np.equal.outer(start, stop)
            + np.equal.outer(start, start)
        )
        return rate_hz**2 * shared / np.outer(size, size)

    @classmethod
    def allan_variance(cls, tau, values, rate_hz):
        """3 Q^2 / tau^2 (IEEE Std 952, eq. C.2 squared)."""
        return 3 * values["Q"] ** 2 / tau**2

    @classmethod
    def allan_exponents(cls, tau, values, rate_hz):
        return [(2, cls.allan_variance(tau, values, rate_hz))]

    @classmethod
    def sample(cls, keys, n, rate_hz, values):
        """Quantization of the integrated signal: a uniform error of variance Q^2 per sample,
        differenced over each period."""
        key = keys[cls.streams[0]]
        phase_error = jax.random.uniform(key, (n + 1,), minval=-0.5, maxval=0.5)
        return values["Q"] * math.sqrt(12.0) * jnp.diff(phase_error) / (1.0 / rate_hz)
