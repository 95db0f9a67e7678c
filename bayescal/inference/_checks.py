"""Checks of a fitted model against the data it was fitted to: do the data look like a draw
from the model?

Each check gives a statistic, a p-value (Bonferroni-corrected over the places it looked) and
where it looked: the Allan deviation of the residual against the model's band (the model's
own EDF for the noise type it says dominates at each tau), the spectrum in octave bands and
its largest line, the residual block means over time and against each covariate
(temperature, accelerometers), tails, a rail, discrete levels, the time stamps. A check fails
when its p-value is below ``CHECK_LEVEL``.
"""

import math

import numpy as np
from scipy import fft, stats
from scipy.signal import windows

from ..classical._allan import allan_deviation
from ..classical._edf import equivalent_degrees_of_freedom
from ..models._composite import (
    ModelFit,
    bin_ratios,
    block_covariance,
    block_means,
    model_allan_variance,
)
from ..models.effects.gauss_markov import GaussMarkov
from ..models.effects.outliers import robust_scores
from ..recording._levels import discrete_step, rail_check

CHECK_LEVEL = 0.01
"""A check fails when its (Bonferroni-corrected) p-value is below this."""
TIME_BLOCKS = 32
"""Blocks of the residual-over-time check."""


def _bonferroni(p_values) -> tuple[float, int]:
    p_values = np.asarray(p_values, dtype=float)
    worst = int(np.nanargmin(p_values))
    return float(min(1.0, p_values[worst] * np.count_nonzero(np.isfinite(p_values)))), worst


def _dominant_exponent(fit: ModelFit, tau, rate_hz: float) -> list[int]:
    """Power-law exponent alpha of S_y(f) of the model term with the largest Allan variance at
    each tau (a Gauss-Markov term counts as a random walk below its time constant, as white
    noise above it)."""
    noise = fit.noise
    terms = [
        (2, 3 * noise["Q"] ** 2 / tau**2),
        (0, noise["N"] ** 2 / tau),
        (-1, 2 * math.log(2) / math.pi * noise["B"] ** 2 + 0 * tau),
        (-2, noise["K"] ** 2 * tau / 3 + noise["R"] ** 2 * tau**2 / 2),
    ]
    if noise["G"] > 0:
        variance = GaussMarkov(fit.spec.gauss_markov_s).allan_variance(tau, noise["G"])
        below = tau < fit.spec.gauss_markov_s
        terms.append((-2, np.where(below, variance, 0.0)))
        terms.append((0, np.where(below, 0.0, variance)))
    exponents = np.array([alpha for alpha, _ in terms])
    values = np.stack([np.broadcast_to(value, np.shape(tau)) for _, value in terms])
    return exponents[np.argmax(values, axis=0)].tolist()


def _allan_check(fit: ModelFit, rate_hz: float, unit: str) -> dict:
    allan = allan_deviation(fit.residual, rate_hz, "octave")
    usable = np.isfinite(allan.deviation)
    tau, deviation = allan.tau[usable], allan.deviation[usable]
    predicted = model_allan_variance(fit, tau, rate_hz)
    # The band is the model's: its EDF for the noise type the model says dominates at each
    # tau, not for a type identified from the data (unreliable from a few long averages).
    n_phase = int(np.count_nonzero(np.isfinite(fit.residual))) + 1
    edf = np.array(
        [
            equivalent_degrees_of_freedom(
                alpha, 2, int(m), n_phase, overlapping=True, modified=False
            )
            for alpha, m in zip(_dominant_exponent(fit, tau, rate_hz), allan.m[usable], strict=True)
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
    return {
        "name": "allan_deviation",
        "statistic": float(np.max(np.abs(np.log(ratio)))),
        "p_value": p_value,
        "location": location,
        "unit": unit,
        "curve": {
            "tau_s": tau.tolist(),
            "adev": deviation.tolist(),
            "model_low": np.sqrt(predicted * stats.chi2.ppf(0.05, edf) / edf).tolist(),
            "model_high": np.sqrt(predicted * stats.chi2.ppf(0.95, edf) / edf).tolist(),
        },
    }


def _spectrum_check(fit: ModelFit) -> dict:
    summary = fit.design.summary
    ratio, _ = bin_ratios(fit)
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
        bands.append(
            (float(frequency[members].min()), float(frequency[members].max()), observed / shape)
        )
    p_value, worst = _bonferroni(p_each)
    low, high, power_ratio = bands[worst]
    return {
        "name": "spectrum_bands",
        "statistic": float(abs(math.log(power_ratio))),
        "p_value": p_value,
        "location": {"frequency_hz": [low, high], "power_over_model": power_ratio},
    }


def line_search(fit: ModelFit, rate_hz: float) -> tuple[float, float, int]:
    """The largest ratio of the tapered periodogram of the residual's increments to the
    model's, its frequency (refined between Fourier frequencies) and how many were searched."""
    residual = fit.residual
    finite = np.isfinite(residual)
    increments = np.diff(np.where(finite, residual, np.nanmean(residual)))
    length = increments.size
    taper = windows.tukey(length, 0.1)
    power = np.abs(fft.rfft(taper * (increments - increments.mean()))) ** 2 / np.sum(taper**2)
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
    step = discrete_step(fit.clean)
    white_sd = fit.noise["N"] * math.sqrt(rate_hz)
    material = step > 0 and step > 0.5 * white_sd
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
