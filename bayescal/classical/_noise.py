"""The classical noise numbers of a static channel, and whether their interval holds.

- bias: the sample mean with its Student-t interval, t(1 - a/2, n - 1) s / sqrt(n);
- standard deviation of the samples;
- Allan deviation with chi-square intervals (:mod:`bayescal._allan`);
- the IEEE Std 952-1997 (Annex C) slope readings: N on the -1/2 line at tau = 1 s, K on the
  +1/2 line at tau = 3 s, B from the flat floor / sqrt(2 ln 2 / pi), Q on the -1 line at
  tau = sqrt(3) s. Where the curve has no stretch of the term's slope, the reading is
  replaced by the upper bound the curve puts on the term (each term's Allan variance is at
  most the total), read from the upper confidence limits;
- the validity of the t-interval. It assumes independent samples. The Allan variance at tau
  is the variance of tau-averages, so the standard error of the mean over k = T / tau
  batches is ADEV(tau) / sqrt(k) (batch means, with the Allan variance as the batch variance
  that a drift does not inflate); at the longest tau with at least eight batches it is
  ``ratio`` = ADEV(tau) sqrt(m) / s times the t-interval's s / sqrt(n). The interval is
  declared invalid when the whole confidence interval of that ratio lies above 1, and then
  widened by the ratio.
"""

import math

import equinox as eqx
import numpy as np
from scipy import stats

from ..recording._units import BIAS_INSTABILITY_FACTOR
from ._allan import DeviationResult, allan_deviation

_MIN_BATCHES = 8
# A local slope within this distance of a term's slope counts as that term's stretch.
_SLOPE_TOLERANCE = 0.125

# parameter -> (slope, c) of its Allan-deviation line sigma(tau) = c * parameter * tau**slope
# (DESIGN.md table): Q sqrt(3)/tau, N/sqrt(tau), K sqrt(tau/3). The line crosses the value of
# the parameter at tau = sqrt(3), 1 and 3 s, where IEEE 952 reads it.
_SLOPE_LINES = {"Q": (-1.0, math.sqrt(3.0)), "N": (-0.5, 1.0), "K": (0.5, 1.0 / math.sqrt(3.0))}


class SlopeReading(eqx.Module):
    """A noise parameter read off the Allan deviation (IEEE 952 Annex C)."""

    value: float
    ci_low: float
    ci_high: float
    tau_s: float
    """Averaging time where it was read (for an upper bound: where the bound is tightest)."""
    local_slope: float
    kind: str = eqx.field(static=True)
    """"reading" on a stretch of the term's slope, or "upper_bound" where there is none."""


class TIntervalCheck(eqx.Module):
    valid: bool
    widening: float
    """Factor to widen the t-interval by (1.0 when it is valid)."""
    ratio: float
    ratio_ci_low: float
    ratio_ci_high: float
    tau_s: float


class ClassicalNoise(eqx.Module):
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


def student_t_interval(values: np.ndarray, confidence: float) -> tuple[float, float, float]:
    """Mean and its two-sided Student-t interval, ignoring NaN (../shared/DESIGN.md)."""
    present = values[~np.isnan(values)]
    n = present.size
    mean = float(present.mean())
    half = float(stats.t.ppf(0.5 + confidence / 2, n - 1) * present.std(ddof=1) / math.sqrt(n))
    return mean, mean - half, mean + half


def _local_slopes(allan: DeviationResult) -> np.ndarray:
    return np.diff(np.log(allan.deviation)) / np.diff(np.log(allan.tau))


def _line_reading(allan: DeviationResult, parameter: str) -> SlopeReading:
    slope, coefficient = _SLOPE_LINES[parameter]
    tau = allan.tau
    scale = coefficient * tau**slope
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
            return SlopeReading(
                *read, math.sqrt(tau[best] * tau[best + 1]), float(local[best]), "reading"
            )
    # Each term's Allan variance is at most the total, so at every tau
    # parameter <= sigma(tau) / (c tau**slope); the upper confidence limit makes it a bound.
    bound = allan.ci_high / scale
    tightest = int(np.argmin(bound))
    nearest = float(local[min(tightest, local.size - 1)]) if local.size else math.nan
    return SlopeReading(
        float(allan.deviation[tightest] / scale[tightest]),
        0.0,
        float(bound[tightest]),
        float(tau[tightest]),
        nearest,
        "upper_bound",
    )


def _floor_reading(allan: DeviationResult) -> SlopeReading:
    lowest = int(np.argmin(allan.deviation))
    local = _local_slopes(allan)
    interior = 0 < lowest < allan.tau.size - 1
    nearest = float(local[min(lowest, local.size - 1)]) if local.size else math.nan
    return SlopeReading(
        float(allan.deviation[lowest] / BIAS_INSTABILITY_FACTOR),
        float(allan.ci_low[lowest] / BIAS_INSTABILITY_FACTOR) if interior else 0.0,
        float(allan.ci_high[lowest] / BIAS_INSTABILITY_FACTOR),
        float(allan.tau[lowest]),
        nearest,
        "reading" if interior else "upper_bound",
    )


def slope_readings(allan: DeviationResult) -> dict[str, SlopeReading]:
    """IEEE 952 readings of Q, N, B and K from an Allan deviation of one channel."""
    return {
        "Q": _line_reading(allan, "Q"),
        "N": _line_reading(allan, "N"),
        "B": _floor_reading(allan),
        "K": _line_reading(allan, "K"),
    }


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


def classical_noise(y, rate: float, *, confidence: float = 0.95, taus="octave") -> ClassicalNoise:
    """Classical noise summary of one static channel ``y`` (NaN marks missing samples)."""
    values = np.asarray(y, dtype=float)
    n = int(np.count_nonzero(~np.isnan(values)))
    bias, low, high = student_t_interval(values, confidence)
    std = float(np.nanstd(values, ddof=1))
    allan = allan_deviation(values, rate, taus, confidence=confidence)
    return ClassicalNoise(
        n_samples=n,
        rate_hz=float(rate),
        duration_s=values.size / rate,
        bias=bias,
        bias_ci_low=low,
        bias_ci_high=high,
        std=std,
        confidence=float(confidence),
        allan=allan,
        t_interval=t_interval_check(allan, std, n),
        slope_readings=slope_readings(allan),
    )
