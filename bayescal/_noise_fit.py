"""Fitting the stationary noise model: the point estimate by optimistix with its Laplace
covariance, the posterior by emcee, both checked, and the result as ArviZ data.

The noise parameters (N, B, K, Q) and the ramp R are sampled; the bias, linear and Gaussian
given them, is drawn for each posterior draw from its exact conditional
(:func:`bayescal._level.bias_given_noise`).

Parameters are sampled unconstrained: the logarithm of each noise scale and R divided by its
prior scale. Priors (weakly informative unless a sensor card is given): each noise scale is
log-normal with its median at the level the classical Allan curve suggests for that term and
a standard deviation of 4 in the logarithm (a factor 55); R is normal around zero with ten
times the drift that would explain the whole Allan deviation at the longest tau; the bias
is flat.
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from ._allan import DeviationResult
from ._errors import InputError
from ._level import LevelSummary, bias_given_noise, level_summary
from ._mcmc import Diagnostics, batch_log_density, diagnose, sample_ensemble, walker_count
from ._noise_model import component_weights
from ._whittle import SpectralSummary, spectral_summary, whittle_log_likelihood

PARAMETER_OF_TERM = {
    "output_filter": "F",
    "quantization": "Q",
    "white": "N",
    "bias_instability": "B",
    "rate_random_walk": "K",
    "rate_ramp": "R",
}
TERM_OF_PARAMETER = {parameter: term for term, parameter in PARAMETER_OF_TERM.items()}
TERM_ALIASES = {
    "white": "white",
    "n": "white",
    "arw": "white",
    "vrw": "white",
    "bias_instability": "bias_instability",
    "flicker": "bias_instability",
    "b": "bias_instability",
    "rate_random_walk": "rate_random_walk",
    "rrw": "rate_random_walk",
    "k": "rate_random_walk",
    "quantization": "quantization",
    "q": "quantization",
    "rate_ramp": "rate_ramp",
    "ramp": "rate_ramp",
    "r": "rate_ramp",
    "output_filter": "output_filter",
    "filter": "output_filter",
    "f": "output_filter",
}
DEFAULT_TERMS = ("white", "bias_instability", "rate_random_walk")
ALL_TERMS = (
    "quantization",
    "white",
    "output_filter",
    "bias_instability",
    "rate_random_walk",
    "rate_ramp",
)
PRIOR_LOG_SD = 4.0
RAMP_PRIOR_FACTOR = 10.0


def parse_terms(spec: str) -> tuple[str, ...]:
    """Noise terms from ``--terms`` (comma-separated names or aliases, or ``all``), in the
    canonical order; the bias is always part of the model."""
    if spec.strip().lower() == "all":
        return ALL_TERMS
    terms = set()
    for word in spec.split(","):
        name = word.strip().lower()
        if not name or name == "bias":
            continue
        if name not in TERM_ALIASES:
            raise InputError(
                f"--terms: unknown term '{word.strip()}'",
                fix="choose from white, bias_instability, rate_random_walk, "
                "quantization, rate_ramp (or rrw, flicker, ramp, all)",
            )
        terms.add(TERM_ALIASES[name])
    if not terms & {"white", "bias_instability", "rate_random_walk", "quantization"}:
        raise InputError("--terms: the model needs at least one noise term (e.g. white)")
    if "output_filter" in terms and "white" not in terms:
        raise InputError("--terms: output_filter shapes the white noise; add white")
    return tuple(term for term in ALL_TERMS if term in terms)


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


def allan_reference_scales(allan: DeviationResult) -> dict[str, float]:
    """The level of each term the classical Allan curve allows (its upper bound, DESIGN.md
    table): the centres of the weakly informative priors."""
    usable = np.isfinite(allan.deviation)
    tau, sigma = allan.tau[usable], allan.deviation[usable]
    return {
        "Q": float(np.min(sigma * tau / math.sqrt(3.0))),
        "N": float(np.min(sigma * np.sqrt(tau))),
        "B": float(np.min(sigma) / math.sqrt(2 * math.log(2) / math.pi)),
        "K": float(np.min(sigma * np.sqrt(3.0 / tau))),
        "R": float(np.min(sigma * math.sqrt(2.0) / tau)),
    }


def default_prior(terms: tuple[str, ...], allan: DeviationResult) -> NoisePrior:
    scales = allan_reference_scales(allan)
    parameters = tuple(PARAMETER_OF_TERM[term] for term in terms)
    location = [0.0 if p in ("R", "F") else math.log(scales[p]) for p in parameters]
    scale = [1.0 if p in ("R", "F") else PRIOR_LOG_SD for p in parameters]
    return NoisePrior(
        np.array(location),
        np.array(scale),
        np.asarray(RAMP_PRIOR_FACTOR * scales["R"]),
        parameters,
        "weakly informative: log-normal noise scales, median at the Allan-curve "
        f"bound of each term, sd {PRIOR_LOG_SD:g} in the log; normal ramp around 0; "
        "atanh of the output filter coefficient standard normal",
    )


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


class ParameterSummary(eqx.Module):
    mean: float
    sd: float
    q05: float
    q95: float
    map: float
    map_sd: float
    """Laplace (Hessian) standard deviation at the MAP, by the delta method."""


class NoiseFit(eqx.Module):
    """Posterior of the noise model of one channel, with its point estimate and checks."""

    parameters: dict
    """name -> :class:`ParameterSummary`, in the channel's units."""
    diagnostics: Diagnostics
    draws: dict
    """name -> (walkers, draws) posterior draws, bias included."""
    log_posterior: np.ndarray
    """(walkers, draws) log posterior density of each draw."""
    pointwise_log_likelihood: np.ndarray
    """(walkers, draws, bins) Whittle log-likelihood of each frequency bin."""
    map_theta: np.ndarray
    laplace_covariance: np.ndarray
    problem: NoiseProblem
    terms: tuple[str, ...] = eqx.field(static=True)
    seed: int = eqx.field(static=True)


@eqx.filter_jit
def _maximum_a_posteriori(problem: NoiseProblem):
    """Minimise the negative log-posterior from two starts — the prior centres (the Allan
    bounds) and a point well below them, where the terms a record does not hold sit — and
    return the better optimum, its Hessian and whether that run converged."""

    def objective(theta, _):
        return -problem.log_posterior(theta)

    solver = optx.BFGS(rtol=1e-9, atol=1e-9)
    base = jnp.asarray(problem.prior.location)
    lowered = base - 3.0 * jnp.array([p != "R" for p in problem.parameters])
    solutions = [
        optx.minimise(objective, solver, start, max_steps=2000, throw=False)
        for start in (base, lowered)
    ]
    values = jnp.stack([objective(solution.value, None) for solution in solutions])
    values = jnp.where(jnp.isfinite(values), values, jnp.inf)
    pick = jnp.argmin(values)
    best = jnp.where(pick == 0, solutions[0].value, solutions[1].value)
    converged = jnp.where(
        pick == 0,
        solutions[0].result == optx.RESULTS.successful,
        solutions[1].result == optx.RESULTS.successful,
    )
    return best, jax.hessian(lambda theta: objective(theta, None))(best), converged


@eqx.filter_jit
def _draw_quantities(problem: NoiseProblem, kept, key):
    """Parameter values, bias draws (from its Gaussian conditional) and the pointwise
    log-likelihood for each kept posterior draw."""
    natural = problem.natural(kept)
    mean, variance = bias_given_noise(problem.level, problem.variances(kept), problem.ramp(kept))
    natural["bias"] = mean + jnp.sqrt(variance) * jax.random.normal(key, mean.shape)
    pointwise = jax.vmap(jax.vmap(problem.pointwise_log_likelihood))(kept)
    log_posterior = jax.vmap(jax.vmap(problem.log_posterior))(kept)
    return natural, pointwise, log_posterior


@eqx.filter_jit
def _bias_at(problem: NoiseProblem, theta):
    """Bias mean and variance at ``theta``, and its change per unit of the ramp R."""
    variances, ramp = problem.variances(theta), problem.ramp(theta)
    mean, variance = bias_given_noise(problem.level, variances, ramp)
    return mean, variance, mean - bias_given_noise(problem.level, variances, ramp + 1.0)[0]


def noise_problem(
    values,
    rate_hz: float,
    allan: DeviationResult,
    *,
    terms: tuple[str, ...] = DEFAULT_TERMS,
    prior: NoisePrior | None = None,
) -> NoiseProblem:
    """The log-posterior of a rate series ``values`` (NaN: missing); ``allan`` is its classical
    Allan deviation, which centres the default priors."""
    values = np.asarray(values, dtype=float)
    return NoiseProblem(
        spectral_summary(values, rate_hz),
        level_summary(values, rate_hz),
        prior or default_prior(terms, allan),
    )


class PointEstimate(eqx.Module):
    """The MAP: sampled coordinates, values in the channel's units, the Laplace covariance of
    the sampled coordinates, and whether the optimisation converged."""

    theta: np.ndarray
    values: dict
    covariance: np.ndarray
    converged: bool


def point_estimate(problem: NoiseProblem) -> PointEstimate:
    best, hessian, converged = _maximum_a_posteriori(problem)
    values = {name: float(value) for name, value in problem.natural(best).items()}
    return PointEstimate(
        np.asarray(best), values, np.linalg.pinv(np.asarray(hessian)), bool(converged)
    )


def fit_noise(
    values,
    rate_hz: float,
    allan: DeviationResult,
    *,
    terms: tuple[str, ...] = DEFAULT_TERMS,
    prior: NoisePrior | None = None,
    seed: int = 0,
    n_walkers: int = 32,
    max_steps: int = 40_000,
    progress: bool = False,
) -> NoiseFit:
    """Posterior of bias and noise terms of a static channel ``values`` (NaN: missing).

    ``allan`` is the classical Allan deviation of the same values (it centres the default
    priors). The same inputs and ``seed`` give the same result.
    """
    problem = noise_problem(values, rate_hz, allan, terms=terms, prior=prior)
    return sample_noise(
        problem, terms=terms, seed=seed, n_walkers=n_walkers, max_steps=max_steps, progress=progress
    )


def sample_noise(
    problem: NoiseProblem,
    *,
    terms: tuple[str, ...],
    seed: int = 0,
    n_walkers: int = 32,
    max_steps: int = 40_000,
    progress: bool = False,
) -> NoiseFit:
    """MAP, Laplace covariance and emcee posterior of a :class:`NoiseProblem`, checked."""
    rng = np.random.default_rng(seed)
    estimate = point_estimate(problem)
    sampler, converged = sample_ensemble(
        batch_log_density(NoiseProblem.log_posterior, problem),
        estimate.theta,
        estimate.covariance,
        rng,
        walker_count(estimate.theta.size, n_walkers),
        max_steps,
        progress,
    )
    diagnostics, kept = diagnose(sampler, problem.parameters, converged, estimate.converged)
    natural, pointwise, log_posterior = _draw_quantities(
        problem, jnp.asarray(kept), jax.random.PRNGKey(int(rng.integers(2**31)))
    )
    natural = {name: np.asarray(value) for name, value in natural.items()}
    map_values, map_sd = _map_summary(problem, estimate)
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
    return NoiseFit(
        parameters=summaries,
        diagnostics=diagnostics,
        draws=natural,
        log_posterior=np.asarray(log_posterior),
        pointwise_log_likelihood=np.asarray(pointwise),
        map_theta=estimate.theta,
        laplace_covariance=estimate.covariance,
        problem=problem,
        terms=tuple(terms),
        seed=seed,
    )


def _map_summary(problem: NoiseProblem, estimate: PointEstimate) -> tuple[dict, dict]:
    """MAP values and their Laplace sds (delta method) in the channel's units, the bias
    included (its conditional sd, widened by the ramp's uncertainty when R is fitted)."""
    values, spread = dict(estimate.values), {}
    for i, name in enumerate(problem.parameters):
        sd = math.sqrt(max(estimate.covariance[i, i], 0.0))
        slope = {"R": float(problem.prior.ramp_scale), "F": 1.0 - values.get("F", 0.0) ** 2}
        spread[name] = sd * slope.get(name, values[name])
    mean, variance, per_ramp = (
        float(value) for value in _bias_at(problem, jnp.asarray(estimate.theta))
    )
    if "R" in problem.parameters:
        variance += per_ramp**2 * spread["R"] ** 2
    values["bias"], spread["bias"] = mean, math.sqrt(variance)
    return values, spread
