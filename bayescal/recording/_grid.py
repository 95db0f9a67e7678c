"""Placing time stamps on the sample grid (compiled: it visits every stamp once)."""

import numba
import numpy as np


@numba.njit(cache=True)
def track_grid(time, period, gain):  # pragma: no cover - compiled
    """Grid index of each time stamp: one period after the last, plus any whole periods the
    stamp runs ahead (dropped samples); the slowly varying lag of the stamps behind the
    grid is tracked with ``gain``, so jitter, bursts and clock wander do not become drops."""
    index = np.empty(time.size, np.int64)
    residual = np.zeros(time.size)
    index[0] = 0
    lag = 0.0
    for k in range(1, time.size):
        expected = index[k - 1] + 1
        error = time[k] / period - expected - lag
        skipped = max(0, int(np.floor(error + 0.5)))
        index[k] = expected + skipped
        residual[k] = error - skipped
        lag += gain * residual[k]
    return index, residual
