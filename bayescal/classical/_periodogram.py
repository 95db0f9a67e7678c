"""The tapered periodogram of a record's increments: the one the Whittle likelihood
(:mod:`bayescal.models._whittle`) summarises and the spectral-line test
(:mod:`bayescal.classical._lines`) reads.

Increments d_k = y_{k+1} - y_k, not the samples: every noise term's increments are stationary
(a rate random walk's and a flicker's too), so their periodogram has no leakage from the
record's slow wander. A Tukey taper over 10 % of the record removes the boundary term that
differencing leaves; the periodogram I_j = |sum_k h_k (d_k - dbar) e^{-2 pi i j k / M}|^2 /
sum h^2 then has the spectrum of the increments as its mean, per cycle per sample, two-sided
(white increments of variance s^2 read s^2).
"""

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy import fft

from .._threads import usable_cores
from ..recording._series import gap_free_runs, is_spooled

TAPER_FRACTION = 0.1
"""The share of the record the Tukey taper's two cosine ends span."""


KEPT_TAPER_LENGTH = 2**21
"""The longest taper kept between calls (16 MB): a notebook fits one record again and again,
and its line scan, summaries and checks each take the taper of their length; a longer one
(64 MB at 2^23 points, 800 MB at 10^8) is made each time (20 ms at 2^23) rather than held
after the call."""


def tukey_window(length: int, fraction: float) -> np.ndarray:
    """The symmetric Tukey (tapered cosine) window of ``length`` points whose tapers span
    ``fraction`` (0 < fraction < 1) of it, as ``scipy.signal.windows.tukey`` computes it
    (importing ``scipy.signal`` costs a run 1.7 s). Read-only; kept for the last lengths met
    up to :data:`KEPT_TAPER_LENGTH`."""
    if length <= KEPT_TAPER_LENGTH:
        return _kept_tukey_window(length, fraction)
    return _tukey_window(length, fraction)


def _tukey_window(length: int, fraction: float) -> np.ndarray:
    """:func:`tukey_window`, made in one array of the window's length: its flat middle
    written once, its two cosine ends over it (at 2^23 points, three arrays of that length
    fewer for the kernel to hand out and zero)."""
    window = np.ones(length)
    if length > 1:
        width = math.floor(fraction * (length - 1) / 2.0)
        rising = np.arange(width + 1, dtype=float)
        falling = np.arange(length - width - 1, length, dtype=float)
        rising_phase = -1 + 2.0 * rising / fraction / (length - 1)
        falling_phase = -2.0 / fraction + 1 + 2.0 * falling / fraction / (length - 1)
        window[: width + 1] = 0.5 * (1 + np.cos(np.pi * rising_phase))
        window[length - width - 1 :] = 0.5 * (1 + np.cos(np.pi * falling_phase))
    window.flags.writeable = False
    return window


_kept_tukey_window = functools.lru_cache(maxsize=4)(_tukey_window)


@functools.lru_cache(maxsize=64)
def fast_length_at_most(length: int) -> int:
    """The longest length <= ``length`` whose prime factors are 2, 3 and 5 (an FFT of it is
    fast; one of 2^23 - 1 points would take a minute). Kept for the lengths met: the search
    down from 2^20 - 1 takes some 10 ms, twice a fit (the lines' scan, the summaries)."""
    candidate = length
    while fft.next_fast_len(candidate, real=True) != candidate:
        candidate -= 1
    return candidate


@dataclass(frozen=True)
class RecordTransform:
    """The tapered transform (:func:`tapered_transform`) of the increments of a record's
    samples [start, stop), cut to a fast length (:func:`fast_length_at_most`): computed once
    where a record is read two ways — a noise fit's line scan and its Whittle summaries, the
    same numbers in the same order — and handed to each (:func:`longest_run_transform`)."""

    start: int
    stop: int
    increments: np.ndarray
    """The increments transformed (read-only)."""
    taper: np.ndarray
    """The taper they were transformed under (read-only): the readers' own, not made again."""
    mean: float
    """Their taper-weighted mean."""
    transform: np.ndarray
    """The real DFT of the tapered increments less their mean (read-only)."""

    def of(self, start: int, stop: int) -> bool:
        """Whether it is the transform of samples [start, stop)."""
        return (start, stop) == (self.start, self.stop)


def longest_run(values) -> tuple[int, int] | None:
    """[start, stop) of the record's longest run without a gap (the first of equal ones),
    or None where it has no sample."""
    runs = gap_free_runs(values).tolist()
    if not runs:
        return None
    start, stop = max(runs, key=lambda run: run[1] - run[0])
    return start, stop


def longest_run_transform(values) -> RecordTransform | None:
    """The :class:`RecordTransform` of the record's longest run without a gap (what the line
    scan reads, and the summaries where they take it in one piece), under the Tukey taper of
    :data:`TAPER_FRACTION`; None for a spooled record (nothing reads it whole) or a run of
    fewer than two increments."""
    run = None if is_spooled(values) else longest_run(values)
    if run is None or run[1] - run[0] < 3:
        return None
    start, stop = run
    increments = np.diff(np.asarray(values[start:stop], dtype=float))
    increments = increments[: fast_length_at_most(increments.size)]
    increments.flags.writeable = False
    taper = tukey_window(increments.size, TAPER_FRACTION)
    mean, transform = tapered_transform(increments, taper)
    return RecordTransform(start, stop, increments, taper, mean, transform)


def tapered_transform(increments: np.ndarray, taper: np.ndarray) -> tuple[float, np.ndarray]:
    """The taper-weighted mean of ``increments`` and the real DFT of ``taper * (increments -
    mean)`` (read-only): the transform whose squared modulus is the periodogram (module
    docstring)."""
    mean = float(np.dot(taper, increments) / taper.sum())
    # SciPy splits one long transform over threads with the same result to the bit (2^23
    # points: 0.11-0.15 s on one core of a 2-core machine, 0.08-0.10 s on both).
    transform = fft.rfft(taper * (increments - mean), workers=usable_cores())
    transform.flags.writeable = False
    return mean, transform


@functools.lru_cache(maxsize=16)
def tukey_energy(length: int, fraction: float) -> float:
    """sum h^2 of :func:`tukey_window` (``length``, ``fraction``): the periodogram's
    normalization, kept per length (a number; the squared taper it is summed from is 64 MB at
    2^23 points)."""
    return float(np.sum(tukey_window(length, fraction) ** 2))


def transform_power(transform: np.ndarray, energy: float) -> np.ndarray:
    """I_j at j = 0 .. M // 2 from the tapered transform of M increments
    (:func:`tapered_transform`) under a taper of sum of squares ``energy``
    (:func:`tukey_energy`): its squared modulus / sum h^2, in place in one array (the same
    operations in the same order as squaring, adding and dividing each whole)."""
    power = transform.real**2
    power += transform.imag**2
    power /= energy
    return power
