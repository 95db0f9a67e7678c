"""The noise posteriors of many records of one structure at once: a fleet's recordings of a
common length and rate on one JAX device (a GPU where there is one).

The records' problems, in the shapes the likelihood reads (:meth:`NoiseProblem.
for_likelihood`), are stacked as one pytree (:func:`stack_problems`: every array with a
leading axis of records; their static parts — terms, rate, components — must agree). Their
MAPs are one ``vmap`` of the optimiser (:func:`~._optimize.maximum_a_posteriori_each`), each
with its own convergence; their posteriors one emcee run of ``records x walkers`` walkers
whose steps are one compiled call each (vmap over the records of vmap over their walkers,
:func:`~._mcmc.batch_log_density` ``grouped``), moved by :class:`~._mcmc.GroupedDEMove`:
differential evolution whose walkers pair only within their own record, so that each record's
walkers are an ensemble of its own posterior, as if sampled alone. Each record's walkers start
from its own Laplace approximation, and its chain is judged by the same checks
(:func:`~._mcmc.diagnose` of its walkers) and turned into the same
:class:`~._noise_posterior.NoisePosterior` as :func:`~._noise_posterior.sample_noise` gives.

What differs from sampling each record alone: the run goes on until every record's chain is
long enough (a record that converged early keeps sampling, which only lengthens its chain), and
a stuck run is not restarted here (:func:`~._mcmc.sample_ensemble` restarts one): a record
whose batched posterior fails its checks is for the caller to fit alone. The draws are not
those of the records sampled alone (the random streams differ); their distribution is.
"""

import jax
import numpy as np

from .._errors import InputError
from ..models._noise_problem import NoiseProblem
from ._mcmc import (
    FIRST_CHUNK,
    advance,
    autocorrelation_time,
    batch_log_density,
    diagnose,
    ensemble,
    laplace_start,
    long_enough,
    walker_count,
)
from ._noise_posterior import NoisePosterior, noise_posterior_of, noise_starts
from ._optimize import maximum_a_posteriori_each


def stack_problems(problems, names) -> NoiseProblem:
    """``problems`` (of records named ``names``) in the likelihood's shapes, stacked: each
    array with a leading axis of records. Their static parts and array shapes must agree;
    InputError names the first record that differs from the first."""
    shaped = [problem.for_likelihood() for problem in problems]
    first, first_tree = shaped[0], jax.tree.structure(shaped[0])
    shapes = [np.shape(leaf) for leaf in jax.tree.leaves(first)]
    for name, problem in zip(names[1:], shaped[1:], strict=True):
        if first.terms != problem.terms:
            differs = f"its terms {problem.terms} are not {first.terms}"
        elif jax.tree.structure(problem) != first_tree:
            differs = "its rate, length or summaries' components differ"
        elif [np.shape(leaf) for leaf in jax.tree.leaves(problem)] != shapes:
            differs = "its summaries' shapes differ"
        else:
            continue
        raise InputError(
            f"records fitted together must share one problem's structure: {name}: {differs} "
            f"from {names[0]}'s",
            fix="fit records of one length, rate and terms together",
        )
    return jax.tree.map(lambda *leaves: np.stack(leaves), *shaped)


class _GroupOfWalkers:
    """One group's walkers of a grouped emcee run, read as :func:`~._mcmc.diagnose` reads a
    sampler of its own."""

    restarts = 0

    def __init__(self, sampler, walkers: slice):
        self._sampler, self._walkers = sampler, walkers
        self.iteration = sampler.iteration
        self.ndim = sampler.ndim
        self.acceptance_fraction = sampler.acceptance_fraction[walkers]

    def get_chain(self, discard: int = 0):
        return self._sampler.get_chain(discard=discard)[:, self._walkers]


def sample_noise_each(
    problems,
    *,
    names,
    terms: tuple[str, ...],
    seeds,
    n_walkers: int = 32,
    max_steps: int = 40_000,
) -> list[NoisePosterior]:
    """The posterior of each of ``problems`` (records of one structure, :func:`stack_problems`)
    in one batched run (module docstring), as :func:`~._noise_posterior.sample_noise` gives it.

    Each record's Laplace start and bias draws come from its own seed (``seeds``); the
    sampler's random stream from all of them, in order: the same problems and seeds give the
    same posteriors.
    """
    stacked = stack_problems(problems, names)
    starts = [noise_starts(problem) for problem in problems]
    modes = maximum_a_posteriori_each(
        NoiseProblem.log_posterior,
        stacked,
        tuple(np.stack([own[k] for own in starts]) for k in range(len(starts[0]))),
    )
    rngs = [np.random.default_rng(seed) for seed in seeds]
    dimension = modes[0].theta.size
    walkers = walker_count(dimension, n_walkers)
    state = np.concatenate(
        [
            laplace_start(mode.theta, mode.covariance, rng, walkers)
            for mode, rng in zip(modes, rngs, strict=True)
        ]
    )
    stream = np.random.default_rng(np.random.SeedSequence([int(seed) for seed in seeds]))
    sampler = ensemble(
        batch_log_density(NoiseProblem.log_posterior, stacked, grouped=True),
        len(problems) * walkers,
        dimension,
        stream,
        groups=len(problems),
    )
    groups = [slice(g * walkers, (g + 1) * walkers) for g in range(len(problems))]
    converged = np.zeros(len(problems), dtype=bool)
    longer_before, chunk = converged.copy(), FIRST_CHUNK
    while sampler.iteration < max_steps:
        steps = min(chunk, max_steps - sampler.iteration)
        state = advance(sampler, state, steps)
        chain = sampler.get_chain()
        longer = np.array(
            [long_enough(autocorrelation_time(chain[:, g]), sampler.iteration) for g in groups]
        )
        converged |= longer & longer_before
        longer_before = longer
        if converged.all():
            break
        # After each quarter of the run so far, on the autocorrelation criterion alone: a
        # record failing its checks here is sampled alone (``sample_ensemble``, its checks
        # each eighth, R-hat and ESS gating its stop).
        chunk = max(chunk, sampler.iteration // 4)
    posteriors = []
    for g, problem in enumerate(problems):
        diagnostics, kept = diagnose(
            _GroupOfWalkers(sampler, groups[g]),
            problem.parameters,
            bool(converged[g]),
            modes[g].converged,
        )
        posteriors.append(
            noise_posterior_of(
                problem, modes[g], diagnostics, kept, rngs[g], terms=terms, seed=int(seeds[g])
            )
        )
    return posteriors
