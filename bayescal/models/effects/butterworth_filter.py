"""The output filter's Butterworth shape: the low-pass of configurable bandwidths."""

from typing import ClassVar

import jax
import jax.numpy as jnp

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ._lowpass import LowpassShape
from ._parameter import Parameter


class ButterworthFilter(LowpassShape):
    """|H|^2 = 1 / (1 + (w(f) / w(f_c))^(2n)), w(f) = tan(kappa pi f / fs), the cutoff f_c (Hz,
    below Nyquist), the order n > 1 and the warping kappa in (0, 1) continuous — the low-pass
    of consumer parts' configurable bandwidths. kappa = 1 is a digital Butterworth (bilinear
    transform) running at the output rate, with its zero at Nyquist; kappa -> 0 is
    (f / f_c)^(2n), one running far faster than the output is decimated to (or an analogue
    one), whose response has no zero and falls at most 2n decades of power per decade of
    frequency. Records show either: a 1 kHz filter read at 200 Hz, or one read at its rate and
    rounded (the rounding fills its zero). Unit gain at zero frequency (:mod:`.output_filter`)."""

    name: ClassVar[str] = "butterworth_filter"
    aliases: ClassVar[tuple[str, ...]] = ("butterworth", "lowpass")
    filter_shape: ClassVar[str] = "butterworth"
    parameters: ClassVar[tuple[Parameter, ...]] = (
        # logit(2 f_c / fs): a quarter of the sample rate, 95 % within fs / 100 and 0.49 fs.
        Parameter(
            "filter_cutoff",
            "cutoff frequency",
            time_power=None,
            unit="Hz",
            link="logit",
            span="half_rate",
            prior=(0.0, 2.0),
        ),
        # log(n - 1): second order, 95 % within 1.1 and 8.
        Parameter(
            "filter_order", "filter order", time_power=None, unit="1", offset=1.0, prior=(0.0, 1.0)
        ),
        # logit kappa: between a filter at the output rate (1) and one far faster (0).
        Parameter(
            "filter_warping",
            "frequency warping",
            time_power=None,
            unit="1",
            link="logit",
            prior=(0.0, 2.0),
        ),
    )

    @classmethod
    def gain(cls, nu, values, rate_hz):
        cutoff = values["filter_cutoff"] / rate_hz
        order, warping = values["filter_order"], values["filter_warping"]
        ratio = jnp.tan(warping * jnp.pi * nu) / jnp.tan(warping * jnp.pi * cutoff)
        # 1 / (1 + ratio^(2n)) as the logistic of -2n log(ratio): the same gain, and where
        # ratio^(2n) overflows (a steep filter far above its corner) a gradient of zero, not
        # inf / inf = NaN, on which the MAP's BFGS stalled to its step limit.
        return jax.nn.sigmoid(-2.0 * order * jnp.log(ratio))
