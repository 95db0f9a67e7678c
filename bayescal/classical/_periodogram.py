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

import contextlib
import contextvars
import functools
import math

import numpy as np
from scipy import fft

TAPER_FRACTION = 0.1
"""The share of the record the Tukey taper's two cosine ends span."""


def tukey_window(length: int, fraction: float) -> np.ndarray:
    """The symmetric Tukey (tapered cosine) window of ``length`` points whose tapers span
    ``fraction`` (0 < fraction < 1) of it, as ``scipy.signal.windows.tukey`` computes it
    (importing ``scipy.signal`` costs a run 1.7 s)."""
    if length <= 1:
        return np.ones(length)
    n = np.arange(length, dtype=float)
    width = math.floor(fraction * (length - 1) / 2.0)
    rising = n[: width + 1]
    falling = n[length - width - 1 :]
    return np.concatenate(
        (
            0.5 * (1 + np.cos(np.pi * (-1 + 2.0 * rising / fraction / (length - 1)))),
            np.ones(max(length - 2 * width - 2, 0)),
            0.5
            * (1 + np.cos(np.pi * (-2.0 / fraction + 1 + 2.0 * falling / fraction / (length - 1)))),
        )
    )


@functools.lru_cache(maxsize=64)
def fast_length_at_most(length: int) -> int:
    """The longest length <= ``length`` whose prime factors are 2, 3 and 5 (an FFT of it is
    fast; one of 2^23 - 1 points would take a minute). Kept for the lengths met: the search
    down from 2^20 - 1 takes some 10 ms, twice a fit (the lines' scan, the summaries)."""
    candidate = length
    while fft.next_fast_len(candidate, real=True) != candidate:
        candidate -= 1
    return candidate


_KEPT = contextvars.ContextVar("bayescal_kept_transform", default=None)
"""Inside :func:`one_transform_per_record`: (a list holding at most one (increments, taper,
mean, transform), the most increments kept)."""


@contextlib.contextmanager
def one_transform_per_record(most: int):
    """Within the block, the first :func:`tapered_transform` of at most ``most`` increments
    is kept, and a later one of the same increments under the same taper is that one, not
    computed again: a noise fit's line scan and its Whittle summaries both transform the whole
    record's increments where the summaries take it in one piece (``most``: the longest piece
    they take; a longer record's pieces are other transforms, and nothing is kept for them),
    the same numbers in the same order, so the same bits. Kept only within the block (a copy
    of the increments and the transform: 24 MB at 2^20 samples)."""
    token = _KEPT.set(([], most))
    try:
        yield
    finally:
        _KEPT.reset(token)


def tapered_transform(increments: np.ndarray, taper: np.ndarray) -> tuple[float, np.ndarray]:
    """The taper-weighted mean of ``increments`` and the real DFT of ``taper * (increments -
    mean)`` (read-only): the transform whose squared modulus is the periodogram (module
    docstring). Inside :func:`one_transform_per_record`, those of the first increments and
    taper are kept."""
    kept, most = _KEPT.get() or (None, 0)
    if kept:
        ((data, window, mean, transform),) = kept
        if (
            data.shape == increments.shape
            and (window is taper or np.array_equal(window, taper))
            and np.array_equal(data, increments)
        ):
            return mean, transform
    mean = float(np.dot(taper, increments) / taper.sum())
    transform = fft.rfft(taper * (increments - mean))
    transform.flags.writeable = False
    if kept == [] and increments.size <= most:
        kept.append((increments.copy(), taper, mean, transform))
    return mean, transform


def increment_periodogram(increments: np.ndarray, taper: np.ndarray) -> np.ndarray:
    """I_j at j = 0 .. M // 2 of ``increments`` (M of them) under ``taper``: |DFT of the
    tapered increments less their taper-weighted mean|^2 / sum h^2 (module docstring)."""
    _, transform = tapered_transform(increments, taper)
    return (transform.real**2 + transform.imag**2) / np.sum(taper**2)
