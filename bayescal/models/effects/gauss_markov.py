"""First-order Gauss-Markov bias: exponentially correlated, with a time constant."""

import math
from typing import ClassVar

import numpy as np

from ._base import TIME_CONSTANT_PENALTY, NoiseTerm


class GaussMarkov(NoiseTerm):
    """An Ornstein-Uhlenbeck bias of variance sigma^2 (sigma in the channel's unit) and
    correlation time tau_c (``time_constant_s``, s), each sample its average over the sample
    period: it wanders but returns, a bump in the Allan deviation and a Lorentzian spectrum.
    The time constant is a nonlinear parameter discovery finds by search; the instance holds
    it."""

    name: ClassVar[str] = "gauss_markov"
    explanation: ClassVar[str] = (
        "The bias is exponentially correlated with a time constant: it wanders but returns, "
        "which leaves a bump in the Allan deviation and a Lorentzian spectrum."
    )
    located_by: ClassVar[str] = "allan_deviation"
    band: ClassVar[str] = "low"
    parameter: ClassVar[str] = "sigma_gm"
    long_memory: ClassVar[bool] = True
    time_constant_s: float

    @staticmethod
    def unit(channel_unit: str) -> str:
        return channel_unit

    @property
    def searched(self) -> int:
        return 1

    def search_penalty(self, n_frequencies: int) -> float:
        return TIME_CONSTANT_PENALTY

    @classmethod
    def propose(cls, search, current):
        if current.spec.has(cls.name):
            return None
        return search.search_time(
            lambda time_constant: current.spec.with_effect(cls(time_constant)), cls.name
        )

    def describe(self, finding, posterior, search) -> dict:
        time_constant = search.profile_interval(finding.search)
        sigma = search.summarize(posterior.draws["sigma_gm"], posterior.units["sigma_gm"])
        return {
            "sigma_gm": search.widened(
                sigma, finding.search, "sigma_gm", time_constant, log_scale=True
            ),
            "time_constant": time_constant,
        }

    def rate_autocovariance(self, lags, rate_hz: float):
        """Autocovariance of period averages of an Ornstein-Uhlenbeck rate of unit
        variance."""
        a = 1.0 / (rate_hz * self.time_constant_s)
        lags = np.abs(np.asarray(lags, dtype=float))
        scale = 1.0 / (a * a)
        same = 2.0 * scale * (a - 1.0 + math.exp(-a))
        apart = scale * (-math.expm1(-a)) ** 2 * np.exp(-a * np.maximum(lags - 1.0, 0.0))
        return np.where(lags == 0, same, apart)

    def autocovariance(self, lags, rate_hz: float):
        """Increment autocovariance of a unit-variance Gauss-Markov rate."""
        lags = np.asarray(lags, dtype=float)
        return (
            2.0 * self.rate_autocovariance(lags, rate_hz)
            - self.rate_autocovariance(lags - 1.0, rate_hz)
            - self.rate_autocovariance(lags + 1.0, rate_hz)
        )

    def block_covariance(self, start, stop, rate_hz: float):
        """Covariance of block means of a unit-variance Gauss-Markov rate (continuous time):
        T^2 (1 - e^{-La/T}) (1 - e^{-Lb/T}) e^{-gap/T} / (La Lb) between blocks, and
        2 T^2 (L/T - 1 + e^{-L/T}) / L^2 for a block with itself."""
        a, b = start / rate_hz, stop / rate_hz
        length = b - a
        t = self.time_constant_s
        decay = -np.expm1(-length / t)
        before = np.subtract.outer(a, b)  # a_i - b_j
        gap = np.maximum(np.maximum(before, before.T), 0.0)
        apart = t * t * np.outer(decay, decay) * np.exp(-gap / t) / np.outer(length, length)
        same = 2 * t * t * (length / t - decay) / length**2
        return np.where(np.equal.outer(start, start), np.diag(same), apart)

    def allan_variance(self, tau, sigma):
        """(2 sigma^2 T / tau) [1 - T / (2 tau) (3 - 4 e^{-tau/T} + e^{-2 tau/T})] (IEEE Std
        952, annex C)."""
        ratio = np.asarray(tau, dtype=float) / self.time_constant_s
        return (2 * sigma**2 / ratio) * (
            1 - (3 - 4 * np.exp(-ratio) + np.exp(-2 * ratio)) / (2 * ratio)
        )

    def simulate(self, rng: np.random.Generator, n: int, rate_hz: float, sigma: float):
        """``n`` samples of a first-order autoregression with the term's variance and
        correlation time, phi = exp(-1 / (fs tau_c)): the sampled process, which matches the
        period averages of the model to O(1 / (fs tau_c)) in its variance."""
        from scipy.signal import lfilter

        phi = math.exp(-1 / (rate_hz * self.time_constant_s))
        drive = rng.standard_normal(n) * sigma * math.sqrt(1 - phi * phi)
        return lfilter([1.0], [1.0, -phi], drive)
