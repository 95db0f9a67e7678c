"""The posterior of a channel's noise parameters, as a log density: the Whittle likelihood of
the increments (:mod:`._whittle`) and a prior on each sampled coordinate; the bias, linear and
Gaussian given the noise, comes from the block means (:mod:`._level`).

Parameters are sampled unconstrained: the logarithm of each noise scale, R divided by its prior
scale, and atanh of the output filter's coefficient F.
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ._components import component_weights
from ._level import LevelSummary
from ._whittle import SpectralSummary, whittle_log_likelihood

PRIOR_LOG_SD = 4.0
"""Standard deviation of the log-normal priors on the noise scales, in the log (a factor
55): weakly informative around the Allan curve's bound of each term."""


class NoisePrior(eqx.Module):
    """Independent normal priors on the sampled coordinates: log P for a noise scale P, and
    R / ramp_scale for the ramp (whose prior is then N(0, 1))."""

    location: np.ndarray
    scale: np.ndarray
    ramp_scale: np.ndarray
    """Scale of the ramp's sampled coordinate (an array, so that jit traces it)."""
    parameters: tuple[str, ...] = eqx.field(static=True)
    description: str = eqx.field(static=True)

    def __check_init__(self):
        if len(self.parameters) != len(self.location) or len(self.location) != len(self.scale):
            raise ValueError("prior: parameters, location and scale must have equal lengths")
        if not np.all(np.asarray(self.scale) > 0):
            raise ValueError("prior: every scale must be positive")


class NoiseProblem(eqx.Module):
    """The log-posterior of the noise parameters of one record."""

    spectral: SpectralSummary
    level: LevelSummary
    prior: NoisePrior

    @property
    def parameters(self) -> tuple[str, ...]:
        return self.prior.parameters

    def natural(self, theta):
        """Sampled coordinates -> parameter values in the channel's units."""
        transform = {"R": lambda x: x * self.prior.ramp_scale, "F": jnp.tanh}
        return {
            name: transform.get(name, jnp.exp)(theta[..., index])
            for index, name in enumerate(self.parameters)
        }

    def variances(self, theta):
        """Weights of the spectral components (:func:`component_weights`)."""
        values = self.natural(theta)
        return component_weights(**{name: value for name, value in values.items() if name != "R"})

    def ramp(self, theta):
        return self.natural(theta).get("R", jnp.zeros(theta.shape[:-1]))

    def pointwise_log_likelihood(self, theta):
        return whittle_log_likelihood(self.spectral, self.variances(theta), self.ramp(theta))

    def log_prior(self, theta):
        return -0.5 * jnp.sum(((theta - self.prior.location) / self.prior.scale) ** 2)

    def log_posterior(self, theta):
        value = self.log_prior(theta) + jnp.sum(self.pointwise_log_likelihood(theta))
        return jnp.where(jnp.isfinite(value), value, -jnp.inf)
