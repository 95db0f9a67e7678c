"""Checks that look in time: where in the record a fitted model's residual departs from the
model's own predictive distribution, with a p-value corrected for the number of places
looked at.

- :func:`level_scan`: the residual's block means against the model's exact block-mean
  covariance (every noise term's, :func:`~bayescal.models._composite.block_covariance`),
  Cholesky-whitened (the standardised one-block-ahead prediction errors). Each shape of a
  departure is a regressor tested by generalised least squares: a step at every block
  boundary, a stretch of 1, 2, 4 ... blocks at every position, a drift that starts at every
  boundary. The largest |z| over all of them is the statistic; its p-value is calibrated by
  simulation from the fitted model (exact in the whitened coordinates: the block means'
  prediction errors are independent N(0, 1) under the model), with the Bonferroni bound
  where no simulated maximum reaches the observed one.
- :func:`variance_scan`: the residual's local spectrum. The increments are cut into short
  blocks; in each, the Hann-tapered periodogram over the model's expected one
  (:func:`~bayescal.models._composite.bin_ratios`) summed over the bins above the lowest
  few is, under the model, a Gamma variable. A burst (a stretch of 1, 2, 4 ... blocks) or a
  step of the noise level (the blocks after a boundary) is tested against the rest of the
  record by the Beta law of a Gamma share (relative to the record's own level: the global
  level is the spectrum check's); the p-value is the Bonferroni (analytic max-statistic)
  bound over every stretch and step tried. The located stretch's spectrum against the rest's
  in octave bands says where in frequency the departure sits.

Both say what the departure looks like (a step, a stretch, a late drift, levels that
switch; a burst, a step of the noise level), when, and how large, in the channel's unit.
"""

import math

import numpy as np
from scipy import fft, special, stats

from .._threads import usable_cores
from ..models._composite import ModelFit, bin_ratios, block_covariance, block_means

SCAN_BLOCKS = 128
"""Block means of the level scan (fewer on a short record: at least 8 samples each)."""
SIMULATIONS = 2000
"""Draws from the fitted model that calibrate the level scan's maximum."""
SCAN_SEED = 20251
"""The simulations' seed (fixed: a check's p-value is a function of the record and model)."""
VARIANCE_BLOCKS = 1024
"""At most this many blocks of the variance scan (each at least MIN_VARIANCE_BLOCK)."""
MIN_VARIANCE_BLOCK = 64
"""Shortest block of the variance scan, samples."""
LOWEST_BIN = 4
"""Bins of a block's periodogram below this are left out: a short block's lowest bins hold
leakage from the rest of the spectrum, and the level scan sees those frequencies."""


def _bonferroni_normal(z: float, places: int) -> float:
    return float(min(1.0, places * 2 * stats.norm.sf(abs(z))))


def _dyadic_boxes(size: int, longest: int) -> list[tuple[int, int]]:
    """(start, stop) of stretches of 1, 2, 4 ... ``longest`` units at every position."""
    boxes, length = [], 1
    while length <= longest:
        boxes += [(start, start + length) for start in range(size - length + 1)]
        length *= 2
    return boxes


def _level_regressors(blocks: int) -> tuple[np.ndarray, list[tuple[str, int, int]]]:
    """The shapes the level scan tests (rows), each with its kind and block span."""
    rows, kinds = [], []
    index = np.arange(blocks)
    for boundary in range(1, blocks):
        rows.append((index >= boundary).astype(float))
        kinds.append(("step", boundary, blocks))
    for start, stop in _dyadic_boxes(blocks, blocks // 2):
        rows.append(((index >= start) & (index < stop)).astype(float))
        kinds.append(("stretch", start, stop))
    for boundary in range(1, blocks - 2):
        rows.append(np.maximum(index - boundary + 0.5, 0.0))
        kinds.append(("drift", boundary, blocks))
    return np.array(rows), kinds


def _whitened_shapes(fit: ModelFit, rate_hz: float):
    """The level scan's data and shapes in the model's whitened coordinates, the model's free
    level terms taken out: the block means, the shapes' unit rows, their norms, rows and
    kinds, and the blocks' first and last samples."""
    residual = fit.residual
    blocks = int(min(SCAN_BLOCKS, residual.size // 8))
    edges = np.linspace(0, residual.size, blocks + 1).round().astype(np.int64)
    start, stop = edges[:-1], edges[1:]
    time = (start + stop) / 2 / rate_hz
    means = block_means(residual, start, stop) - fit.noise["R"] * time
    factor = np.linalg.cholesky(block_covariance(fit, start, stop, rate_hz))
    # The model's free level terms are taken out: the bias, and the ramp where the model has
    # one (its slope is fitted, so a departure the scan reports is one beyond it).
    fitted = [np.ones(blocks)] + ([time - time.mean()] if fit.spec.has("rate_ramp") else [])
    basis, _ = np.linalg.qr(np.linalg.solve(factor, np.array(fitted).T))

    def projected(matrix):  # whitened, with the model's free level terms taken out
        white = np.linalg.solve(factor, matrix)
        return white - basis @ (basis.T @ white)

    white_means = projected(means[:, None])[:, 0]
    rows, kinds = _level_regressors(blocks)
    white_rows = projected(rows.T).T
    norms = np.linalg.norm(white_rows, axis=1)
    usable = norms > 1e-12 * norms.max()
    white_rows, norms, rows = white_rows[usable], norms[usable], rows[usable]
    kinds = [kind for kind, keep in zip(kinds, usable, strict=True) if keep]
    return white_means, white_rows / norms[:, None], norms, rows, kinds, start, stop


def strongest_step(fit: ModelFit, rate_hz: float) -> tuple[float, float, float] | None:
    """The step of the level scan's shapes (a step at a block boundary) that stands out most
    from ``fit``'s predictive distribution of the block means, however little: its time (s),
    its z and the scan's block length (s); None where the record has no step shape."""
    white_means, unit_rows, _, _, kinds, start, stop = _whitened_shapes(fit, rate_hz)
    steps = [k for k, kind in enumerate(kinds) if kind[0] == "step"]
    if not steps:
        return None
    z = unit_rows[steps] @ white_means
    best = int(np.argmax(np.abs(z)))
    block_s = float((stop - start).mean() / rate_hz)
    return float(start[kinds[steps[best]][1]] / rate_hz), float(z[best]), block_s


def level_scan(fit: ModelFit, rate_hz: float, unit: str) -> dict:
    """The level scan (module docstring): steps, stretches and late drifts of the residual's
    block means against the fitted model's predictive distribution of them."""
    white_means, unit_rows, norms, rows, kinds, start, stop = _whitened_shapes(fit, rate_hz)
    blocks = start.size
    z = unit_rows @ white_means
    worst = int(np.argmax(np.abs(z)))
    statistic = float(abs(z[worst]))
    draws = np.random.default_rng(SCAN_SEED).standard_normal((SIMULATIONS, blocks))
    maxima = np.max(np.abs(draws @ unit_rows.T), axis=1)
    simulated = (1 + np.count_nonzero(maxima >= statistic)) / (SIMULATIONS + 1)
    p_value = min(simulated, _bonferroni_normal(statistic, z.size))
    threshold = float(np.quantile(maxima, 1 - 0.01))
    events = _level_events(white_means, unit_rows, norms, rows, kinds, threshold)
    location = _level_location(events, start, stop, rate_hz, unit) if events else {}
    location["threshold_z"] = threshold
    return {
        "name": "level_scan",
        "statistic": statistic,
        "p_value": float(p_value),
        "location": location,
        "calibration": f"maximum |z| over {z.size} shapes, {SIMULATIONS} simulations from the "
        "fitted model (Bonferroni bound below their reach)",
        "places": int(z.size),
    }


def _level_events(white_means, unit_rows, norms, rows, kinds, threshold, most: int = 6):
    """The departures beyond the scan's threshold, strongest first: each found, its size
    taken out, the scan repeated (greedy), so that levels that switch show as several."""
    events, remaining = [], white_means.copy()
    for _ in range(most):
        z = unit_rows @ remaining
        best = int(np.argmax(np.abs(z)))
        if abs(z[best]) < threshold:
            break
        size = z[best] / norms[best]  # GLS coefficient of the shape, in the channel's unit
        remaining = remaining - z[best] * unit_rows[best]
        kind, first, last = kinds[best]
        events.append(
            {"kind": kind, "first": first, "last": last, "size": float(size), "z": float(z[best])}
        )
    return events


def _level_location(events, start, stop, rate_hz: float, unit: str) -> dict:
    """Where the level scan's departures are, in seconds and the channel's unit, and what
    they look like."""
    described = []
    for event in events:
        begin = float(start[event["first"]] / rate_hz)
        entry = {"kind": event["kind"], "z": event["z"], "unit": unit}
        if event["kind"] == "stretch":
            entry["time_s"] = [begin, float(stop[event["last"] - 1] / rate_hz)]
            entry["size"] = event["size"]
        elif event["kind"] == "step":
            entry["time_s"] = begin
            entry["size"] = event["size"]
        else:  # a drift that starts late: its size is a slope per block
            width = float((stop - start).mean() / rate_hz)
            entry["time_s"] = begin
            entry["size"] = event["size"] / width
            entry["unit"] = f"{unit}/s"
        described.append(entry)
    levels = [event for event in events if event["kind"] in ("step", "stretch")]
    shape = described[0]["kind"]
    if len(levels) >= 3:
        shape = "switching levels"
    first = described[0]
    return {
        "shape": shape,
        "time_s": first["time_s"],
        "size": first["size"],
        "unit": first["unit"],
        "z": first["z"],
        "events": described,
        "block_s": float((stop - start).mean() / rate_hz),
    }


def _taper_factor(window: np.ndarray) -> float:
    """Variance of a sum of neighbouring tapered periodogram ordinates over that of as many
    independent ones: the sum over lags of the squared correlation of the tapered Fourier
    coefficients, L sum w^4 / (sum w^2)^2 by Parseval (35/18 for a Hann taper)."""
    return float(window.size * np.sum(window**4) / np.sum(window**2) ** 2)


def _block_power(fit: ModelFit, rate_hz: float, length: int):
    """(blocks, bins) Hann-tapered periodogram of the residual's increments in blocks of
    ``length`` over the model's expected one, the bins' frequencies (Hz) and the Gamma
    shape of one bin's ratio."""
    residual = fit.residual
    finite = np.isfinite(residual)
    filled = np.where(
        finite,
        residual,
        np.interp(np.arange(residual.size), np.flatnonzero(finite), residual[finite]),
    )
    increments = np.diff(filled)
    blocks = increments.size // length
    window = np.hanning(length + 2)[1:-1]
    segments = increments[: blocks * length].reshape(blocks, length)
    segments = segments - segments.mean(axis=1, keepdims=True)
    transform = fft.rfft(window * segments, axis=1, workers=usable_cores())
    power = np.abs(transform) ** 2 / np.sum(window**2)
    frequency = np.arange(power.shape[1]) * rate_hz / length
    _, expected = bin_ratios(fit)
    summary = fit.design.summary
    keep = slice(LOWEST_BIN, power.shape[1] - 1)
    model = np.interp(np.log(frequency[keep]), np.log(summary.frequency_hz), expected)
    return power[:, keep] / model, frequency[keep], 1.0 / _taper_factor(window)


def variance_scan(fit: ModelFit, rate_hz: float, unit: str) -> dict:
    """The variance scan (module docstring): bursts and steps of the residual's local
    power against the rest of the record."""
    residual = fit.residual
    length = max(
        MIN_VARIANCE_BLOCK, 2 ** math.ceil(math.log2(max(residual.size / VARIANCE_BLOCKS, 1)))
    )
    ratios, frequency, shape = _block_power(fit, rate_hz, length)
    blocks = ratios.shape[0]
    if blocks < 4:
        return {
            "name": "variance_scan",
            "statistic": 0.0,
            "p_value": 1.0,
            "location": {"untested": "a record of fewer than four blocks"},
        }
    per_block = ratios.sum(axis=1)
    a_block = shape * ratios.shape[1]
    total = per_block.sum()
    cumulative = np.concatenate(([0.0], np.cumsum(per_block)))
    spans = [(first, blocks, "step") for first in range(1, blocks)]
    spans += [(a, b, "burst") for a, b in _dyadic_boxes(blocks, blocks // 2)]
    first = np.array([s[0] for s in spans])
    last = np.array([s[1] for s in spans])
    inside = cumulative[last] - cumulative[first]
    count = last - first
    a_in, a_out = a_block * count, a_block * (blocks - count)
    # Ranked by the likelihood ratio of a separate Gamma scale inside (the Beta tail below
    # underflows for a gross burst, and then cannot rank two of them).
    z = _signed_root(inside, total, a_in, a_out)
    worst = int(np.argmax(np.abs(z)))
    a, b, kind = spans[worst]
    # The p-value is the tried stretch's (the refinement below is a further choice).
    count = b - a
    share = (cumulative[b] - cumulative[a]) / total
    lower = special.betainc(a_block * count, a_block * (blocks - count), share)
    upper = special.betainc(a_block * (blocks - count), a_block * count, 1 - share)
    p_value = float(min(1.0, max(2 * min(lower, upper), 1e-300) * len(spans)))
    if kind == "burst":
        a, b = _refined(cumulative, a, b, a_block)
    count = b - a
    inside = cumulative[b] - cumulative[a]
    outside = (total - inside) / (blocks - count)
    ratio = float(inside / count / outside)
    time_s = [float(a * length / rate_hz), float(b * length / rate_hz)]
    band, broadband = _excess_band(ratios, frequency, a, b, ratio)
    location = {
        "shape": "burst" if kind == "burst" else "noise level step",
        "time_s": time_s if kind == "burst" else time_s[0],
        "variance_ratio": ratio,
        "band_hz": band,
        "broadband": broadband,
        "block_s": float(length / rate_hz),
    }
    return {
        "name": "variance_scan",
        "places": len(spans),
        "log_likelihood_ratio": float(
            _signed_root(inside, total, a_block * count, a_block * (blocks - count)) ** 2 / 2
        ),
        "shapes": [float(a_block * count), float(a_block * (blocks - count))],
        "statistic": float(abs(z[worst])),
        "p_value": p_value,
        "location": location,
        "calibration": f"Bonferroni bound over {len(spans)} stretches and steps of "
        f"{blocks} blocks of {length} samples",
    }


def _refined(cumulative, first: int, last: int, a_block: float) -> tuple[int, int]:
    """The ends of a located burst moved, each within the dyadic stretch's own length, to
    where the burst's share departs most from the rest (a burst seldom starts on a dyadic
    boundary)."""
    blocks, length = cumulative.size - 1, last - first
    starts = np.arange(max(first - length, 0), min(first + length, blocks - 1) + 1)
    stops = np.arange(max(last - length, 1), min(last + length, blocks) + 1)
    a, b = np.meshgrid(starts, stops, indexing="ij")
    valid = (b > a) & (b - a < blocks)
    a, b = a[valid], b[valid]
    inside = cumulative[b] - cumulative[a]
    a_in, a_out = a_block * (b - a), a_block * (blocks - (b - a))
    best = int(np.argmax(np.abs(_signed_root(inside, cumulative[-1], a_in, a_out))))
    return int(a[best]), int(b[best])


def _signed_root(inside, total, a_in, a_out):
    """Signed root of twice the log likelihood ratio of Gamma sums (shapes ``a_in``,
    ``a_out``) with a scale of their own inside a stretch against one scale for the record:
    about N(0, 1) for one stretch under the model, its sign that of the departure."""
    outside = total - inside
    a_all = a_in + a_out
    log_ratio = (
        a_all * np.log(total / a_all)
        - a_in * np.log(inside / a_in)
        - a_out * np.log(outside / a_out)
    )
    return np.sign(inside / a_in - outside / a_out) * np.sqrt(2 * np.maximum(log_ratio, 0.0))


def _excess_band(ratios, frequency, first: int, last: int, ratio: float):
    """The octave band where the located stretch departs most from the rest of the record
    (in the direction of ``ratio``), Hz, and whether the departure is broadband (every
    octave departs by at least half as much, in the log, as the most)."""
    octave = np.floor(np.log2(frequency / frequency[0])).astype(int)
    inside = ratios[first:last].mean(axis=0)
    rest = np.concatenate((ratios[:first], ratios[last:])).mean(axis=0)
    bands, departures = [], []
    for value in np.unique(octave):
        members = octave == value
        departure = math.log(inside[members].mean() / rest[members].mean())
        departures.append(departure if ratio >= 1 else -departure)
        bands.append([float(frequency[members].min()), float(frequency[members].max())])
    departures = np.array(departures)
    if bool(departures.min() > 0.5 * departures.max()):  # every octave departs alike
        return [float(frequency[0]), float(frequency[-1])], True
    return bands[int(np.argmax(departures))], False
