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

The mean increment, R / fs for a rate ramp R, enters as one more Gaussian term (its variance
again exact for the taper). Records with gaps contribute one periodogram per segment. Each
segment's increments are cut to the longest length with no prime factor above 5 (dropping at
most a few percent at its end), for which FFTs are fast; a length such as 2^23 - 1 would
otherwise cost a minute.
"""

import itertools
import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from scipy import fft
from scipy.signal import windows

from ._noise_model import SPECTRAL_COMPONENTS, increment_autocovariance_shapes

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

    @property
    def n_bins(self) -> int:
        return int(self.count.size)


def _segments(values: np.ndarray, minimum: int) -> list[np.ndarray]:
    present = ~np.isnan(values)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], present.astype(np.int8), [0]))))
    return [
        values[start:stop]
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


def _expected_periodogram(taper: np.ndarray, rate_hz: float, index: np.ndarray) -> np.ndarray:
    """(terms, len(index)): expected tapered periodogram of each term per unit parameter^2 at
    the Fourier frequencies index / M, and (index 0) at zero frequency.

    sum over lags tau of r(tau) c(tau) e^{-2 pi i nu tau} / sum h^2, with c the taper's
    autocorrelation: a few lags for the moving-average terms, all lags (one FFT) for flicker.
    """
    length = taper.size
    size = 2 * length
    autocorrelation = fft.irfft(np.abs(fft.rfft(taper, size)) ** 2, size)[:length]
    frequency = index / length
    short_lags = np.arange(3)
    short = increment_autocovariance_shapes(short_lags, rate_hz)
    expected = []
    for term in SPECTRAL_COMPONENTS:
        if term == "bias_instability":  # long memory: all lags
            product = increment_autocovariance_shapes(np.arange(length), rate_hz)[term]
            product = product * autocorrelation
            symmetric = np.zeros(size)
            symmetric[:length] = product
            symmetric[length + 1 :] = product[1:][::-1]
            expected.append(fft.rfft(symmetric).real[2 * index])
        else:
            weights = short[term] * autocorrelation[:3] * np.array([1.0, 2.0, 2.0])
            expected.append(np.cos(2 * np.pi * np.outer(frequency, short_lags)) @ weights)
    return np.array(expected) / np.sum(taper**2)


def spectral_summary(
    values, rate_hz: float, *, taper_fraction: float = TAPER_FRACTION, bin_width: float = BIN_WIDTH
) -> SpectralSummary:
    """Summarise a rate series (NaN marks missing samples) for the Whittle likelihood."""
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
    for segment in _segments(np.asarray(values, dtype=float), MIN_INCREMENTS):
        increments = np.diff(segment)
        increments = increments[: _fast_length_at_most(increments.size)]
        length = increments.size
        taper = windows.tukey(length, taper_fraction)
        mean = float(np.dot(taper, increments) / taper.sum())
        information = np.sum(taper**2) ** 2 / (length * np.sum(taper**4))
        periodogram = np.abs(fft.rfft(taper * (increments - mean))) ** 2 / np.sum(taper**2)
        n_frequencies = (length - 1) // 2
        edges = _bin_edges(n_frequencies, bin_width)
        nodes = np.array(
            [
                (low, (low + high - 1) // 2, high - 1) if high - low >= 3 else (low,) * 3
                for low, high in itertools.pairwise(edges)
            ]
        )
        expected = _expected_periodogram(taper, rate_hz, np.concatenate(([0], nodes.ravel())))
        mean_increment.append(mean)
        mean_basis.append(expected[:, 0] * np.sum(taper**2) / taper.sum() ** 2)
        at_nodes = expected[:, 1:].reshape(len(SPECTRAL_COMPONENTS), -1, 3)

        log_frequency = np.log(np.arange(1, n_frequencies + 1) / length)
        for bin_index, (low, high) in enumerate(itertools.pairwise(edges)):
            members = slice(low - 1, high - 1)
            centre = float(log_frequency[members].mean())
            u = log_frequency[members] - centre
            power = periodogram[low:high]
            offsets = (
                np.log(nodes[bin_index] / length) - centre
                if high - low >= 3
                else np.array([-1.0, 0.0, 1.0])
            )
            vandermonde = np.stack([np.ones(3), offsets, offsets**2], axis=1)
            parts["count"].append(high - low)
            parts["frequency_hz"].append(math.exp(centre) * rate_hz)
            parts["moment0"].append(power.sum())
            parts["moment1"].append(np.dot(power, u))
            parts["moment2"].append(np.dot(power, u * u))
            parts["spread"].append(np.dot(u, u))
            parts["basis"].append(np.linalg.solve(vandermonde, at_nodes[:, bin_index].T))
            parts["weight"].append(information)
    if not parts["count"]:
        raise ValueError(f"no run of more than {MIN_INCREMENTS} samples without a gap")
    arrays = {name: np.array(values_) for name, values_ in parts.items()}
    arrays["basis"] = np.transpose(arrays["basis"], (2, 1, 0))  # (terms, 3, bins)
    return SpectralSummary(
        **arrays,
        mean_increment=np.array(mean_increment),
        mean_basis=np.array(mean_basis).T,
        rate_hz=float(rate_hz),
    )


def whittle_log_likelihood(summary: SpectralSummary, variances, ramp=0.0):
    """Pointwise log-likelihood: one value per frequency bin, then one per segment for the
    mean increment. ``variances`` are the weights of the spectral components
    (:func:`bayescal._noise_model.component_weights`), ``ramp`` is R."""
    variances = jnp.asarray(variances)
    # S(u) = s0 + s1 u + s2 u^2 in the bin, so log S = a + b u + (c/2) u^2 with a = log s0,
    # b = s1 / s0 and c/2 = s2 / s0 - b^2 / 2.
    s0, s1, s2 = jnp.einsum("t,tkb->kb", variances, summary.basis)
    b = s1 / s0
    curvature = s2 / s0
    log_sum = summary.count * jnp.log(s0) + (curvature - 0.5 * b * b) * summary.spread
    ratio_sum = (summary.moment0 - b * summary.moment1 + (b * b - curvature) * summary.moment2) / s0
    bins = -summary.weight * (log_sum + ratio_sum)
    variance = jnp.einsum("t,ts->s", variances, summary.mean_basis)
    residual = summary.mean_increment - ramp / summary.rate_hz
    mean_terms = -0.5 * (jnp.log(2 * jnp.pi * variance) + residual**2 / variance)
    return jnp.concatenate((bins, mean_terms))
