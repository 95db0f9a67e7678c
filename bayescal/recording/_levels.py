"""The values a record sits on: its distinct levels, its resolution (the converter's LSB or the
printed precision), and whether its extreme values pile up (a rail).

A clipped channel piles samples up on one value — the largest (or smallest) it can output —
where an unclipped one would have spread them over the tail beyond it. :func:`rail_check` asks
whether the record's extremes hold more samples than a normal spread puts in their resolution
bin; the saturation effect (:mod:`bayescal.models.effects.saturation`) decides whether they are
clipped, and models it. :func:`discrete_step` finds the grid of levels a quantized output sits
on.
"""

import functools

import numpy as np

from ._series import blocks, is_spooled

SIDES = ("upper", "lower")
MIN_LEVELS = 5
"""Fewer distinct values than this: the converter's step hides any rail (and the spread)."""
RAIL_SIGMAS = 6.0
"""A pile farther than this many robust standard deviations from the median clips nothing of
the noise: it is a disturbance beyond the range (the loader refuses a run of it) or repeated
glitches (``outliers``), not saturation."""
END = {"upper": -1, "lower": 0}
"""Index of each side's extreme among the sorted levels."""


def log_bin(low, width):
    """log(Phi(low + width) - Phi(low)) for standard scores, accurate in either tail and for
    bins far narrower than the spread (the width passed as such: a difference of two scores
    far from zero would lose it)."""
    from scipy import special, stats

    high = low + width
    upper_tail = low > 0
    a = np.where(upper_tail, -high, low)
    b = np.where(upper_tail, -low, high)
    log_b = special.log_ndtr(b)
    with np.errstate(divide="ignore", invalid="ignore"):
        exact = log_b + np.log1p(-np.exp(special.log_ndtr(a) - log_b))
    narrow = stats.norm.logpdf(low + 0.5 * width) + np.log(width)
    return np.where(width < 1e-3, narrow, exact)


class Levels:
    """The distinct values of a record, how many samples sit on each, its resolution (the
    least step between values: the converter's LSB or the printed precision) and the extremes
    that at least two samples share within the noise."""

    def __init__(self, values: np.ndarray):
        self._finite = values[np.isfinite(values)]
        ordered = np.sort(self._finite)
        first = np.flatnonzero(np.concatenate(([True], ordered[1:] != ordered[:-1])))
        self.levels = ordered[first]
        self.counts = np.diff(np.append(first, ordered.size))
        self.n = ordered.size
        self.rails = {}
        if self.levels.size < MIN_LEVELS:
            return
        self.step = float(np.min(np.diff(self.levels)))
        median = np.median(ordered)
        spread = 1.4826 * np.median(np.abs(ordered - median))
        for side in SIDES:
            rail, count = self.levels[END[side]], self.counts[END[side]]
            if count >= 2 and abs(rail - median) <= RAIL_SIGMAS * spread:
                self.rails[side] = (float(rail), int(count))

    @functools.cached_property
    def inverse(self) -> np.ndarray:
        """The level of each finite sample, as an index into :attr:`levels`."""
        return np.searchsorted(self.levels, self._finite)


MAX_GRID_LEVELS = 1 << 20
"""A spooled (long) record whose samples take more distinct values than this is read as on
no grid: its step would be below a thousandth of a noise spanning them, and its rounding
(step^2 / 12) nothing beside the noise."""


def _distinct_levels(values) -> tuple[np.ndarray | None, int]:
    """The distinct finite values and the number of finite samples, or levels None where
    they are too many for a grid (:func:`discrete_step`): for an array, more than a quarter
    of the samples; for a spooled series gathered block by block, beyond MAX_GRID_LEVELS."""
    if not is_spooled(values):
        finite = values if np.isfinite(values).all() else values[np.isfinite(values)]
        # The first quarter of the samples and one more, when all distinct, hold more
        # distinct values than a grid allows; so then does the whole record, whose sort (a
        # tenth of a second at 2^23 samples) an unquantized record need not pay.
        head = finite[: finite.size // 4 + 1]
        if np.unique(head).size > finite.size / 4:
            return None, finite.size
        return np.unique(finite), finite.size
    levels, n = np.empty(0), 0
    for _, block in blocks(values):
        finite = block[np.isfinite(block)]
        n += finite.size
        levels = np.union1d(levels, finite)
        if levels.size > MAX_GRID_LEVELS:
            return None, n
    return levels, n


def discrete_step(values) -> float:
    """The spacing of the levels the samples sit on, or 0 when they are not on a grid
    (``values``: an array or a spooled series)."""
    levels, n = _distinct_levels(values)
    if levels is None or levels.size > n / 4 or levels.size < 3:
        return 0.0
    steps = np.diff(levels)
    step = float(np.min(steps))
    on_grid = np.abs(steps / step - np.round(steps / step)) < 1e-3
    return step if np.mean(on_grid) > 0.99 else 0.0


def _extreme_shared(values: np.ndarray) -> bool:
    """Whether two samples or more sit on the record's largest or smallest value: a rail
    needs that, and without it the sort :class:`Levels` makes (seconds on 10^7 samples) is
    not needed."""
    finite = values if np.isfinite(values).all() else values[np.isfinite(values)]
    if finite.size == 0:
        return False
    return any(np.count_nonzero(finite == extreme) >= 2 for extreme in (finite.max(), finite.min()))


def rail_check(values: np.ndarray, rate_hz: float, unit: str) -> dict:
    """Samples stuck on an extreme value within the noise, against the normal with the
    record's mean and sd: the chance that as many others share the extreme's resolution bin,
    for either side (Bonferroni). With fine resolution, two samples on the extreme are
    already improbable; on a coarse converter step the top level holds a few anyway."""
    worst = {"name": "rail", "statistic": 1, "p_value": 1.0, "location": {}}
    if not _extreme_shared(values):
        return worst
    from scipy import stats

    record = Levels(values)
    finite = values[np.isfinite(values)]
    mean, sd = float(np.mean(finite)), float(np.std(finite))
    for side, (rail, count) in record.rails.items():
        low = (rail - 0.5 * record.step - mean) / sd
        in_bin = float(np.exp(log_bin(np.array(low), record.step / sd)))
        p_value = min(1.0, len(SIDES) * stats.binom.sf(count - 2, record.n - 1, in_bin))
        if p_value <= worst["p_value"]:
            where = np.flatnonzero(values == rail)
            worst["statistic"], worst["p_value"] = count, float(p_value)
            worst["location"] = {
                "side": side,
                "rail": rail,
                "unit": unit,
                "samples": count,
                "fraction": count / record.n,
                "first_s": float(where[0] / rate_hz),
                "last_s": float(where[-1] / rate_hz),
            }
    return worst
