"""How long to record: the interval each noise parameter's posterior would have after a record
of a given length, predicted from a pilot record's posterior (pre-posterior analysis).

For a record of n samples drawn from the noise model at parameters theta, the expected
curvature of the log posterior at theta is the Fisher information of the likelihood plus the
prior's precision. For the binned Whittle likelihood of the increments
(:mod:`bayescal.models._whittle`) whose node powers P_k have expectation c_k S_k, the Fisher
information is exact and needs no data:

    I_ab = sum_k w c_k (d log S_k / d theta_a) (d log S_k / d theta_b),

over the bins' nodes k (c_k the frequencies each stands for, w the taper's 1 / kappa), plus the
mean increments' information about the ramp. Its inverse is the Laplace covariance of a record
of that length; each noise scale's relative half-width at confidence c is sinh(z sd) for the sd
of its logarithm (z the normal quantile), the half-width of the interval exp(m -/+ z sd) over its
median. Averaged over draws of the pilot's posterior (the median over them), this is what the
pilot predicts a longer record will give. A parameter whose predicted variance stays above half
its prior's is bounded by the data, not pinned: its interval is then the prior's reach, and no
length is recommended for it.

A record longer than one periodogram's piece (:data:`~bayescal.models._whittle.MAX_SEGMENT`)
is summarised as equal pieces whose bins pool (:func:`~bayescal.models._whittle.
spectral_summary`): one piece's summary, its counts times the number of pieces.
"""

import math
from dataclasses import dataclass

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from scipy import stats

from .._x64 import require_x64  # float64 before any JAX array
from ..models._noise_problem import NoiseProblem, record_components
from ..models._terms import PARAMETERS
from ..models._whittle import MAX_SEGMENT, node_spectrum, spectral_summary
from ._noise_posterior import NoisePosterior

PAD_BINS = 128
"""Bins of a length's summary are padded to a multiple of this (module's compilations)."""
PRIOR_DOMINATED = 0.5
"""A parameter whose predicted posterior variance exceeds this fraction of its prior's is
bounded by the record, not pinned."""


@dataclass(frozen=True)
class PredictedWidths:
    """The relative half-widths each parameter's interval is predicted to have at each of
    ``lengths_s``."""

    lengths_s: np.ndarray
    """Record lengths, s."""
    widths: dict
    """parameter -> (lengths,) predicted relative half-width of its interval (the median
    over the pilot's posterior draws)."""
    prior_dominated: dict
    """parameter -> (lengths,) whether its predicted posterior stays above half its prior's
    variance (bounded, not pinned)."""
    confidence: float


def record_summary(problem: NoiseProblem, n_samples: int, seed: int = 0):
    """The spectral summary of a record of ``n_samples`` holding ``problem``'s components:
    its bins and expected periodograms per unit weight (no data enters the information; the
    summary is made from a stand-in series of that length, in pieces as a long record is)."""
    rate = problem.spectral.rate_hz
    pieces = -(-n_samples // MAX_SEGMENT)
    length = n_samples // pieces
    components = record_components(problem.terms, rate, n_samples)
    stand_in = np.random.default_rng(seed).standard_normal(length)
    summary = spectral_summary(stand_in, rate, components=components)
    # Bins padded to a multiple of PAD_BINS (counting for nothing), so that records of many
    # lengths share one compiled information.
    pad = -summary.n_bins % PAD_BINS

    def padded(array, value):
        widths = [(0, 0)] * (np.ndim(array) - 1) + [(0, pad)]
        return np.pad(np.asarray(array), widths, constant_values=value)

    return eqx.tree_at(
        lambda s: (
            s.count,
            s.frequency_hz,
            s.node_power,
            s.node_count,
            s.node_frequency,
            s.basis,
            s.weight,
            s.mean_basis,
            s.mean_increment,
            s.duration_s,
        ),
        summary,
        (
            padded(summary.count * pieces, 1),
            padded(summary.frequency_hz, rate / 4),
            padded(summary.node_power, 0.0),
            padded(summary.node_count * pieces, 0.0),
            padded(summary.node_frequency, 0.25),
            padded(summary.basis, 1.0),
            padded(summary.weight, 0.0),
            np.tile(summary.mean_basis, (1, pieces)),
            np.zeros(pieces),
            np.asarray(n_samples / rate),
        ),
    )


@eqx.filter_jit
def _information(problem: NoiseProblem, theta):
    """The Fisher information of the binned Whittle likelihood at each row of ``theta``, plus
    the prior's precision (module docstring)."""

    def log_spectrum(point):
        variances, filtered = problem.whittle_weights(point)
        return jnp.log(node_spectrum(problem.spectral, variances, filtered))

    def one(point):
        jacobian = jax.jacfwd(log_spectrum)(point)  # (3, bins, parameters)
        spectral = problem.spectral
        weight = spectral.node_count * spectral.weight
        fisher = jnp.einsum("kb,kbp,kbq->pq", weight, jacobian, jacobian)
        # The mean increments: each segment's is normal around R / fs with a variance the
        # noise sets, so they inform the ramp (and, through their variance, the noise).
        variance = jnp.einsum("t,ts->s", problem.variances(point), spectral.mean_basis)
        slope = jax.jacfwd(lambda q: problem.ramp(q) / spectral.rate_hz)(point)
        fisher = fisher + jnp.einsum("s,p,q->pq", 1.0 / variance, slope, slope)
        return fisher + jnp.diag(1.0 / problem.prior.scale**2)

    return jax.vmap(one)(theta)


def predicted_widths(
    posterior: NoisePosterior,
    lengths_s,
    *,
    confidence: float = 0.9,
    draws: int = 16,
    seed: int = 0,
) -> PredictedWidths:
    """The relative half-width each parameter of ``posterior``'s model is predicted to have
    after a record of each of ``lengths_s`` (module docstring).

    Parameters
    ----------
    posterior : NoisePosterior
        The pilot record's posterior.
    lengths_s : array_like
        Record lengths to predict at, s.
    confidence : float
        Confidence of the intervals.
    draws : int
        Posterior draws the prediction is the median over.
    seed : int
        Chooses the draws.

    Returns
    -------
    PredictedWidths
        The widths at each length, and where each parameter stays prior-dominated.
    """
    require_x64()
    problem = posterior.problem
    rate = problem.spectral.rate_hz
    flat = {name: np.ravel(posterior.draws[name]) for name in problem.parameters}
    total = next(iter(flat.values())).size
    chosen = np.random.default_rng(seed).choice(total, size=min(draws, total), replace=False)
    context = problem.context
    theta = np.array(
        [
            [PARAMETERS[name].coordinate(float(flat[name][i]), context) for name in flat]
            for i in chosen
        ]
    )
    z = float(stats.norm.ppf(0.5 + confidence / 2))
    prior_variance = np.asarray(problem.prior.scale) ** 2
    widths = {name: [] for name in problem.parameters}
    dominated = {name: [] for name in problem.parameters}
    lengths_s = np.asarray(lengths_s, dtype=float)
    for length in lengths_s:
        n_samples = max(round(length * rate), 64)
        summary = record_summary(problem, n_samples, seed)
        longer = eqx.tree_at(lambda p: p.spectral, problem, summary)
        covariance = np.linalg.inv(np.asarray(_information(longer, jnp.asarray(theta))))
        variance = np.diagonal(covariance, axis1=-2, axis2=-1)  # (draws, parameters)
        for index, name in enumerate(problem.parameters):
            sd = np.sqrt(np.median(variance[:, index]))
            widths[name].append(math.sinh(z * sd) if PARAMETERS[name].link == "log" else z * sd)
            dominated[name].append(bool(sd**2 > PRIOR_DOMINATED * prior_variance[index]))
    return PredictedWidths(
        lengths_s,
        {name: np.array(values) for name, values in widths.items()},
        {name: np.array(values) for name, values in dominated.items()},
        confidence,
    )
