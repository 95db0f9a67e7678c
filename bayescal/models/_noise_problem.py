"""The posterior of a channel's noise parameters, as a log density: the Whittle likelihood of
the increments (:mod:`._whittle`) and a prior on each sampled coordinate; the bias, linear and
Gaussian given the noise, comes from the block means (:mod:`._level`).

Parameters are sampled unconstrained: the logarithm of each noise scale, R divided by its prior
scale, the logit of the one-tap output filter's coefficient F (a low-pass: F in (0, 1); a
negative F would shape the white noise exactly as white angle noise does, which Q models), and
the low-pass filters' coordinates (:mod:`.effects.output_filter`).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ._components import component_weights
from ._level import LevelSummary
from ._terms import LOWPASS_PARAMETERS
from ._whittle import SpectralSummary, whittle_log_likelihood
from .effects.output_filter import lowpass_gain, lowpass_natural

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
    """The log-posterior of the noise parameters of one record.

    Its parameters are the prior's: noise scales (N, B, K, Q), the ramp R, the one-tap output
    filter F, or a low-pass output filter's (``filter_length`` and ``filter_stages``, or
    ``filter_cutoff``, ``filter_order`` and ``filter_warping``;
    :mod:`.effects.output_filter`). ``lsb`` is the resolution the samples are rounded to
    (zero: not rounded), whose known white floor LSB^2 / (12 fs) comes after the filter;
    ``mask`` (when given) switches parameters off for model selection: a masked noise scale
    is zero, a masked filter passes everything.
    """

    spectral: SpectralSummary
    level: LevelSummary
    prior: NoisePrior
    lsb: np.ndarray = eqx.field(default_factory=lambda: np.asarray(0.0))
    mask: np.ndarray | None = None

    @property
    def rounding(self):
        """The rounding's white floor, LSB^2 / (12 fs): the weight of the white component."""
        return self.lsb**2 / (12.0 * self.spectral.rate_hz)

    @property
    def parameters(self) -> tuple[str, ...]:
        return self.prior.parameters

    @property
    def shape(self) -> str | None:
        """The low-pass output filter's shape, if the model has one."""
        for shape, names in LOWPASS_PARAMETERS.items():
            if names[0] in self.parameters:
                return shape
        return None

    def _lowpass(self, theta) -> tuple:
        """The low-pass filter's coordinates in ``theta``."""
        return tuple(
            theta[..., self.parameters.index(name)] for name in LOWPASS_PARAMETERS[self.shape]
        )

    def natural(self, theta):
        """Sampled coordinates -> parameter values in their units (channel units for the
        noise, samples, Hz or 1 for a low-pass filter's)."""
        transform = {"R": lambda x: x * self.prior.ramp_scale, "F": jax.nn.sigmoid}
        values = {}
        shape = self.shape
        for index, name in enumerate(self.parameters):
            if name.startswith("filter_"):
                continue
            values[name] = transform.get(name, jnp.exp)(theta[..., index])
        if shape is not None:
            values |= lowpass_natural(shape, self._lowpass(theta), self.spectral.rate_hz)
        return values

    def _switched(self, theta) -> dict:
        """The noise values with masked ones set to zero."""
        values = self.natural(theta)
        if self.mask is None:
            return values
        for index, name in enumerate(self.parameters):
            if name in values and not name.startswith("filter_"):
                values[name] = values[name] * self.mask[index]
        return values

    def variances(self, theta):
        """Weights of the spectral components (:func:`component_weights`), the rounding floor
        on the white noise."""
        values = self._switched(theta)
        weights = component_weights(
            **{name: values[name] for name in ("N", "B", "K", "Q", "F") if name in values}
        )
        return weights.at[..., 0].add(self.rounding)

    def whittle_weights(self, theta):
        """(variances, filtered) for the Whittle likelihood: all weights and None without a
        low-pass; with one, the weights it does not shape and (its gain at the bins' nodes,
        the white components it shapes) (:func:`~bayescal.models._whittle.node_spectrum`)."""
        weights = self.variances(theta)
        shape = self.shape
        if shape is None:
            return weights, None
        gain = lowpass_gain(shape, self.spectral.node_frequency, self._lowpass(theta))
        if self.mask is not None:
            on = self.mask[self.parameters.index(LOWPASS_PARAMETERS[shape][0])]
            gain = 1.0 + on * (gain - 1.0)
        values = self._switched(theta)
        white = component_weights(N=values["N"], F=values.get("F", 0.0))[..., :2]
        rest = weights.at[..., 0].set(self.rounding).at[..., 1].set(0.0)
        return rest, (gain, white)

    def ramp(self, theta):
        return self._switched(theta).get("R", jnp.zeros(theta.shape[:-1]))

    def pointwise_log_likelihood(self, theta):
        variances, filtered = self.whittle_weights(theta)
        return whittle_log_likelihood(self.spectral, variances, self.ramp(theta), filtered=filtered)

    def log_prior(self, theta):
        return -0.5 * jnp.sum(((theta - self.prior.location) / self.prior.scale) ** 2)

    def log_posterior(self, theta):
        value = self.log_prior(theta) + jnp.sum(self.pointwise_log_likelihood(theta))
        return jnp.where(jnp.isfinite(value), value, -jnp.inf)
