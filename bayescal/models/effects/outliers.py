"""Outliers: isolated glitches far outside the noise."""

import math
from typing import ClassVar

import numpy as np
from scipy import stats

from ...recording._levels import discrete_step
from ._base import Effect


def _grid_quantiles(x: np.ndarray, q, width: float) -> np.ndarray:
    """The ``q`` quantiles of values on a grid of ``width``, each value taken as spread evenly
    over its cell (the grouped-data quantile): a plain quantile can only be a grid point."""
    levels, counts = np.unique(np.round(x / width), return_counts=True)
    below = np.concatenate([[0], np.cumsum(counts)])
    target = np.asarray(q) * x.size
    cell = np.minimum(np.searchsorted(below[1:], target), levels.size - 1)
    return (levels[cell] - 0.5 + (target - below[cell]) / counts[cell]) * width


def robust_scores(values: np.ndarray) -> np.ndarray:
    """Each sample's departure from the mean of its two neighbours, in units of the robust
    spread of that departure (at least the grid's step, for samples on a grid): Gaussian for
    any noise that is smooth or white at the sample scale, and a glitch of one sample stands
    out at its own index."""
    filled = np.where(np.isfinite(values), values, np.nanmedian(values))
    detail = np.zeros_like(filled)
    detail[1:-1] = filled[1:-1] - 0.5 * (filled[:-2] + filled[2:])
    detail[0], detail[-1] = filled[0] - filled[1], filled[-1] - filled[-2]
    step = discrete_step(values)
    if step > 0:
        # On a grid the details sit on half-steps, and a median absolute deviation can only
        # be one of them: 14 % under the spread at an LSB of half the noise sd, which made
        # 94 samples of a clean rounded record "glitches". The grouped interquartile range
        # interpolates within the cells instead (within 1 % there, 0.6 % at worst).
        lower, upper = _grid_quantiles(detail, (0.25, 0.75), 0.5 * step)
        spread = float(upper - lower) / 1.349
    else:
        spread = 1.4826 * np.median(np.abs(detail - np.median(detail)))
    # A detail of one LSB is never a glitch (on a coarse grid most details are 0 or one step).
    spread = max(spread, step)
    return detail / spread if spread > 0 else np.zeros_like(detail)


def outlier_scan(values: np.ndarray) -> dict:
    """Contaminated-normal against normal on the robust scores: the log Bayes factor (Schwarz,
    two parameters), the ELPD gain with its standard error (per sample: the scores are nearly
    independent), the fraction and scale of the glitches and which samples they are."""
    scores = robust_scores(values)
    n = scores.size
    normal = stats.norm.logpdf(scores)
    best = None
    for fraction in np.geomspace(1.0 / n, 0.05, 12):
        for scale in (5.0, 10.0, 20.0, 50.0, 100.0):
            mixture = np.logaddexp(
                np.log1p(-fraction) + normal,
                math.log(fraction) + stats.norm.logpdf(scores, scale=scale),
            )
            total = float(mixture.sum())
            if best is None or total > best[0]:
                best = (total, fraction, scale, mixture)
    total, fraction, scale, mixture = best
    difference = mixture - normal
    outlier_probability = np.exp(
        math.log(fraction) + stats.norm.logpdf(scores, scale=scale) - mixture
    )
    # A glitch also shifts its neighbours' scores by half its own: flag only the peak.
    magnitude = np.abs(scores)
    peak = magnitude >= np.maximum(np.roll(magnitude, 1), np.roll(magnitude, -1))
    flagged = (outlier_probability > 0.5) & peak
    return {
        "log_bayes_factor": float(difference.sum() - math.log(n)),
        "delta_elpd": float(difference.sum() - 2.0),
        "delta_elpd_se": float(math.sqrt(n) * np.std(difference)),
        "fraction": fraction,
        "scale": scale,
        "flagged": flagged,
    }


def without_outliers(values: np.ndarray, flagged: np.ndarray) -> np.ndarray:
    """The flagged samples replaced by the mean of their nearest unflagged neighbours."""
    index = np.arange(values.size)
    keep = ~flagged & np.isfinite(values)
    return np.where(flagged, np.interp(index, index[keep], values[keep]), values)


class Outliers(Effect):
    """Impulsive glitches, heavy tails: decided before the search, on the robust scores
    (:func:`outlier_scan`, a contaminated normal against the normal); the flagged samples
    are replaced by their neighbours' mean (:func:`without_outliers`) for every fit that
    follows."""

    name: ClassVar[str] = "outliers"
    explanation: ClassVar[str] = (
        "Isolated glitches far outside the noise: the residual has heavier tails than a Gaussian."
    )
    located_by: ClassVar[str] = "tails"
    band: ClassVar[str] = "samples"
    rank: ClassVar[int] = 6

    def simulate(
        self, rng: np.random.Generator, values: np.ndarray, count: int, size: float
    ) -> np.ndarray:
        """``values`` with ``count`` glitches of ``size`` (either sign) at random samples."""
        glitched = np.array(values, dtype=float)
        where = rng.choice(glitched.size, size=count, replace=False)
        glitched[where] += size * rng.choice([-1.0, 1.0], size=count)
        return glitched
