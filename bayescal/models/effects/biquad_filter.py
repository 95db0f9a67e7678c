"""The output filter's biquad shape: a second-order section."""

from typing import ClassVar

import jax.numpy as jnp

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ._lowpass import LowpassShape
from ._parameter import Parameter

BIQUAD_RADIUS = 0.9
"""The largest radius of a biquad's poles and zeros (:class:`BiquadFilter`)."""


def section_power(k1, k2, nu):
    """|C(e^(2 pi i nu))|^2 / C(1)^2 of C(z) = 1 + c1 z^-1 + c2 z^-2 given by its reflection
    coefficients (k1, k2) at the radius rho: c2 = rho^2 k2, c1 = rho k1 (1 + k2)."""
    c1, c2 = BIQUAD_RADIUS * k1 * (1.0 + k2), BIQUAD_RADIUS**2 * k2
    omega = 2.0 * jnp.pi * nu
    power = 1.0 + c1 * c1 + c2 * c2 + 2.0 * c1 * (1.0 + c2) * jnp.cos(omega)
    power = power + 2.0 * c2 * jnp.cos(2.0 * omega)
    return power / (1.0 + c1 + c2) ** 2


def _reflection(name: str, meaning: str) -> Parameter:
    # A flat section (k = 0) at the centre, 95 % within |k| < 0.994, near enough the radius
    # bound for a pair of poles or zeros on it.
    return Parameter(name, meaning, time_power=None, unit="1", link="tanh", prior=(0.0, 1.5))


class BiquadFilter(LowpassShape):
    """A second-order section, |H|^2 = (|B(z)|^2 / B(1)^2) / (|A(z)|^2 / A(1)^2) with
    A(z) = 1 + a1 z^-1 + a2 z^-2 and B likewise, each given by two reflection coefficients
    (k1, k2) in (-1, 1) and scaled to the radius rho = 0.9: a2 = rho^2 k2, a1 = rho k1 (1 + k2),
    so that every value is a stable, minimum-phase section whose poles and zeros all lie within
    0.9 of the origin. The radius keeps them off z = 1: a pole or zero near zero frequency gives
    unit gain at f = 0 but a step just above it, a slow term in disguise (a pole at 0.99 beside
    one at -0.89 is a Gauss-Markov process) that would move the level the Allan curve reads. A
    real pole of 0.9 has its corner at fs / 60, a second-order Butterworth of radius 0.9 its
    cutoff at fs / 40; below those the Butterworth shape holds the filter, and a digital
    Butterworth's zeros at Nyquist too. The biquad holds the one-tap filter and, what neither
    the decimation nor the Butterworth shape holds, a second-order filter running faster than
    the output and read without a further anti-alias filter: decimating an ARMA process keeps
    it ARMA, its poles raised to the decimation factor (so well inside the radius), and a
    second-order Butterworth read at a fifth of its rate folds its tail back near Nyquist,
    flattening the spectrum there (its derivative is zero at Nyquist, as every |H|^2 of
    cosines has). Where its poles and zeros coincide the filter is flat whatever they are:
    there the prior alone places them, and N is unaffected."""

    name: ClassVar[str] = "biquad_filter"
    aliases: ClassVar[tuple[str, ...]] = ("biquad", "second_order_section", "sos")
    filter_shape: ClassVar[str] = "biquad"
    parameters: ClassVar[tuple[Parameter, ...]] = (
        _reflection("filter_pole_k1", "first reflection coefficient of the poles"),
        _reflection("filter_pole_k2", "second reflection coefficient of the poles"),
        _reflection("filter_zero_k1", "first reflection coefficient of the zeros"),
        _reflection("filter_zero_k2", "second reflection coefficient of the zeros"),
    )

    @classmethod
    def gain(cls, nu, values, rate_hz):
        poles = section_power(values["filter_pole_k1"], values["filter_pole_k2"], nu)
        zeros = section_power(values["filter_zero_k1"], values["filter_zero_k2"], nu)
        return zeros / poles
