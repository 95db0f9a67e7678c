"""Static sections of a calibration session: the stretches where the sensor is held still.

Motion shows as scatter: the running standard deviation of every channel over a short window
(0.25 s) rises when the sensor is handled. The still level of that scatter is the lowest
tenth of its values (a calibration session is still for more than a tenth of its time), and
at least half a quantization step, so that a coarsely quantized channel whose still windows
often hold one value is not declared never still; a sample is still where the scatter of
every channel stays within three times its still level and the running mean has not moved,
one window on, by more than ten standard errors of a window (still stretches reach six or
seven over a few hundred windows; a slow tilt reaches hundreds). Runs of
still samples shorter than ``min_duration_s`` are dropped, and each run is trimmed by the
window at both ends, where the handling fades in and out.
"""

from dataclasses import dataclass

import numpy as np

from .._errors import InputError
from ._inputs import samples_and_rate

WINDOW_S = 0.25
SCATTER_FACTOR = 3.0
MIN_DURATION_S = 2.0


@dataclass(frozen=True)
class StaticSection:
    """One still stretch of a session (:func:`find_static_sections`), as sample indices."""

    start: int
    """first sample"""
    stop: int
    """one past the last sample"""
    mean: np.ndarray
    """mean of each channel"""


def _running(values: np.ndarray, width: int):
    total = np.vstack([np.zeros(values.shape[1]), np.cumsum(values, axis=0)])
    squares = np.vstack([np.zeros(values.shape[1]), np.cumsum(values**2, axis=0)])
    mean = (total[width:] - total[:-width]) / width
    variance = (squares[width:] - squares[:-width]) / width - mean**2
    return mean, np.sqrt(np.maximum(variance, 0.0))


def find_static_sections(
    values, rate_hz: float | None = None, *, min_duration_s: float = MIN_DURATION_S
) -> list[StaticSection]:
    """Still stretches of a (samples, channels) array, in time order.

    A sample is still where the 0.25 s running scatter of every channel stays within three
    times its still level and the running mean has not moved (see the module's notes); runs
    shorter than ``min_duration_s`` are dropped and each run is trimmed by one window at
    both ends.

    Parameters
    ----------
    values : array_like or Channel
        The samples, (samples,) or (samples, channels), any unit (counts welcome).
    rate_hz : float
        Sample rate, Hz (from the channel when ``values`` is a :class:`~bayescal.Channel`).
    min_duration_s : float
        The shortest still stretch kept, s.

    Returns
    -------
    list of StaticSection
        The still stretches (empty when there is none), with each channel's mean.

    Examples
    --------
    >>> import numpy as np
    >>> import bayescal as bc
    >>> rng = np.random.default_rng(0)
    >>> still = rng.normal(0.0, 0.01, 500)
    >>> handled = rng.normal(0.0, 1.0, 200)
    >>> session = np.concatenate([still, handled, still + 2.0])
    >>> [(s.start, s.stop) for s in bc.find_static_sections(session, 100.0)]
    [(25, 451), (725, 1176)]
    """
    values, rate_hz = samples_and_rate(values, rate_hz, argument="values")
    values = np.asarray(values, dtype=float)
    if values.ndim == 1:
        values = values[:, None]
    finite = np.isfinite(values).all(axis=1)
    if not finite.all():
        # One NaN or infinity would enter every running sum after it: no window still.
        raise InputError(
            f"values: {np.count_nonzero(~finite)} sample(s) not finite, the first at index "
            f"{int(np.argmin(finite))}",
            fix="repair or remove them, or pass the stretch without them",
        )
    width = max(3, round(WINDOW_S * rate_hz))
    if values.shape[0] < 2 * width:
        return []
    centred = values - np.median(values, axis=0)
    mean, scatter = _running(centred, width)
    steps = np.abs(np.diff(values, axis=0))
    quantum = np.array([np.min(column[column > 0], initial=np.inf) for column in steps.T])
    floor = np.where(np.isfinite(quantum), 0.5 * quantum, 1e-12)
    still_level = np.maximum(np.quantile(scatter, 0.1, axis=0), floor)
    quiet = np.all(scatter <= SCATTER_FACTOR * still_level, axis=1)
    # A slow tilt keeps the scatter low but moves the mean: compare with the mean one window on.
    moved = np.zeros(quiet.size, dtype=bool)
    moved[:-width] = np.any(
        np.abs(mean[width:] - mean[:-width]) > 10 * still_level / np.sqrt(width), axis=1
    )
    quiet &= ~moved
    edges = np.flatnonzero(np.diff(np.concatenate(([0], quiet.astype(np.int8), [0]))))
    sections = []
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        # A window starting at i covers samples i .. i + width - 1: trim one window each side.
        first, last = start + width, stop
        if (last - first) / rate_hz >= min_duration_s:
            sections.append(StaticSection(int(first), int(last), values[first:last].mean(axis=0)))
    return sections
