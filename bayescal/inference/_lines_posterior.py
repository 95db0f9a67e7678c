"""The spectral lines of a record beside its noise posterior: each line's amplitude drawn at
every posterior draw of the noise, so that its interval carries the floor's uncertainty.

A coherent line's (sine, cosine) coefficients are a least-squares fit to the record's
increments (:func:`~bayescal.classical._lines.find_lines`): given the noise, they are normal
around the fit with the covariance its locally flat floor gives
(:meth:`~bayescal.classical._lines.LineSearch.coefficient_covariance_at`). At each posterior
draw of the noise the floor at each line is the model's spectrum there
(:meth:`~bayescal.NoiseModel.psd`); the coefficients are drawn from that normal and the
amplitude is their norm. A broadened line keeps the power and width its test measured, with
their standard errors. A line is named aliased where the fitted output filter passes less
than :data:`ALIAS_GAIN` of the power at its frequency: a line that strong there came
through the filter's decimation from above the output's Nyquist frequency (or was added
after it), not through its pass band.
"""

from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..classical._lines import LineSearch
from ..models._noise_model import NoiseModel
from ..models._terms import FILTER_SHAPE_OF_TERM, PARAMETERS_OF_TERM
from ._mcmc import summarize

ALIAS_GAIN = 0.1
"""A line where the output filter's power gain is below this is named aliased."""
INTERVAL = 0.90
"""The intervals reported for a line (as every posterior interval of bayescal)."""


@dataclass(frozen=True)
class LinePosterior:
    """One spectral line of a record, in the channel's unit U (:func:`lines_posterior`)."""

    frequency_hz: dict
    """mean (the located frequency), sd, q05, q95 and unit (Hz), and how it was found."""
    amplitude: dict
    """mean, sd, q05, q95 and unit of its peak amplitude in the samples, U (a broadened
    line's: sqrt(2 power))."""
    power: dict
    """mean, sd, q05, q95 and unit of its mean square, U^2."""
    broadened: bool
    """Whether its power spreads beyond a sinusoid's (then ``width_hz`` and ``band_hz``)."""
    width_hz: float
    """Twice the rms spread of a broadened line's power, Hz (0 for a sinusoid)."""
    band_hz: tuple[float, float]
    """The band a broadened line's power lies in, Hz."""
    ratio: float
    """The test's statistic: its periodogram over the local floor."""
    p_value: float
    """The test's p-value, corrected for every frequency and width looked at."""
    floor: float
    """The local floor of the samples' spectrum at the line, one-sided, U^2/Hz."""
    filter_gain: float
    """The fitted output filter's power gain at the line (1 without a filter)."""
    aliased: bool
    """Whether the filter says the line came from above the output's Nyquist frequency."""

    def as_dict(self, unit: str) -> dict:
        """Its JSON form, every number with its unit."""
        return {
            "frequency": self.frequency_hz,
            "amplitude": self.amplitude,
            "power": self.power,
            "kind": "broadened" if self.broadened else "sinusoid",
            "width_hz": self.width_hz,
            "band_hz": list(self.band_hz),
            "ratio_to_floor": self.ratio,
            "p_value": self.p_value,
            "floor": {"value": self.floor, "unit": f"{unit}^2/Hz", "sided": "one"},
            "filter_gain": self.filter_gain,
            "aliased": self.aliased,
        }


@dataclass(frozen=True)
class SpectralLinesFit:
    """The spectral lines of a record (:func:`lines_posterior`): each with its frequency,
    amplitude (or power and width) and intervals, and what the test looked at."""

    search: LineSearch
    """The test and the lines' estimates (:func:`~bayescal.classical._lines.find_lines`)."""
    lines: tuple[LinePosterior, ...]
    """The lines, by frequency."""
    unit: str
    """The channel's unit U."""

    @property
    def test(self) -> dict:
        """What the test looked at: frequencies, widths, level, the single-ordinate threshold,
        the record's resolution and the strongest ordinate it did not call a line."""
        search = self.search
        return {
            "method": "periodogram of the increments against the local floor, F test, "
            "Sidak-corrected over every frequency and width looked at",
            "frequencies_searched": search.searched,
            "family_wise_level": search.level,
            "threshold_ratio": search.threshold,
            "resolution_hz": search.resolution_hz,
            "strongest_not_a_line": dict(search.largest),
            "note": search.note,
        }

    def as_dict(self) -> dict:
        """Its JSON form."""
        return {
            "test": self.test,
            "lines": [line.as_dict(self.unit) for line in self.lines],
        }


def _filter_values(values: dict) -> dict:
    """The output filter's parameters among ``values`` (those of every filter shape)."""
    names = {p for term in FILTER_SHAPE_OF_TERM for p in PARAMETERS_OF_TERM[term]}
    return {name: value for name, value in values.items() if name in names}


def filter_gain(frequency_hz: np.ndarray, rate_hz: float, values: dict) -> np.ndarray:
    """The power gain of the output filter in ``values`` (a noise model's parameters) at
    each frequency: the spectrum of unit white noise through it (1 without a filter)."""
    filters = _filter_values(values)
    if not filters:
        return np.ones(np.shape(frequency_hz))
    model = NoiseModel(rate_hz, N=1.0, **filters)
    return np.asarray(model.psd(np.asarray(frequency_hz, dtype=float)))


def _floors(posterior, frequency_hz: np.ndarray, rate_hz: float) -> np.ndarray:
    """(draws, lines): the increments' two-sided spectrum at each line (cycles per sample) at
    each posterior draw of the noise."""
    draws = {name: np.ravel(posterior.draws[name]) for name in posterior.problem.parameters}
    model = NoiseModel(rate_hz, lsb=float(posterior.problem.lsb), **draws)
    density = np.asarray(model.psd(frequency_hz[:, None])).T
    nu = frequency_hz / rate_hz
    return density * rate_hz * 4 * np.sin(np.pi * nu) ** 2


def _summary(draws: np.ndarray, unit: str) -> dict:
    summary = summarize(draws, unit)
    summary.pop("unit")
    return {**summary, "unit": unit}


def _normal(mean: float, sd: float, unit: str) -> dict:
    z = float(stats.norm.ppf(0.5 + INTERVAL / 2))
    return {"mean": mean, "sd": sd, "q05": mean - z * sd, "q95": mean + z * sd, "unit": unit}


def lines_posterior(search: LineSearch, posterior, unit: str, seed: int = 0) -> SpectralLinesFit:
    """The lines of ``search`` with their intervals at the noise posterior ``posterior``
    (a :class:`~bayescal.inference._noise_posterior.NoisePosterior` of the record less the
    lines; module docstring).

    Parameters
    ----------
    search : LineSearch
        The record's lines.
    posterior : NoisePosterior
        The noise posterior of the record less them.
    unit : str
        The channel's unit.
    seed : int
        Seeds the coefficients' draws.

    Returns
    -------
    SpectralLinesFit
        Each line with its frequency, amplitude, power and intervals.
    """
    rate = search.rate_hz
    coherent = search.coherent
    map_values = {name: s.map for name, s in posterior.parameters.items() if name != "bias"}
    rng = np.random.default_rng(seed)
    amplitudes = np.zeros((0, 0))
    if coherent:
        frequency = np.array([line.frequency_hz for line in coherent])
        floors = _floors(posterior, frequency, rate)
        covariance = search.coefficient_covariance_at(floors)
        root = np.linalg.cholesky(covariance + 1e-300 * np.eye(covariance.shape[-1]))
        centre = np.ravel([(line.sine, line.cosine) for line in coherent])
        noise = rng.standard_normal((floors.shape[0], centre.size))
        coefficients = centre + np.einsum("dij,dj->di", root, noise)
        amplitudes = np.hypot(coefficients[:, 0::2], coefficients[:, 1::2])
    lines = []
    gains = filter_gain(np.array([line.frequency_hz for line in search.lines]), rate, map_values)
    for line, gain in zip(search.lines, np.atleast_1d(gains), strict=True):
        frequency = _normal(line.frequency_hz, line.frequency_sd_hz, "Hz")
        if line.broadened:
            frequency["method"] = "centre of the line's excess power, its spread over the band"
            power = _normal(line.power, line.power_sd, f"{unit}^2")
            amplitude = _normal(line.amplitude, line.amplitude_sd, unit)
        else:
            frequency["method"] = "Cramér-Rao bound at the located frequency"
            draws = amplitudes[:, coherent.index(line)]
            amplitude = _summary(draws, unit)
            power = _summary(draws**2 / 2, f"{unit}^2")
        lines.append(
            LinePosterior(
                frequency_hz=frequency,
                amplitude=amplitude,
                power=power,
                broadened=line.broadened,
                width_hz=line.width_hz,
                band_hz=line.band_hz,
                ratio=line.ratio,
                p_value=line.p_value,
                floor=line.floor,
                filter_gain=float(gain),
                aliased=bool(gain < ALIAS_GAIN),
            )
        )
    return SpectralLinesFit(search, tuple(lines), unit)
