"""Warm-up transient: after power-on the bias settles exponentially."""

from typing import ClassVar

import numpy as np

from ._base import TIME_CONSTANT_PENALTY, RegressionTerm


class WarmupTransient(RegressionTerm):
    """A exp(-t / tau) from the first sample: the start of the recording departs from the
    rest, and the departure decays. tau (``time_constant_s``) is found by search; the
    amplitude A, in the channel's unit, is the column's coefficient."""

    name: ClassVar[str] = "warmup_transient"
    explanation: ClassVar[str] = (
        "After power-on the bias settles exponentially: the start of the recording departs "
        "from the rest, and the departure decays."
    )
    located_by: ClassVar[str] = "residual_time"
    band: ClassVar[str] = "low"
    rank: ClassVar[int] = 2
    max_columns: ClassVar[int] = 1
    time_constant_s: float

    @property
    def searched(self) -> int:
        return 1

    def search_penalty(self, n_frequencies: int) -> float:
        return TIME_CONSTANT_PENALTY

    def column_names(self, index):
        return ["warmup_amplitude"]

    def columns(self, data, time_s):
        return [np.exp(-time_s / self.time_constant_s)], [1.0], [data.unit]

    @classmethod
    def propose(cls, search, current):
        if current.spec.has(cls.name):
            return None
        return search.search_time(
            lambda time_constant: current.spec.with_effect(cls(time_constant)), cls.name
        )

    def describe(self, finding, posterior, search) -> dict:
        amplitude = search.summarize(
            posterior.draws["warmup_amplitude"], posterior.units["warmup_amplitude"]
        )
        time_constant = search.profile_interval(finding.search)
        return {
            "warmup_amplitude": search.widened(
                amplitude, finding.search, "warmup_amplitude", time_constant, log_scale=False
            ),
            "time_constant": time_constant,
        }

    def simulate(self, time_s: np.ndarray, amplitude: float) -> np.ndarray:
        return amplitude * np.exp(-time_s / self.time_constant_s)
