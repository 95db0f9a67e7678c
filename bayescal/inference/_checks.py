"""Checks of a fitted model against the data it was fitted to: do the data look like a draw
from the model?

Each check gives a statistic, a p-value (Bonferroni-corrected over the places it looked) and
where it looked: the Allan deviation of the residual against the model's band (the model's
own EDF for the noise type it says dominates at each tau), the spectrum in octave bands and
its largest line, the residual block means over time and against each covariate
(temperature, accelerometers), the scans that locate a departure in time (steps, stretches,
late drifts of the level; bursts and steps of the noise level: :mod:`._scans`), tails, a
rail, discrete levels, the time stamps. A check fails
when its p-value is below ``CHECK_LEVEL``.
"""

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import fft, stats

from .._threads import usable_cores
from ..classical._allan import allan_deviation
from ..classical._edf import equivalent_degrees_of_freedom
from ..models._composite import (
    ModelFit,
    bin_ratios,
    block_covariance,
    block_means,
    model_allan_exponents,
    model_allan_variance,
)
from ..models._whittle import tukey_window
from ..models.effects.outliers import robust_scores
from ..recording._levels import discrete_step, rail_check
from ..recording._series import blocks, finite_moments
from ._scans import level_scan, variance_scan

CHECK_LEVEL = 0.01
"""A check fails when its (Bonferroni-corrected) p-value is below this."""
TIME_BLOCKS = 32
"""Blocks of the residual-over-time check."""


def _bonferroni(p_values) -> tuple[float, int]:
    p_values = np.asarray(p_values, dtype=float)
    worst = int(np.nanargmin(p_values))
    return float(min(1.0, p_values[worst] * np.count_nonzero(np.isfinite(p_values)))), worst


def allan_check(
    residual, rate_hz: float, unit: str, model_variance, exponents, allan=None, count=None
) -> dict:
    """The measured overlapping Allan deviation of ``residual`` against the model's band:
    ``model_variance(tau)`` its Allan variance, ``exponents(tau)`` the noise type it says
    dominates at each tau. The band is the model's: its EDF for that noise type, not for a type
    identified from the data (unreliable from a few long averages). ``allan``: that deviation
    at octave taus, and ``count`` the residual's present samples, when already known (a long
    record's each cost a pass over it).

    Its ``curve`` holds what a figure of it draws: the measured deviation, the model's 90 %
    band at each tau (``model_low``, ``model_high``: pointwise, so about one point in ten lies
    outside by chance) and the check's own bounds (``check_low``, ``check_high``: the band at
    the Bonferroni-corrected level CHECK_LEVEL / taus, two-sided), outside which a point fails
    the check."""
    if allan is None:
        allan = allan_deviation(residual, rate_hz, "octave")
    finite = np.isfinite(allan.deviation)
    predicted = np.full(allan.tau.shape, np.nan)
    predicted[finite] = model_variance(allan.tau[finite])
    # A model whose Allan variance is not positive at a tau (a shaped white noise's numerical
    # integral where the shape nearly cancels itself) says nothing testable there.
    usable = finite & (predicted > 0)
    if not usable.any():  # a record too short for one measured tau: nothing to test
        return {
            "name": "allan_deviation",
            "statistic": math.nan,
            "p_value": 1.0,
            "location": {"untested": "no tau with a measured Allan deviation and a model's"},
            "unit": unit,
            "curve": {
                "tau_s": [],
                "adev": [],
                "model": [],
                "model_low": [],
                "model_high": [],
                "check_low": [],
                "check_high": [],
            },
        }
    tau, deviation, predicted = allan.tau[usable], allan.deviation[usable], predicted[usable]
    n_phase = (finite_moments(residual)[0] if count is None else count) + 1
    edf = np.array(
        [
            equivalent_degrees_of_freedom(
                alpha, 2, int(m), n_phase, overlapping=True, modified=False
            )
            for alpha, m in zip(exponents(tau), allan.m[usable], strict=True)
        ]
    )
    ratio = deviation**2 / predicted
    lower = stats.chi2.cdf(edf * ratio, edf)
    p_each = 2 * np.minimum(lower, 1 - lower)
    p_value, worst = _bonferroni(p_each)
    flagged = p_each * usable.sum() < CHECK_LEVEL
    location = {"tau_s": float(tau[worst]), "adev_over_model": float(math.sqrt(ratio[worst]))}
    if flagged.any():
        location["tau_range_s"] = [float(tau[flagged].min()), float(tau[flagged].max())]
        if flagged.sum() >= 2:
            excess = np.sqrt(np.maximum(deviation[flagged] ** 2 - predicted[flagged], 1e-300))
            slope = np.polyfit(np.log(tau[flagged]), np.log(excess), 1)[0]
            location["excess_slope"] = float(slope)
    tail = CHECK_LEVEL / usable.sum() / 2  # a point whose p_each * taus < CHECK_LEVEL fails

    def bound(probability):
        return np.sqrt(predicted * stats.chi2.ppf(probability, edf) / edf).tolist()

    return {
        "name": "allan_deviation",
        "statistic": float(np.max(np.abs(np.log(ratio)))),
        "p_value": p_value,
        "location": location,
        "unit": unit,
        "curve": {
            "tau_s": tau.tolist(),
            "adev": deviation.tolist(),
            "model": np.sqrt(predicted).tolist(),
            "model_low": bound(0.05),
            "model_high": bound(0.95),
            "check_low": bound(tail),
            "check_high": bound(1 - tail),
        },
    }


def _allan_check(fit: ModelFit, rate_hz: float, unit: str) -> dict:
    return allan_check(
        fit.residual,
        rate_hz,
        unit,
        lambda tau: model_allan_variance(fit, tau),
        lambda tau: model_allan_exponents(fit, tau),
    )


def spectrum_check(summary, ratio: np.ndarray, expected: np.ndarray) -> dict:
    """The binned periodogram against the model's expected one in octave bands: ``ratio`` is
    each bin's sum of I / S, ``expected`` each bin's mean S. Each band's weighted sum of the
    ratios is Gamma-distributed under the model (the test); the band's measured power over
    the model's (the size of a departure, what the message reports) weighs the bins by their
    power, so a band holding a filter's null is not judged by the null alone."""
    weight = summary.weight
    frequency = summary.frequency_hz
    octave = np.floor(np.log2(frequency / frequency.min())).astype(int)
    p_each, bands = [], []
    for band in np.unique(octave):
        members = octave == band
        shape = float(np.sum(summary.count[members] * weight[members]))
        observed = float(np.sum(ratio[members] * weight[members]))
        lower = stats.gamma.cdf(observed, shape)
        p_each.append(2 * min(lower, 1 - lower))
        model_power = summary.count[members] * expected[members]
        power_ratio = float(np.sum(ratio[members] * expected[members]) / np.sum(model_power))
        bands.append(
            (float(frequency[members].min()), float(frequency[members].max()), power_ratio)
        )
    p_value, worst = _bonferroni(p_each)
    low, high, power_ratio = bands[worst]
    return {
        "name": "spectrum_bands",
        "statistic": float(abs(math.log(power_ratio))),
        "p_value": p_value,
        "location": {"frequency_hz": [low, high], "power_over_model": power_ratio},
        "bands": [
            {"frequency_hz": [lo, hi], "power_over_model": r, "p_value": float(p)}
            for (lo, hi, r), p in zip(bands, p_each, strict=True)
        ],
    }


def _spectrum_check(fit: ModelFit) -> dict:
    return spectrum_check(fit.design.summary, *bin_ratios(fit))


def line_search(fit: ModelFit, rate_hz: float) -> tuple[float, float, int]:
    """The largest ratio of the tapered periodogram of the residual's increments to the
    model's, its frequency (refined between Fourier frequencies) and how many were searched."""
    residual = fit.residual
    finite = np.isfinite(residual)
    increments = np.diff(np.where(finite, residual, np.nanmean(residual)))
    length = increments.size
    taper = tukey_window(length, 0.1)
    transform = fft.rfft(taper * (increments - increments.mean()), workers=usable_cores())
    power = np.abs(transform) ** 2 / np.sum(taper**2)
    _, s0 = bin_ratios(fit)
    summary = fit.design.summary
    frequency = np.arange(power.size) * rate_hz / length
    expected = np.interp(np.log(np.maximum(frequency, 1e-300)), np.log(summary.frequency_hz), s0)
    lowest = 10  # below ten cycles per record a line cannot be told from a drift
    ratio = power[lowest:-1] / expected[lowest:-1]
    peak = int(np.argmax(ratio))
    index = peak + lowest
    # Refine between Fourier frequencies: the DFT of the tapered increments on ever finer
    # grids, then the vertex of a parabola through the best three (the estimate's own scatter,
    # about 1 / (record length * sqrt(SNR)), is far below a Fourier bin).
    time = np.arange(length)
    tapered = taper * (increments - increments.mean())
    centre, half_width = float(index), 1.0
    for _ in range(3):
        fine = centre + np.linspace(-half_width, half_width, 21)
        strength = np.array(
            [abs(np.dot(tapered, np.exp(-2j * np.pi * nu / length * time))) for nu in fine]
        )
        best = int(np.clip(np.argmax(strength), 1, fine.size - 2))
        centre, half_width = float(fine[best]), half_width / 10
    low, middle, high = np.log(strength[best - 1 : best + 2])
    step = half_width  # the last grid's spacing
    curvature = low - 2 * middle + high
    if curvature < 0:
        centre += step * 0.5 * (low - high) / curvature
    return float(ratio[peak]), float(centre / length * rate_hz), ratio.size


def _line_check(fit: ModelFit, rate_hz: float) -> dict:
    ratio, frequency, searched = line_search(fit, rate_hz)
    # The largest of `searched` unit exponentials exceeds x with probability 1 - (1-e^-x)^M.
    p_value = float(-np.expm1(searched * np.log1p(-math.exp(-ratio))))
    return {
        "name": "spectral_line",
        "statistic": ratio,
        "p_value": p_value,
        "location": {"frequency_hz": frequency, "power_over_model": ratio},
    }


def _block_edges(size: int) -> tuple[np.ndarray, np.ndarray]:
    edges = np.linspace(0, size, TIME_BLOCKS + 1).round().astype(np.int64)
    return edges[:-1], edges[1:]


def _whitened_blocks(fit: ModelFit, rate_hz: float):
    """GLS residual of the block means around the bias, Cholesky-whitened."""
    start, stop = _block_edges(fit.residual.size)
    time = (start + stop) / 2 / rate_hz
    means = block_means(fit.residual, start, stop) - fit.noise["R"] * time
    factor = np.linalg.cholesky(block_covariance(fit, start, stop, rate_hz))
    white_means = np.linalg.solve(factor, means)
    white_ones = np.linalg.solve(factor, np.ones_like(means))
    bias = np.dot(white_ones, white_means) / np.dot(white_ones, white_ones)
    return white_means - bias * white_ones, white_ones, factor, start, stop


def _time_check(fit: ModelFit, rate_hz: float, unit: str) -> dict:
    whitened, _, _, start, stop = _whitened_blocks(fit, rate_hz)
    statistic = float(np.dot(whitened, whitened))
    p_value = float(stats.chi2.sf(statistic, whitened.size - 1))
    worst = int(np.argmax(np.abs(whitened)))
    means = block_means(fit.residual, start, stop)
    return {
        "name": "residual_time",
        "statistic": statistic,
        "p_value": p_value,
        "location": {
            "window_s": [float(start[worst] / rate_hz), float(stop[worst] / rate_hz)],
            "largest_departure": float(means[worst] - np.nanmean(fit.residual)),
            "unit": unit,
            "start_versus_rest": float(means[0] - np.nanmean(means[1:])),
        },
        "curve": {
            "time_s": ((start + stop) / 2 / rate_hz).tolist(),
            "residual": (means - np.nanmean(fit.residual)).tolist(),
        },
    }


def _covariate_check(fit: ModelFit, rate_hz, covariate, name, unit, covariate_unit) -> dict:
    """GLS slope of the residual block means on the covariate's block means."""
    whitened, white_ones, factor, start, stop = _whitened_blocks(fit, rate_hz)
    regressor = block_means(covariate, start, stop)
    white_regressor = np.linalg.solve(factor, regressor)
    white_regressor = white_regressor - (
        np.dot(white_ones, white_regressor) / np.dot(white_ones, white_ones) * white_ones
    )
    information = float(np.dot(white_regressor, white_regressor))
    if not information > 0:
        slope, z = 0.0, 0.0
    else:
        slope = float(np.dot(white_regressor, whitened) / information)
        z = slope * math.sqrt(information)
    means = block_means(fit.residual, start, stop)
    return {
        "name": f"residual_vs_{name}",
        "statistic": abs(z),
        "p_value": float(2 * stats.norm.sf(abs(z))),
        "location": {
            "range": [float(np.nanmin(regressor)), float(np.nanmax(regressor))],
            "range_unit": covariate_unit,
            "slope": slope,
            "slope_unit": f"{unit}/{covariate_unit}",
        },
        "curve": {"covariate": regressor.tolist(), "residual": (means - means.mean()).tolist()},
    }


def _tail_threshold(n: int) -> float:
    """|z| exceeded by 0.01 samples on average among n Gaussian ones."""
    return float(stats.norm.isf(0.005 / n))


def _tail_check(values: np.ndarray, rate_hz: float) -> dict:
    scores = robust_scores(values)
    threshold = _tail_threshold(scores.size)
    beyond = np.flatnonzero(np.abs(scores) > threshold)
    return {
        "name": "tails",
        "statistic": int(beyond.size),
        "p_value": float(stats.poisson.sf(beyond.size - 1, 0.01)) if beyond.size else 1.0,
        "location": {
            "threshold_sigma": threshold,
            "times_s": (beyond[:10] / rate_hz).tolist(),
        },
    }


def _levels_check(fit: ModelFit, rate_hz: float, unit: str) -> dict:
    """Samples on a grid the model does not know of (a model with the grid's rounding floor,
    :attr:`ModelFit.lsb`, knows it)."""
    step = discrete_step(fit.clean)
    white_sd = fit.noise["N"] * math.sqrt(rate_hz)
    material = step > 0 and step > 0.5 * white_sd and fit.lsb != step
    return {
        "name": "discrete_levels",
        "statistic": step / white_sd if white_sd > 0 else 0.0,
        "p_value": 0.0 if material else 1.0,
        "location": {"lsb": step, "unit": unit},
    }


def _timestamp_check(data) -> dict:
    issues = [note for note in data.notes if "gap" in note or "missing" in note]
    return {
        "name": "timestamps",
        "statistic": len(issues),
        "p_value": 1.0 if not issues else 0.0,
        "location": {"notes": list(issues)},
    }


def run_checks(fit: ModelFit, data) -> list[dict]:
    """Every check of the model ``fit`` against the data; each dict has name, statistic,
    p_value, location and passed."""
    rate, unit = data.rate_hz, data.unit
    checks = [
        _allan_check(fit, rate, unit),
        _spectrum_check(fit),
        _line_check(fit, rate),
        _time_check(fit, rate, unit),
        level_scan(fit, rate, unit),
        variance_scan(fit, rate, unit),
    ]
    if data.temperature is not None:
        checks.append(
            _covariate_check(
                fit, rate, data.temperature, "temperature", unit, data.temperature_unit
            )
        )
    for name, covariate in data.covariates.items():
        checks.append(
            _covariate_check(fit, rate, covariate, name, unit, data.covariate_units.get(name, ""))
        )
    checks += [
        _tail_check(fit.clean, rate),
        rail_check(fit.clean, rate, unit),
        _levels_check(fit, rate, unit),
        _timestamp_check(data),
    ]
    for check in checks:
        check["passed"] = bool(check["p_value"] >= CHECK_LEVEL)
    return checks


# --- the checks of a fitted noise model ---------------------------------------------------

ADEV_TOLERANCE = 0.10
"""A fitted noise model misfits where the measured Allan deviation departs from the model's by
more than this fraction (and significantly): smaller departures are below what matters for
the parameters a user reads (N, B, K to 10 %), and every long real record shows some."""
POWER_TOLERANCE = 0.20
"""Likewise for the power in an octave band of the spectrum (ADEV ~ sqrt(power): 10 %)."""
LAG_ONE_TOLERANCE = 0.05
"""Likewise for the lag-1 autocorrelation of the increments (white noise: -0.5)."""


def _increment_sums(values) -> dict:
    """Sums of the increments d_k = y_{k+1} - y_k between present samples (an array or a
    spooled series, read block by block): their count, sum and sum of squares, and over the
    pairs of neighbouring increments the count, the sum of both members and of products."""
    sums = dict.fromkeys(("count", "sum", "squares", "pairs", "pair_sum", "pair_products"), 0.0)
    carry = np.empty(0)
    for _, block in blocks(values):
        joined = np.concatenate((carry, block))
        increments = np.diff(joined)
        present = np.isfinite(increments)
        counted = max(carry.size - 1, 0)  # counted with the block before
        if present.all():  # slices, not masks: the same samples in the same order
            new, later, earlier = increments[counted:], increments[1:], increments[:-1]
        else:
            present_new = present.copy()
            present_new[:counted] = False
            pairs = present[1:] & present[:-1]
            new = increments[present_new]
            later, earlier = increments[1:][pairs], increments[:-1][pairs]
        sums["count"] += new.size
        sums["sum"] += float(np.sum(new))
        sums["squares"] += float(np.sum(new**2))
        sums["pairs"] += later.size
        sums["pair_sum"] += float(np.sum(later + earlier))
        sums["pair_products"] += float(np.sum(later * earlier))
        carry = joined[-2:]
    sums["pairs"] = int(sums["pairs"])
    return sums


def lag_one_check(values, autocovariance: np.ndarray) -> dict:
    """The lag-1 autocorrelation of the increments of ``values`` (runs between gaps) against
    the model's, ``autocovariance`` its increments' autocovariance at lags 0, 1, 2 ...;
    standard error by Bartlett's formula from the model's autocorrelations. ``values``: an
    array or a spooled series."""
    return _lag_one(_increment_sums(values), autocovariance)


def _lag_one(sums: dict, autocovariance: np.ndarray) -> dict:
    """:func:`lag_one_check` from the increments' sums (:func:`_increment_sums`)."""
    mean = sums["sum"] / sums["count"]
    observed = float(
        (sums["pair_products"] - mean * sums["pair_sum"] + mean**2 * sums["pairs"])
        / (sums["squares"] - sums["sum"] * mean)
    )
    rho = np.asarray(autocovariance, dtype=float) / autocovariance[0]
    predicted = float(rho[1])
    lags = np.arange(1, rho.size - 1)
    extended = np.concatenate((rho, [0.0]))
    variance = (
        np.sum((extended[lags + 1] + extended[lags - 1] - 2 * predicted * extended[lags]) ** 2)
        + (rho[1] * 2 - 2 * predicted * rho[0]) ** 2 / 2
    )
    standard_error = math.sqrt(max(variance, 1e-12) / max(sums["pairs"], 1))
    z = (observed - predicted) / standard_error
    return {
        "name": "lag_one_autocorrelation",
        "statistic": abs(z),
        "p_value": float(2 * stats.norm.sf(abs(z))),
        "location": {"increments_lag_one": observed, "model": predicted},
    }


@dataclass(frozen=True)
class FitCheck:
    """One check of a fitted noise model against its record (:func:`noise_model_checker`):
    whether the record looks like a draw from the model there.

    Attributes
    ----------
    name : str
        The check: ``allan_deviation`` (the measured overlapping Allan deviation within the
        model's band, the model's own EDF at each tau), ``spectrum_bands`` (the binned
        periodogram in octave bands) or ``lag_one_autocorrelation`` (the increments').
    statistic : float
        Its statistic at the worst place (as the check defines it).
    p_value : float
        Its p-value, Bonferroni-corrected over the places it looked.
    location : dict
        Where it looked worst: a tau and the measured over the model's Allan deviation, a
        frequency band and its power over the model's, the lag-1 autocorrelations.
    passed : bool
        Whether the model fits there: the departure is not both significant (p below
        ``CHECK_LEVEL`` = 0.01) and material (beyond 10 % in Allan deviation, 20 % in a band's
        power, 0.05 in the lag-1 autocorrelation).
    misfit : str
        Where and by how much the model misfits, in words (empty when it passed).
    curve : dict
        What a figure of the check draws (the Allan deviation's: ``tau_s``, ``adev``, the
        model's ``model``, its pointwise 90 % band ``model_low``/``model_high`` and the
        check's bounds ``check_low``/``check_high``, outside which a point fails it); empty
        for the other checks. Not part of the JSON.
    """

    name: str
    statistic: float
    p_value: float
    location: dict
    passed: bool
    misfit: str
    curve: dict = field(default_factory=dict, compare=False, repr=False)

    def as_dict(self) -> dict:
        """The check as the JSON documents hold it (``fit_checks``).

        Returns
        -------
        dict
            ``name``, ``statistic``, ``p_value``, ``location``, ``passed``, ``misfit``.
        """
        return {
            "name": self.name,
            "statistic": self.statistic,
            "p_value": self.p_value,
            "location": self.location,
            "passed": self.passed,
            "misfit": self.misfit,
        }


def noise_model_checker(summary, values, unit: str, allan=None) -> Callable[..., list[FitCheck]]:
    """model -> the checks of a stationary noise model (a :class:`~bayescal.NoiseModel`, at a
    posterior's MAP) against ``values``, its record (``summary`` their spectral summary,
    ``allan`` their Allan deviation at octave taus when already computed): the Allan deviation
    within the model's predictive band, the spectrum in octave bands, the increments' lag-1
    autocorrelation. Each says where it failed and by how much; a check fails only where the
    departure is both significant (Bonferroni p < CHECK_LEVEL) and material (beyond the
    tolerances above): a model that fits a long record to a few percent is a model that fits.

    Made for checking many models of one record (the term search): what the checks read of
    the record (its Allan deviation, sample count and increments' sums) is read once, here,
    not once per model (a pass over a long spooled record each)."""
    from ..models._whittle import expected_power

    rate_hz = summary.rate_hz
    if allan is None:
        allan = allan_deviation(values, rate_hz, "octave")
    count = finite_moments(values)[0]
    increments = _increment_sums(values)

    def check(model) -> list[FitCheck]:
        weights = model.whittle_weights(summary)
        expected = np.asarray(expected_power(summary, *weights)) / summary.count
        checks = [
            allan_check(
                values,
                rate_hz,
                unit,
                lambda tau: np.asarray(model.allan_variance(tau)),
                model.allan_exponents,
                allan,
                count,
            ),
            spectrum_check(summary, summary.power / expected, expected),
            _lag_one(increments, model.increment_autocovariance(np.arange(64))),
        ]
        found = []
        for one in checks:
            material = _material(one)
            passed = bool(one["p_value"] >= CHECK_LEVEL or not material)
            found.append(
                FitCheck(
                    name=one["name"],
                    statistic=one["statistic"],
                    p_value=one["p_value"],
                    location=one["location"],
                    passed=passed,
                    misfit="" if passed else material,
                    curve=_tolerated(one.get("curve", {})),
                )
            )
        return found

    return check


def _tolerated(curve: dict) -> dict:
    """An Allan check's curve with its bounds widened to the tolerance: a departure within
    ADEV_TOLERANCE of the model's deviation is no misfit, however significant."""
    if not curve.get("model"):
        return dict(curve)
    model = np.asarray(curve["model"])
    low = np.minimum(curve["check_low"], (1 - ADEV_TOLERANCE) * model)
    high = np.maximum(curve["check_high"], (1 + ADEV_TOLERANCE) * model)
    return {**curve, "check_low": low.tolist(), "check_high": high.tolist()}


def _material(check: dict) -> str:
    """How the check's worst place departs from the model beyond the tolerance, in words
    (empty where it does not)."""
    location = check["location"]
    match check["name"]:
        case "allan_deviation":
            if "untested" in location:
                return ""
            ratio = location["adev_over_model"]
            if abs(ratio - 1) <= ADEV_TOLERANCE:
                return ""
            low, high = location.get("tau_range_s", [location["tau_s"]] * 2)
            span = (
                f" (departing over {low:.3g}-{high:.3g} s)" if f"{low:.3g}" != f"{high:.3g}" else ""
            )
            return (
                f"the measured Allan deviation is {ratio:.2f}x the model's at tau = "
                f"{location['tau_s']:.3g} s{span}"
            )
        case "spectrum_bands":
            ratio = location["power_over_model"]
            if abs(ratio - 1) <= POWER_TOLERANCE:
                return ""
            low, high = location["frequency_hz"]
            return f"the power in the band {low:.3g}-{high:.3g} Hz is {ratio:.2f}x the model's"
        case "lag_one_autocorrelation":
            observed, predicted = location["increments_lag_one"], location["model"]
            if abs(observed - predicted) <= LAG_ONE_TOLERANCE:
                return ""
            return (
                f"the increments' lag-1 autocorrelation is {observed:+.3f}, the model's "
                f"{predicted:+.3f}"
            )
    return ""
