"""Bias step: the bias jumps once, at one time, and stays (a mode change, a power glitch,
a restart of the sensor's internal filter)."""

import math
from typing import ClassVar

import numpy as np
from scipy import stats

from ._base import RegressionTerm

MAX_COUNT = 2
"""The most steps discovery adds to one model."""
PROFILE_DROP = 0.5 * stats.chi2.ppf(0.90, 1)
"""Fall of the step time's profile log-likelihood at the ends of its 90 % interval."""


def step_profile(residual: np.ndarray, first: int, last: int, sd: float) -> np.ndarray:
    """Log-likelihood (up to a constant) of a step at each sample between ``first`` and
    ``last`` of ``residual`` with a level of its own on each side, the noise white of
    ``sd`` at that scale (the CUSUM statistic of a change in mean: Hinkley 1970)."""
    segment = residual[first:last]
    segment = np.where(np.isfinite(segment), segment, np.nanmean(segment))
    size = segment.size
    before = np.arange(1, size)
    sums = np.cumsum(segment)[:-1]
    contrast = sums - before / size * segment.sum()
    return contrast**2 / (sd**2 * before * (size - before) / size) / 2


class BiasStep(RegressionTerm):
    """b (t >= t0): the bias jumps by b (``bias_step{k}_size``, the channel's unit) at
    t0 (``time_s``), located by the level scan (:func:`bayescal.inference._scans.level_scan`)
    to a block, then to a sample by the CUSUM profile of the residual around that block;
    the size from the block means by generalised least squares under the model's noise."""

    name: ClassVar[str] = "bias_step"
    explanation: ClassVar[str] = (
        "The bias jumped once and stayed (a mode change, a power glitch, a restart): the "
        "level of the record differs before and after one time."
    )
    located_by: ClassVar[str] = "level_scan"
    band: ClassVar[str] = "low"
    rank: ClassVar[int] = 2
    max_columns: ClassVar[int] = MAX_COUNT
    time_s: float

    @property
    def searched(self) -> int:
        return 1

    def search_penalty(self, n_frequencies: int) -> float:
        """Located among the record's samples (about twice its frequencies): log of their
        number."""
        return math.log(2 * n_frequencies)

    def column_names(self, index):
        return [f"bias_step{index}_size"]

    def columns(self, data, time_s):
        return [(time_s >= self.time_s).astype(float)], [1.0], [data.unit]

    @classmethod
    def propose(cls, search, current, anywhere: bool = False):
        """A step where the level scan of the current model locates one, at the sample the
        CUSUM profile puts it. ``anywhere``: at the step the scan's shapes see standing out
        most, its scan passing or not (a step beside a slow term that already leaves every
        check passing: it is named only on its own decisive evidence)."""
        if current.spec.count(cls.name) >= MAX_COUNT:
            return None
        if anywhere:
            located = search.strongest_step(current)
        else:
            located = search.level_event(current, "step")
        if located is None:
            return None
        time_s, record = located
        return search.fit(current.spec.with_effect(cls(time_s))), record

    def describe(self, finding, posterior, search) -> dict:
        index = finding.fit.spec.index_of(self)
        name = f"bias_step{index}_size"
        record = finding.search
        return {
            "size": search.summarize(posterior.draws[name], posterior.units[name]),
            "time": {
                "mean": self.time_s,
                "q05": record["time_interval_s"][0],
                "q95": record["time_interval_s"][1],
                "unit": "s",
                "method": "profile likelihood of the step's sample (CUSUM, white noise at "
                "the scale of the block it was located in)",
            },
        }

    def location(self, finding, checks: dict) -> dict:
        return {"check": self.located_by, "time_s": self.time_s}

    def simulate(self, time_s: np.ndarray, size: float) -> np.ndarray:
        return size * (time_s >= self.time_s)
