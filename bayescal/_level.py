"""The bias: the level of a record, given its noise.

The increments (:mod:`bayescal._whittle`) carry no information on the level; the bias
(turn-on bias, the expected reading at the start of the record) comes from the data's level
given the noise parameters. The record is cut into blocks — single samples at its start,
growing geometrically, plus an even grid — and the block means z_i = bias + R t_i + e_i have
an exact Gaussian covariance, a sum over terms of parameter^2 times a fixed matrix:

- white: N^2 fs / m on the diagonal; through the output filter, a lag-one part adds the
  number of neighbouring sample pairs the two blocks share (2 (m - 1) within a block, 1
  across a block boundary);
- quantization: the telescoped white phase, Q^2 fs^2 / (m_i m_j) at shared block ends;
- rate random walk, a Brownian path from zero at t = 0 averaged over the blocks:
  K^2 times the mean of min(s, t) over the two blocks;
- flicker, started at zero at the first sample: Cov(X_a, X_b) = [D(a) + D(b) - D(|a - b|)] / 2
  with structure function D(h) = (B^2 / pi) (second difference of t^2 log|t|)(h), summed
  over the blocks in closed form.

Given the noise parameters and R, the bias is then Gaussian (generalised least squares with
a flat prior), which :func:`bias_given_noise` returns for any number of posterior draws.
"""

import itertools

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jax.scipy.linalg import cho_solve

from ._noise_model import SPECTRAL_COMPONENTS

GEOMETRIC_BLOCKS = 96
EVEN_BLOCKS = 32


class LevelSummary(eqx.Module):
    block_mean: np.ndarray
    block_time_s: np.ndarray
    """Mean time (s, sample centres) of each block, for the ramp."""
    basis: np.ndarray
    """(terms, blocks, blocks): covariance of the block means per unit parameter^2."""


def _block_edges(values: np.ndarray) -> list[tuple[int, int]]:
    """Blocks [start, stop) that never contain a missing sample."""
    n = values.size
    cuts = set(np.unique(np.round(np.geomspace(1, n, GEOMETRIC_BLOCKS)).astype(int)).tolist())
    cuts |= set(np.linspace(0, n, EVEN_BLOCKS + 1).astype(int).tolist())
    present = ~np.isnan(values)
    runs = np.flatnonzero(np.diff(np.concatenate(([0], present.astype(np.int8), [0]))))
    blocks = []
    for start, stop in zip(runs[::2], runs[1::2], strict=True):
        inner = sorted(c for c in cuts if start < c < stop)
        edges = [start, *inner, stop]
        blocks += list(itertools.pairwise(edges))
    return blocks


def _t2_log(t):
    t = np.asarray(t, dtype=np.longdouble)
    return np.where(t == 0, 0, t * t * np.log(np.where(t == 0, 1, np.abs(t))))


def block_covariance_basis(start: np.ndarray, stop: np.ndarray, rate_hz: float) -> np.ndarray:
    """(components, blocks, blocks): covariance of the means of samples [start, stop) per unit
    weight of each spectral component, the nonstationary terms started at sample 0."""
    size = (stop - start).astype(float)
    period = 1.0 / rate_hz
    same = np.equal.outer(start, start)
    white = np.diag(rate_hz / size)
    touching = np.equal.outer(stop, start) | np.equal.outer(start, stop)
    white_lag = rate_hz * (np.diag(2.0 * (size - 1)) + touching) / np.outer(size, size)
    # Block mean of (e_{k+1} - e_k) / period over [a, b) is (e_b - e_a) / (m period).
    shared = (
        np.equal.outer(stop, stop).astype(float)
        - np.equal.outer(stop, start)
        - np.equal.outer(start, stop)
        + same
    )
    quantization = rate_hz**2 * shared / np.outer(size, size)
    # Mean of min(s, t): the middle of the earlier block for disjoint blocks,
    # a + m / 3 for a block with itself (in periods).
    earlier_middle = np.minimum.outer((start + stop) / 2.0, (start + stop) / 2.0)
    walk = period * np.where(same, start[:, None] + size[:, None] / 3.0, earlier_middle)
    # Flicker: sums of second differences of t^2 log|t| telescope to t^2 log|t| itself.
    first = _t2_log(stop) - _t2_log(stop - 1) - (_t2_log(start) - _t2_log(start - 1))
    rectangle = (
        _t2_log(np.subtract.outer(stop, start).T)
        - _t2_log(np.subtract.outer(stop, stop).T)
        - _t2_log(np.subtract.outer(start, start).T)
        + _t2_log(np.subtract.outer(start, stop).T)
    )
    outer_size = np.outer(size, size)
    flicker = ((first / size)[:, None] + (first / size)[None, :] - rectangle / outer_size) / (
        2 * np.pi
    )
    basis = {
        "white": white,
        "white_lag": white_lag,
        "quantization": quantization,
        "rate_random_walk": walk,
        "bias_instability": np.asarray(flicker, dtype=float),
    }
    return np.stack([basis[term] for term in SPECTRAL_COMPONENTS])


def level_summary(values, rate_hz: float) -> LevelSummary:
    """Block means of a rate series (NaN marks missing samples) and their covariance bases."""
    values = np.asarray(values, dtype=float)
    blocks = np.array(_block_edges(values), dtype=np.int64)
    start, stop = blocks[:, 0], blocks[:, 1]
    return LevelSummary(
        block_mean=np.array([values[a:b].mean() for a, b in blocks]),
        block_time_s=(start + stop) / 2.0 / rate_hz,
        basis=block_covariance_basis(start, stop, rate_hz),
    )


def bias_given_noise(summary: LevelSummary, variances, ramp=0.0):
    """Mean and variance of the bias given the noise (the weights of the spectral components,
    :func:`bayescal._noise_model.component_weights`) and the ramp R, under a flat prior.
    Works on a batch of draws (leading axes of ``variances``)."""
    variances = jnp.asarray(variances)
    covariance = jnp.einsum("...t,tij->...ij", variances, summary.basis)
    target = summary.block_mean - jnp.asarray(ramp)[..., None] * summary.block_time_s
    factor = jnp.linalg.cholesky(covariance)
    ones = jnp.broadcast_to(jnp.ones(summary.block_mean.shape), target.shape)
    weights = cho_solve((factor, True), ones[..., None])[..., 0]
    precision = jnp.sum(weights, axis=-1)
    return jnp.sum(weights * target, axis=-1) / precision, 1.0 / precision
