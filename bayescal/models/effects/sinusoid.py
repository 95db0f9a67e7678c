"""Sinusoid: a periodic disturbance at a fixed frequency (vibration, a rotor, mains)."""

import math
from typing import ClassVar

import numpy as np

from ._base import RegressionTerm

MAX_COUNT = 2
"""The most sinusoids discovery adds to one model."""
SAME_LINE_BINS = 5.0
"""A line within this many Fourier resolutions of a fitted one (or of its harmonic) is
taken for it."""
MAX_HARMONIC = 10
"""The highest multiple of a line taken for its harmonic. A periodic waveform's power lies in
its first harmonics (a sawtooth's k-th has 1/k of the fundamental's amplitude); and whole
multiples of a slow line lie so close that any frequency is near one (of a 0.0109 Hz line
over 1085 s, within the 5 resolutions taken for one line, 85 % of all frequencies are): a
5 Hz sinusoid is not the 459th harmonic of a line left at 0.0109 Hz."""


class Sinusoid(RegressionTerm):
    """a sin(2 pi f t) + b cos(2 pi f t), f (``frequency_hz``) located among the Fourier
    frequencies and refined between them; the amplitude sqrt(a^2 + b^2) is in the channel's
    unit. A line's coefficients come from the increments' periodogram, not the block
    means."""

    name: ClassVar[str] = "sinusoid"
    explanation: ClassVar[str] = (
        "A periodic disturbance (vibration, a rotor, mains pickup) adds a line to the "
        "spectrum at a fixed frequency."
    )
    located_by: ClassVar[str] = "spectral_line"
    band: ClassVar[str] = "line"
    rank: ClassVar[int] = 3
    max_columns: ClassVar[int] = 2 * MAX_COUNT
    slow: ClassVar[bool] = False
    frequency_hz: float

    @property
    def searched(self) -> int:
        return 1

    def search_penalty(self, n_frequencies: int) -> float:
        """Located among the Fourier frequencies: log of their number."""
        return math.log(n_frequencies)

    def column_names(self, index):
        return [f"sinusoid{index}_sin", f"sinusoid{index}_cos"]

    def columns(self, data, time_s):
        phase = 2 * np.pi * self.frequency_hz * time_s
        return [np.sin(phase), np.cos(phase)], [1.0, 1.0], [data.unit, data.unit]

    def derive(self, draws: dict, units: dict, index: int) -> None:
        """The amplitude A = sqrt(a^2 + b^2) and phase phi = atan2(b, a) (rad) in place of
        the sine and cosine coefficients: a sin(2 pi f t) + b cos(2 pi f t) =
        A sin(2 pi f t + phi), t from the record's first sample."""
        sine, cosine = (draws.pop(f"sinusoid{index}_{part}") for part in ("sin", "cos"))
        unit = units.pop(f"sinusoid{index}_sin")
        units.pop(f"sinusoid{index}_cos")
        draws[f"sinusoid{index}_amplitude"] = np.hypot(sine, cosine)
        units[f"sinusoid{index}_amplitude"] = unit
        draws[f"sinusoid{index}_phase"] = np.arctan2(cosine, sine)
        units[f"sinusoid{index}_phase"] = "rad"

    @classmethod
    def propose(cls, search, current):
        if current.spec.count(cls.name) >= MAX_COUNT:
            return None
        frequency = search.line_frequency(current)
        return search.fit(current.spec.with_effect(cls(frequency))), {"frequency_hz": frequency}

    def describe(self, finding, posterior, search) -> dict:
        index = finding.fit.spec.index_of(self)
        amplitude = search.summarize(
            posterior.draws[f"sinusoid{index}_amplitude"], search.data.unit
        )
        frequency = search.frequency_interval(finding.fit, index, amplitude["mean"])
        # Lines closer than this are one line in the record's periodogram.
        frequency["resolution_hz"] = 1.0 / search.data.duration_s
        phase = _circular_summary(np.ravel(posterior.draws[f"sinusoid{index}_phase"]))
        return {"frequency": frequency, "amplitude": amplitude, "phase": phase}

    def location(self, finding, checks: dict) -> dict:
        return {"check": self.located_by, "frequency_hz": self.frequency_hz}

    def apart(self, check: dict, duration_s: float) -> bool:
        """The line still found lies more than :data:`SAME_LINE_BINS` Fourier resolutions
        (1 / duration) from this one and from each of its harmonics: another source's line,
        so this sinusoid explained its own. A line left at this frequency (one that wanders
        or is broad) or at a harmonic (a periodic signal that is not a sine: a sawtooth, a
        controller's cycle) is not a sinusoid's."""
        # Either way round: a sinusoid at a harmonic of the line left (the fundamental of a
        # sawtooth left failing) is as much the waveform's as one at its fundamental.
        return (
            harmonic_family(check["location"]["frequency_hz"], self.frequency_hz, duration_s)
            is None
        )

    def simulate(self, time_s: np.ndarray, amplitude: float, phase: float) -> np.ndarray:
        return amplitude * np.sin(2 * np.pi * self.frequency_hz * time_s + phase)


def harmonic_family(first_hz: float, second_hz: float, duration_s: float) -> tuple | None:
    """(fundamental, harmonic) where the two frequencies (Hz) are one and a whole multiple of
    the other within :data:`SAME_LINE_BINS` resolutions (1 / ``duration_s``): lines of one
    periodic waveform, the lower the fundamental, ``harmonic`` the higher's multiple of it
    (1: the same line), at most :data:`MAX_HARMONIC`; None otherwise."""
    low, high = sorted((first_hz, second_hz))
    harmonic = max(round(high / low), 1)
    if harmonic <= MAX_HARMONIC and abs(high - harmonic * low) <= SAME_LINE_BINS / duration_s:
        return low, harmonic
    return None


def _circular_summary(angles: np.ndarray) -> dict:
    """Mean, sd and 90 % interval of an angle's draws (rad), taken about their circular
    mean, in whichever of (-pi, pi] and [0, 2 pi) holds the interval without a wrap; the sd
    is the circular one, sqrt(-2 log R)."""
    resultant = np.mean(np.exp(1j * angles))
    centre = float(np.angle(resultant))
    about = centre + np.angle(np.exp(1j * (angles - centre)))  # within pi of the centre
    low, high = (float(q) for q in np.quantile(about, [0.05, 0.95]))
    wraps = low <= -math.pi or high > math.pi  # (-pi, pi] cuts the interval: [0, 2 pi)
    shift = 2 * math.pi if wraps and centre < 0 else 0.0
    return {
        "mean": centre + shift,
        "sd": float(math.sqrt(max(-2 * math.log(abs(resultant)), 0.0))),
        "q05": low + shift,
        "q95": high + shift,
        "unit": "rad",
        "range": "[0, 2 pi)" if wraps else "(-pi, pi]",
        "definition": "A sin(2 pi f t + phase), t from the record's first sample",
    }
