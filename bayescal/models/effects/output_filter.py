"""The sensor's output filter: the digital low-pass most MEMS parts apply before decimating,
which shapes the white noise (../shared/DESIGN.md, ``output_filter``).

Four shapes, each with unit gain at zero frequency, so that N stays the low-frequency density
the Allan curve reads (IEEE Std 952) whatever the filter does near Nyquist, each a term of its
own (one shape per model):

- ``one_tap`` (this file's term, ``output_filter``): (1 + F z^-1) / (1 + F), one coefficient F
  in (0, 1) — a mild smoothing (the ADIS16405's 100 Hz output: lag-1 autocorrelation 0.17,
  half the power at Nyquist). Exact in the likelihood: a lag-one component of the white noise.
  A negative F would shape the white noise as white angle noise does, which Q models: F's one
  range is (0, 1), wherever it is fitted (the noise fit, discovery, the thermal fit);
- ``decimation`` (:mod:`.decimation_filter`), ``butterworth`` (:mod:`.butterworth_filter`) and
  ``biquad`` (:mod:`.biquad_filter`): low-pass shapes that multiply the white noise's spectrum
  (:mod:`._lowpass`).
"""

import math
from typing import ClassVar

import jax.numpy as jnp
import numpy as np

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ._base import moving_average
from ._lowpass import LOWPASS_EXPLANATION, LowpassShape
from ._parameter import Parameter
from .biquad_filter import BiquadFilter
from .butterworth_filter import ButterworthFilter
from .decimation_filter import DecimationFilter
from .white import taps

LOWPASS_SHAPES = {
    shape.filter_shape: shape for shape in (DecimationFilter, ButterworthFilter, BiquadFilter)
}
"""The low-pass shapes by name."""
_FIELD = {
    "filter_length": "length",
    "filter_stages": "stages",
    "filter_cutoff": "cutoff_hz",
    "filter_order": "order",
    "filter_warping": "warping",
}
"""The :class:`OutputFilter` field of each decimation and Butterworth parameter."""


class OutputFilter(LowpassShape):
    """The sensor's output filter (module docstring). As a noise term with the exact one-tap
    shape, it is the lag-one part of the filtered white noise, weight N^2 a b with (a, b) =
    (1, F) / (1 + F); as discovery's effect, an instance holds the shape decided before its
    search — "one_tap" with its ``coefficient``, or "decimation", "butterworth" or "biquad"
    with the low-pass's parameters in their units (``length`` and ``stages``; ``cutoff_hz``,
    ``order`` and ``warping``; the reflection coefficients ``poles`` and ``zeros``). Left out,
    a model explains the fall of the spectrum toward Nyquist with flicker or quantization, and
    bends N."""

    name: ClassVar[str] = "output_filter"
    explanation: ClassVar[str] = LOWPASS_EXPLANATION
    aliases: ClassVar[tuple[str, ...]] = ("one_tap", "filter", "f")
    filter_shape: ClassVar[str] = "one_tap"
    parameters: ClassVar[tuple[Parameter, ...]] = (
        # logit F: around F = 0.2 (sd 1.5).
        Parameter(
            "F",
            "one-tap filter coefficient",
            time_power=None,
            unit="1",
            link="logit",
            prior=(math.log(0.2 / 0.8), 1.5),
        ),
    )
    long_memory: ClassVar[bool] = False
    filtered: ClassVar[bool] = True
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
    :data:`~.biquad_filter.BIQUAD_RADIUS`."""
    zeros: tuple[float, float] = (0.0, 0.0)
    """The biquad's numerator B(z), as its reflection coefficients (k1, k2) at the radius
    :data:`~.biquad_filter.BIQUAD_RADIUS`."""

    def __check_init__(self):
        if self.shape not in ("one_tap", *LOWPASS_SHAPES):
            raise ValueError(f"shape={self.shape!r}: one_tap, decimation, butterworth or biquad")
        if self.shape == "one_tap" and not 0 <= self.coefficient < 1:
            raise ValueError(f"coefficient={self.coefficient!r}: F lies in [0, 1)")
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

    @classmethod
    def components(cls, context) -> tuple:
        return (cls,)

    @classmethod
    def weights(cls, values, components):
        """N^2 a b, (a, b) = :func:`~.white.taps` of F (zero without F)."""
        a, b = taps(values.get("F", 0.0))
        return jnp.asarray(values["N"] ** 2 * a * b)[..., None]

    @classmethod
    def gain(cls, nu, values, rate_hz):
        """|H|^2 of the one-tap shape: (1 + F^2 + 2 F cos 2 pi nu) / (1 + F)^2."""
        F = values["F"]
        return (1 + F * F + 2 * F * jnp.cos(2 * jnp.pi * jnp.asarray(nu))) / (1 + F) ** 2

    @property
    def term(self) -> type[LowpassShape]:
        """The term of this instance's shape."""
        return OutputFilter if self.shape == "one_tap" else LOWPASS_SHAPES[self.shape]

    def shape_gain(self, nu, rate_hz: float):
        """|H|^2 of this instance's shape at ``nu`` cycles per sample."""
        return self.term.gain(jnp.asarray(nu, dtype=float), self.values, rate_hz)

    @classmethod
    def from_values(cls, shape: str, values: dict) -> "OutputFilter":
        """The filter of ``shape`` from its parameters by name (``F`` for the one-tap shape,
        those of its term for the others), as a fit reports them."""
        if shape == "one_tap":
            return cls(coefficient=float(values["F"]))
        names = [p.name for p in LOWPASS_SHAPES[shape].parameters]
        named = {name: float(values[name]) for name in names}
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
        names = [p.name for p in LOWPASS_SHAPES[self.shape].parameters]
        if self.shape == "biquad":
            return dict(zip(names, (*self.poles, *self.zeros), strict=True))
        return {name: getattr(self, _FIELD[name]) for name in names}

    def describe(self, finding, posterior, search) -> dict:
        """The shape's parameters, decided before the search (MAP with Laplace intervals)."""
        return finding.search["parameters"]

    @property
    def decided_before_search(self) -> bool:
        return True

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

    @classmethod
    def allan_variance(cls, tau, values, rate_hz):
        """3 N^2 b (b - 1) / (fs tau^2), b = F / (1 + F): the filter's change to the white
        noise's Allan variance, which dies out as 1 / tau^2."""
        lag = taps(values.get("F", 0.0))[1]
        return 3 * values["N"] ** 2 * lag * (lag - 1) / (rate_hz * tau**2)
