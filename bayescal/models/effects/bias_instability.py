"""Bias instability: flicker (1/f) noise of the bias, IEEE Std 952's B."""

import math
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.special import zeta

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ...classical._noise import FLICKER_FLOOR, IEEE952_READINGS
from ._base import NoiseTerm
from ._parameter import Parameter


def t2_log(t, dtype=float):
    """t^2 log|t|, zero at zero: the kernel of flicker's covariances (``dtype`` np.longdouble
    where sums of many of them cancel)."""
    t = np.asarray(t, dtype=dtype)
    return np.where(t == 0, 0, t * t * np.log(np.where(t == 0, 1, np.abs(t))))


def _t2_log_fourth_difference(t):
    """Fourth central difference of t^2 log|t| at t >= 0. Beyond t = 20 the direct
    difference of numbers near t^2 log t loses every digit, and the expansion
    delta^4 = 16 sinh^4(D/2) = D^4 + D^6/6 + D^8/80 + D^10/1779 + ... gives
    -2/t^2 - 2/t^4 - 3/t^6 - (17/3)/t^8 to better than 1e-9 relative."""
    t = np.asarray(t, dtype=float)
    result = np.empty_like(t)
    far = t >= 20
    inverse_square = t[far] ** -2.0
    result[far] = -inverse_square * (
        2 + inverse_square * (2 + inverse_square * (3 + inverse_square * 17 / 3))
    )
    near = t[~far]
    result[~far] = (
        t2_log(near + 2)
        - 4 * t2_log(near + 1)
        + 6 * t2_log(near)
        - 4 * t2_log(near - 1)
        + t2_log(near - 2)
    )
    return result


class BiasInstability(NoiseTerm):
    """Flicker noise of the bias with two-sided PSD B^2 / (2 pi |f|) (B in the channel's unit),
    started at zero at the first sample. Its Allan variance is the flat floor
    (2 ln 2 / pi) B^2; its generalized covariance is -(B^2 / pi) log|t|."""

    name: ClassVar[str] = "bias_instability"
    explanation: ClassVar[str] = (
        "The bias wanders with a 1/f (flicker) spectrum, so averaging longer stops helping: "
        "the Allan deviation flattens into a floor."
    )
    located_by: ClassVar[str] = "allan_deviation"
    band: ClassVar[str] = "low"
    aliases: ClassVar[tuple[str, ...]] = ("flicker", "b")
    parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter(
            "B",
            "bias instability",
            time_power=0.0,
            datasheet=True,
        ),
    )
    streams: ClassVar[tuple[int, ...]] = (3,)
    reading: ClassVar[object] = IEEE952_READINGS["B"]
    classical_caveat: ClassVar[str] = (
        "the flat floor of the Allan curve is where white noise meets the slower terms "
        "(a rate random walk, a ramp), not necessarily bias instability"
    )
    card_entries: ClassVar[tuple[str, ...]] = ("bias_instability",)
    long_memory: ClassVar[bool] = True

    @classmethod
    def components(cls, context) -> tuple:
        return (cls,)

    @classmethod
    def weights(cls, values, components):
        """B^2."""
        return jnp.asarray(values["B"] ** 2)[..., None]

    @classmethod
    def card_value(cls, item: dict, unit: str) -> float:
        """A datasheet's "in-run bias stability" is the minimum of the Allan deviation, so
        B = that / 0.664 (IEEE Std 952) unless the entry's ``definition`` says otherwise."""
        value = super().card_value(item, unit)
        if item.get("definition", "allan_minimum") == "allan_minimum":
            value /= FLICKER_FLOOR
        return value

    @staticmethod
    def spectrum(nu, rate_hz):
        """(1 / (2 pi^3)) sin^2(pi nu) [zeta(3, nu) + zeta(3, 1 - nu)] is the aliased,
        period-averaged spectrum of B^2 / (2 pi |f|); differencing multiplies it by
        4 sin^2(pi nu). 0 < nu < 1."""
        sin2 = jnp.sin(jnp.pi * nu) ** 2
        return 4 * sin2 * sin2 * (zeta(3.0, nu) + zeta(3.0, 1.0 - nu)) / (2 * jnp.pi**3)

    @staticmethod
    def autocovariance(lags, rate_hz):
        """(1 / 2 pi) times the fourth central difference of t^2 log|t|; r(0) =
        (4 ln 2 / pi) B^2, twice its Allan variance."""
        return _t2_log_fourth_difference(np.abs(np.asarray(lags, dtype=float))) / (2 * np.pi)

    @staticmethod
    def block_covariance(start, stop, rate_hz):
        """Cov(X_a, X_b) = [D(a) + D(b) - D(|a - b|)] / 2 with the structure function D(h) =
        (B^2 / pi) (second difference of t^2 log|t|)(h), summed over the blocks in closed
        form: sums of second differences telescope to t^2 log|t| itself."""
        size = (stop - start).astype(float)
        first = (
            t2_log(stop, np.longdouble)
            - t2_log(stop - 1, np.longdouble)
            - (t2_log(start, np.longdouble) - t2_log(start - 1, np.longdouble))
        )
        rectangle = (
            t2_log(np.subtract.outer(stop, start).T, np.longdouble)
            - t2_log(np.subtract.outer(stop, stop).T, np.longdouble)
            - t2_log(np.subtract.outer(start, start).T, np.longdouble)
            + t2_log(np.subtract.outer(start, stop).T, np.longdouble)
        )
        outer_size = np.outer(size, size)
        flicker = ((first / size)[:, None] + (first / size)[None, :] - rectangle / outer_size) / (
            2 * np.pi
        )
        return np.asarray(flicker, dtype=float)

    @staticmethod
    def structure_function(lag_samples):
        """Variance of the change of the flicker level over ``lag_samples`` samples per unit
        B^2: (1 / pi) (second difference of t^2 log|t|)(h)."""
        h = lag_samples
        return float(t2_log(h + 1) - 2 * t2_log(h) + t2_log(h - 1)) / math.pi

    @classmethod
    def allan_variance(cls, tau, values, rate_hz):
        """(2 ln 2 / pi) B^2 (IEEE Std 952, eq. C.9 squared)."""
        return FLICKER_FLOOR**2 * values["B"] ** 2 + 0.0 * tau

    @classmethod
    def level_change_variance(cls, gap_s, values, rate_hz):
        """B^2 times the structure function at the gap (:meth:`structure_function`)."""
        return values["B"] ** 2 * cls.structure_function(gap_s * rate_hz)

    @classmethod
    def allan_exponents(cls, tau, values, rate_hz):
        return [(-1, cls.allan_variance(tau, values, rate_hz))]

    @classmethod
    def sample(cls, keys, n, rate_hz, values):
        """B times :meth:`flicker` from its stream."""
        return values["B"] * cls.flicker(keys[cls.streams[0]], n)

    @staticmethod
    def flicker(key, n):
        """Sampled flicker noise with B = 1, starting at zero: the increments are drawn by
        spectral synthesis on a circulant twice the record's length, then summed."""
        size = 1 << max(4, (2 * n - 1).bit_length())
        nu = jnp.arange(1, size // 2 + 1) / size
        amplitude = jnp.sqrt(BiasInstability.spectrum(nu, 1.0) * size)
        real_key, imag_key, nyquist_key = jax.random.split(key, 3)
        half = size // 2
        spectrum = jax.random.normal(real_key, (half,)) + 1j * jax.random.normal(imag_key, (half,))
        spectrum = spectrum * amplitude / math.sqrt(2.0)
        # The Nyquist bin of a real series is real; its variance is the full PSD there.
        spectrum = spectrum.at[-1].set(jax.random.normal(nyquist_key, ()) * amplitude[-1])
        increments = jnp.fft.irfft(jnp.concatenate((jnp.zeros(1), spectrum)), n=size)[: n - 1]
        return jnp.concatenate((jnp.zeros(1), jnp.cumsum(increments)))
