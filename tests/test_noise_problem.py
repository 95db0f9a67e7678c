"""A noise problem of its own terms (the components of a term search's family that it uses)
and the bias of a batch of draws, against the family's problem and a direct solve."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import bayescal as bc
from bayescal.inference._priors import default_prior
from bayescal.models._level import bias_given_noise
from bayescal.models._noise_problem import NoiseProblem, noise_summaries
from bayescal.models._terms import CANDIDATE_TERMS

RATE = 100.0
TRUTH = {"N": 0.005, "B": 5e-4, "K": 5e-6}


def _problems(terms, family=("white", *CANDIDATE_TERMS)):
    """(the problem of ``terms`` with the summaries of ``family``, of its own terms) of a
    record."""
    values = bc.NoiseModel(rate_hz=RATE, bias=0.3, **TRUTH).simulate(2**14, seed=2)
    spectral, level = noise_summaries(values, RATE, family)
    prior = default_prior(terms, bc.allan_deviation(values, RATE))
    problem = NoiseProblem(spectral, level, prior, lsb=np.asarray(1e-4))
    return problem, problem.of_own_terms()


@eqx.filter_jit
def _evaluated(problem, padded, theta):
    """Log densities at each ``theta``, the pointwise likelihood (of ``padded``, the
    problem as the sampler takes it) at the first, and the bias's
    mean and variance at each (ramp zero: no ramp among the terms)."""
    bias = bias_given_noise(problem.level, problem.variances(theta), problem.ramp(theta))
    return (
        jax.vmap(problem.log_posterior)(theta),
        padded.pointwise_log_likelihood(theta[0]),
        *bias,
    )


def test_a_problem_of_its_own_terms_has_the_family_s_log_density_and_bias():
    """Its summaries hold only its terms' components (the family's hold some fifty, the
    Gauss-Markov grid among them), and its log density, pointwise likelihood and bias are
    the family problem's, in which every other component weighs zero."""
    rng = np.random.default_rng(0)
    for terms in (("white", "rate_random_walk"), ("white", "bias_instability", "rate_random_walk")):
        family, own = _problems(terms)
        assert own.components.names == terms
        assert len(own.components.shapes) < 10 < len(family.components.shapes)
        assert own.level.basis.shape[0] == len(own.components.shapes)
        theta = family.prior.location + 0.5 * rng.standard_normal((6, len(terms)))
        expected, got = (
            _evaluated(p, p.for_likelihood(), jnp.asarray(theta)) for p in (family, own)
        )
        np.testing.assert_allclose(got[0], expected[0], rtol=1e-12)
        np.testing.assert_allclose(got[1], expected[1], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(got[2], expected[2], rtol=1e-10)
        np.testing.assert_allclose(got[3], expected[3], rtol=1e-10)


def test_the_bias_of_a_batch_is_each_draw_s_generalised_least_squares():
    """:func:`bias_given_noise` of a batch of draws (more than one batch of
    :data:`~bayescal.models._level.BIAS_BATCH`, a ramp broadcast over them) is, draw by
    draw, the GLS mean and variance of the level from a direct solve."""
    terms = ("white", "rate_random_walk")
    level = _problems(terms, family=terms)[1].level
    rng = np.random.default_rng(1)
    variances = np.exp(rng.normal(0.0, 1.0, (5, 9, 2))) * np.array([TRUTH["N"] ** 2, 1e-10])
    ramp = rng.normal(0.0, 1e-5, (9,))
    mean, variance = (np.asarray(v) for v in bias_given_noise(level, variances, ramp))
    assert mean.shape == variance.shape == (5, 9)
    ones = np.ones(level.block_mean.size)
    for i, j in np.ndindex(5, 9):
        covariance = np.einsum("t,tij->ij", variances[i, j], level.basis)
        weights = np.linalg.solve(covariance, ones)
        target = level.block_mean - ramp[j] * level.block_time_s
        np.testing.assert_allclose(variance[i, j], 1.0 / weights.sum(), rtol=1e-9)
        np.testing.assert_allclose(
            mean[i, j],
            weights @ target / weights.sum(),
            rtol=0,
            atol=1e-9 * np.sqrt(variance[i, j]),
        )
