"""The posterior of a thermal bias calibration (the model of :mod:`bayescal.models._thermal`):
the MAP and Laplace approximation of the noise, emcee from it (checked like every posterior),
and for each noise draw the coefficients c_0..c_d and period offsets from their Gaussian
conditional, whose mixture is their posterior (:func:`sample_thermal`); and the polynomial's
degree chosen by one-block-ahead predictive density (:func:`choose_degree`)."""

import math
from dataclasses import dataclass

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._errors import InputError
from ..models._noise_problem import NoisePrior
from ..models._terms import PARAMETERS, term_parameters
from ..models._thermal import (
    MAX_DEGREE,
    ThermalProblem,
    ThermalRecord,
    _blocks,
    _identified_from,
    prequential_score,
    record_spectrum,
    thermal_problem,
)
from ..models.effects._parameter import Context
from ._mcmc import batch_log_density, diagnose, sample_ensemble, walker_count
from ._optimize import maximum_a_posteriori
from ._sampler import Sampler


@eqx.filter_jit
def _draw_regression(problem: ThermalProblem, theta, key):
    """For each noise draw, a draw of the regression from its Gaussian conditional; also the
    conditional means and covariances, whose mixture is the posterior."""

    def one(theta_one, key_one):
        precision, mean, _, _ = problem.conditional(theta_one)
        covariance = jnp.linalg.inv(precision)
        draw = mean + jnp.linalg.cholesky(covariance) @ jax.random.normal(key_one, mean.shape)
        return draw, mean, covariance

    keys = jax.random.split(key, theta.shape[0])
    return jax.vmap(one)(theta, keys)


@dataclass(frozen=True)
class ThermalFit:
    """Posterior of the thermal coefficients c_0..c_d (and period offsets) and the noise."""

    degree: int
    reference: float
    coefficient_mean: np.ndarray
    coefficient_covariance: np.ndarray
    coefficient_draws: np.ndarray
    """(draws, d + 1)"""
    offset_mean: np.ndarray
    offset_sd: np.ndarray
    noise: dict
    """noise parameter -> (mean, q05, q95) in the channel's units"""
    map_coefficients: np.ndarray
    map_covariance: np.ndarray
    """Conditional covariance of the coefficients at the MAP noise (the Laplace answer)."""
    diagnostics: object
    degree_scores: dict
    """degree -> (elpd, se of the difference to the best) when the degree was chosen"""
    drift: tuple[float, float, float] | None = None
    """Learned drift scale s since the prior calibration: (mean, q05, q95), channel units."""


def sample_thermal(
    problem: ThermalProblem,
    degree: int,
    reference: float,
    *,
    seed: int,
    sampler: Sampler = Sampler(),
    degree_scores: dict | None = None,
) -> ThermalFit:
    """MAP and Laplace for the noise, emcee posterior, regression draws; checked."""
    mode = maximum_a_posteriori(ThermalProblem.log_posterior, problem, problem.location)
    best, converged = mode.theta, mode.converged
    start, covariance = mode.theta, mode.covariance
    rng = np.random.default_rng(seed)
    ensemble, done = sample_ensemble(
        batch_log_density(ThermalProblem.log_posterior, problem),
        start,
        covariance,
        rng,
        walker_count(start.size, sampler.n_walkers),
        sampler.max_steps,
        sampler.progress,
    )
    names = problem.parameters
    diagnostics, kept = diagnose(ensemble, names, done, bool(converged))
    flat_theta = kept.reshape(-1, kept.shape[-1])
    draws, means, covariances = (
        np.asarray(x)
        for x in _draw_regression(
            problem, jnp.asarray(flat_theta), jax.random.PRNGKey(int(rng.integers(2**31)))
        )
    )
    # The posterior of the regression is the mixture of its conditionals over the noise draws.
    mean = means.mean(axis=0)
    covariance_total = covariances.mean(axis=0) + np.cov(means.T, bias=True).reshape(
        covariances.shape[1:]
    )
    coefficients = slice(0, degree + 1)
    precision_map, mean_map, _, _ = problem.conditional(best)
    map_covariance = np.linalg.inv(np.asarray(precision_map))
    natural = {
        name: np.asarray(value) for name, value in problem.natural(jnp.asarray(flat_theta)).items()
    }
    drift = None
    if problem.learns_drift:
        scale = np.asarray(problem.drift(jnp.asarray(flat_theta)))
        drift = tuple(float(x) for x in (scale.mean(), *np.quantile(scale, [0.05, 0.95])))
    return ThermalFit(
        degree=degree,
        reference=reference,
        coefficient_mean=mean[coefficients],
        coefficient_covariance=covariance_total[coefficients, coefficients],
        coefficient_draws=draws[:, coefficients],
        offset_mean=mean[degree + 1 :],
        offset_sd=np.sqrt(np.diag(covariance_total)[degree + 1 :]),
        noise={
            name: (float(v.mean()), float(np.quantile(v, 0.05)), float(np.quantile(v, 0.95)))
            for name, v in natural.items()
        },
        map_coefficients=np.asarray(mean_map)[coefficients],
        map_covariance=map_covariance[coefficients, coefficients],
        diagnostics=diagnostics,
        degree_scores=degree_scores or {},
        drift=drift,
    )


def choose_degree(
    record: ThermalRecord, reference: float, *, noise_prior: NoisePrior
) -> tuple[int, dict]:
    """The lowest degree whose prequential ELPD is within max(4, 2 SE) of the best. Under the
    flat prior a degree has a predictive only once the blocks so far identify its
    coefficients: scoring starts where every candidate is identified, and a degree the first
    half of the blocks cannot identify is no candidate (absent from the table)."""
    blocks = _blocks(record)[0].size
    spectral = record_spectrum(record, noise_prior.terms)
    problems = {}
    for degree in range(MAX_DEGREE + 1):
        if blocks < degree + 3:  # too few blocks for this degree's problem
            break
        problem = thermal_problem(
            record, degree, reference, noise_prior=noise_prior, spectral=spectral
        )
        if _identified_from(problem.design) > blocks // 2:
            break
        problems[degree] = problem
    skip = max(
        MAX_DEGREE + 2,
        math.ceil(0.1 * blocks),
        *(_identified_from(problem.design) for problem in problems.values()),
    )
    if not problems or blocks <= skip:
        highest = min(MAX_DEGREE, blocks - 3)  # thermal_problem's blocks for a degree
        raise InputError(
            f"degree='auto': {record.values.size} samples make {blocks} block(s), and "
            f"choosing a degree scores each block after the first {skip} by those before it",
            fix=f"give degree=0..{highest}, or record longer" if highest >= 0 else "record longer",
        )
    scores = {}
    for degree, problem in problems.items():
        mode = maximum_a_posteriori(ThermalProblem.log_posterior, problem, problem.location)
        scores[degree] = prequential_score(problem, mode.theta, skip)
    best = max(scores, key=lambda d: scores[d].sum())
    table = {}
    for degree, pointwise in scores.items():
        difference = scores[best] - pointwise
        table[degree] = (
            float(pointwise.sum()),
            float(math.sqrt(difference.size * np.var(difference))),
        )
    chosen = min(d for d, (elpd, se) in table.items() if table[best][0] - elpd < max(4.0, 2 * se))
    return chosen, table


def calibrated_noise_prior(noise: dict, context: Context) -> NoisePrior:
    """The prior of the noise of an update: the noise as the calibration measured it
    (``noise``, the calibration's noise block: its terms and, per parameter, its mean, q05
    and q95), normal in each parameter's coordinate (for the update's record, ``context``)
    around its posterior mean, with the spread of its 90 % interval."""
    parameters = tuple(p for p in term_parameters(tuple(noise["terms"])) if p in noise)
    location, scale = [], []
    for name in parameters:
        mean, low, high = (
            PARAMETERS[name].coordinate(noise[name][key], context) for key in ("mean", "q05", "q95")
        )
        location.append(mean)
        scale.append(max((high - low) / 3.29, 0.01))
    return NoisePrior(
        np.array(location),
        np.array(scale),
        np.asarray(1.0),
        parameters,
        # A fixed text: it is a static field of the problem, and a path in it would make
        # every calibration file compile its own likelihood (the provenance names it).
        "the noise of the prior calibration",
    )
