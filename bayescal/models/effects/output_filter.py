"""The sensor's output filter: the digital low-pass most MEMS parts apply before decimating,
which shapes the white noise (../shared/DESIGN.md, ``output_filter``).

Three shapes, each with unit gain at zero frequency, so that N stays the low-frequency density
the Allan curve reads (IEEE Std 952) whatever the filter does near Nyquist:

- ``one_tap``: (1 + F z^-1) / (1 + F), one coefficient F in (-1, 1) — a mild smoothing (the
  ADIS16405's 100 Hz output: lag-1 autocorrelation 0.17, half the power at Nyquist). Exact in
  the likelihood: a lag-one component of the white noise.
- ``decimation``: a cascade of moving averages, |H|^2 = [sin(pi nu M) / (M sin(pi nu))]^(2p),
  the length M (samples) and the number of stages p continuous — the Bartlett and CIC (sinc^p)
  filters of decimating MEMS converters (the ADIS16405's 819 Hz output: M = 4, p = 2).
- ``butterworth``: |H|^2 = 1 / (1 + (w(f) / w(f_c))^(2n)), w(f) = tan(kappa pi f / fs), the
  cutoff f_c (Hz, below Nyquist), the order n > 1 and the warping kappa in (0, 1) continuous — the
  low-pass of consumer parts' configurable bandwidths. kappa = 1 is a digital Butterworth
  (bilinear transform) running at the output rate, with its zero at Nyquist; kappa -> 0 is
  (f / f_c)^(2n), one running far faster than the output is decimated to (or an analogue
  one), whose response has no zero and falls at most 2n decades of power per decade of
  frequency. Records show either: a 1 kHz filter read at 200 Hz, or one read at its rate and
  rounded (the rounding fills its zero).

The two low-pass shapes multiply the white noise's spectrum (the expected periodogram at each
bin's nodes, :func:`bayescal.models._whittle._bin_coefficients`): exact where the shape
varies slowly over the taper's spectral window (a few Fourier frequencies), which it does. A
rounding floor (the samples' LSB, :mod:`.quantization`) comes after the filter and is not
shaped.
"""

import math
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from .._terms import LOWPASS_PARAMETERS
from ._base import NoiseTerm, moving_average

LOWPASS_UNITS = {
    "filter_length": "samples",
    "filter_stages": "1",
    "filter_cutoff": "Hz",
    "filter_order": "1",
    "filter_warping": "1",
}


def lowpass_gain(shape: str, nu, coordinates):
    """|H|^2 of a low-pass shape at ``nu`` cycles per sample from its sampled coordinates:
    decimation (a, b): M = 1 + e^a, p = e^b; Butterworth (a, b, c): nu_c = sigmoid(a) / 2,
    n = 1 + e^b (a
    Butterworth filter is at least first order), kappa = sigmoid(c) (module docstring)."""
    if shape == "decimation":
        a, b = coordinates
        length, stages = 1.0 + jnp.exp(a), jnp.exp(b)
        ratio = jnp.sin(jnp.pi * nu * length) / (length * jnp.sin(jnp.pi * nu))
        return jnp.exp(stages * jnp.log(ratio * ratio + 1e-300))
    a, b, c = coordinates
    cutoff, order, warping = 0.5 * jax.nn.sigmoid(a), 1.0 + jnp.exp(b), jax.nn.sigmoid(c)
    ratio = jnp.tan(warping * jnp.pi * nu) / jnp.tan(warping * jnp.pi * cutoff)
    return 1.0 / (1.0 + jnp.exp(2.0 * order * jnp.log(ratio)))


def lowpass_natural(shape: str, coordinates, rate_hz: float) -> dict:
    """The shape's parameters in their units (samples, 1, Hz) from its coordinates."""
    if shape == "decimation":
        a, b = coordinates
        return {"filter_length": 1.0 + jnp.exp(a), "filter_stages": jnp.exp(b)}
    a, b, c = coordinates
    return {
        "filter_cutoff": 0.5 * jax.nn.sigmoid(a) * rate_hz,
        "filter_order": 1.0 + jnp.exp(b),
        "filter_warping": jax.nn.sigmoid(c),
    }


def _logit(fraction: float) -> float:
    return math.log(fraction / (1.0 - fraction))


def lowpass_coordinates(shape: str, values: dict, rate_hz: float) -> tuple[float, ...]:
    """The inverse of :func:`lowpass_natural`."""
    if shape == "decimation":
        return math.log(values["filter_length"] - 1.0), math.log(values["filter_stages"])
    return (
        _logit(2.0 * values["filter_cutoff"] / rate_hz),
        math.log(values["filter_order"] - 1.0),
        _logit(values["filter_warping"]),
    )


class OutputFilter(NoiseTerm):
    """The sensor's output filter (module docstring). As a noise term with the exact one-tap
    shape, it is the lag-one part of the filtered white noise, weight N^2 a b with (a, b) =
    (1, F) / (1 + F); an instance with ``shape`` "decimation" or "butterworth" holds the
    low-pass's parameters in their units (``length`` and ``stages``, or ``cutoff_hz``,
    ``order`` and ``warping``). Left out, a model explains the fall of the spectrum toward
    Nyquist with flicker or quantization, and bends N."""

    name: ClassVar[str] = "output_filter"
    explanation: ClassVar[str] = (
        "The sensor low-pass filters its output before decimating: the white noise is "
        "smoothed, its spectrum falls toward the Nyquist frequency and neighbouring samples "
        "are positively correlated."
    )
    located_by: ClassVar[str] = "spectrum_bands"
    band: ClassVar[str] = "high"
    parameter: ClassVar[str] = "F"
    long_memory: ClassVar[bool] = False
    shape: str = "one_tap"
    coefficient: float = 0.0
    """The one-tap shape's F (discovery's filter; a noise model carries its own F)."""
    length: float = 0.0
    stages: float = 0.0
    cutoff_hz: float = 0.0
    order: float = 0.0
    warping: float = 1e-3

    def __check_init__(self):
        if self.shape not in ("one_tap", *LOWPASS_PARAMETERS):
            raise ValueError(f"shape={self.shape!r}: one_tap, decimation or butterworth")
        if self.shape == "decimation" and not (self.length > 1 and self.stages > 0):
            raise ValueError("a decimation filter needs length > 1 sample and stages > 0")
        if self.shape == "butterworth" and not (
            self.cutoff_hz > 0 and self.order > 1 and 0 < self.warping < 1
        ):
            raise ValueError(
                "a Butterworth filter needs cutoff_hz > 0, order > 1 and warping in (0, 1)"
            )

    def gain(self, nu, rate_hz: float):
        """|H|^2 at ``nu`` cycles per sample: (1 + F^2 + 2 F cos 2 pi nu) / (1 + F)^2 for the
        one-tap shape with its ``coefficient`` F, the low-pass's otherwise."""
        if self.shape == "one_tap":
            F = self.coefficient
            return (1 + F * F + 2 * F * jnp.cos(2 * jnp.pi * jnp.asarray(nu))) / (1 + F) ** 2
        values = (
            {"filter_length": self.length, "filter_stages": self.stages}
            if self.shape == "decimation"
            else {
                "filter_cutoff": self.cutoff_hz,
                "filter_order": self.order,
                "filter_warping": self.warping,
            }
        )
        coordinates = lowpass_coordinates(self.shape, values, rate_hz)
        return lowpass_gain(self.shape, jnp.asarray(nu, dtype=float), coordinates)

    def apply(self, samples, rate_hz: float):
        """``samples`` (JAX, last axis time) through the low-pass, zero phase: each Fourier
        coefficient times sqrt|H|^2. Circular: pass a record twice the length needed and keep
        the first half, so that no sample is filtered with the record's other end."""
        length = samples.shape[-1]
        nu = jnp.maximum(jnp.fft.rfftfreq(length), 1e-12)  # the gain is 1 at zero frequency
        shaped = jnp.fft.rfft(samples, axis=-1) * jnp.sqrt(self.gain(nu, rate_hz))
        return jnp.fft.irfft(shaped, length, axis=-1)

    def shaped_allan_variance(self, tau, N, rate_hz: float):
        """The Allan variance of white noise of density N through the low-pass: N^2 fs times
        the integral of |H|^2 against the Allan filter 2 sin^4(pi m nu) / (m^2 sin^2(pi nu))
        (m = tau fs), which is N^2 / tau without the filter; numerically, the oscillating
        kernel replaced by its mean 3 / (4 m^2 sin^2(pi nu)) where the gain falls (beyond 64
        samples an average spans many of its periods, above nu = 1 / (2 m))."""
        nu = (np.arange(1, 8193) - 0.5) / 16384  # midpoints on (0, 1/2)
        loss = 1.0 - np.asarray(self.gain(nu, rate_hz))
        m = np.atleast_1d(np.asarray(tau, dtype=float) * rate_hz)
        sin2 = np.sin(np.pi * nu) ** 2
        exact = 2 * np.sin(np.pi * np.outer(m, nu)) ** 4 / (m[:, None] ** 2 * sin2)
        averaged = 3.0 / (4.0 * m[:, None] ** 2 * sin2)
        # Below nu = 1 / (2 m) the kernel does not oscillate (and its mean would overstate it).
        oscillating = (m[:, None] > 64) & (np.outer(m, nu) > 0.5)
        kernel = np.where(oscillating, averaged, exact)
        # Both halves of the band: twice the integral over (0, 1/2).
        lost = 2 * np.sum(loss * kernel, axis=1) / 16384
        return (N**2 / m - N**2 * lost) * rate_hz

    @staticmethod
    def unit(channel_unit: str) -> str:
        return "1"  # the filter's coefficient is a pure number

    def describe(self, finding, posterior, search) -> dict:
        """The shape's parameters, decided before the search (MAP with Laplace intervals)."""
        return finding.search["parameters"]

    @property
    def decided_before_search(self) -> bool:
        return True

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
