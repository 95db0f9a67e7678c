"""The posterior of an alignment at rest: the drift scale s sampled with emcee, every state at
the alignment's end drawn from the mixture over s.

The fine-alignment filter (:mod:`bayescal.navigation._alignment`) runs once at a reference s;
:class:`~bayescal.navigation._alignment.DriftProblem` turns it into log p(s | y) at any s
(closed form), which the one MAP + Laplace routine and the ensemble sampler of
:mod:`._mcmc` sample with the usual checks. Given s the states are Gaussian, so each kept draw
of s gives one draw of the states from that Gaussian: the draws follow the posterior mixture.
"""

import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ..navigation._alignment import DriftProblem, FineAlignment, draw_final_states, drift_problem
from ._mcmc import (
    MAX_STORED_DRAWS,
    Diagnostics,
    batch_log_density,
    diagnose,
    sample_ensemble,
    walker_count,
)
from ._optimize import maximum_a_posteriori
from ._sampler import Sampler


@dataclass(frozen=True)
class AlignmentPosterior:
    """Draws of the drift scale and of the states at the alignment's end."""

    drift: np.ndarray
    """(draws,) s, rad/s."""
    states: np.ndarray
    """(draws, n) every state at the alignment's end, in its own unit (unscaled)."""
    diagnostics: Diagnostics | None
    """The sampler's checks (None when the drift scale was given: nothing was sampled)."""
    filtered: object
    """The filter's run at the reference s."""


def sample_alignment(
    alignment: FineAlignment,
    *,
    location: float,
    seed: int,
    drift: float | str = "auto",
    sampler: Sampler = Sampler(),
) -> AlignmentPosterior:
    """Sample the drift scale of ``alignment`` (``location``: the log of its half-Cauchy
    prior's scale, s in rad/s) and draw the final states from the mixture; seeded. A given
    ``drift`` (s, rad/s; 0 for none) is taken as known: the states' posterior is then one
    Gaussian, drawn from as many times as the sampler keeps."""
    reference = math.exp(location)
    filtered = alignment.model.filter(reference)
    problem = drift_problem(alignment, filtered, reference, location)
    rng = np.random.default_rng(seed)
    if drift == "auto":
        mode = maximum_a_posteriori(DriftProblem.log_posterior, problem, problem.location)
        ensemble, done = sample_ensemble(
            batch_log_density(DriftProblem.log_posterior, problem),
            mode.theta,
            mode.covariance,
            rng,
            walker_count(mode.theta.size, sampler.n_walkers),
            sampler.max_steps,
            sampler.progress,
        )
        diagnostics, kept = diagnose(ensemble, problem.parameters, done, mode.converged)
        theta = kept.reshape(-1, kept.shape[-1])
    else:
        diagnostics = None
        theta = np.full((MAX_STORED_DRAWS, 1), math.log(drift) if drift > 0 else -np.inf)
    draws = draw_final_states(
        problem,
        filtered.mean[-1],
        filtered.covariance[-1],
        alignment.layout.all_coefficients.start,
        jnp.asarray(theta),
        jax.random.PRNGKey(int(rng.integers(2**31))),
    )
    return AlignmentPosterior(
        drift=np.exp(theta[:, 0]),
        states=np.asarray(draws) * np.asarray(alignment.model.scale),
        diagnostics=diagnostics,
        filtered=filtered,
    )
