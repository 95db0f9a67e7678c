"""Allan, modified Allan and Hadamard deviations with confidence intervals.

The estimators are those of NIST SP 1065 (Riley 2008), written on the phase x, the time
integral of the rate y (x_k = tau0 * sum_{i<k} y_i; for a gyro the angle, for an
accelerometer the velocity):

- Allan variance, eq. (11) overlapping / eq. (7) non-overlapping:
  sigma^2(tau) = sum (x_{i+2m} - 2 x_{i+m} + x_i)^2 / (2 tau^2 n_terms);
- modified Allan variance, eq. (14): the inner m-sums of those second differences, squared,
  divided by 2 m^2 tau^2 n_terms;
- Hadamard variance, eq. (17): third differences x_{i+3m} - 3 x_{i+2m} + 3 x_{i+m} - x_i,
  squared, divided by 6 tau^2 n_terms.

The sums run in compiled loops (numba) that read the phase once per averaging factor and keep
no temporaries, which is what makes 10^7-sample records fast. ``NaN`` in ``y`` marks missing
samples: terms that would span one are left out (the gap-tolerant estimator), which is how
``--gaps split`` pools the segments of a recording without bridging its gaps.
"""

import bisect
import functools
import math
from dataclasses import dataclass
from typing import Literal

import numba
import numpy as np

from .._errors import InputError
from ..recording._inputs import samples_and_rate
from ..recording._series import blocks, gap_free_runs, is_spooled, read
from ._edf import (
    _LAG1_MAX_POINTS,
    deviation_interval,
    equivalent_degrees_of_freedom,
    identify_noise_exponent,
)

TauSpec = Literal["octave", "decade", "all"] | int | np.ndarray | list


@dataclass(frozen=True)
class DeviationResult:
    """An Allan-family deviation at each averaging time, with its confidence interval.

    Arrays over averaging times are last; leading axes are those of the input less ``axis``.
    """

    tau: np.ndarray
    """Averaging times tau = m / rate, s."""
    m: np.ndarray
    """Averaging factors (samples per average)."""
    deviation: np.ndarray
    """The deviation, in the unit of the rate signal."""
    ci_low: np.ndarray
    """Lower end of the chi-square confidence interval of the deviation, its unit."""
    ci_high: np.ndarray
    """Upper end of the chi-square confidence interval of the deviation, its unit."""
    n: np.ndarray
    """Number of terms in each estimate (Stable32's "#" column)."""
    edf: np.ndarray
    """Equivalent degrees of freedom (Greenhall & Riley 2003)."""
    alpha: np.ndarray
    """Power-law exponent of S_y(f) used for the EDF (identified, or as given)."""
    confidence: float
    """Two-sided confidence of the interval."""
    estimator: str
    """Which deviation this is (overlapping Allan, modified Allan, Hadamard ...)."""


@numba.njit(parallel=True, cache=True)
def _difference_sums(phase, missing, factors, order, overlapping):  # pragma: no cover - compiled
    """Sum of squared lag-m differences of order 2 or 3 and the number of terms, per lane
    and factor; ``missing`` is the running count of missing samples (empty when none)."""
    lanes, length = phase.shape
    n_factors = factors.size
    sums = np.zeros((lanes, n_factors))
    counts = np.zeros((lanes, n_factors), dtype=np.int64)
    gapped = missing.shape[1] > 0
    for job in numba.prange(lanes * n_factors):
        lane = job // n_factors
        index = job % n_factors
        m = factors[index]
        x = phase[lane]
        step = 1 if overlapping else m
        total = 0.0
        terms = 0
        for k in range(0, length - order * m, step):
            if gapped and missing[lane, k + order * m] != missing[lane, k]:
                continue
            if order == 2:
                value = x[k + 2 * m] - 2.0 * x[k + m] + x[k]
            else:
                value = x[k + 3 * m] - 3.0 * x[k + 2 * m] + 3.0 * x[k + m] - x[k]
            total += value * value
            terms += 1
        sums[lane, index] = total
        counts[lane, index] = terms
    return sums, counts


@numba.njit(parallel=True, cache=True)
def _modified_sums(phase, missing, factors):  # pragma: no cover - compiled
    """Sum over j of (sum_{i=j}^{j+m-1} second difference_i)^2, and the number of terms."""
    lanes, length = phase.shape
    n_factors = factors.size
    sums = np.zeros((lanes, n_factors))
    counts = np.zeros((lanes, n_factors), dtype=np.int64)
    gapped = missing.shape[1] > 0
    for job in numba.prange(lanes * n_factors):
        lane = job // n_factors
        index = job % n_factors
        m = factors[index]
        x = phase[lane]
        n_windows = length - 3 * m + 1
        if n_windows < 1:
            continue
        window = 0.0
        for i in range(m):
            window += x[i + 2 * m] - 2.0 * x[i + m] + x[i]
        total = 0.0
        terms = 0
        for j in range(n_windows):
            if j > 0:
                last = j + m - 1
                window += (
                    x[last + 2 * m]
                    - 2.0 * x[last + m]
                    + x[last]
                    - (x[j + 2 * m - 1] - 2.0 * x[j + m - 1] + x[j - 1])
                )
            if gapped and missing[lane, j + 3 * m - 1] != missing[lane, j]:
                continue
            total += window * window
            terms += 1
        sums[lane, index] = total
        counts[lane, index] = terms
    return sums, counts


@dataclass(frozen=True)
class _Estimator:
    name: str
    order: int
    overlapping: bool
    modified: bool
    normalisation: float  # sigma^2 = sums / (normalisation * tau^2 * n_terms [* m^2 if modified])

    def span(self, m):
        """Phase points one term spans, less one."""
        return 3 * m - 1 if self.modified else self.order * m

    def equivalent_phase_points(self, m, n_terms):
        """Phase points of a gap-free record that gives ``n_terms`` terms."""
        if self.overlapping:
            return n_terms + self.span(m)
        return (n_terms + self.order - 1) * m + 1


_ALLAN = _Estimator("oadev", 2, True, False, 2.0)
_ALLAN_NON_OVERLAPPING = _Estimator("adev", 2, False, False, 2.0)
_MODIFIED = _Estimator("mdev", 2, True, True, 2.0)
_HADAMARD = _Estimator("ohdev", 3, True, False, 6.0)
_HADAMARD_NON_OVERLAPPING = _Estimator("hdev", 3, False, False, 6.0)


def averaging_factors(taus: TauSpec, n_phase: int, rate: float, *, longest: int) -> np.ndarray:
    """Averaging factors m for a tau specification.

    ``"octave"``: m = 1, 2, 4, ...; ``"decade"``: 1, 2, 4 per decade; ``"all"``: every m;
    an integer N: N log-spaced factors (duplicates dropped); these stop at a quarter of the
    record (as Stable32 does), where fewer than about four independent averages remain.
    An array gives averaging times in seconds, each a whole number of sample periods and no
    longer than ``longest`` samples.
    """
    default_top = max(1, min(longest, n_phase // 4))
    if isinstance(taus, str):
        if taus == "octave":
            return 2 ** np.arange(int(math.log2(default_top)) + 1)
        if taus == "decade":
            decades = 10 ** np.arange(int(math.log10(default_top)) + 1)
            factors = (decades[:, None] * np.array([1, 2, 4])).ravel()
            return factors[factors <= default_top]
        if taus == "all":
            return np.arange(1, default_top + 1)
        raise InputError(
            f"taus={taus!r} is not a tau grid",
            fix="use 'octave', 'decade', 'all', a count or averaging times in seconds",
        )
    if isinstance(taus, (int, np.integer)):
        if taus < 1:
            raise InputError(f"taus={taus} must be a positive count of averaging times")
        return np.unique(
            np.round(np.logspace(0, math.log10(default_top), int(taus))).astype(np.int64)
        )
    seconds = np.atleast_1d(np.asarray(taus, dtype=float))
    factors = np.round(seconds * rate).astype(np.int64)
    off_grid = np.abs(factors - seconds * rate) > 1e-6 * np.maximum(1.0, seconds * rate)
    if np.any(off_grid) or np.any(factors < 1):
        bad = seconds[off_grid | (factors < 1)][0]
        raise InputError(f"taus: {bad:g} s is not a whole number of sample periods (1/{rate:g} s)")
    if np.any(factors > longest):
        bad = seconds[factors > longest][0]
        raise InputError(
            f"taus: {bad:g} s needs more samples than the record has "
            f"(longest averaging time here is {longest / rate:g} s)",
            fix="shorten the averaging time or record longer",
        )
    return factors


@numba.njit(cache=True)
def _integrate(lanes, period, with_missing):  # pragma: no cover - compiled
    """Phase of each lane, x_0 = 0 and x_{k+1} = x_k + (y_k - mean) * period, with missing
    (NaN) samples read as the mean; and the running count of missing samples."""
    n_lanes, length = lanes.shape
    phase = np.zeros((n_lanes, length + 1))
    missing = np.zeros((n_lanes, length + 1 if with_missing else 0), dtype=np.int64)
    for lane in range(n_lanes):
        total = 0.0
        present = 0
        for k in range(length):
            if not np.isnan(lanes[lane, k]):
                total += lanes[lane, k]
                present += 1
        mean = total / max(present, 1)
        running = 0.0
        gaps = 0
        for k in range(length):
            value = lanes[lane, k]
            if np.isnan(value):
                gaps += 1
            else:
                running += (value - mean) * period
            phase[lane, k + 1] = running
            if with_missing:
                missing[lane, k + 1] = gaps
    return phase, missing


def _phase_lanes(y: np.ndarray, rate: float, kind: str):
    """Phase per lane and the running count of missing samples (empty when there are none).

    The mean rate is taken out before integrating: it changes none of these variances and
    keeps the phase small, so the differences lose no digits to cancellation.
    """
    if kind == "rate":
        return _integrate(y, 1.0 / rate, bool(np.isnan(y).any()))
    if kind == "phase":
        if np.isnan(y).any():
            raise InputError("y: NaN in phase data; gaps are supported for kind='rate' only")
        index = np.arange(y.shape[1])
        slope = (y[:, -1:] - y[:, :1]) / max(1, y.shape[1] - 1)
        return y - y[:, :1] - slope * index, np.zeros((y.shape[0], 0), dtype=np.int64)
    raise InputError(f"kind={kind!r} must be 'rate' or 'phase'")


def _longest_complete_run(phase_lane: np.ndarray, missing_lane: np.ndarray) -> np.ndarray:
    if missing_lane.size == 0:
        return phase_lane
    steps = np.diff(missing_lane) == 0  # True where sample i is present
    edges = np.flatnonzero(np.diff(np.concatenate(([0], steps.astype(np.int8), [0]))))
    starts, stops = edges[::2], edges[1::2]
    best = np.argmax(stops - starts)
    return phase_lane[starts[best] : stops[best] + 1]


@numba.njit(parallel=True, cache=True)
def _window_sums(span, missing, points, steps, order, first, counts_, lanes):  # pragma: no cover
    """As :func:`_difference_sums` for the terms k = first .. first + count - 1 of one lane
    (``counts_``: the count for each factor): term k of a factor reads span[k + p] for each
    of its points p (``points``: (factors, order + 1), where its terms' j-th phase point
    starts in ``span``), every step-th k of the record; ``missing`` (empty: none) is laid out
    as ``span``. The terms are taken a stretch of the record at a time, every factor's over
    that stretch before the next: the stretch's phase points stay in the cache for all the
    factors, not only the one (each factor's sum still runs over its terms in order);
    ``lanes`` (the threads) share out the factors."""
    n_factors = points.shape[0]
    sums = np.zeros(n_factors)
    counts = np.zeros(n_factors, dtype=np.int64)
    gapped = missing.size > 0
    longest = 0
    for index in range(n_factors):
        longest = max(longest, counts_[index])
    for lane in numba.prange(lanes):
        for low in range(0, longest, _STRETCH):
            for index in range(lane, n_factors, lanes):
                step = steps[index]
                p0, p1, p2 = points[index, 0], points[index, 1], points[index, 2]
                p3 = points[index, order]
                total = sums[index]
                terms = counts[index]
                for k in range(
                    low + (-first - low) % step, min(low + _STRETCH, counts_[index]), step
                ):
                    if gapped and missing[k + p3] != missing[k + p0]:
                        continue
                    if order == 2:
                        value = span[k + p2] - 2.0 * span[k + p1] + span[k + p0]
                    else:
                        value = (
                            span[k + p3] - 3.0 * span[k + p2] + 3.0 * span[k + p1] - span[k + p0]
                        )
                    total += value * value
                    terms += 1
                sums[index] = total
                counts[index] = terms
    return sums, counts


_STRETCH = 1 << 13
"""Terms of each factor per stretch in :func:`_window_sums` (the stretches of a few tens of
factors' points fit in a core's cache)."""
_SPAN_BLOCK = 1 << 22
"""Terms per window of the sums over a spooled phase: 32 MB of phase points per window a
factor's terms read, these joined where they touch (octave factors of 10^8 samples: 160 MB)."""


@numba.njit(cache=True)
def _sum_present(block, total, present):  # pragma: no cover - compiled
    """``total`` and ``present`` carried on over the samples of ``block`` that are not NaN,
    in order (the sum :func:`_integrate` takes the mean from, to the last bit)."""
    for value in block:
        if not np.isnan(value):
            total += value
            present += 1
    return total, present


@numba.njit(cache=True)
def _phase_points(block, mean, period, running, gaps, skip, with_missing):  # pragma: no cover
    """:func:`_integrate` carried on over one block from the running phase and count of
    missing samples before it: its phase points and counts from the skip-th on (the first,
    at index 0, is the one before the block; the last the one after it)."""
    phase = np.empty(block.size + 1 - skip)
    missing = np.empty(block.size + 1 - skip if with_missing else 0)
    for k in range(block.size + 1):
        if k >= skip:
            phase[k - skip] = running
            if with_missing:
                missing[k - skip] = gaps
        if k < block.size:
            if np.isnan(block[k]):
                gaps += 1
            else:
                running += (block[k] - mean) * period
    return phase, missing


class _SpooledPhase:
    """The phase of a spooled rate series, and the running count of its missing samples,
    read in windows: integrated once, keeping the running phase and count where each block
    of the series begins, a window is integrated again from the block it begins in. The
    arithmetic is :func:`_integrate`'s in its order, so every point is the in-memory one to
    the last bit, and nothing the size of the record is written.

    ``picks``: (start, stop, step) of phase points to keep from the first integration
    (:attr:`picked`, in that order): the decimated phase the noise identification reads."""

    def __init__(self, y, rate: float, picks=()):
        total, present = 0.0, 0
        for _, block in blocks(y):
            total, present = _sum_present(block, total, present)
        self.y, self.size = y, y.size + 1
        self.mean, self.period = total / max(present, 1), 1.0 / rate
        self.gapped = present < y.size
        self.firsts, self.states = [], []
        picked = [[] for _ in picks]
        running, gaps = 0.0, 0
        for first, block in blocks(y):
            self.firsts.append(first)
            self.states.append((running, gaps))
            phase, missing = _phase_points(
                block, self.mean, self.period, running, gaps, 0, self.gapped
            )
            running, gaps = phase[-1], (int(missing[-1]) if self.gapped else 0)
            end = first + block.size + (1 if first + block.size == y.size else 0)
            for kept, (start, stop, step) in zip(picked, picks, strict=True):
                low = max(start, first)
                low += (start - low) % step
                kept.append(phase[low - first : max(0, min(stop, end) - first) : step].copy())
        self.picked = [np.concatenate(kept) for kept in picked]

    def fill(self, start: int, phase: np.ndarray, missing: np.ndarray) -> None:
        """Write phase points ``start``, ``start + 1`` ... into ``phase`` (as many as it
        holds) and their running counts of missing samples into ``missing`` (when any are
        missing), integrating again block by block from the block ``start`` is in."""
        stop = start + phase.size
        block = bisect.bisect_right(self.firsts, start) - 1
        running, gaps = self.states[block]
        while True:
            position = self.firsts[block]
            end = min(stop - 1, self.firsts[block + 1] if block + 1 < len(self.firsts) else stop)
            skip = max(0, start - position)
            points, counts = _phase_points(
                read(self.y, position, end),
                self.mean,
                self.period,
                running,
                gaps,
                skip,
                self.gapped,
            )
            at = position + skip - start
            phase[at : at + points.size] = points
            missing[at : at + counts.size] = counts
            if end == stop - 1:
                return
            block += 1
            running, gaps = self.states[block]


def _spooled_difference_sums(phase: _SpooledPhase, factors, order, overlapping):
    """:func:`_difference_sums` of one spooled phase, a window of terms at a time: the phase
    points every factor's terms in the window read, the windows (one per factor and point)
    joined where they touch, read once and laid side by side (the record between them is
    not needed); the sum of each factor over a window added to its total in order."""
    length = phase.size
    sums = np.zeros(factors.size)
    counts = np.zeros(factors.size, dtype=np.int64)
    steps = np.ones_like(factors) if overlapping else factors.astype(np.int64)
    reach = order * factors.astype(np.int64)  # phase points a term spans, less one
    for first in range(0, length - int(reach.min()), _SPAN_BLOCK):
        terms = np.clip(length - reach - first, 0, _SPAN_BLOCK)
        active = np.flatnonzero(terms > 0)
        offsets = np.arange(order + 1) * factors[active, None].astype(np.int64)
        width = int(terms.max())
        windows = []  # [low, high) of the phase points read, after first
        for low in np.unique(offsets).tolist():
            high = min(low + width, length - first)  # the last window's run to the end
            if windows and low <= windows[-1][1]:
                windows[-1][1] = high
            else:
                windows.append([low, high])
        sizes = [high - low for low, high in windows]
        starts = np.cumsum([0, *sizes])
        span = np.empty(starts[-1])
        gaps = np.empty(starts[-1] if phase.gapped else 0)
        for (low, high), at in zip(windows, starts[:-1].tolist(), strict=True):
            phase.fill(first + low, span[at : at + high - low], gaps[at : at + high - low])
        lows = np.array([low for low, _ in windows])
        window = np.searchsorted(lows, offsets, side="right") - 1
        part, made = _window_sums(
            span,
            gaps,
            (starts[window] + offsets - lows[window]).astype(np.int64),
            steps[active],
            order,
            first,
            terms[active],
            numba.get_num_threads(),
        )
        sums[active] += part
        counts[active] += made
    return sums[None, :], counts[None, :]


def _lane_exponents(exponent_at, size: int, factors) -> list[int]:
    """The noise exponent at each factor (``exponent_at(m)``) where the longest complete run
    (``size`` phase points) holds more than two averages; 0 where it does not."""
    return [exponent_at(m) if size > 2 * m else 0 for m in factors.tolist()]


def _spooled_lanes(estimator, y, rate, taus, noise_type, max_differences):
    """(factors, sums, counts, exponents) of one spooled rate series."""
    if estimator.modified:
        raise InputError(
            "y: the modified Allan deviation of a spooled (long) record is not computed",
            fix="use allan_deviation or hadamard_deviation, or a record that fits in memory",
        )
    n_phase = y.size + 1
    longest = (n_phase - 1) // estimator.order
    if longest < 1:
        raise InputError(f"y: {y.size} samples are too few for a {estimator.name}")
    factors = averaging_factors(taus, n_phase, float(rate), longest=longest)
    picks, size = (), 0
    if noise_type == "auto":
        runs = gap_free_runs(y)
        start, stop = runs[np.argmax(runs[:, 1] - runs[:, 0])]
        size = int(stop - start + 1)  # phase points of the run
        # The run's phase decimated, as much of it as the lag-1 method reads: the same points
        # the in-memory path uses, kept while the phase is integrated. Only below 30
        # averages, where the R(n) ratio of phase noise would need the undecimated phase, is
        # it taken on the decimated one.
        picks = [(start, start + min(size, m * _LAG1_MAX_POINTS), m) for m in factors.tolist()]
    phase = _SpooledPhase(y, float(rate), picks)
    sums, counts = _spooled_difference_sums(phase, factors, estimator.order, estimator.overlapping)
    exponents = None
    if noise_type == "auto":
        decimated = dict(zip(factors.tolist(), phase.picked, strict=True))
        exponents = [
            _lane_exponents(
                lambda m: identify_noise_exponent(decimated[m], 1, max_differences=max_differences),
                size,
                factors,
            )
        ]
    return factors, sums, counts, exponents


def _memory_lanes(estimator, lanes, rate, taus, kind, noise_type, max_differences):
    """(factors, sums, counts, exponents) of the lanes of an in-memory array."""
    phase, missing = _phase_lanes(lanes, float(rate), kind)
    n_phase = phase.shape[1]
    longest = n_phase // 3 if estimator.modified else (n_phase - 1) // estimator.order
    if longest < 1:
        raise InputError(f"y: {lanes.shape[-1]} samples are too few for a {estimator.name}")
    factors = averaging_factors(taus, n_phase, float(rate), longest=longest)
    if estimator.modified:
        sums, counts = _modified_sums(phase, missing, factors)
        sums = sums / factors.astype(float) ** 2
    else:
        sums, counts = _difference_sums(
            phase, missing, factors, estimator.order, estimator.overlapping
        )
    exponents = None
    if noise_type == "auto":
        exponents = []
        for lane in range(lanes.shape[0]):
            complete = _longest_complete_run(phase[lane], missing[lane])
            exponents.append(
                _lane_exponents(
                    lambda m, complete=complete: identify_noise_exponent(
                        complete, m, max_differences=max_differences
                    ),
                    complete.size,
                    factors,
                )
            )
    return factors, sums, counts, exponents


def _deviation(estimator: _Estimator, y, rate, taus, axis, kind, confidence, noise_type, ci_method):
    if not rate > 0:
        raise InputError(f"rate_hz={rate!r} must be a positive sample rate in Hz")
    if not 0 < confidence < 1:
        raise InputError(f"confidence={confidence!r} must lie between 0 and 1")
    max_differences = 3 if estimator.order == 3 else 2
    if is_spooled(y):
        if kind != "rate":
            raise InputError(f"kind={kind!r}: a spooled series is read as rate samples")
        lead_shape = ()
        factors, sums, counts, exponents = _spooled_lanes(
            estimator, y, rate, taus, noise_type, max_differences
        )
    else:
        values = np.moveaxis(np.asarray(y, dtype=float), axis, -1)
        lead_shape = values.shape[:-1]
        lanes = values.reshape(-1, values.shape[-1])
        factors, sums, counts, exponents = _memory_lanes(
            estimator, lanes, rate, taus, kind, noise_type, max_differences
        )
    tau = factors / float(rate)
    with np.errstate(invalid="ignore", divide="ignore"):
        deviation = np.sqrt(sums / (estimator.normalisation * tau**2 * counts))

    alpha = (
        np.full(counts.shape, int(noise_type), dtype=np.int64)
        if exponents is None
        else np.array(exponents, dtype=np.int64)
    )
    edf = np.full(counts.shape, np.nan)
    edf_of = functools.cache(
        lambda noise, m, terms: equivalent_degrees_of_freedom(
            noise,
            estimator.order,
            m,
            estimator.equivalent_phase_points(m, terms),
            overlapping=estimator.overlapping,
            modified=estimator.modified,
            phase_averaged=ci_method == "stable32",
        )
    )
    for lane, index in np.argwhere(counts > 0):
        edf[lane, index] = edf_of(
            int(alpha[lane, index]), int(factors[index]), int(counts[lane, index])
        )
    ci_low, ci_high = deviation_interval(deviation, edf, confidence, ci_method)
    shape = (*lead_shape, factors.size)
    return DeviationResult(
        tau=tau,
        m=factors,
        deviation=deviation.reshape(shape),
        ci_low=ci_low.reshape(shape),
        ci_high=ci_high.reshape(shape),
        n=counts.reshape(shape),
        edf=edf.reshape(shape),
        alpha=alpha.reshape(shape),
        confidence=float(confidence),
        estimator=estimator.name,
    )


def allan_deviation(
    y,
    rate_hz: float | None = None,
    taus: TauSpec = "octave",
    *,
    axis: int = -1,
    kind: str = "rate",
    overlapping: bool = True,
    confidence: float = 0.95,
    noise_type: int | Literal["auto"] = "auto",
    ci_method: str = "exact",
) -> DeviationResult:
    """Allan deviation of a rate signal, with chi-square confidence intervals.

    Parameters
    ----------
    y : array_like or Channel
        Rate (frequency-like) samples, e.g. a gyro in deg/s; with ``kind="phase"`` the
        integrated signal (angle) instead. NaN marks a missing sample (rate data only).
    rate_hz : float
        Sample rate in Hz (from the channel when ``y`` is a :class:`~bayescal.Channel`);
        tau = m / rate_hz.
    taus : "octave", "decade", "all", int or array
        Averaging times; see :func:`averaging_factors`.
    axis : int
        Axis of ``y`` along which time runs.
    overlapping : bool
        The overlapping estimator (SP 1065 eq. 11, the default) or the original eq. (7).
    confidence : float
        Two-sided confidence of the interval (Stable32 tables use 0.683).
    noise_type : "auto" or int
        Power-law exponent alpha of S_y(f) for the EDF, or "auto" to identify it per tau.
    ci_method : "exact" or "stable32"
        "exact": EDF for phase point samples (exact for IMU rate samples, see
        :func:`equivalent_degrees_of_freedom`) and exact chi-square quantiles; "stable32":
        Greenhall's phase-averaged EDF and Stable32's quantile approximation, to compare with
        Stable32's tables.

    Returns
    -------
    DeviationResult
        tau (s), the deviation (the unit of ``y``) and its interval, the number of terms,
        the EDF and the noise exponent at each tau; arrays over tau last.

    Raises
    ------
    InputError
        Too few samples for the taus asked, a tau no estimate reaches, a confidence outside
        (0, 1).

    Examples
    --------
    >>> import numpy as np
    >>> import bayescal as bc
    >>> y = np.random.default_rng(0).normal(0.0, 0.1, 100_000)  # white noise at 100 Hz, deg/s
    >>> result = bc.allan_deviation(y, 100.0, taus=[0.1, 1.0])
    >>> result.tau  # s
    array([0.1, 1. ])
    >>> result.deviation.round(4)  # N / sqrt(tau), N = 0.1 / sqrt(100 Hz) = 0.01 deg/s/√Hz
    array([0.0315, 0.0102])
    """
    estimator = _ALLAN if overlapping else _ALLAN_NON_OVERLAPPING
    y, rate = samples_and_rate(y, rate_hz)
    return _deviation(estimator, y, rate, taus, axis, kind, confidence, noise_type, ci_method)


def modified_allan_deviation(
    y,
    rate_hz: float | None = None,
    taus: TauSpec = "octave",
    *,
    axis: int = -1,
    kind: str = "rate",
    confidence: float = 0.95,
    noise_type: int | Literal["auto"] = "auto",
    ci_method: str = "exact",
) -> DeviationResult:
    """Modified Allan deviation (SP 1065 eq. 14), with chi-square confidence intervals.

    Parameters
    ----------
    y : array_like or Channel
        Rate samples (``kind="phase"``: the integrated signal); NaN marks a missing sample.
    rate_hz : float
        Sample rate, Hz (from the channel when ``y`` is a :class:`~bayescal.Channel`).
    taus : "octave", "decade", "all", int or array
        Averaging times, s (as :func:`allan_deviation`).
    axis : int
        Axis of ``y`` along which time runs.
    kind : "rate" or "phase"
        What ``y`` holds.
    confidence : float
        Two-sided confidence of the interval.
    noise_type : "auto" or int
        Power-law exponent of S_y(f) for the EDF, or "auto" to identify it per tau.
    ci_method : "exact" or "stable32"
        As :func:`allan_deviation`.

    Returns
    -------
    DeviationResult
        The deviation (the unit of ``y``) and its interval at each tau.

    Raises
    ------
    InputError
        As :func:`allan_deviation`.
    """
    y, rate = samples_and_rate(y, rate_hz)
    return _deviation(_MODIFIED, y, rate, taus, axis, kind, confidence, noise_type, ci_method)


def hadamard_deviation(
    y,
    rate_hz: float | None = None,
    taus: TauSpec = "octave",
    *,
    axis: int = -1,
    kind: str = "rate",
    overlapping: bool = True,
    confidence: float = 0.95,
    noise_type: int | Literal["auto"] = "auto",
    ci_method: str = "exact",
) -> DeviationResult:
    """Hadamard deviation (SP 1065 eq. 17, overlapping by default); insensitive to a linear
    drift of the rate.

    Parameters
    ----------
    y : array_like or Channel
        Rate samples (``kind="phase"``: the integrated signal); NaN marks a missing sample.
    rate_hz : float
        Sample rate, Hz (from the channel when ``y`` is a :class:`~bayescal.Channel`).
    taus : "octave", "decade", "all", int or array
        Averaging times, s (as :func:`allan_deviation`).
    axis : int
        Axis of ``y`` along which time runs.
    kind : "rate" or "phase"
        What ``y`` holds.
    overlapping : bool
        The overlapping estimator (the default) or the non-overlapping one.
    confidence : float
        Two-sided confidence of the interval.
    noise_type : "auto" or int
        Power-law exponent of S_y(f) for the EDF, or "auto" to identify it per tau.
    ci_method : "exact" or "stable32"
        As :func:`allan_deviation`.

    Returns
    -------
    DeviationResult
        The deviation (the unit of ``y``) and its interval at each tau.

    Raises
    ------
    InputError
        As :func:`allan_deviation`.
    """
    estimator = _HADAMARD if overlapping else _HADAMARD_NON_OVERLAPPING
    y, rate = samples_and_rate(y, rate_hz)
    return _deviation(estimator, y, rate, taus, axis, kind, confidence, noise_type, ci_method)
