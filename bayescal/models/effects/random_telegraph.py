"""Random telegraph noise: the bias switches between two levels at random times (the
"popcorn" noise of a semiconductor part with one trap that fills and empties; Kirton & Uren
1989), the dwell in each level exponential with its own switching rate."""

import math
from typing import ClassVar

import numpy as np
from scipy import stats

from ._base import RegressionTerm


def telegraph_switches(
    rng: np.random.Generator, duration_s: float, rates_hz: tuple[float, float]
) -> tuple[float, ...]:
    """The switch times (s) of a two-level telegraph over ``duration_s`` seconds, started in
    the low level: dwell times exponential with rate ``rates_hz[0]`` (low to high, 1/s) in the
    low level and ``rates_hz[1]`` (high to low, 1/s) in the high one."""
    switches, now, state = [], 0.0, 0
    while True:
        now += rng.exponential(1.0 / rates_hz[state])
        if now >= duration_s:
            return tuple(switches)
        switches.append(now)
        state = 1 - state


class RandomTelegraph(RegressionTerm):
    """b s(t): the bias is b (``random_telegraph{k}_size``, the channel's unit) higher while
    the telegraph state s(t) is 1, which flips at each of ``switches_s`` (s) from 0 at the
    start. Located by the level scan's *switching levels* (three or more level departures:
    :func:`bayescal.inference._scans.level_scan`); each switch refined to a sample by the
    CUSUM profile of the residual around its block; b from the block means by generalised
    least squares under the model's noise. The switching rates (1/s) are the switches out of
    each level over the time spent in it, with their exact Poisson (chi-square) 90 %
    intervals."""

    name: ClassVar[str] = "random_telegraph"
    explanation: ClassVar[str] = (
        "The bias switches between two levels at random times (popcorn noise of a part, a "
        "mode that toggles): the record's level flips back and forth."
    )
    located_by: ClassVar[str] = "level_scan"
    band: ClassVar[str] = "low"
    rank: ClassVar[int] = 2
    max_columns: ClassVar[int] = 1
    switches_s: tuple[float, ...]

    @property
    def searched(self) -> int:
        return len(self.switches_s)

    def search_penalty(self, n_frequencies: int) -> float:
        """Each switch located among the record's samples (about twice its frequencies): the
        log of their number, per switch."""
        return len(self.switches_s) * math.log(2 * n_frequencies)

    def state(self, time_s: np.ndarray) -> np.ndarray:
        """The telegraph state s(t) (0 or 1) at ``time_s`` (s)."""
        flips = np.searchsorted(np.asarray(self.switches_s), time_s, side="right")
        return (flips % 2).astype(float)

    def column_names(self, index):
        return [f"random_telegraph{index}_size"]

    def columns(self, data, time_s):
        return [self.state(time_s)], [1.0], [data.unit]

    @classmethod
    def propose(cls, search, current):
        """Switches where the level scan of the current model locates levels that switch."""
        if current.spec.has(cls.name):
            return None
        located = search.level_event(current, "switches")
        if located is None:
            return None
        switches, record = located
        return search.fit(current.spec.with_effect(cls(switches))), record

    def rates(self, duration_s: float) -> dict:
        """The switching rates out of each level (1/s), each with its 90 % interval."""
        edges = np.array([0.0, *self.switches_s, duration_s])
        dwell = np.diff(edges)
        rates = {}
        for state, name in ((0, "rate_up"), (1, "rate_down")):
            time_in = float(dwell[state::2].sum())
            count = int(np.count_nonzero(np.arange(len(self.switches_s)) % 2 == state))
            low = stats.chi2.ppf(0.05, 2 * count) / (2 * time_in) if count else 0.0
            high = stats.chi2.ppf(0.95, 2 * count + 2) / (2 * time_in)
            rates[name] = {
                "mean": count / time_in,
                "q05": float(low),
                "q95": float(high),
                "unit": "1/s",
                "method": f"{count} switches in {time_in:.4g} s (exact Poisson interval)",
            }
        return rates

    def describe(self, finding, posterior, search) -> dict:
        index = finding.fit.spec.index_of(self)
        name = f"random_telegraph{index}_size"
        return {
            "size": search.summarize(posterior.draws[name], posterior.units[name]),
            **self.rates(search.data.duration_s),
            "switches": {"value": list(self.switches_s), "unit": "s"},
        }

    def location(self, finding, checks: dict) -> dict:
        return {"check": self.located_by, "time_s": list(self.switches_s)}

    def simulate(self, time_s: np.ndarray, size: float) -> np.ndarray:
        return size * self.state(time_s)
