"""The output filter's decimation shape: a cascade of moving averages."""

import math
from typing import ClassVar

import jax.numpy as jnp

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ._lowpass import LowpassShape
from ._parameter import Parameter


class DecimationFilter(LowpassShape):
    """A cascade of moving averages, |H|^2 = [sin(pi nu M) / (M sin(pi nu))]^(2p), the length
    M (samples) and the number of stages p continuous — the Bartlett and CIC (sinc^p) filters
    of decimating MEMS converters (the ADIS16405's 819 Hz output: M = 4, p = 2). Unit gain at
    zero frequency (:mod:`.output_filter`)."""

    name: ClassVar[str] = "decimation_filter"
    aliases: ClassVar[tuple[str, ...]] = ("decimation", "cic")
    filter_shape: ClassVar[str] = "decimation"
    parameters: ClassVar[tuple[Parameter, ...]] = (
        # log(M - 1): M = 3 samples, 95 % within 1.2 to 60 samples.
        Parameter(
            "filter_length",
            "moving-average length",
            time_power=None,
            unit="samples",
            offset=1.0,
            prior=(math.log(2.0), 1.5),
        ),
        # log p: one stage, 95 % within 0.14 to 7.
        Parameter(
            "filter_stages", "moving-average stages", time_power=None, unit="1", prior=(0.0, 1.0)
        ),
    )

    @classmethod
    def gain(cls, nu, values, rate_hz):
        length, stages = values["filter_length"], values["filter_stages"]
        ratio = jnp.sin(jnp.pi * nu * length) / (length * jnp.sin(jnp.pi * nu))
        return jnp.exp(stages * jnp.log(ratio * ratio + 1e-300))
