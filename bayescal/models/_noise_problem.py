"""The posterior of a channel's noise parameters, as a log density: the Whittle likelihood of
the increments (:mod:`._whittle`) and a prior on each sampled coordinate; the bias, linear and
Gaussian given the noise, comes from the block means (:mod:`._level`).

Parameters are sampled unconstrained, each in its term's coordinate
(:class:`~bayescal.models.effects._parameter.Parameter`): the logarithm of a noise scale, the
ramp over its prior scale, the logit of the one-tap output filter's coefficient F in (0, 1),
the low-pass shapes' coordinates, a Gauss-Markov correlation time's logit within the record's
decades. Which terms a problem holds is its prior's parameters; its summaries hold the
components of a family of terms (every candidate of a term search), a term the problem lacks
weighing zero.
"""

import dataclasses

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ._components import Components
from ._level import LevelSummary, level_summary
from ._terms import PARAMETERS, TERM_OF_PARAMETER, TERMS
from ._whittle import SpectralSummary, padded_summary, spectral_summary, whittle_log_likelihood
from .effects._parameter import Context

PRIOR_LOG_SD = 4.0
"""Standard deviation of the log-normal priors on the noise scales, in the log (a factor
55): weakly informative around the Allan curve's bound of each term."""


class NoisePrior(eqx.Module):
    """Independent normal priors on the sampled coordinates of ``parameters``."""

    location: np.ndarray
    scale: np.ndarray
    linear_scale: np.ndarray
    """The natural scale of a linear coordinate (the ramp's: R / linear_scale is sampled, its
    prior N(0, 1)); an array, so that jit traces it."""
    parameters: tuple[str, ...] = eqx.field(static=True)
    description: str = eqx.field(static=True)

    def __check_init__(self):
        if len(self.parameters) != len(self.location) or len(self.location) != len(self.scale):
            raise ValueError("prior: parameters, location and scale must have equal lengths")
        if not np.all(np.asarray(self.scale) > 0):
            raise ValueError("prior: every scale must be positive")

    @property
    def terms(self) -> tuple[str, ...]:
        """The terms whose parameters it holds, in its order."""
        return tuple(dict.fromkeys(TERM_OF_PARAMETER[name] for name in self.parameters))


def record_components(terms, rate_hz: float, n_samples: int) -> Components:
    """The components of ``terms`` for a record of ``n_samples`` at ``rate_hz``."""
    return Components.of(terms, Context(rate_hz, n_samples / rate_hz))


def noise_summaries(values, rate_hz: float, terms, level_values=None, exclude=(), transform=None):
    """(spectral, level) summaries of a record (NaN marks a gap) holding the components of
    ``terms``: what every :class:`NoiseProblem` of those terms shares. ``level_values``: the
    samples whose level the bias is (``values`` by default); ``exclude``: bands (low, high),
    Hz, the likelihood leaves out (a broadened spectral line's); ``transform``: a tapered
    transform of ``values`` already taken (:func:`~bayescal.models._whittle.spectral_summary`)."""
    components = record_components(terms, rate_hz, len(values))
    spectral = spectral_summary(
        values, rate_hz, components=components, exclude=exclude, transform=transform
    )
    level = level_summary(values if level_values is None else level_values, rate_hz, components)
    return spectral, level


class NoiseProblem(eqx.Module):
    """The log-posterior of the noise parameters of one record.

    Its parameters are the prior's; its summaries' components those of a family of terms that
    holds them (:func:`noise_summaries`). ``lsb`` is the resolution the samples are rounded to
    (zero: not rounded), whose known white floor LSB^2 / (12 fs) comes after the filter;
    ``mask`` (when given) switches parameters off for model selection: a masked term's first
    parameter — its scale — is zero, a masked filter shape passes everything.
    """

    spectral: SpectralSummary
    level: LevelSummary | None
    """The block means (None: left out, :meth:`for_likelihood`)."""
    prior: NoisePrior
    lsb: np.ndarray = eqx.field(default_factory=lambda: np.asarray(0.0))
    mask: np.ndarray | None = None

    @property
    def components(self) -> Components:
        return self.spectral.components

    @property
    def rounding(self):
        """The rounding's white floor, LSB^2 / (12 fs): the weight of the white component."""
        return self.lsb**2 / (12.0 * self.spectral.rate_hz)

    @property
    def parameters(self) -> tuple[str, ...]:
        return self.prior.parameters

    @property
    def terms(self) -> tuple[str, ...]:
        return self.prior.terms

    @property
    def context(self) -> Context:
        """What the parameters' ranges depend on (the record's rate and length, the ramp's
        scale)."""
        spectral = self.spectral
        return Context(spectral.rate_hz, spectral.duration_s, self.prior.linear_scale)

    @property
    def filter_term(self):
        """The output filter's low-pass shape term, if the model has one (the one-tap filter,
        exact in the components, is not one)."""
        for name in self.terms:
            shape = TERMS[name].filter_shape
            if shape is not None and shape != "one_tap":
                return TERMS[name]
        return None

    @property
    def shape(self) -> str | None:
        """The low-pass output filter's shape, if the model has one."""
        term = self.filter_term
        return None if term is None else term.filter_shape

    def natural(self, theta) -> dict:
        """Sampled coordinates -> parameter values in their units (channel units for the
        noise, samples, Hz, s or 1 for the others)."""
        context = self.context
        return {
            name: PARAMETERS[name].natural(theta[..., index], context)
            for index, name in enumerate(self.parameters)
        }

    def _switched(self, theta) -> dict:
        """The values with each masked term's scale (its first parameter) set to zero; a
        filter shape's are left to :meth:`whittle_weights`."""
        values = self.natural(theta)
        if self.mask is None:
            return values
        for name in self.terms:
            term = TERMS[name]
            if term.filter_shape in (None, "one_tap"):
                first = term.parameters[0].name
                values[first] = values[first] * self.mask[self.parameters.index(first)]
        return values

    def _weights(self, theta) -> tuple:
        """(the components' weights at ``theta``, the values they come from)."""
        values = self._switched(theta)
        return self.components.weights(values), values

    def variances(self, theta):
        """Weights of the summaries' components (:meth:`Components.weights`), the rounding
        floor on the white noise's."""
        return self._weights(theta)[0].at[..., self.components.white].add(self.rounding)

    def whittle_weights(self, theta):
        """(variances, filtered) for the Whittle likelihood: all weights and None without a
        low-pass; with one, the weights it does not shape and (its gain at the bins' nodes,
        the weights of the components it shapes)
        (:func:`~bayescal.models._whittle.node_spectrum`)."""
        weights, values = self._weights(theta)
        white = self.components.white
        term = self.filter_term
        if term is None:
            return weights.at[..., white].add(self.rounding), None
        gain = term.gain(self.spectral.node_frequency, values, self.spectral.rate_hz)
        if self.mask is not None:
            on = self.mask[self.parameters.index(term.parameters[0].name)]
            gain = 1.0 + on * (gain - 1.0)
        shaped = self.spectral.shaped
        rest = weights.at[..., shaped].set(0.0).at[..., white].set(self.rounding)
        return rest, (gain, weights[..., shaped])

    def ramp(self, theta):
        values = self._switched(theta)
        rates = [TERMS[name].mean_rate for name in self.terms if TERMS[name].mean_rate]
        return values[rates[0]] if rates else jnp.zeros(theta.shape[:-1])

    def pointwise_log_likelihood(self, theta):
        variances, filtered = self.whittle_weights(theta)
        return whittle_log_likelihood(self.spectral, variances, self.ramp(theta), filtered=filtered)

    def log_prior(self, theta):
        return -0.5 * jnp.sum(((theta - self.prior.location) / self.prior.scale) ** 2)

    def for_likelihood(self) -> "NoiseProblem":
        """This problem as its log density reads it, in shapes that do not change with the
        record: the spectral summary padded (:func:`~bayescal.models._whittle.
        padded_summary`: the same log density, its pointwise values followed by zeros) and
        the level left out (the bias is drawn apart, given the noise). What the compiled
        optimiser and sampler take, so that records whose arrays differ only in length share
        one trace."""
        return NoiseProblem(
            padded_summary(self.spectral), None, self.prior, lsb=self.lsb, mask=self.mask
        )

    def of_own_terms(self, terms=None) -> "NoiseProblem":
        """This problem with its summaries holding only the components of its own terms
        (:meth:`~bayescal.models._components.Components.restricted`), or of ``terms``: the
        same log density and bias where every other component of the family weighs zero (a
        term the problem lacks, or one it holds that ``terms`` leaves out and its mask
        switches off), at the cost of its few components, not of a term search's family of
        some sixty (the Gauss-Markov term's grid of correlation times among them).

        What the posterior's MAP, chain, draws and bias take
        (:func:`~bayescal.inference._noise_posterior.sample_noise`: a log density of two
        components, not sixty, at each of the sampler's steps; 2,000 block-mean covariances
        of two components for the bias) and each family of the term search
        (:mod:`~bayescal.inference._selection`: the Gauss-Markov grid only where a model holds
        the term). The same log density to rounding is another chain, within Monte Carlo
        error: a borderline posterior that met its autocorrelation criterion with an R-hat or
        ESS short of the bar runs on until they pass (:func:`~bayescal.inference._mcmc.
        sample_ensemble`) rather than failing for one seed and passing for another."""
        components, rows = self.components.restricted(self.terms if terms is None else terms)
        if len(rows) == len(self.components.shapes):
            return self
        spectral = self.spectral
        # Rows after the components' own are extra components (none in a noise problem's).
        rows = np.concatenate((rows, np.arange(len(self.components.shapes), len(spectral.basis))))
        spectral = dataclasses.replace(
            spectral,
            basis=np.asarray(spectral.basis)[rows],
            mean_basis=np.asarray(spectral.mean_basis)[rows],
            components=components,
        )
        level = self.level
        if level is not None:
            level = dataclasses.replace(level, basis=np.asarray(level.basis)[rows])
        return dataclasses.replace(self, spectral=spectral, level=level)

    def log_posterior(self, theta):
        value = self.log_prior(theta) + jnp.sum(self.pointwise_log_likelihood(theta))
        return jnp.where(jnp.isfinite(value), value, -jnp.inf)
