"""The posterior of a channel's noise parameters: the MAP with its Laplace covariance, then
emcee from it, checked; the bias drawn for each posterior draw from its exact Gaussian
conditional (:func:`bayescal.models._level.bias_given_noise`)."""

import math
from functools import partial

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._threads import in_threads
from ..models._level import bias_given_noise
from ..models._noise_model import NoiseModel
from ..models._noise_problem import NoiseProblem
from ..models._terms import PARAMETERS, TERMS
from ..models._whittle import padded_index
from ._mcmc import Diagnostics, batch_log_density, diagnose, sample_ensemble, walker_count
from ._optimize import Mode, maximum_a_posteriori
from ._traced import persistent_jit


def _scales(problem: NoiseProblem) -> list[bool]:
    """Which coordinates are a stochastic term's scale (the first parameter of a term that
    is neither a low-pass shape nor the ramp)."""
    scales = {
        TERMS[name].parameters[0].name
        for name in problem.terms
        if TERMS[name].filter_shape in (None, "one_tap") and TERMS[name].mean_rate is None
    }
    return [name in scales for name in problem.parameters]


def noise_starts(problem: NoiseProblem) -> tuple[np.ndarray, np.ndarray]:
    """The MAP's two starts: the prior centres (the Allan bounds) and a point well below
    them, where the terms a record does not hold sit."""
    # numpy: each JAX operation outside a compiled function loads a kernel on a process's
    # first call (some 8 ms each).
    base = np.asarray(problem.prior.location, dtype=float)
    return base, base - 3.0 * np.array(_scales(problem), dtype=float)


def noise_mode(problem: NoiseProblem) -> Mode:
    """The MAP from :func:`noise_starts`. The optimiser takes the problem in the shapes
    every record shares (:meth:`NoiseProblem.for_likelihood`)."""
    return maximum_a_posteriori(
        NoiseProblem.log_posterior, problem.for_likelihood(), noise_starts(problem)
    )


def noise_model(problem: NoiseProblem, values: dict) -> NoiseModel:
    """The :class:`NoiseModel` of ``problem`` at parameter ``values`` (natural units, of the
    terms switched on; arrays broadcast, except a low-pass filter's, which are numbers), with
    the record's LSB."""
    noise = {name: values[name] for name in problem.parameters if name in values}
    return NoiseModel(problem.spectral.rate_hz, lsb=float(problem.lsb), **noise)


class ParameterSummary(eqx.Module):
    mean: float
    sd: float
    q05: float
    q95: float
    map: float
    map_sd: float
    """Laplace (Hessian) standard deviation at the MAP, by the delta method."""


class NoisePosterior(eqx.Module):
    """Posterior of the noise model of one channel, with its point estimate and checks."""

    parameters: dict
    """name -> :class:`ParameterSummary`, in the channel's units."""
    diagnostics: Diagnostics
    draws: dict
    """name -> (walkers, draws) posterior draws, bias included."""
    bias_conditional: tuple[np.ndarray, np.ndarray]
    """(mean, sd), each (walkers, draws): the Gaussian of the bias given the noise at each
    draw, from which its draw was taken (kept whole: a fleet's population integrates the bias
    out with it)."""
    log_posterior: np.ndarray
    """(walkers, draws) log posterior density of each draw."""
    pointwise_log_likelihood: np.ndarray
    """(walkers, draws, bins) Whittle log-likelihood of each frequency bin."""
    map_theta: np.ndarray
    laplace_covariance: np.ndarray
    problem: NoiseProblem
    terms: tuple[str, ...] = eqx.field(static=True)
    seed: int = eqx.field(static=True)

    def model_at_map(self) -> NoiseModel:
        """The noise model at the MAP."""
        return noise_model(self.problem, {n: s.map for n, s in self.parameters.items()})

    def models(self, draws: dict):
        """The noise model of each of ``draws`` (name -> flat array of draws), one by one."""
        count = next(iter(draws.values())).size
        for index in range(count):
            yield noise_model(self.problem, {n: float(v[index]) for n, v in draws.items()})


@eqx.filter_jit
def _bias_conditional(problem: NoiseProblem, kept):
    """The mean and sd of the bias's Gaussian conditional at each of ``kept`` draws."""
    mean, variance = bias_given_noise(problem.level, problem.variances(kept), problem.ramp(kept))
    return mean, jnp.sqrt(variance)


@eqx.filter_jit
def _draw_values(problem: NoiseProblem, kept, mean, sd, key):
    """Parameter values and the bias drawn from its Gaussian conditional (``mean``, ``sd``:
    :func:`_bias_conditional`) for each kept posterior draw."""
    natural = problem.natural(kept)
    natural["bias"] = mean + sd * jax.random.normal(key, mean.shape)
    return natural


BIAS_PIECES = 2
"""The pieces (of walkers) whose bias conditionals are computed side by side where there are
threads (:func:`~bayescal._threads.in_threads`), beside the draws' densities: a Cholesky factor per
draw, 70 of a 2^20-sample fit's 95 ms there on one thread. Fixed, not the thread count: the
shapes, so the compiled functions and their numbers, are the same on any machine."""


@persistent_jit
def _draw_densities(problem: NoiseProblem, kept):
    """The pointwise log-likelihood and the log posterior of each kept posterior draw, of
    ``problem`` in the shapes every record shares (:meth:`NoiseProblem.for_likelihood`)."""
    pointwise = jax.vmap(jax.vmap(problem.pointwise_log_likelihood))(kept)
    return pointwise, jax.vmap(jax.vmap(problem.log_posterior))(kept)


@eqx.filter_jit
def _bias_at(problem: NoiseProblem, theta):
    """Bias mean and variance at ``theta``, and its change per unit of the ramp R."""
    variances, ramp = problem.variances(theta), problem.ramp(theta)
    mean, variance = bias_given_noise(problem.level, variances, ramp)
    return mean, variance, mean - bias_given_noise(problem.level, variances, ramp + 1.0)[0]


def sample_noise(
    problem: NoiseProblem,
    *,
    terms: tuple[str, ...],
    seed: int = 0,
    n_walkers: int = 32,
    max_steps: int = 40_000,
    progress: bool = False,
) -> NoisePosterior:
    """MAP, Laplace covariance and emcee posterior of a :class:`NoiseProblem`, checked."""
    rng = np.random.default_rng(seed)
    # The MAP and the chain on the problem's own components (a term search's family holds
    # some sixty, the others weighing zero): the same log density to rounding at a fraction
    # of the cost per step; the posterior keeps the problem whole, as its checks read it.
    own = problem.of_own_terms()
    estimate = noise_mode(own)
    sampler, converged = sample_ensemble(
        batch_log_density(NoiseProblem.log_posterior, own.for_likelihood()),
        estimate.theta,
        estimate.covariance,
        rng,
        walker_count(estimate.theta.size, n_walkers),
        max_steps,
        progress,
    )
    diagnostics, kept = diagnose(sampler, problem.parameters, converged, estimate.converged)
    return noise_posterior_of(problem, estimate, diagnostics, kept, rng, terms=terms, seed=seed)


def noise_posterior_of(
    problem: NoiseProblem,
    estimate: Mode,
    diagnostics: Diagnostics,
    kept: np.ndarray,
    rng: np.random.Generator,
    *,
    terms: tuple[str, ...],
    seed: int,
) -> NoisePosterior:
    """The :class:`NoisePosterior` of ``problem`` from its MAP, its sampler's checks and the
    draws kept (walkers, draws, dimension; :func:`~._mcmc.diagnose`): each draw's values, its
    bias from the Gaussian conditional (keyed by ``rng``), densities and summaries."""
    # The bias and the densities on the problem's own components: the family's others weigh
    # zero in them.
    own = problem.of_own_terms()
    likelihood, key = own.for_likelihood(), jax.random.PRNGKey(int(rng.integers(2**31)))
    pieces = np.array_split(kept, BIAS_PIECES)
    *conditionals, (pointwise, log_posterior) = in_threads(
        lambda task: jax.block_until_ready(task()),
        [
            *(partial(_bias_conditional, own, jnp.asarray(piece)) for piece in pieces),
            partial(_draw_densities, likelihood, jnp.asarray(kept)),
        ],
    )
    bias_conditional = tuple(jnp.concatenate(parts) for parts in zip(*conditionals, strict=True))
    natural = _draw_values(own, jnp.asarray(kept), *bias_conditional, key)
    pointwise = np.asarray(pointwise)[..., padded_index(problem.spectral)]
    natural = {name: np.asarray(value) for name, value in natural.items()}
    map_values, map_sd = map_summary(own, estimate)
    summaries = {
        name: ParameterSummary(
            float(np.mean(natural[name])),
            float(np.std(natural[name], ddof=1)),
            float(np.quantile(natural[name], 0.05)),
            float(np.quantile(natural[name], 0.95)),
            map_values[name],
            map_sd[name],
        )
        for name in ("bias", *problem.parameters)
    }
    return NoisePosterior(
        parameters=summaries,
        diagnostics=diagnostics,
        draws=natural,
        bias_conditional=tuple(np.asarray(value) for value in bias_conditional),
        log_posterior=np.asarray(log_posterior),
        pointwise_log_likelihood=np.asarray(pointwise),
        map_theta=estimate.theta,
        laplace_covariance=estimate.covariance,
        problem=problem,
        terms=tuple(terms),
        seed=seed,
    )


def map_summary(problem: NoiseProblem, estimate: Mode) -> tuple[dict, dict]:
    """MAP values and their Laplace sds (delta method) in the channel's units, the bias
    included (its conditional sd, widened by the ramp's uncertainty when R is fitted)."""
    values = {name: float(v) for name, v in problem.natural(jnp.asarray(estimate.theta)).items()}
    context = problem.context
    spread = {}
    for i, name in enumerate(problem.parameters):
        sd = math.sqrt(max(estimate.covariance[i, i], 0.0))
        spread[name] = sd * float(PARAMETERS[name].slope(values[name], context))
    mean, variance, per_ramp = (
        float(value) for value in _bias_at(problem, jnp.asarray(estimate.theta))
    )
    for name in problem.terms:
        if TERMS[name].mean_rate:
            variance += per_ramp**2 * spread[TERMS[name].mean_rate] ** 2
    values["bias"], spread["bias"] = mean, math.sqrt(variance)
    return values, spread
