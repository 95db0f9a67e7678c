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
  autocovariance of each term, c the taper's autocorrelation; at the bins' nodes), the
  "debiased Whittle" likelihood of Sykulski et al. (2019), so no bias is left at the lowest
  frequencies of short records;
- compression: above the lowest frequencies the ordinates are grouped in bins of 2 % relative
  width, each with three nodes (its first, middle and last frequency). Within a bin, log S
  and 1 / S are interpolated linearly in u = log nu between the nodes (hat functions), so
  sum_j log S_j = sum_k c_k log S(nu_k) and sum_j I_j / S_j = sum_k P_k / S(nu_k), with
  c_k = sum_j hat_k(u_j) and P_k = sum_j I_j hat_k(u_j) kept per bin. sum log S is exact for
  a power law, and 1 / S ~ nu^-a is off by at most a^2 (du)^2 / 8 between nodes du = 1 %
  apart (5e-5 for a = 2): far below the statistical error. The weights are never negative,
  so the approximation can only penalise a model whose spectrum vanishes where the record has
  power, never reward it: a steep low-pass (:mod:`.effects.output_filter`) or a filter's zero
  stays safe. A likelihood evaluation costs three logarithms per bin — a few hundred bins —
  not one per frequency.

The bins grow with the logarithm of the record's length, so every record has a few hundred
of them; :func:`padded_summary` rounds their number up to a multiple of BIN_BUCKET, and the
segments' to one of SEGMENT_BUCKET, with padding that weighs exactly zero. The compiled
likelihood, optimiser and sampler then take arrays of one shape for records of many lengths
(every gap-free one of 2^20 samples and more) and are kept on disk between processes
(:mod:`bayescal._caches`); what else keys their trace (the components, among them the
Gauss-Markov term's grid of correlation times over the record's decades) is the model's.

Deterministic terms (a thermal polynomial, a sinusoid, an exponential transient ...) enter as
regressors x_j with coefficients beta: the periodogram of the increments of y - X beta is a
quadratic form in beta, so each bin also keeps the hat-weighted cross sums of y with every
regressor and of the regressors with each other, and the likelihood stays exact in beta.
Extra stationary components with a shape fixed in advance (a Gauss-Markov term at a given
correlation time) are given by the autocovariance of their increments.

The mean increment, R / fs for a rate ramp R, enters as one more Gaussian term (its variance
again exact for the taper). Records with gaps contribute one periodogram per segment, and
so do the pieces of a long segment: a run longer than MAX_SEGMENT samples is cut into equal
pieces no longer than that, each its own periodogram. That bounds the memory of the summary
(one piece's FFT and its expected periodogram, a few hundred MB, whatever the record's
length), and costs only the lowest few ordinates of the whole run, below 1 / (piece
duration): the pieces together hold as many ordinates in every band above it. Each
segment's increments are cut to the longest length with no prime factor above 5 (dropping at
most a few percent at its end), for which FFTs are fast; a length such as 2^23 - 1 would
otherwise cost a minute.
"""

import dataclasses
import functools
import hashlib
import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from scipy import fft

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._caches import kept_array
from .._errors import InputError
from ..classical._periodogram import (
    TAPER_FRACTION,
    RecordTransform,
    fast_length_at_most,
    tapered_transform,
    tukey_window,
)
from ..recording._series import gap_free_runs, is_spooled, read, series_size

BIN_WIDTH = 0.02
MIN_INCREMENTS = 32
MAX_SEGMENT = 1 << 21
"""Samples in the longest piece one periodogram is taken of (a longer gap-free run is cut
into equal pieces): 5.8 h at 100 Hz."""
BIN_BUCKET = 128
"""Bins are padded to a multiple of this (:func:`padded_summary`): a gap-free record of 2^17
to 2^19 samples has 412 to 481 bins (512 padded), every longer one 516 or 551 (640)."""
SEGMENT_BUCKET = 8
"""Segments (one mean increment each) are padded to a multiple of this."""


class SpectralSummary(eqx.Module):
    """Binned periodogram of the increments and the expected periodogram of each term at the
    bins' nodes (module docstring)."""

    count: np.ndarray
    """Fourier frequencies in each bin."""
    frequency_hz: np.ndarray
    """Geometric mean frequency of each bin."""
    node_power: np.ndarray
    """(3, bins): sum_j I_j hat_k(u_j) over each bin, for its three nodes k."""
    node_count: np.ndarray
    """(3, bins): sum_j hat_k(u_j), the frequencies each node stands for."""
    node_frequency: np.ndarray
    """(3, bins): the nodes' frequencies, cycles per sample."""
    basis: np.ndarray
    """(components, 3, bins): expected periodogram per unit weight of each component at the
    nodes."""
    weight: np.ndarray
    """1 / kappa of the bin's segment (see the module docstring)."""
    mean_increment: np.ndarray
    """Taper-weighted mean increment of each segment."""
    mean_basis: np.ndarray
    """(components, segments): variance of the mean increment per unit weight."""
    duration_s: np.ndarray
    """The record's length, s (samples spanned / rate)."""
    rate_hz: float = eqx.field(static=True)
    components: object = eqx.field(static=True, default=None)
    """The spectral components of the basis's first rows
    (:class:`~bayescal.models._components.Components`); any extra ones follow."""
    cross: np.ndarray | None = None
    """(3, regressors, bins): sum_j Re(conj(Y_j) X_j) hat_k(u_j) over each bin."""
    gram: np.ndarray | None = None
    """(3, regressors, regressors, bins): sum_j Re(conj(X_ij) X_lj) hat_k(u_j)."""
    mean_regressor: np.ndarray | None = None
    """(segments, regressors): taper-weighted mean increment of each regressor."""
    segment_weight: np.ndarray | None = None
    """1 for each segment's mean increment and 0 for padding (:func:`padded_summary`);
    None: every segment counts."""

    @property
    def shaped(self) -> np.ndarray:
        """Indices of the components an output filter's low-pass shapes (the white noise's)."""
        return self.components.shaped

    @property
    def n_bins(self) -> int:
        return int(self.count.size)

    @property
    def power(self) -> np.ndarray:
        """sum I over each bin."""
        return np.sum(self.node_power, axis=0)


def _segment_bounds(values, minimum: int) -> list[tuple[int, int]]:
    """[start, stop) of each run of more than ``minimum`` samples without NaN, a run longer
    than MAX_SEGMENT cut into equal pieces no longer than that (the few samples left over at
    its end unused)."""
    bounds = []
    for start, stop in gap_free_runs(values).tolist():
        if stop - start <= minimum:
            continue
        pieces = -(-(stop - start) // MAX_SEGMENT)
        length = (stop - start) // pieces
        bounds += [(start + k * length, start + (k + 1) * length) for k in range(pieces)]
    return bounds


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
    taper = tukey_window(length, taper_fraction)
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


def _described(shape) -> str | None:
    """A stable description of a spectral component (a class, or a module of numbers), or
    None where it has none."""
    kind = shape if isinstance(shape, type) else type(shape)
    name = f"{kind.__module__}.{kind.__qualname__}"
    if isinstance(shape, type):
        return name
    values = [getattr(shape, field.name) for field in dataclasses.fields(shape)]
    if not all(isinstance(value, (int, float, str)) for value in values):
        return None
    return f"{name}{tuple(values)!r}"


@functools.lru_cache(maxsize=8)
def _expected_periodogram(
    length: int, rate_hz: float, taper_fraction: float, index: tuple[int, ...], shapes: tuple
) -> np.ndarray:
    """(components, len(index)): expected tapered periodogram of each of ``shapes`` (spectral
    components, :mod:`._components`) per unit weight at the Fourier frequencies index / M,
    and (index 0) at zero frequency.

    sum over lags tau of r(tau) c(tau) e^{-2 pi i nu tau} / sum h^2, with c the taper's
    autocorrelation: a few lags for the moving-average shapes, all lags (one FFT) for those
    of long memory. Cached, and kept on disk between runs (:func:`bayescal._caches.
    kept_array`): it depends on the record only through its length, and its FFTs of every
    long-memory component cost a first fit of 2^20 samples more than a second.
    """
    described = [_described(shape) for shape in shapes]

    def compute():
        return _expected_computed(length, rate_hz, taper_fraction, np.asarray(index), shapes)

    if None in described:
        return compute()
    indices = hashlib.sha256(np.asarray(index, dtype=np.int64).tobytes()).hexdigest()
    description = f"{length}|{rate_hz!r}|{taper_fraction!r}|{indices}|{described}"
    return kept_array("expected_periodogram", description, compute)


def _expected_computed(
    length: int, rate_hz: float, taper_fraction: float, index: np.ndarray, shapes: tuple
) -> np.ndarray:
    """:func:`_expected_periodogram`, computed."""
    taper, autocorrelation = _taper(length, taper_fraction)
    index = np.asarray(index)
    frequency = index / length
    short_lags = np.arange(3)
    expected = []
    for shape in shapes:
        if shape.long_memory:  # all lags
            memory = shape.autocovariance(np.arange(length, dtype=float), rate_hz)
            expected.append(_all_lags_expected(memory, autocorrelation, index))
        else:
            short = shape.autocovariance(short_lags.astype(float), rate_hz)
            weights = short * autocorrelation[:3] * np.array([1.0, 2.0, 2.0])
            expected.append(np.cos(2 * np.pi * np.outer(frequency, short_lags)) @ weights)
    return np.array(expected).reshape(len(shapes), index.size) / np.sum(taper**2)


def _extra_expected(length: int, taper_fraction: float, index, components) -> np.ndarray:
    """As :func:`_expected_periodogram` for ``components`` (functions lags -> increment
    autocovariance), all lags each."""
    if not components:
        return np.zeros((0, len(index)))
    taper, autocorrelation = _taper(length, taper_fraction)
    lags = np.arange(length)
    return np.array(
        [_all_lags_expected(c(lags), autocorrelation, np.asarray(index)) for c in components]
    ).reshape(len(components), len(index)) / np.sum(taper**2)


def _hats(u: np.ndarray, lows: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """(3, frequencies): the hat functions of each bin's three nodes (first, middle, last
    frequency) at every frequency's u; a bin of one frequency puts all of it on its first."""
    first = np.repeat(lows - 1, counts)
    last = first + np.repeat(counts, counts) - 1
    middle = (first + last) // 2
    u_low, u_mid, u_high = u[first], u[middle], u[last]
    with np.errstate(divide="ignore", invalid="ignore"):
        low = np.where(u < u_mid, (u_mid - u) / (u_mid - u_low), 0.0)
        high = np.where(u > u_mid, (u - u_mid) / (u_high - u_mid), 0.0)
    single = np.repeat(counts == 1, counts)
    low, high = np.where(single, 1.0, low), np.where(single, 0.0, high)
    return np.stack([low, 1.0 - low - high, high])


def _bin_sums(per_frequency: np.ndarray, hats: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """(3, ..., bins): sums over each bin of ``per_frequency`` (frequencies on axis 0) times
    each node's hat function."""
    shape = (-1,) + (1,) * (per_frequency.ndim - 1)
    return np.stack(
        [
            np.moveaxis(np.add.reduceat(per_frequency * hat.reshape(shape), starts), 0, -1)
            for hat in hats
        ]
    )


@dataclasses.dataclass(frozen=True)
class _Layout:
    """What a segment's summary takes from its length alone (taper, bins, hats, nodes), the
    same for every segment of that length: a long record's equal pieces share one."""

    taper: np.ndarray
    taper_sum: float
    norm: float
    """sum h^2."""
    information: float
    """1 / kappa (module docstring)."""
    n_frequencies: int
    lows: np.ndarray
    hats: np.ndarray
    """(3, frequencies): :func:`_hats`, zero at the excluded frequencies."""
    keep: np.ndarray
    """The bins left with a frequency."""
    index: tuple[int, ...]
    """0, then the bins' nodes (first, middle, last), as Fourier indices."""
    count: np.ndarray
    frequency_hz: np.ndarray
    node_count: np.ndarray
    node_frequency: np.ndarray


@functools.lru_cache(maxsize=4)
def _layout(
    length: int, rate_hz: float, taper_fraction: float, bin_width: float, exclude: tuple
) -> _Layout:
    """The :class:`_Layout` of a segment of ``length`` increments (cached)."""
    taper, _ = _taper(length, taper_fraction)
    n_frequencies = (length - 1) // 2
    edges = _bin_edges(n_frequencies, bin_width)
    lows, highs = edges[:-1], edges[1:]
    counts = highs - lows
    u = np.log(np.arange(1, n_frequencies + 1) / length)
    present = _outside(np.arange(1, n_frequencies + 1) * rate_hz / length, exclude)
    hats = _hats(u, lows, counts) * present
    kept = np.add.reduceat(present, lows - 1)
    keep = kept > 0
    nodes = np.stack([lows, (lows + highs - 1) // 2, highs - 1])  # (3, bins)
    return _Layout(
        taper=taper,
        taper_sum=taper.sum(),
        norm=np.sum(taper**2),
        information=np.sum(taper**2) ** 2 / (length * np.sum(taper**4)),
        n_frequencies=n_frequencies,
        lows=lows,
        hats=hats,
        keep=keep,
        index=(0, *nodes.ravel().tolist()),
        count=kept[keep].astype(int),
        frequency_hz=(np.exp(np.add.reduceat(u, lows - 1) / counts) * rate_hz)[keep],
        node_count=_bin_sums(np.ones_like(u), hats, lows - 1)[:, keep],
        node_frequency=nodes[:, keep] / length,
    )


def spectral_summary(
    values,
    rate_hz: float,
    *,
    components,
    taper_fraction: float = TAPER_FRACTION,
    bin_width: float = BIN_WIDTH,
    regressors=None,
    extra_components=(),
    exclude=(),
    transform: RecordTransform | None = None,
) -> SpectralSummary:
    """Summarise a rate series (NaN marks missing samples) for the Whittle likelihood.

    ``components``: the spectral components of the terms the likelihood may hold
    (:class:`~bayescal.models._components.Components`); ``regressors``: (samples, p)
    deterministic terms whose coefficients the likelihood takes
    (:func:`whittle_log_likelihood`, ``beta``); ``extra_components``: functions of the lag
    giving the increment autocovariance of further stationary terms, appended to the basis in
    that order; ``exclude``: bands (low, high), Hz, whose Fourier frequencies the likelihood
    leaves out (a broadened spectral line's), a bin left empty dropped; ``transform``: the
    tapered transform of a stretch of ``values`` the caller has already taken
    (:func:`~bayescal.classical._periodogram.longest_run_transform`, a noise fit's line
    scan's), read where a segment is that stretch under the same taper, not computed again."""
    regressors = None if regressors is None else np.asarray(regressors, dtype=float)
    cross, gram, mean_regressor = [], [], []
    parts = {
        name: [] for name in ("count", "frequency_hz", "node_power", "node_count", "node_frequency")
    }
    basis, weight, mean_increment, mean_basis, lengths = [], [], [], [], []
    if is_spooled(values) and regressors is not None:
        raise InputError("regressors: a spooled (long) record is summarised without them")
    values = values if is_spooled(values) else np.asarray(values, dtype=float)
    exclude = tuple(tuple(float(edge) for edge in band) for band in exclude)
    shared = transform if taper_fraction == TAPER_FRACTION else None
    for start, stop in _segment_bounds(values, MIN_INCREMENTS):
        increments = np.diff(read(values, start, stop))
        increments = increments[: fast_length_at_most(increments.size)]
        length = increments.size
        layout = _layout(length, float(rate_hz), taper_fraction, bin_width, exclude)
        taper, lows, keep = layout.taper, layout.lows, layout.keep
        if shared is not None and shared.of(start, stop):
            mean, transform = shared.mean, shared.transform
        else:
            mean, transform = tapered_transform(increments, taper)
        periodogram = np.abs(transform) ** 2 / layout.norm
        n_frequencies = layout.n_frequencies
        if regressors is not None:
            x_increments = np.diff(regressors[start:stop], axis=0)[:length]
            x_mean = taper @ x_increments / layout.taper_sum
            x_transform = fft.rfft(taper[:, None] * (x_increments - x_mean), axis=0)
            y_part = transform[1 : n_frequencies + 1]
            x_part = x_transform[1 : n_frequencies + 1]
            real, imaginary = x_part.real, x_part.imag
            cross.append(
                _bin_sums(
                    y_part.real[:, None] * real + y_part.imag[:, None] * imaginary,
                    layout.hats,
                    lows - 1,
                )[..., keep]
                / layout.norm
            )
            gram.append(
                _bin_sums(
                    real[:, :, None] * real[:, None, :]
                    + imaginary[:, :, None] * imaginary[:, None, :],
                    layout.hats,
                    lows - 1,
                )[..., keep]
                / layout.norm
            )
            mean_regressor.append(x_mean)
        expected = np.concatenate(
            (
                _expected_periodogram(
                    length, float(rate_hz), taper_fraction, layout.index, components.shapes
                ),
                _extra_expected(length, taper_fraction, layout.index, extra_components),
            )
        )
        mean_increment.append(mean)
        mean_basis.append(expected[:, 0] * layout.norm / layout.taper_sum**2)
        basis.append(expected[:, 1:].reshape(expected.shape[0], 3, -1)[..., keep])
        parts["count"].append(layout.count)
        parts["frequency_hz"].append(layout.frequency_hz)
        power = _bin_sums(periodogram[1 : n_frequencies + 1], layout.hats, lows - 1)
        parts["node_power"].append(power[:, keep])
        parts["node_count"].append(layout.node_count)
        parts["node_frequency"].append(layout.node_frequency)
        weight.append(np.full(int(keep.sum()), layout.information))
        lengths.append(length)
    if not parts["count"]:
        raise InputError(
            f"no run of more than {MIN_INCREMENTS} samples without a gap",
            fix="record longer, or pick a window without gaps",
        )
    # Segments of one length share their bins, nodes and expected periodogram: their bins
    # are pooled (powers and counts summed), which leaves the likelihood as it is and keeps
    # the bins of a long record's equal pieces to one segment's few hundred.
    groups = {}
    for index, length in enumerate(lengths):
        groups.setdefault(length, []).append(index)
    members = list(groups.values())
    summed, first = ("count", "node_power", "node_count"), ("frequency_hz", "node_frequency")

    def pooled(items, add):
        return np.concatenate(
            [sum(items[i] for i in group) if add else items[group[0]] for group in members],
            axis=-1,
        )

    arrays = {name: pooled(parts[name], name in summed) for name in (*summed, *first)}
    regression = {}
    if regressors is not None:
        regression = {
            "cross": pooled(cross, True),
            "gram": pooled(gram, True),
            "mean_regressor": np.array(mean_regressor),
        }
    return SpectralSummary(
        **arrays,
        basis=pooled(basis, False),
        weight=pooled(weight, False),
        mean_increment=np.array(mean_increment),
        mean_basis=np.array(mean_basis).T,
        duration_s=np.asarray(series_size(values) / rate_hz),
        rate_hz=float(rate_hz),
        components=components,
        **regression,
    )


def _outside(frequency_hz: np.ndarray, bands) -> np.ndarray:
    """1.0 for each frequency outside every band (low, high), else 0.0."""
    present = np.ones(frequency_hz.size)
    for low, high in bands:
        present[(frequency_hz >= low) & (frequency_hz <= high)] = 0.0
    return present


def node_spectrum(summary: SpectralSummary, variances, filtered=None):
    """(..., 3, bins): the expected periodogram at the bins' nodes.

    ``filtered``: (gain, white) of a low-pass shape on the white noise — its |H|^2 at the
    nodes (3, bins) and the weights of the components it shapes (:attr:`SpectralSummary.
    shaped`); the
    ``variances`` then hold everything the filter does not shape (the other terms, a rounding
    floor after the filter). Kept apart, a deep stop band is no difference of near-equal
    numbers."""
    spectrum = jnp.einsum("...t,tkb->...kb", jnp.asarray(variances), summary.basis)
    if filtered is not None:
        gain, white = filtered
        shaped = summary.basis[summary.shaped]
        spectrum = spectrum + gain * jnp.einsum("...c,ckb->...kb", jnp.asarray(white), shaped)
    return spectrum


def expected_power(summary: SpectralSummary, variances, filtered=None):
    """(..., bins): the expected periodogram summed over each bin (to set beside
    :attr:`SpectralSummary.power`)."""
    return jnp.sum(summary.node_count * node_spectrum(summary, variances, filtered), axis=-2)


def _bin_coefficients(summary: SpectralSummary, variances, filtered=None):
    """sum_j log S_j over each bin and the weights 1 / S(nu_k) of its node powers
    (:func:`node_spectrum`; the module docstring)."""
    spectrum = node_spectrum(summary, variances, filtered)
    return jnp.sum(summary.node_count * jnp.log(spectrum), axis=-2), 1.0 / spectrum


def whittle_log_likelihood(summary: SpectralSummary, variances, ramp=0.0, beta=None, filtered=None):
    """Pointwise log-likelihood: one value per frequency bin, then one per segment for the
    mean increment. ``variances`` are the weights of the spectral components
    (:meth:`~bayescal.models._components.Components.weights`, then any extra components),
    ``ramp`` is R, ``beta`` the coefficients of the summary's regressors (the data minus X
    beta), ``filtered`` a low-pass shape on the white noise, ``variances`` then holding the
    rest (:func:`node_spectrum`)."""
    variances = jnp.asarray(variances)
    log_sum, coefficients = _bin_coefficients(summary, variances, filtered)
    moments = summary.node_power
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
    if filtered is not None:  # unit gain at zero frequency: the mean increment's as unfiltered
        shaped = summary.mean_basis[summary.shaped]
        variance = variance + jnp.einsum("c,cs->s", filtered[1], shaped)
    residual = mean_increment - ramp / summary.rate_hz
    mean_terms = -0.5 * (jnp.log(2 * jnp.pi * variance) + residual**2 / variance)
    if summary.segment_weight is not None:
        mean_terms = summary.segment_weight * mean_terms
    return jnp.concatenate((bins, mean_terms))


def padded_summary(summary: SpectralSummary) -> SpectralSummary:
    """``summary`` with its bins padded to a multiple of :data:`BIN_BUCKET` and its segments
    to one of :data:`SEGMENT_BUCKET` (module docstring): the likelihood it gives is the
    same, its pointwise values the same followed by zeros (:func:`padded_index` picks the
    real ones).

    A padded bin has no frequencies and weight zero, and the last bin's nodes and basis (a
    finite, positive spectrum: nothing undefined is multiplied by zero); a padded segment has
    the first segment's variance, a zero mean increment and weight zero. A summary with
    regressors is returned as it is (their fits are not the noise fit's shapes)."""
    if summary.cross is not None:
        return summary
    bins = summary.n_bins
    segments = summary.mean_increment.size
    extra_bins = -bins % BIN_BUCKET
    extra_segments = -segments % SEGMENT_BUCKET

    def bins_padded(array, value=None):
        array = np.asarray(array)
        tail = np.repeat(array[..., -1:], extra_bins, axis=-1)
        if value is not None:
            tail = np.full_like(tail, value)
        return np.concatenate((array, tail), axis=-1)

    mean_basis = np.asarray(summary.mean_basis)
    return SpectralSummary(
        count=bins_padded(summary.count, 0),
        frequency_hz=bins_padded(summary.frequency_hz),
        node_power=bins_padded(summary.node_power, 0.0),
        node_count=bins_padded(summary.node_count, 0.0),
        node_frequency=bins_padded(summary.node_frequency),
        basis=bins_padded(summary.basis),
        weight=bins_padded(summary.weight, 0.0),
        mean_increment=np.concatenate((summary.mean_increment, np.zeros(extra_segments))),
        mean_basis=np.concatenate(
            (mean_basis, np.repeat(mean_basis[:, :1], extra_segments, axis=1)), axis=1
        ),
        duration_s=summary.duration_s,
        rate_hz=summary.rate_hz,
        components=summary.components,
        segment_weight=np.concatenate((np.ones(segments), np.zeros(extra_segments))),
    )


def padded_index(summary: SpectralSummary) -> np.ndarray:
    """The positions of ``summary``'s pointwise log-likelihood values (its bins, then its
    segments) among those of :func:`padded_summary` of it."""
    padded = summary.n_bins + -summary.n_bins % BIN_BUCKET
    if summary.cross is not None:
        padded = summary.n_bins
    return np.concatenate(
        (np.arange(summary.n_bins), padded + np.arange(summary.mean_increment.size))
    )


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
