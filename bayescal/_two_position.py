"""Two-position accelerometer calibration: the axis held vertical (up), then anti-vertical.

Classical (the course method, ../shared/DESIGN.md): the mean of each section with its
Student-t uncertainty; span = up - down with the RMS of the two uncertainties; scale factor
2 g_local / span with the uncertainty propagated to first order (gravity's included, at the
same confidence); offset = (up + down) / 2 with half the RMS of the two.

Bayesian: one joint model of both sections. Each reads offset + (+-g_local) / scale plus noise
from the stationary noise model, whose parameters the two sections share (one Whittle
likelihood over both). Given the noise, each section's level is Gaussian (its turn-on level,
:mod:`bayescal._level`); g_local has its prior (the data cannot tell it from the scale); when
both sections come from one file, the offset is allowed to drift between their starts by the
noise model's own random walk and flicker over that time. The offset is the one at the start
of the up section (the turn-on convention of the noise model). The posterior of scale and
offset follows draw by draw, which carries correlated noise into them — the part the classical
RMS uncertainty, built on independent samples, leaves out.
"""

import math
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np
from scipy import stats

from ._allan import allan_deviation
from ._errors import InputError
from ._gravity import LocalGravity
from ._level import bias_given_noise, level_summary
from ._noise_fit import NoiseFit, NoiseProblem, default_prior, sample_noise
from ._noise_model import _t2_log, component_weights
from ._units import STANDARD_GRAVITY, parse_unit
from ._whittle import spectral_summary

# A section whose level moves by more than this many standard errors between its halves is
# moving, not static.
MOVING_LIMIT = 8.0


@dataclass(frozen=True)
class Section:
    values: np.ndarray
    start_s: float
    """Time of the first sample, seconds from the start of its file."""
    source: str


def _mean_and_uncertainty(values: np.ndarray, confidence: float) -> tuple[float, float]:
    present = values[~np.isnan(values)]
    half = stats.t.ppf(0.5 + confidence / 2, present.size - 1) * present.std(ddof=1)
    return float(present.mean()), float(half / math.sqrt(present.size))


def check_sections(up: Section, down: Section, unit: str, channel: str) -> None:
    """Bad calibration data: a moving section, sections not opposite, a span far from 2 g."""
    for name, section in (("up", up), ("down", down)):
        present = section.values[~np.isnan(section.values)]
        if present.size < 16:
            raise InputError(
                f"the {name} section has only {present.size} samples",
                column=channel,
                source=section.source,
                fix="record at least a few seconds",
            )
        halves = np.array_split(present, 2)
        spread = math.hypot(*(h.std(ddof=1) / math.sqrt(h.size) for h in halves))
        change = abs(halves[1].mean() - halves[0].mean())
        if change > MOVING_LIMIT * spread and change > 0.01 * abs(present.mean()):
            raise InputError(
                f"the {name} section is not static: its level moves by {change:.4g} {unit} "
                f"between its halves ({change / spread:.0f} standard errors)",
                source=section.source,
                column=channel,
                fix="choose a still stretch (--sections) or hold the sensor still",
            )
    up_mean, down_mean = np.nanmean(up.values), np.nanmean(down.values)
    span = up_mean - down_mean
    if not (span > 0 and abs(up_mean + down_mean) < 0.5 * span):
        raise InputError(
            f"the sections are not opposite: up reads {up_mean:.4g} and down {down_mean:.4g} "
            f"{unit}; they should be about +g and -g around the offset",
            source=up.source,
            column=channel,
            fix="check which section is up and which down (--sections)",
        )
    parsed = parse_unit(unit)
    if parsed.quantity == "acceleration":
        expected = 2 * STANDARD_GRAVITY / parsed.to_si
        if not 0.7 < span / expected < 1.3:
            raise InputError(
                f"the span is {span:.4g} {unit} but 2 g is {expected:.4g} {unit}: the unit is "
                "probably wrong",
                source=up.source,
                column=channel,
                fix="check --unit",
            )


def classical_two_position(
    up: np.ndarray, down: np.ndarray, gravity: LocalGravity, confidence: float
) -> dict:
    """The course method; every uncertainty is a half-width at ``confidence``."""
    mean_up, u_up = _mean_and_uncertainty(up, confidence)
    mean_down, u_down = _mean_and_uncertainty(down, confidence)
    span, u_span = mean_up - mean_down, math.hypot(u_up, u_down)
    g_half_width = float(stats.norm.ppf(0.5 + confidence / 2)) * gravity.uncertainty
    scale = 2 * gravity.value / span
    u_scale = scale * math.hypot(u_span / span, g_half_width / gravity.value)
    offset, u_offset = (mean_up + mean_down) / 2, u_span / 2
    return {
        "mean_up": (mean_up, u_up),
        "mean_down": (mean_down, u_down),
        "span": (span, u_span),
        "scale": (scale, u_scale),
        "offset": (offset, u_offset),
        "g_local": (gravity.value, g_half_width),
    }


def _drift_weights(gap_s: float, rate_hz: float) -> np.ndarray:
    """Variance of the noise level's change over ``gap_s`` seconds, per unit weight of each
    spectral component: t for the random walk (K^2 t), the structure function
    (1 / pi) (second difference of t^2 log|t|)(h) for flicker, h = t fs samples."""
    h = gap_s * rate_hz
    flicker = float(_t2_log(h + 1) - 2 * _t2_log(h) + _t2_log(h - 1)) / math.pi
    return np.array([0.0, 0.0, flicker, gap_s, 0.0])


@dataclass(frozen=True)
class BayesianTwoPosition:
    draws: dict
    """scale, offset, g_local, level_up, level_down: posterior draws."""
    map_values: dict
    map_sd: dict
    noise: NoiseFit


def bayesian_two_position(
    up: Section,
    down: Section,
    rate_hz: float,
    gravity: LocalGravity,
    *,
    terms: tuple[str, ...],
    gap_s: float | None,
    seed: int,
    progress: bool = False,
) -> BayesianTwoPosition:
    """Joint posterior of scale, offset and g_local; ``gap_s`` is the time between the
    starts of the sections when it is known (one file)."""
    joined = np.concatenate([up.values, [np.nan], down.values])
    prior = default_prior(terms, allan_deviation(joined, rate_hz))
    problem = NoiseProblem(
        spectral_summary(joined, rate_hz), level_summary(up.values, rate_hz), prior
    )
    noise = sample_noise(problem, terms=terms, seed=seed, progress=progress)
    rng = np.random.default_rng(seed + 1)

    levels = {
        name: level_summary(section.values, rate_hz)
        for name, section in (("up", up), ("down", down))
    }
    drift = _drift_weights(gap_s, rate_hz) if gap_s else np.zeros(5)

    def level_draws(parameters, ramp):
        weights = np.asarray(component_weights(**parameters))
        conditional = {
            name: [
                np.asarray(v)
                for v in bias_given_noise(level, jnp.asarray(weights), jnp.asarray(ramp))
            ]
            for name, level in levels.items()
        }
        return conditional, weights @ drift

    shape = next(iter(noise.draws.values())).shape
    parameters = {
        name: noise.draws[name] for name in ("N", "B", "K", "Q", "F") if name in noise.draws
    }
    conditional, drift_variance = level_draws(parameters, noise.draws.get("R", np.zeros(shape)))
    level_up = conditional["up"][0] + np.sqrt(conditional["up"][1]) * rng.standard_normal(shape)
    level_down = conditional["down"][0] + np.sqrt(conditional["down"][1]) * rng.standard_normal(
        shape
    )
    g_local = gravity.value + gravity.uncertainty * rng.standard_normal(shape)
    drift_draw = np.sqrt(drift_variance) * rng.standard_normal(shape)
    span = level_up - level_down + drift_draw
    draws = {
        "scale": 2 * g_local / span,
        "offset": (level_up + level_down - drift_draw) / 2,
        "g_local": g_local,
        "level_up": level_up,
        "level_down": level_down,
    }

    map_parameters = {name: np.asarray(noise.parameters[name].map) for name in parameters}
    ramp_map = np.asarray(noise.parameters["R"].map if "R" in noise.parameters else 0.0)
    conditional, drift_at_map = level_draws(map_parameters, ramp_map)
    (up_mean, up_var), (down_mean, down_var) = conditional["up"], conditional["down"]
    span_map = float(up_mean - down_mean)
    span_var = float(up_var + down_var + drift_at_map)
    scale_map = 2 * gravity.value / span_map
    map_values = {
        "scale": scale_map,
        "offset": float(up_mean + down_mean) / 2,
        "g_local": gravity.value,
    }
    map_sd = {
        "scale": scale_map
        * math.hypot(math.sqrt(span_var) / span_map, gravity.uncertainty / gravity.value),
        "offset": math.sqrt(float(up_var + down_var + drift_at_map)) / 2,
        "g_local": gravity.uncertainty,
    }
    return BayesianTwoPosition(draws, map_values, map_sd, noise)
