"""The bias: the level of a record, given its noise.

The increments (:mod:`bayescal.models._whittle`) carry no information on the level; the bias
(turn-on bias, the expected reading at the start of the record) comes from the data's level
given the noise parameters. The record is cut into blocks — single samples at its start,
growing geometrically, plus an even grid — and the block means z_i = bias + R t_i + e_i have
an exact Gaussian covariance, a sum over terms of parameter^2 times a fixed matrix:

each term gives its part in closed form (``block_covariance`` of the terms in
:mod:`bayescal.models.effects`: white noise on the diagonal, the output filter's neighbouring
pairs, the telescoped quantization error, the Brownian rate random walk, flicker's structure
function).

Given the noise parameters and R, the bias is then Gaussian (generalised least squares with
a flat prior), which :func:`bias_given_noise` returns for any number of posterior draws.
"""

import functools
import itertools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.linalg import cho_solve

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ..recording._series import blocks, gap_free_runs, is_spooled, series_size

GEOMETRIC_BLOCKS = 96
EVEN_BLOCKS = 32


class LevelSummary(eqx.Module):
    block_mean: np.ndarray
    block_time_s: np.ndarray
    """Mean time (s, sample centres) of each block, for the ramp."""
    basis: np.ndarray
    """(components, blocks, blocks): covariance of the block means per unit weight of each
    component."""


def _block_edges(values) -> list[tuple[int, int]]:
    """Blocks [start, stop) that never contain a missing sample."""
    n = series_size(values)
    cuts = set(np.unique(np.round(np.geomspace(1, n, GEOMETRIC_BLOCKS)).astype(int)).tolist())
    cuts |= set(np.linspace(0, n, EVEN_BLOCKS + 1).astype(int).tolist())
    edges_of_blocks = []
    for start, stop in gap_free_runs(values).tolist():
        inner = sorted(c for c in cuts if start < c < stop)
        edges_of_blocks += list(itertools.pairwise([start, *inner, stop]))
    return edges_of_blocks


def _block_means(values, edges: np.ndarray) -> np.ndarray:
    """The mean of values[start:stop] for each block, read a block of the series at a time
    (each level block's sum gathered from the pieces of it in each read)."""
    sums = np.zeros(len(edges))
    for first, part in blocks(values):
        last = first + part.size
        inside = np.flatnonzero((edges[:, 0] < last) & (edges[:, 1] > first))
        for index in inside.tolist():
            a, b = max(edges[index, 0], first), min(edges[index, 1], last)
            sums[index] += part[a - first : b - first].sum()
    return sums / (edges[:, 1] - edges[:, 0])


def level_summary(values, rate_hz: float, components) -> LevelSummary:
    """Block means of a rate series (NaN marks missing samples; an array or a spooled
    series) and their covariance bases, one per component of ``components``
    (:class:`~bayescal.models._components.Components`)."""
    values = values if is_spooled(values) else np.asarray(values, dtype=float)
    edges = np.array(_block_edges(values), dtype=np.int64)
    start, stop = edges[:, 0], edges[:, 1]
    return LevelSummary(
        block_mean=_block_means(values, edges),
        block_time_s=(start + stop) / 2.0 / rate_hz,
        basis=_block_covariances(components, edges.tobytes(), float(rate_hz)),
    )


@functools.lru_cache(maxsize=4)
def _block_covariances(components, edges: bytes, rate_hz: float) -> np.ndarray:
    """The components' block-mean covariances for blocks ``edges`` (int64 [start, stop)
    pairs, as bytes), kept for the blocks met: they depend on the record only through its
    length and gaps, and a term search's family (some sixty components, the Gauss-Markov
    grid among them) took 20-40 ms to build at every fit of a notebook's record. Read-only."""
    pairs = np.frombuffer(edges, dtype=np.int64).reshape(-1, 2)
    basis = components.block_covariances(pairs[:, 0], pairs[:, 1], rate_hz)
    basis.setflags(write=False)
    return basis


def bias_given_noise(summary: LevelSummary, variances, ramp=0.0):
    """Mean and variance of the bias given the noise (the weights of the spectral components,
    :meth:`~bayescal.models._components.Components.weights`) and the ramp R, under a flat prior.
    Works on a batch of draws (leading axes of ``variances``, and of ``ramp`` broadcast with
    them)."""
    variances = jnp.asarray(variances)
    batch = jnp.broadcast_shapes(variances.shape[:-1], jnp.shape(ramp))
    count = variances.shape[-1]
    flat = (
        jnp.broadcast_to(variances, (*batch, count)).reshape(-1, count),
        jnp.broadcast_to(jnp.asarray(ramp, dtype=variances.dtype), batch).reshape(-1),
    )
    # BIAS_BATCH draws at a time: the covariances of a whole posterior's draws at once
    # (2,000 of 119 x 119) are 230 MB, and building and factorising them took ten times as
    # long as a batch small enough to stay in the processor's cache.
    mean, variance = jax.lax.map(
        lambda draw: _bias_of_draw(summary, *draw), flat, batch_size=BIAS_BATCH
    )
    return mean.reshape(batch), variance.reshape(batch)


BIAS_BATCH = 32
"""Draws whose block-mean covariances :func:`bias_given_noise` builds and factorises at once."""


def _bias_of_draw(summary: LevelSummary, variances, ramp):
    """:func:`bias_given_noise` of one draw: generalised least squares of the block means."""
    covariance = jnp.einsum("t,tij->ij", variances, summary.basis)
    target = summary.block_mean - ramp * summary.block_time_s
    factor = jnp.linalg.cholesky(covariance)
    weights = cho_solve((factor, True), jnp.ones(summary.block_mean.shape))
    precision = jnp.sum(weights)
    return jnp.sum(weights * target) / precision, 1.0 / precision
