"""The Whittle likelihood of a record's increments, compressed into frequency bins.

Why this likelihood: the increments d_k = y_{k+1} - y_k of every noise term are stationary
(the rate random walk and flicker are not, their increments are), and a stationary Gaussian
series is summarised, to first order, by its periodogram, whose ordinates at the Fourier
frequencies are independent exponentials with mean the spectrum. The log-likelihood is then
-sum_j [log S_j + I_j / S_j] (Whittle 1953): one FFT of the data, and afterwards a cost that
depends only on the number of frequencies. It is asymptotically efficient — it reaches the
Cramér-Rao bound of the exact Gaussian likelihood (benchmarks/noise_efficiency.py measures
how close it comes).

Three refinements make it hold on real records of any length:

- taper: differencing white noise leaves a boundary term in the DFT whose power (about
  2 s^2 / M) swamps the small low-frequency spectrum of a rate random walk (ignoring it
  overestimates K several-fold); a Tukey taper over 10 % of the record removes it, at a
  variance cost of about 5 %. Tapered ordinates are slightly correlated, so together they
  carry less information than as many independent ones: by the factor
  kappa = M sum h^4 / (sum h^2)^2 (1.055 here), and each segment's log-likelihood is divided
  by it, which makes the posterior's spread the estimator's true spread (the magnitude
  adjustment of a composite likelihood, Ribatet et al. 2012);
- expected periodogram: S_j is replaced by the exact expectation of the tapered periodogram,
  sum over lags of r(tau) c(tau) e^{-2 pi i nu tau} / sum h^2 (r the increments'
  autocovariance of each term, c the taper's autocorrelation), the "debiased Whittle"
  likelihood of Sykulski et al. (2019), so no bias is left at the lowest frequencies of short
  records;
- compression: above the lowest frequencies the ordinates are grouped in bins of 2 % relative
  width; within a bin each term's expected periodogram is a quadratic in u = log(nu / nu_bin)
  (fitted through three nodes, far below the statistical error), so sum_j log S_j and
  sum_j I_j / S_j follow to second order in u from the bin's moments sum I, sum I u and
  sum I u^2. A likelihood evaluation costs one logarithm per bin — a few hundred — not one
  per frequency.

Deterministic terms (a thermal polynomial, a sinusoid, an exponential transient ...) enter as
regressors x_j with coefficients beta: the periodogram of the increments of y - X beta is a
quadratic form in beta, so each bin also keeps the cross moments of y with every regressor and
of the regressors with each other, and the likelihood stays exact in beta. Extra stationary
components with a shape fixed in advance (a Gauss-Markov term at a given correlation time)
are given by the autocovariance of their increments.

The mean increment, R / fs for a rate ramp R, enters as one more Gaussian term (its variance
again exact for the taper). Records with gaps contribute one periodogram per segment. Each
segment's increments are cut to the longest length with no prime factor above 5 (dropping at
most a few percent at its end), for which FFTs are fast; a length such as 2^23 - 1 would
otherwise cost a minute.
"""

import functools
import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from scipy import fft
from scipy.signal import windows

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ._components import SPECTRAL_TERMS, increment_autocovariance_shapes

TAPER_FRACTION = 0.1
BIN_WIDTH = 0.02
MIN_INCREMENTS = 32


class SpectralSummary(eqx.Module):
    """Binned periodogram of the increments and the expected periodogram of each term."""

    count: np.ndarray
    """Fourier frequencies in each bin."""
    frequency_hz: np.ndarray
    """Geometric mean frequency of each bin."""
    moment0: np.ndarray
    moment1: np.ndarray
    moment2: np.ndarray
    """sum I, sum I u, sum I u^2 over each bin's frequencies, u = log(nu / nu_bin)."""
    spread: np.ndarray
    """sum u^2 over each bin."""
    basis: np.ndarray
    """(components, 3, bins): expected periodogram per unit weight within each bin, as the
    coefficients of 1, u and u^2."""
    weight: np.ndarray
    """1 / kappa of the bin's segment (see the module docstring)."""
    mean_increment: np.ndarray
    """Taper-weighted mean increment of each segment."""
    mean_basis: np.ndarray
    """(components, segments): variance of the mean increment per unit weight."""
    rate_hz: float = eqx.field(static=True)
    cross: np.ndarray | None = None
    """(3, regressors, bins): sum of Re(conj(Y) X_j) u^m over each bin, m = 0, 1, 2."""
    gram: np.ndarray | None = None
    """(3, regressors, regressors, bins): sum of Re(conj(X_i) X_j) u^m over each bin."""
    mean_regressor: np.ndarray | None = None
    """(segments, regressors): taper-weighted mean increment of each regressor."""

    @property
    def n_bins(self) -> int:
        return int(self.count.size)


def _segment_bounds(values: np.ndarray, minimum: int) -> list[tuple[int, int]]:
    """[start, stop) of each run of more than ``minimum`` samples without NaN."""
    present = ~np.isnan(values)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], present.astype(np.int8), [0]))))
    return [
        (int(start), int(stop))
        for start, stop in zip(edges[::2], edges[1::2], strict=True)
        if stop - start > minimum
    ]


def _fast_length_at_most(length: int) -> int:
    """The longest length <= ``length`` whose prime factors are 2, 3 and 5."""
    candidate = length
    while fft.next_fast_len(candidate, real=True) != candidate:
        candidate -= 1
    return candidate


def _bin_edges(n_frequencies: int, width: float) -> np.ndarray:
    """Edges (in frequency index, from 1) of bins of relative width ``width``; a bin holds one
    frequency until three or more fit in one."""
    edges = [1]
    while edges[-1] <= n_frequencies:
        low = edges[-1]
        high = max(low + 1, math.ceil(low * math.exp(width)))
        if high - low < 3:
            high = low + 1
        edges.append(min(high, n_frequencies + 1))
    return np.array(edges)


@functools.lru_cache(maxsize=4)
def _taper(length: int, taper_fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """The Tukey taper and its autocorrelation at lags 0 .. length - 1 (cached: every model
    of a record shares them)."""
    taper = windows.tukey(length, taper_fraction)
    size = 2 * length
    autocorrelation = fft.irfft(np.abs(fft.rfft(taper, size)) ** 2, size)[:length]
    return taper, autocorrelation


def _all_lags_expected(autocovariance: np.ndarray, autocorrelation: np.ndarray, index):
    length = autocorrelation.size
    product = autocovariance * autocorrelation
    symmetric = np.zeros(2 * length)
    symmetric[:length] = product
    symmetric[length + 1 :] = product[1:][::-1]
    return fft.rfft(symmetric).real[2 * index]


@functools.lru_cache(maxsize=4)
def _expected_periodogram(
    length: int, rate_hz: float, taper_fraction: float, index: tuple[int, ...]
) -> np.ndarray:
    """(terms, len(index)): expected tapered periodogram of each term per unit parameter^2 at
    the Fourier frequencies index / M, and (index 0) at zero frequency.

    sum over lags tau of r(tau) c(tau) e^{-2 pi i nu tau} / sum h^2, with c the taper's
    autocorrelation: a few lags for the moving-average terms, all lags (one FFT) for flicker.
    Cached: it depends on the record only through its length.
    """
    taper, autocorrelation = _taper(length, taper_fraction)
    index = np.asarray(index)
    frequency = index / length
    short_lags = np.arange(3)
    short = increment_autocovariance_shapes(short_lags, rate_hz)
    expected = []
    for term in SPECTRAL_TERMS:
        if term.long_memory:  # all lags
            memory = term.autocovariance(np.arange(length, dtype=float), rate_hz)
            expected.append(_all_lags_expected(memory, autocorrelation, index))
        else:
            weights = short[term.name] * autocorrelation[:3] * np.array([1.0, 2.0, 2.0])
            expected.append(np.cos(2 * np.pi * np.outer(frequency, short_lags)) @ weights)
    return np.array(expected) / np.sum(taper**2)


def _extra_expected(length: int, taper_fraction: float, index, components) -> np.ndarray:
    """As :func:`_expected_periodogram` for ``components`` (functions lags -> increment
    autocovariance), all lags each."""
    taper, autocorrelation = _taper(length, taper_fraction)
    lags = np.arange(length)
    return np.array(
        [_all_lags_expected(c(lags), autocorrelation, np.asarray(index)) for c in components]
    ).reshape(len(components), len(index)) / np.sum(taper**2)


def _bin_sums(per_frequency: np.ndarray, u: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """(3, ..., bins): sums over each bin of ``per_frequency`` (frequencies on axis 0) times
    u^0, u^1 and u^2."""
    shape = (-1,) + (1,) * (per_frequency.ndim - 1)
    return np.stack(
        [
            np.moveaxis(np.add.reduceat(per_frequency * (u**power).reshape(shape), starts), 0, -1)
            for power in range(3)
        ]
    )


def spectral_summary(
    values,
    rate_hz: float,
    *,
    taper_fraction: float = TAPER_FRACTION,
    bin_width: float = BIN_WIDTH,
    regressors=None,
    extra_components=(),
) -> SpectralSummary:
    """Summarise a rate series (NaN marks missing samples) for the Whittle likelihood.

    ``regressors``: (samples, p) deterministic terms whose coefficients the likelihood takes
    (:func:`whittle_log_likelihood`, ``beta``); ``extra_components``: functions of the lag
    giving the increment autocovariance of stationary terms beyond the spectral components
    (:data:`~bayescal.models._components.SPECTRAL_COMPONENTS`), appended to the basis in
    that order."""
    regressors = None if regressors is None else np.asarray(regressors, dtype=float)
    cross, gram, mean_regressor = [], [], []
    parts = {
        name: []
        for name in (
            "count",
            "frequency_hz",
            "moment0",
            "moment1",
            "moment2",
            "spread",
            "basis",
            "weight",
        )
    }
    mean_increment, mean_basis = [], []
    values = np.asarray(values, dtype=float)
    for start, stop in _segment_bounds(values, MIN_INCREMENTS):
        increments = np.diff(values[start:stop])
        increments = increments[: _fast_length_at_most(increments.size)]
        length = increments.size
        taper, _ = _taper(length, taper_fraction)
        mean = float(np.dot(taper, increments) / taper.sum())
        information = np.sum(taper**2) ** 2 / (length * np.sum(taper**4))
        transform = fft.rfft(taper * (increments - mean))
        periodogram = np.abs(transform) ** 2 / np.sum(taper**2)
        n_frequencies = (length - 1) // 2
        edges = _bin_edges(n_frequencies, bin_width)
        lows, highs = edges[:-1], edges[1:]
        counts = highs - lows
        log_frequency = np.log(np.arange(1, n_frequencies + 1) / length)
        centres = np.add.reduceat(log_frequency, lows - 1) / counts
        u = log_frequency - np.repeat(centres, counts)
        norm = np.sum(taper**2)
        if regressors is not None:
            x_increments = np.diff(regressors[start:stop], axis=0)[:length]
            x_mean = taper @ x_increments / taper.sum()
            x_transform = fft.rfft(taper[:, None] * (x_increments - x_mean), axis=0)
            y_part = transform[1 : n_frequencies + 1]
            x_part = x_transform[1 : n_frequencies + 1]
            real, imaginary = x_part.real, x_part.imag
            cross.append(
                _bin_sums(
                    y_part.real[:, None] * real + y_part.imag[:, None] * imaginary, u, lows - 1
                )
                / norm
            )
            gram.append(
                _bin_sums(
                    real[:, :, None] * real[:, None, :]
                    + imaginary[:, :, None] * imaginary[:, None, :],
                    u,
                    lows - 1,
                )
                / norm
            )
            mean_regressor.append(x_mean)
        wide = counts >= 3
        nodes = np.stack(
            [lows, np.where(wide, (lows + highs - 1) // 2, lows), np.where(wide, highs - 1, lows)],
            axis=1,
        )
        index = (0, *nodes.ravel().tolist())
        expected = np.concatenate(
            (
                _expected_periodogram(length, float(rate_hz), taper_fraction, index),
                _extra_expected(length, taper_fraction, index, extra_components),
            )
        )
        mean_increment.append(mean)
        mean_basis.append(expected[:, 0] * norm / taper.sum() ** 2)
        at_nodes = expected[:, 1:].reshape(expected.shape[0], -1, 3)

        offsets = np.where(
            wide[:, None], np.log(nodes / length) - centres[:, None], np.array([-1.0, 0.0, 1.0])
        )
        vandermonde = np.stack([np.ones_like(offsets), offsets, offsets**2], axis=2)
        power = periodogram[1 : n_frequencies + 1]
        moments = _bin_sums(power, u, lows - 1)
        parts["count"].append(counts)
        parts["frequency_hz"].append(np.exp(centres) * rate_hz)
        parts["moment0"].append(moments[0])
        parts["moment1"].append(moments[1])
        parts["moment2"].append(moments[2])
        parts["spread"].append(_bin_sums(np.ones_like(u), u, lows - 1)[2])
        # (bins, 3, terms): the quadratic through the three nodes of each bin.
        parts["basis"].append(np.linalg.solve(vandermonde, np.moveaxis(at_nodes, 0, -1)))
        parts["weight"].append(np.full(counts.size, information))
    if not parts["count"]:
        raise ValueError(f"no run of more than {MIN_INCREMENTS} samples without a gap")
    arrays = {name: np.concatenate(values_) for name, values_ in parts.items()}
    arrays["basis"] = np.transpose(arrays["basis"], (2, 1, 0))  # (terms, 3, bins)
    regression = {}
    if regressors is not None:
        regression = {
            "cross": np.concatenate(cross, axis=-1),
            "gram": np.concatenate(gram, axis=-1),
            "mean_regressor": np.array(mean_regressor),
        }
    return SpectralSummary(
        **arrays,
        mean_increment=np.array(mean_increment),
        mean_basis=np.array(mean_basis).T,
        rate_hz=float(rate_hz),
        **regression,
    )


def _bin_coefficients(summary: SpectralSummary, variances):
    """log-sum of each bin and the weights g_m of its moments in sum I / S (three rows)."""
    # S(u) = s0 + s1 u + s2 u^2 in the bin, so log S = a + b u + (c/2) u^2 with a = log s0,
    # b = s1 / s0 and c/2 = s2 / s0 - b^2 / 2.
    s0, s1, s2 = jnp.einsum("t,tkb->kb", jnp.asarray(variances), summary.basis)
    b = s1 / s0
    curvature = s2 / s0
    log_sum = summary.count * jnp.log(s0) + (curvature - 0.5 * b * b) * summary.spread
    return log_sum, jnp.stack([1.0 / s0, -b / s0, (b * b - curvature) / s0])


def whittle_log_likelihood(summary: SpectralSummary, variances, ramp=0.0, beta=None):
    """Pointwise log-likelihood: one value per frequency bin, then one per segment for the
    mean increment. ``variances`` are the weights of the spectral components
    (:func:`~bayescal.models._components.component_weights`, then any extra components), ``ramp`` is
    R, ``beta`` the coefficients of the summary's regressors (the data minus X beta)."""
    variances = jnp.asarray(variances)
    log_sum, coefficients = _bin_coefficients(summary, variances)
    moments = jnp.stack([summary.moment0, summary.moment1, summary.moment2])
    mean_increment = summary.mean_increment
    if beta is not None:
        moments = (
            moments
            - 2 * jnp.einsum("p,mpb->mb", beta, summary.cross)
            + jnp.einsum("p,q,mpqb->mb", beta, beta, summary.gram)
        )
        mean_increment = mean_increment - summary.mean_regressor @ beta
    bins = -summary.weight * (log_sum + jnp.sum(coefficients * moments, axis=0))
    variance = jnp.einsum("t,ts->s", variances, summary.mean_basis)
    residual = mean_increment - ramp / summary.rate_hz
    mean_terms = -0.5 * (jnp.log(2 * jnp.pi * variance) + residual**2 / variance)
    return jnp.concatenate((bins, mean_terms))


def regression_coefficients(summary: SpectralSummary, variances, ramp=0.0, ridge=0.0):
    """The beta that maximises :func:`whittle_log_likelihood` given the noise, and the
    precision matrix of beta (the likelihood is quadratic in beta: its conditional posterior
    under a flat prior is normal with this mean and precision). ``ridge`` (a vector) is added
    to the precision's diagonal: a unit ridge with a zero column pins its coefficient at 0."""
    variances = jnp.asarray(variances)
    _, coefficients = _bin_coefficients(summary, variances)
    weighted = summary.weight * coefficients
    variance = jnp.einsum("t,ts->s", variances, summary.mean_basis)
    target = summary.mean_increment - ramp / summary.rate_hz
    precision = (
        2 * jnp.einsum("mb,mpqb->pq", weighted, summary.gram)
        + jnp.einsum("sp,sq,s->pq", summary.mean_regressor, summary.mean_regressor, 1.0 / variance)
        + jnp.diag(jnp.broadcast_to(ridge, summary.gram.shape[1:2]))
    )
    right = 2 * jnp.einsum("mb,mpb->p", weighted, summary.cross) + jnp.einsum(
        "sp,s->p", summary.mean_regressor, target / variance
    )
    return jnp.linalg.solve(precision, right), precision
