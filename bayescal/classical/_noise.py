"""The classical noise numbers of a static channel, and whether their interval holds.

- bias: the sample mean with its Student-t interval, t(1 - a/2, n - 1) s / sqrt(n);
- standard deviation of the samples;
- Allan deviation with chi-square intervals (:mod:`bayescal._allan`);
- the IEEE Std 952-1997 (Annex C) slope readings: N on the -1/2 line at tau = 1 s, K on the
  +1/2 line at tau = 3 s, B from the flat floor / sqrt(2 ln 2 / pi), Q on the -1 line at
  tau = sqrt(3) s. A line is read on the stretch of the curve whose local slope is the term's
  (and extrapolated along the line to its reading tau); the floor at a minimum where the curve
  is flat on both sides. A reading is kept only where the term's own curve, at the reading's
  lower confidence limit, stays within the measured Allan deviation's upper limits at every
  tau, to within 10 % (over the first ten sample periods, where the sensor's output filter
  lowers the curve, within a factor two): a term's Allan variance is at most the total, so a
  reading that would exceed it materially was taken off the term's slope (the edge of a
  bump, a turning point). Otherwise — and where the
  curve has no stretch of the term's slope — the reading is replaced by the upper bound the
  curve puts on the term: the tightest of the curve's upper confidence limits from ten sample
  periods on (below them an output filter lowers the curve under every term's line), each
  widened for the number of taus it was chosen from (Bonferroni);
- the validity of the t-interval. It assumes independent samples. The Allan variance at tau
  is the variance of tau-averages, so the standard error of the mean over k = T / tau
  batches is ADEV(tau) / sqrt(k) (batch means, with the Allan variance as the batch variance
  that a drift does not inflate); at the longest tau with at least eight batches it is
  ``ratio`` = ADEV(tau) sqrt(m) / s times the t-interval's s / sqrt(n). The interval is
  declared invalid when the whole confidence interval of that ratio lies above 1, and then
  widened by the ratio.
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy import special

from ..recording._inputs import samples_and_rate
from ..recording._series import finite_moments, is_spooled, series_size
from ._allan import DeviationResult, allan_deviation
from ._edf import deviation_interval

_MIN_BATCHES = 8
# A local slope within this distance of a term's slope counts as that term's stretch.
_SLOPE_TOLERANCE = 0.125
# The curve is flat at its minimum when both neighbouring local slopes lie within this of 0
# (a white-noise -1/2 meeting a +1/2 random walk has no floor between them).
_FLOOR_TOLERANCE = 0.25
# Over the first few sample periods a sensor's output filter lowers the Allan deviation below
# the white noise's line (a one-tap filter by up to a third at one period, a steeper low-pass
# more): there a reading's line may exceed the curve by up to this factor before the reading
# counts as off its slope. Off-slope readings exceed it by far more (a Q read on the edge of
# a spectral bump: tenfold).
_SAMPLING_PERIODS = 10
_SAMPLING_FACTOR = 2.0
# Elsewhere a reading whose line exceeds the curve by less than this fraction is kept: the
# term's stretch also carries a little of its neighbours (a -1/2 stretch some flicker), and a
# long record's tight intervals would otherwise demote every reading. The fit checks of a
# model use the same materiality (10 % in Allan deviation).
_MATERIAL_EXCESS = 0.10


@dataclass(frozen=True)
class SlopeReading:
    """A noise parameter read off the Allan deviation (IEEE 952 Annex C).

    N is read on the -1/2 line at tau = 1 s, K on the +1/2 line at tau = 3 s, B from the flat
    floor / 0.664, Q on the -1 line at tau = sqrt(3) s; each in the parameter's unit (N in
    unit/√Hz, B in unit, K in unit·√Hz, Q in unit·s, for a channel in unit).
    """

    value: float
    """The reading (for an upper bound: the curve's own value there)."""
    ci_low: float
    """Lower end of its interval (0 for an upper bound)."""
    ci_high: float
    """Upper end of its interval (for an upper bound: the bound)."""
    tau_s: float
    """Averaging time where it was read (for an upper bound: where the bound is tightest)."""
    local_slope: float
    """The Allan curve's slope (d log sigma / d log tau) where it was read."""
    kind: str
    """"reading" on a stretch of the term's slope, or "upper_bound" where there is none."""
    reason: str = ""
    """Why an upper bound replaced the reading (empty for a reading)."""
    where: str = ""
    """Where on the curve it was read, in words (empty for an upper bound)."""


@dataclass(frozen=True)
class TIntervalCheck:
    """Whether the Student-t interval of the mean holds: the batch-means ratio
    ADEV(tau)·sqrt(m)/s at the longest octave tau with at least 8 batches, with its
    interval; the t-interval is invalid when that whole interval lies above 1."""

    valid: bool
    widening: float
    """Factor to widen the t-interval by (1.0 when it is valid)."""
    ratio: float
    ratio_ci_low: float
    ratio_ci_high: float
    tau_s: float


@dataclass(frozen=True)
class ClassicalNoise:
    """The classical noise summary of one static channel (:func:`classical_noise`), in the
    channel's unit U.

    Attributes
    ----------
    n_samples : int
        Samples present (missing ones not counted).
    rate_hz : float
        Sample rate, Hz.
    duration_s : float
        Length of the record, s.
    bias : float
        The sample mean, U.
    bias_ci_low, bias_ci_high : float
        Its Student-t interval at ``confidence``, U (valid only when ``t_interval.valid``).
    std : float
        The sample standard deviation, U.
    confidence : float
        Confidence of the intervals.
    allan : DeviationResult
        The overlapping Allan deviation with chi-square intervals.
    t_interval : TIntervalCheck
        Whether the Student-t interval holds, and the factor to widen it by when not.
    slope_readings : dict
        Parameter (``N``, ``B``, ``K``, ``Q`` by default) -> :class:`SlopeReading` (IEEE Std
        952).
    """

    n_samples: int
    rate_hz: float
    duration_s: float
    bias: float
    bias_ci_low: float
    bias_ci_high: float
    std: float
    confidence: float
    allan: DeviationResult
    t_interval: TIntervalCheck
    slope_readings: dict

    @property
    def widened_interval(self) -> tuple[float, float]:
        """The Student-t interval of the bias widened about the mean by
        ``t_interval.widening`` (the factor the samples' correlation calls for), U: what holds
        when the t-interval does not."""
        half_width = (self.bias_ci_high - self.bias_ci_low) / 2
        widening = self.t_interval.widening
        return self.bias - widening * half_width, self.bias + widening * half_width


def student_t_interval(values, confidence: float) -> tuple[float, float, float]:
    """Mean and its two-sided Student-t interval, ignoring NaN (../shared/DESIGN.md).

    The interval assumes independent samples; :func:`classical_noise` says whether a record
    allows that (``t_interval``).

    Parameters
    ----------
    values : numpy.ndarray or SpooledSeries
        The samples; NaN marks a missing one.
    confidence : float
        Two-sided confidence, in (0, 1).

    Returns
    -------
    mean, low, high : float
        The sample mean and the interval's ends, in the samples' unit.

    Examples
    --------
    >>> import numpy as np
    >>> import bayescal as bc
    >>> mean, low, high = bc.student_t_interval(np.array([1.0, 2.0, 3.0, np.nan]), 0.95)
    >>> mean, round(high - mean, 3)
    (2.0, 2.484)
    """
    n, mean, squares = finite_moments(values)
    return _t_interval(n, mean, math.sqrt(squares / (n - 1)), confidence)


def _t_interval(n: int, mean: float, std: float, confidence: float) -> tuple[float, float, float]:
    half = float(special.stdtrit(n - 1, 0.5 + confidence / 2) * std / math.sqrt(n))
    return mean, mean - half, mean + half


def _local_slopes(allan: DeviationResult) -> np.ndarray:
    return np.diff(np.log(allan.deviation)) / np.diff(np.log(allan.tau))


def _upper_bound(allan: DeviationResult, scale: np.ndarray, reason: str) -> SlopeReading:
    """The bound the whole curve puts on a term whose Allan deviation is ``parameter *
    scale``: each term's Allan variance is at most the total, so at every tau parameter <=
    sigma(tau) / scale(tau), and the tightest over the curve's k taus, each at its upper
    limit of confidence 1 - (1 - c) / k (Bonferroni), is a bound at the curve's confidence c:
    the tightest of k limits each at c would be picked where the curve happened to run low,
    most often at a long tau of a few averages.

    Not over the first ``_SAMPLING_PERIODS`` sample periods where longer taus exist: there a
    sensor's output filter lowers the curve below every term's line, so it bounds nothing (a
    4-sample decimation filter by 8.6x at one period on the PSAS pad gyro, whose N was
    'bounded' at a tenth of its low-frequency level). Beyond them a filter's reach is a few
    percent (a 4-sample moving average: 5-8 % at 16 periods), within the readings' 10 %
    materiality."""
    beyond = allan.m >= _SAMPLING_PERIODS
    used = (beyond if beyond.any() else np.ones_like(beyond)) & np.isfinite(allan.edf)
    if not used.any():  # no degrees of freedom to widen by: the curve's own limits
        used, high = np.ones_like(beyond), allan.ci_high
    else:
        confidence = 1 - (1 - allan.confidence) / int(used.sum())
        _, high = deviation_interval(allan.deviation, np.where(used, allan.edf, 1.0), confidence)
    bound = np.where(used, high / scale, np.inf)
    tightest = int(np.argmin(bound))
    local = _local_slopes(allan)
    nearest = float(local[min(tightest, local.size - 1)]) if local.size else math.nan
    return SlopeReading(
        float(allan.deviation[tightest] / scale[tightest]),
        0.0,
        float(bound[tightest]),
        float(allan.tau[tightest]),
        nearest,
        "upper_bound",
        reason,
    )


def _within_the_curve(allan: DeviationResult, low: float, scale: np.ndarray) -> bool:
    """Whether a term no larger than its reading's lower limit stays within the measured
    curve's upper limits (a reading whose interval lies wholly above the curve somewhere was
    not taken on the term's own slope): within ``_MATERIAL_EXCESS`` of them at every tau from
    ``_SAMPLING_PERIODS`` sample periods on, and within a factor ``_SAMPLING_FACTOR`` below
    that, where the sensor's output filter legitimately lowers the curve under the white
    noise's line."""
    sampling = allan.m < _SAMPLING_PERIODS
    allowed = allan.ci_high * np.where(sampling, _SAMPLING_FACTOR, 1.0 + _MATERIAL_EXCESS)
    return bool(np.all(low * scale <= allowed))


FLICKER_FLOOR = math.sqrt(2 * math.log(2) / math.pi)
"""0.664: the floor of the Allan deviation per unit B of flicker noise, IEEE Std 952 eq. (C.9)."""


@dataclass(frozen=True)
class LineReading:
    """A term read on its line of the Allan deviation, sigma(tau) = coefficient * P *
    tau**slope (the DESIGN.md table): it crosses the value of P at tau =
    coefficient**(-1 / slope) s, where IEEE 952 reads it (Q: slope -1, coefficient sqrt(3);
    N: -1/2, 1; K: +1/2, 1/sqrt(3); R: +1, 1/sqrt(2))."""

    slope: float
    coefficient: float
    description: str
    """The line and where it is read (``-1/2 line, extrapolated to tau = 1 s``)."""

    @property
    def time_power(self) -> float:
        """The power of seconds in the parameter's unit (the channel's unit times s^power,
        :func:`~bayescal.recording._units.time_scaled_unit`): sigma(tau) = coefficient * P *
        tau**slope, in the channel's unit, puts P in it times s^-slope (Q in unit·s, N in
        unit/√Hz, K in unit·√Hz)."""
        return -self.slope

    def scale(self, tau) -> np.ndarray:
        """The term's Allan deviation per unit parameter at ``tau``."""
        return self.coefficient * np.asarray(tau, dtype=float) ** self.slope

    def bound(self, allan: DeviationResult) -> float:
        """The level of the term the measured curve allows: the least of sigma(tau) /
        :meth:`scale` over its taus (a term's Allan variance is at most the total)."""
        usable = np.isfinite(allan.deviation)
        return float(np.min(allan.deviation[usable] / self.scale(allan.tau[usable])))

    def read(self, allan: DeviationResult) -> SlopeReading:
        """The reading on the stretch of the curve whose local slope is the line's, or the
        curve's upper bound where there is none (module docstring)."""
        slope, tau = self.slope, allan.tau
        scale = self.scale(tau)
        local = _local_slopes(allan)
        if local.size:
            best = int(np.argmin(np.abs(local - slope)))
            if abs(local[best] - slope) <= _SLOPE_TOLERANCE:
                pair = slice(best, best + 2)
                # The geometric middle of the stretch, where its slope was measured.
                read = [
                    float(np.exp(np.mean(np.log(values[pair] / scale[pair]))))
                    for values in (allan.deviation, allan.ci_low, allan.ci_high)
                ]
                where = math.sqrt(tau[best] * tau[best + 1])
                if _within_the_curve(allan, read[1], scale):
                    return SlopeReading(
                        *read,
                        where,
                        float(local[best]),
                        "reading",
                        where=f"stretch of slope {local[best]:+.2f} at tau = {where:.3g} s on "
                        f"the {self.description}",
                    )
                return _upper_bound(
                    allan,
                    scale,
                    f"the stretch of slope {local[best]:+.2f} at tau = {where:.3g} s gives a "
                    "term larger than the measured curve elsewhere: not the term's own slope",
                )
            return _upper_bound(allan, scale, f"no stretch of slope {slope:+g}")
        return _upper_bound(allan, scale, "too few averaging times")


@dataclass(frozen=True)
class FloorReading:
    """A term read off the flat floor of the Allan deviation, sigma = factor * P (B: factor
    0.664, IEEE Std 952 eq. C.9)."""

    factor: float

    @property
    def time_power(self) -> float:
        """The power of seconds in the parameter's unit: 0 (sigma = factor * P puts P in the
        channel's unit, as B is)."""
        return 0.0

    def scale(self, tau) -> np.ndarray:
        """The term's Allan deviation per unit parameter at ``tau``: the factor."""
        return np.full(np.shape(tau), self.factor)

    def bound(self, allan: DeviationResult) -> float:
        """The level the measured curve allows: its least value / factor."""
        return float(np.min(allan.deviation[np.isfinite(allan.deviation)]) / self.factor)

    def read(self, allan: DeviationResult) -> SlopeReading:
        """The curve's minimum / factor where the curve is flat on both sides of it, or the
        curve's upper bound where it is not (module docstring)."""
        lowest = int(np.argmin(allan.deviation))
        local = _local_slopes(allan)
        scale = self.scale(allan.tau)
        if not 0 < lowest < allan.tau.size - 1:
            return _upper_bound(allan, scale, "the curve's minimum is at its end")
        around = local[lowest - 1 : lowest + 1]
        if np.any(np.abs(around) > _FLOOR_TOLERANCE):
            return _upper_bound(
                allan,
                scale,
                f"the curve turns at its minimum (local slopes {around[0]:+.2f}, "
                f"{around[1]:+.2f}) without flattening into a floor",
            )
        return SlopeReading(
            float(allan.deviation[lowest] / self.factor),
            float(allan.ci_low[lowest] / self.factor),
            float(allan.ci_high[lowest] / self.factor),
            float(allan.tau[lowest]),
            float(around[np.argmax(np.abs(around))]),
            "reading",
            where=f"flat floor at tau = {allan.tau[lowest]:.3g} s / {self.factor:.3g}",
        )


IEEE952_READINGS = {
    "Q": LineReading(-1.0, math.sqrt(3.0), "-1 line, extrapolated to tau = sqrt(3) s"),
    "N": LineReading(-0.5, 1.0, "-1/2 line, extrapolated to tau = 1 s"),
    "B": FloorReading(FLICKER_FLOOR),
    "K": LineReading(0.5, 1.0 / math.sqrt(3.0), "+1/2 line, extrapolated to tau = 3 s"),
}
"""IEEE Std 952-1997 Annex C's readings by parameter: Q on the -1 line at tau = sqrt(3) s, N
on the -1/2 line at tau = 1 s, B from the flat floor / 0.664, K on the +1/2 line at tau =
3 s. The noise terms of :mod:`bayescal.models.effects` name theirs among these."""


def slope_readings(allan: DeviationResult, readings=None) -> dict[str, SlopeReading]:
    """Readings of the noise parameters off an Allan deviation of one channel:
    ``readings`` maps each parameter to its reading (:class:`LineReading`,
    :class:`FloorReading`; :data:`IEEE952_READINGS` by default)."""
    readings = IEEE952_READINGS if readings is None else readings
    return {name: reading.read(allan) for name, reading in readings.items()}


def t_interval_check(allan: DeviationResult, std: float, n_samples: int) -> TIntervalCheck:
    """Batch-means check of the Student-t interval (see the module docstring)."""
    usable = np.flatnonzero(allan.m * _MIN_BATCHES <= n_samples)
    index = int(usable[-1]) if usable.size else 0
    root_m = math.sqrt(allan.m[index])
    ratio, low, high = (
        float(value[index] * root_m / std)
        for value in (allan.deviation, allan.ci_low, allan.ci_high)
    )
    valid = not low > 1.0
    return TIntervalCheck(valid, 1.0 if valid else ratio, ratio, low, high, float(allan.tau[index]))


def classical_noise(
    y, rate_hz: float | None = None, *, confidence: float = 0.95, taus="octave", readings=None
) -> ClassicalNoise:
    """Classical noise summary of one static channel: mean with its Student-t interval and
    whether that holds, the Allan deviation, and the IEEE Std 952 slope readings.

    Parameters
    ----------
    y : array_like, SpooledSeries or Channel
        The samples, in the channel's unit; NaN marks a missing one. A spooled series (a long
        channel, :func:`stream_channel`) is read in blocks.
    rate_hz : float
        Sample rate, Hz (from the channel when ``y`` is a :class:`~bayescal.Channel`).
    confidence : float
        Confidence of the intervals.
    taus : "octave", "decade", "all", int or array
        Averaging times of the Allan deviation (:func:`allan_deviation`).
    readings : dict, optional
        Parameter -> its reading off the Allan deviation (:class:`LineReading`,
        :class:`FloorReading`); IEEE Std 952's Q, N, B and K by default
        (:data:`IEEE952_READINGS`).

    Returns
    -------
    ClassicalNoise
        The numbers, in the unit of ``y``.

    Examples
    --------
    >>> import bayescal as bc
    >>> y = bc.NoiseModel(rate_hz=100.0, bias=0.4, N=0.01).simulate(2**16, seed=0)
    >>> noise = bc.classical_noise(y, 100.0)
    >>> reading = noise.slope_readings["N"]
    >>> reading.kind, round(reading.value, 3)  # deg/s/√Hz when y is in deg/s
    ('reading', 0.01)
    >>> bool(noise.t_interval.valid)
    True
    """
    y, rate = samples_and_rate(y, rate_hz)
    values = y if is_spooled(y) else np.asarray(y, dtype=float)
    n, mean, squares = finite_moments(values)
    std = math.sqrt(squares / (n - 1)) if n > 1 else math.nan
    bias, low, high = _t_interval(n, mean, std, confidence)
    allan = allan_deviation(values, rate, taus, confidence=confidence)
    return ClassicalNoise(
        n_samples=n,
        rate_hz=float(rate),
        duration_s=series_size(values) / rate,
        bias=bias,
        bias_ci_low=low,
        bias_ci_high=high,
        std=std,
        confidence=float(confidence),
        allan=allan,
        t_interval=t_interval_check(allan, std, n),
        slope_readings=slope_readings(allan, readings),
    )
