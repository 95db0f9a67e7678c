"""Rate random walk: the bias integrates white noise, IEEE Std 952's K."""

import math
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ...classical._noise import IEEE952_READINGS
from ._base import NoiseTerm, moving_average
from ._parameter import Parameter


class RateRandomWalk(NoiseTerm):
    """A Brownian bias of two-sided PSD K^2 / (2 pi f)^2 (K in unit·√Hz), started at zero at
    the first sample; each sample is its average over the sample period."""

    name: ClassVar[str] = "rate_random_walk"
    explanation: ClassVar[str] = (
        "The bias performs a random walk (integrated white noise), so long averages drift "
        "apart: the Allan deviation rises as the square root of tau."
    )
    located_by: ClassVar[str] = "allan_deviation"
    band: ClassVar[str] = "low"
    aliases: ClassVar[tuple[str, ...]] = ("rrw", "k")
    parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter(
            "K",
            "rate random walk",
            time_power=-0.5,
            datasheet=True,
        ),
    )
    streams: ClassVar[tuple[int, ...]] = (1, 2)
    reading: ClassVar[object] = IEEE952_READINGS["K"]
    classical_caveat: ClassVar[str] = (
        "the +1/2 stretch of the Allan curve also carries bias instability and drift"
    )
    card_entries: ClassVar[tuple[str, ...]] = ("rate_random_walk",)

    @classmethod
    def components(cls, context) -> tuple:
        return (cls,)

    @classmethod
    def weights(cls, values, components):
        """K^2."""
        return jnp.asarray(values["K"] ** 2)[..., None]

    @staticmethod
    def spectrum(nu, rate_hz):
        return (1.0 / rate_hz) * (2 + jnp.cos(2 * jnp.pi * nu)) / 3

    @staticmethod
    def autocovariance(lags, rate_hz):
        return (1.0 / rate_hz) * moving_average(lags, (2 / 3, 1 / 6))

    @staticmethod
    def block_covariance(start, stop, rate_hz):
        """K^2 times the mean of min(s, t) over the two blocks: the middle of the earlier
        block for disjoint blocks, a + m / 3 for a block with itself (in periods)."""
        size = (stop - start).astype(float)
        same = np.equal.outer(start, start)
        earlier_middle = np.minimum.outer((start + stop) / 2.0, (start + stop) / 2.0)
        return (1.0 / rate_hz) * np.where(
            same, start[:, None] + size[:, None] / 3.0, earlier_middle
        )

    @classmethod
    def allan_variance(cls, tau, values, rate_hz):
        """K^2 tau / 3 (IEEE Std 952, eq. C.12 squared)."""
        return values["K"] ** 2 * tau / 3

    @classmethod
    def level_change_variance(cls, gap_s, values, rate_hz):
        """K^2 t: a random walk's change over t."""
        return values["K"] ** 2 * gap_s

    @classmethod
    def allan_exponents(cls, tau, values, rate_hz):
        return [(-2, cls.allan_variance(tau, values, rate_hz))]

    @classmethod
    def sample(cls, keys, n, rate_hz, values):
        """``n`` period averages of a Brownian path of density K from zero: the average over a
        period is the path at the period's start plus sqrt(period) (z/2 + u/sqrt(12)), with z
        the step and u the Brownian bridge's part."""
        walk_key, bridge_key = (keys[i] for i in cls.streams)
        K = values["K"]
        steps = jax.random.normal(walk_key, (n,))
        start = jnp.concatenate((jnp.zeros(1), jnp.cumsum(steps)[:-1]))
        bridge = jax.random.normal(bridge_key, (n,))
        return K * math.sqrt(1.0 / rate_hz) * (start + steps / 2 + bridge / math.sqrt(12.0))
