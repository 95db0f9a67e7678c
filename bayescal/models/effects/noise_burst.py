"""Noise burst: for a while the noise is stronger (handling, a passing machine, a vibration
that starts and stops)."""

import math
from typing import ClassVar

import numpy as np
from scipy import stats

from ._base import Effect

MAX_FRACTION = 0.5
"""The longest burst, as a fraction of the record: a change of the noise level that lasts
longer is a step of the level, which the catalogue does not hold (it is reported as
unexplained)."""


class NoiseBurst(Effect):
    """Between ``start_s`` and ``stop_s`` the noise power is ``variance_ratio`` times the
    rest of the record's (broadband or in one band). Decided before the search on the
    variance scan of the baseline (:func:`bayescal.inference._scans.variance_scan`): the
    stretch's power against the rest by the likelihood ratio of a Gamma scale of its own;
    for the fits that follow, the stretch's departures from its mean are scaled down by the
    square root of the ratio (:meth:`descaled`), so that neither the stationary terms nor the
    glitch scan take it up."""

    name: ClassVar[str] = "noise_burst"
    explanation: ClassVar[str] = (
        "For a while the noise was stronger (handling, a passing machine, a vibration that "
        "started and stopped): the record's local power departs from the rest over one "
        "stretch of time."
    )
    located_by: ClassVar[str] = "variance_scan"
    band: ClassVar[str] = "noise"
    rank: ClassVar[int] = 7
    start_s: float = 0.0
    stop_s: float = 0.0
    variance_ratio: float = 1.0

    @classmethod
    def from_scan(cls, scan: dict, duration_s: float):
        """The burst a variance scan located, or None where it located a step of the noise
        level or a stretch longer than MAX_FRACTION of the record."""
        location = scan["location"]
        if location.get("shape") != "burst":
            return None
        start, stop = location["time_s"]
        if stop - start > MAX_FRACTION * duration_s:
            return None
        return cls(start, stop, location["variance_ratio"])

    @property
    def decided_before_search(self) -> bool:
        return True

    def descaled(self, values: np.ndarray, rate_hz: float) -> np.ndarray:
        """``values`` with the burst's departures from its own mean scaled by
        1 / sqrt(variance_ratio)."""
        first, last = round(self.start_s * rate_hz), round(self.stop_s * rate_hz) + 1
        out = np.array(values, dtype=float)
        stretch = out[first:last]
        mean = np.nanmean(stretch)
        out[first:last] = mean + (stretch - mean) / math.sqrt(self.variance_ratio)
        return out

    def describe(self, finding, posterior, search) -> dict:
        """Start and duration to the scan's block (the resolution it located them to), the
        ratio with its 90 % interval from the F law of two Gamma sums."""
        record = finding.search
        shape_in, shape_out, block = record["shape_in"], record["shape_out"], record["block_s"]
        low, high = (
            self.variance_ratio / stats.f.ppf(q, 2 * shape_in, 2 * shape_out) for q in (0.95, 0.05)
        )
        located = f"located to a block of {block:.3g} s by the variance scan"
        return {
            "start": {
                "mean": self.start_s,
                "q05": self.start_s - block,
                "q95": self.start_s + block,
                "unit": "s",
                "method": located,
            },
            "duration": {
                "mean": self.stop_s - self.start_s,
                "q05": max(self.stop_s - self.start_s - 2 * block, 0.0),
                "q95": self.stop_s - self.start_s + 2 * block,
                "unit": "s",
                "method": located,
            },
            "variance_ratio": {
                "mean": self.variance_ratio,
                "q05": float(low),
                "q95": float(high),
                "unit": "",
                "method": "F law of the stretch's and the rest's Gamma sums of periodogram ratios",
            },
        }

    def location(self, finding, checks: dict) -> dict:
        return {
            "check": self.located_by,
            "time_s": [self.start_s, self.stop_s],
            "band_hz": finding.search["band_hz"],
        }

    def simulate(
        self, rng: np.random.Generator, values: np.ndarray, rate_hz: float, sd: float
    ) -> np.ndarray:
        """``values`` with white noise added between start and stop so that a white noise of
        ``sd`` per sample there has ``variance_ratio`` times its variance."""
        first, last = round(self.start_s * rate_hz), round(self.stop_s * rate_hz)
        out = np.array(values, dtype=float)
        extra = sd * math.sqrt(max(self.variance_ratio - 1, 0.0))
        out[first:last] += extra * rng.standard_normal(last - first)
        return out
