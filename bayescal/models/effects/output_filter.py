"""The sensor's output filter: the digital low-pass most MEMS parts apply before decimating,
which shapes the white noise (../shared/DESIGN.md, ``output_filter``).

Four shapes, each with unit gain at zero frequency, so that N stays the low-frequency density
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
- ``biquad``: a second-order section, |H|^2 = (|B(z)|^2 / B(1)^2) / (|A(z)|^2 / A(1)^2) with
  A(z) = 1 + a1 z^-1 + a2 z^-2 and B likewise, each given by two reflection coefficients
  (k1, k2) in (-1, 1) and scaled to the radius rho = 0.9: a2 = rho^2 k2, a1 = rho k1 (1 + k2),
  so that every value is a stable, minimum-phase section whose poles and zeros all lie within
  0.9 of the origin. The radius keeps them off z = 1: a pole or zero near zero frequency gives
  unit gain at f = 0 but a step just above it, a slow term in disguise (a pole at 0.99 beside
  one at -0.89 is a Gauss-Markov process) that would move the level the Allan curve reads. A
  real pole of 0.9 has its corner at fs / 60, a second-order Butterworth of radius 0.9 its
  cutoff at fs / 40; below those the ``butterworth`` shape holds the filter, and a digital
  Butterworth's zeros at Nyquist too. The biquad holds the one-tap filter and, what neither
  the decimation nor the Butterworth shape holds, a second-order filter running faster than
  the output and read without a further anti-alias filter: decimating an ARMA process keeps
  it ARMA, its poles raised to the decimation factor (so well inside the radius), and a
  second-order Butterworth read at a fifth of its rate folds its tail back near Nyquist,
  flattening the spectrum there (its derivative is zero at Nyquist, as every |H|^2 of cosines
  has).

The three low-pass shapes multiply the white noise's spectrum (the expected periodogram at each
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
    "filter_pole_k1": "1",
    "filter_pole_k2": "1",
    "filter_zero_k1": "1",
    "filter_zero_k2": "1",
}


BIQUAD_RADIUS = 0.9
"""The largest radius of a biquad's poles and zeros (module docstring)."""


def reflection(x):
    """A biquad's reflection coefficient in (-1, 1) from its coordinate: tanh."""
    return jnp.tanh(x)


def reflection_coordinate(k: float) -> float:
    """The inverse of :func:`reflection`."""
    return math.atanh(k)


def _section_power(k1, k2, nu):
    """|C(e^(2 pi i nu))|^2 / C(1)^2 of C(z) = 1 + c1 z^-1 + c2 z^-2 given by its reflection
    coefficients (k1, k2) at the radius rho: c2 = rho^2 k2, c1 = rho k1 (1 + k2)."""
    c1, c2 = BIQUAD_RADIUS * k1 * (1.0 + k2), BIQUAD_RADIUS**2 * k2
    omega = 2.0 * jnp.pi * nu
    power = 1.0 + c1 * c1 + c2 * c2 + 2.0 * c1 * (1.0 + c2) * jnp.cos(omega)
    power = power + 2.0 * c2 * jnp.cos(2.0 * omega)
    return power / (1.0 + c1 + c2) ** 2


def lowpass_gain(shape: str, nu, coordinates):
    """|H|^2 of a low-pass shape at ``nu`` cycles per sample from its sampled coordinates:
    decimation (a, b): M = 1 + e^a, p = e^b; Butterworth (a, b, c): nu_c = sigmoid(a) / 2,
    n = 1 + e^b (a
    Butterworth filter is at least first order), kappa = sigmoid(c); biquad (a, b, c, d): the
    reflection coefficients :func:`reflection` of each, (a, b) of the poles, (c, d) of the
    zeros (module docstring)."""
    if shape == "biquad":
        a, b, c, d = (reflection(x) for x in coordinates)
        return _section_power(c, d, nu) / _section_power(a, b, nu)
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
    if shape == "biquad":
        names = LOWPASS_PARAMETERS[shape]
        return {name: reflection(x) for name, x in zip(names, coordinates, strict=True)}
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
    if shape == "biquad":
        return tuple(reflection_coordinate(values[name]) for name in LOWPASS_PARAMETERS[shape])
    if shape == "decimation":
        return math.log(values["filter_length"] - 1.0), math.log(values["filter_stages"])
    return (
        _logit(2.0 * values["filter_cutoff"] / rate_hz),
        math.log(values["filter_order"] - 1.0),
        _logit(values["filter_warping"]),
    )


_FIELD = {
    "filter_length": "length",
    "filter_stages": "stages",
    "filter_cutoff": "cutoff_hz",
    "filter_order": "order",
    "filter_warping": "warping",
}
"""The :class:`OutputFilter` field of each decimation and Butterworth parameter."""


class OutputFilter(NoiseTerm):
    """The sensor's output filter (module docstring). As a noise term with the exact one-tap
    shape, it is the lag-one part of the filtered white noise, weight N^2 a b with (a, b) =
    (1, F) / (1 + F); an instance with ``shape`` "decimation", "butterworth" or "biquad" holds
    the low-pass's parameters in their units (``length`` and ``stages``; ``cutoff_hz``,
    ``order`` and ``warping``; the reflection coefficients ``poles`` and ``zeros``). Left
    out, a model explains the fall of the spectrum toward Nyquist with flicker or
    quantization, and bends N."""

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
    poles: tuple[float, float] = (0.0, 0.0)
    """The biquad's denominator A(z), as its reflection coefficients (k1, k2) at the radius
    :data:`BIQUAD_RADIUS`."""
    zeros: tuple[float, float] = (0.0, 0.0)
    """The biquad's numerator B(z), as its reflection coefficients (k1, k2) at the radius
    :data:`BIQUAD_RADIUS`."""

    def __check_init__(self):
        if self.shape not in ("one_tap", *LOWPASS_PARAMETERS):
            raise ValueError(f"shape={self.shape!r}: one_tap, decimation, butterworth or biquad")
        if self.shape == "biquad" and not all(-1 < k < 1 for k in (*self.poles, *self.zeros)):
            raise ValueError("a biquad's reflection coefficients (poles, zeros) lie in (-1, 1)")
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
        coordinates = lowpass_coordinates(self.shape, self.values, rate_hz)
        return lowpass_gain(self.shape, jnp.asarray(nu, dtype=float), coordinates)

    @classmethod
    def from_values(cls, shape: str, values: dict) -> "OutputFilter":
        """The filter of ``shape`` from its parameters by name (``F`` for the one-tap shape,
        those of :data:`~bayescal.models._terms.LOWPASS_PARAMETERS` for the others), as a
        fit reports them."""
        if shape == "one_tap":
            return cls(coefficient=float(values["F"]))
        named = {name: float(values[name]) for name in LOWPASS_PARAMETERS[shape]}
        if shape == "biquad":
            return cls(
                shape=shape,
                poles=(named["filter_pole_k1"], named["filter_pole_k2"]),
                zeros=(named["filter_zero_k1"], named["filter_zero_k2"]),
            )
        return cls(shape=shape, **{_FIELD[name]: value for name, value in named.items()})

    @property
    def values(self) -> dict:
        """The filter's parameters by name (the inverse of :meth:`from_values`)."""
        if self.shape == "one_tap":
            return {"F": self.coefficient}
        if self.shape == "biquad":
            names = LOWPASS_PARAMETERS["biquad"]
            return dict(zip(names, (*self.poles, *self.zeros), strict=True))
        return {name: getattr(self, _FIELD[name]) for name in LOWPASS_PARAMETERS[self.shape]}

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
