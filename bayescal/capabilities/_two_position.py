"""Two-position accelerometer calibration: the classical course method beside the Bayesian
model's posterior (:mod:`bayescal.models._two_position`), which carries correlated noise into
scale and offset — the part the classical RMS uncertainty, built on independent samples,
leaves out."""

import math
from dataclasses import dataclass
from functools import partial

import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._caches import release_compiled_code
from .._errors import InputError
from ..classical._allan import allan_deviation
from ..classical._gravity import LocalGravity
from ..classical._two_position import Section, check_sections, classical_two_position
from ..inference._checks import FitCheck
from ..inference._mcmc import summarize
from ..inference._noise_posterior import NoisePosterior
from ..inference._priors import default_prior
from ..inference._sampler import Sampler, sampler_of
from ..inference._selection import TermSelection
from ..models._level import bias_given_noise, level_summary
from ..models._terms import DEFAULT_TERMS, check_terms, parse_terms
from ..models._two_position import offset_drift_variance
from ..recording._inputs import channel_input, positive_rate
from ..recording._recording import Channel
from ._checked import Checked
from ._noise import noise_posterior


@dataclass(frozen=True)
class BayesianTwoPosition:
    draws: dict
    """scale, offset, g_local, level_up, level_down: posterior draws."""
    map_values: dict
    map_sd: dict
    noise: NoisePosterior
    checks: tuple[FitCheck, ...] = ()
    """The noise model's checks against the two sections (Allan deviation, spectrum, lag-1
    autocorrelation: :func:`~bayescal.inference._checks.noise_model_checker`)."""
    selection: TermSelection | None = None
    """How the noise terms were chosen (``terms="auto"``)."""

    @property
    def misfits(self) -> tuple[str, ...]:
        """Where the noise model does not fit the sections, and by how much."""
        return tuple(check.misfit for check in self.checks if not check.passed)


def bayesian_two_position(
    up: Section,
    down: Section,
    rate_hz: float,
    gravity: LocalGravity,
    *,
    terms: tuple[str, ...],
    gap_s: float | None,
    unit: str,
    seed: int,
    sampler: Sampler = Sampler(),
) -> BayesianTwoPosition:
    """Joint posterior of scale, offset and g_local; ``gap_s`` is the time between the
    starts of the sections when it is known (one file)."""
    joined = np.concatenate([up.values, [np.nan], down.values])
    fitted = noise_posterior(
        joined,
        rate_hz,
        terms=terms,
        prior_of=partial(default_prior, allan=allan_deviation(joined, rate_hz)),
        unit=unit,
        level_values=up.values,
        seed=seed,
        sampler=sampler,
    )
    noise, selection, lsb, checks = fitted.posterior, fitted.selection, fitted.lsb, fitted.checks
    rounding = lsb**2 / (12.0 * rate_hz)
    rng = np.random.default_rng(seed + 1)

    components = noise.problem.components
    levels = {
        name: level_summary(section.values, rate_hz, components)
        for name, section in (("up", up), ("down", down))
    }

    def level_draws(parameters, ramp):
        weights = np.array(components.weights(parameters))
        weights[..., components.white] += rounding
        conditional = {
            name: [
                np.asarray(v)
                for v in bias_given_noise(level, jnp.asarray(weights), jnp.asarray(ramp))
            ]
            for name, level in levels.items()
        }
        drift = offset_drift_variance(gap_s, parameters, rate_hz, noise.terms) if gap_s else 0.0
        return conditional, np.asarray(drift)

    shape = next(iter(noise.draws.values())).shape
    parameters = {name: noise.draws[name] for name in noise.problem.parameters}
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
    return BayesianTwoPosition(draws, map_values, map_sd, noise, checks, selection)


@dataclass(frozen=True)
class TwoPositionCalibration(Checked):
    """A two-position calibration of one accelerometer axis (:func:`calibrate_two_position`):
    the classical answer (each entry ``(value, half-width at confidence)``) and the posterior
    (draws of scale, offset and g_local, MAP with Laplace sd, the noise posterior)."""

    _check_subject = "two-position: posterior checks failed"

    channel: str
    """The channel's name."""
    unit: str
    """The readings' unit: offsets are in it, the scale in m/s^2 per it."""
    rate_hz: float
    """Sample rate, Hz."""
    up: Section
    """The still section with the sensitive axis up."""
    down: Section
    """The still section with the sensitive axis down."""
    gravity: LocalGravity
    """The local gravity used, m/s^2, with its uncertainty and source."""
    confidence: float
    """Confidence of the classical half-widths."""
    classical: dict
    """mean_up, mean_down, span, scale, offset, g_local: (value, half-width)."""
    bayesian: BayesianTwoPosition | None
    """The posterior of scale, offset and g_local (draws, MAP with Laplace sd, the noise
    model's posterior and fit checks); None with ``bayesian=False``."""

    @property
    def scale_unit(self) -> str:
        """The scale's unit: m/s^2 per reading unit."""
        return f"m/s^2/({self.unit})" if "/" in self.unit else f"m/s^2/{self.unit}"

    @property
    def summary(self) -> dict:
        """``scale``, ``offset`` and ``g_local``, each ``{mean, sd, q05, q95, map, map_sd,
        unit}`` from the posterior (its 90 % interval, and the MAP with its Laplace sd); with
        ``bayesian=False``, the classical answer instead, ``{value, half_width, confidence,
        unit}``."""
        units = {"scale": self.scale_unit, "offset": self.unit, "g_local": "m/s^2"}
        if self.bayesian is None:
            return {
                name: {
                    "value": self.classical[name][0],
                    "half_width": self.classical[name][1],
                    "confidence": self.confidence,
                    "unit": unit,
                }
                for name, unit in units.items()
            }
        posterior = self.bayesian
        return {
            name: summarize(
                posterior.draws[name], unit, posterior.map_values[name], posterior.map_sd[name]
            )
            for name, unit in units.items()
        }

    @property
    def failures(self) -> tuple[str, ...]:
        """The posterior's failed sampler checks, then where its noise model misfits."""
        if self.bayesian is None:
            return ()
        return (
            *self.bayesian.noise.diagnostics.failures,
            *(f"noise model misfit: {misfit}" for misfit in self.bayesian.misfits),
        )


def calibrate_two_position(
    up,
    down,
    rate_hz: float | None = None,
    *,
    gravity: LocalGravity,
    unit: str | None = None,
    channel: str | None = None,
    gap_s: float | None = None,
    terms=DEFAULT_TERMS,
    confidence: float = 0.95,
    bayesian: bool = True,
    seed: int = 0,
    sampler: Sampler = Sampler(),
) -> TwoPositionCalibration:
    """Scale factor and offset of one accelerometer axis from a section held up and one held
    down.

    Parameters
    ----------
    up, down : array_like, Section or Channel
        The readings of each section (``unit``; NaN marks a missing sample); a
        :class:`~bayescal.Channel` brings its rate, unit, name and where it starts.
    rate_hz : float
        Sample rate, Hz (from the channels when ``up`` and ``down`` are Channels).
    gravity : LocalGravity
        Local gravity (:func:`~bayescal.local_gravity`, or :meth:`LocalGravity.measured`).
    unit : str, optional
        The readings' unit (m/s^2, g, or a count unit such as LSB; a Channel's own, else
        m/s^2).
    channel : str, optional
        The axis's name, for the result (a Channel's own, else ``acc``).
    gap_s : float, optional
        Seconds between the starts of the two sections when they come from one recording:
        the offset may then drift between them by the noise model's own random walk and
        flicker.
    terms : str or tuple of str
        Noise terms of the Bayesian model (as :func:`~bayescal.fit_noise`).
    confidence : float
        Confidence of the classical half-widths.
    bayesian : bool
        Also the posterior (else the classical answer only).
    seed : int
        The same inputs and seed give the same posterior.
    sampler : Sampler
        How the noise posterior is sampled (:class:`~bayescal.Sampler`).

    Returns
    -------
    TwoPositionCalibration

    Raises
    ------
    InputError
        A moving section, sections not opposite, a span far from 2 g in an acceleration unit,
        Channels of different rates or units.

    Examples
    --------
    >>> import numpy as np
    >>> import bayescal as bc
    >>> rng = np.random.default_rng(0)
    >>> g = bc.local_gravity(45.0)
    >>> up = 0.03 + g.value / 1.002 + 0.004 * rng.standard_normal(6000)
    >>> down = 0.03 - g.value / 1.002 + 0.004 * rng.standard_normal(6000)
    >>> calibration = bc.calibrate_two_position(up, down, 100.0, gravity=g, bayesian=False)
    >>> round(calibration.classical["scale"][0], 3)
    1.002
    """
    release_compiled_code()
    up, down, rate_hz, unit, channel = _sections(up, down, rate_hz, unit, channel)
    terms = parse_terms(terms) if isinstance(terms, str) else check_terms(tuple(terms))
    check_sections(up, down, unit, channel)
    classical = classical_two_position(up.values, down.values, gravity, confidence)
    posterior = (
        bayesian_two_position(
            up,
            down,
            rate_hz,
            gravity,
            terms=terms,
            gap_s=gap_s,
            unit=unit,
            seed=seed,
            sampler=sampler_of(sampler),
        )
        if bayesian
        else None
    )
    return TwoPositionCalibration(
        channel, unit, float(rate_hz), up, down, gravity, confidence, classical, posterior
    )


def _sections(up, down, rate_hz, unit, channel):
    """(up, down, rate, unit, channel name) from the sections given: arrays or Sections (with
    ``rate_hz``), or Channels, which bring their rate, unit, name, source and start and must
    agree on the rate and the unit."""
    sections, rates, units, names = [], [], [], []
    for name, given in (("up", up), ("down", down)):
        if isinstance(given, Channel):
            data = channel_input(given, rate_hz, unit=unit, channel=None, argument=name)
            sections.append(Section(data.values, given.start_s, data.source))
            rates.append(data.rate_hz)
            units.append(data.unit)
            names.append(data.channel)
        elif isinstance(given, Section):
            sections.append(given)
        else:
            sections.append(Section(np.asarray(given, float), 0.0, "<array>"))
    if rates and (len(set(rates)) > 1 or len(set(units)) > 1):
        raise InputError(
            f"up and down differ: {rates[0]:g} Hz {units[0]} against {rates[-1]:g} Hz {units[-1]}",
            fix="record both positions with the same settings",
        )
    rate = rates[0] if rates else positive_rate(rate_hz)
    return (
        *sections,
        rate,
        units[0] if units else unit or "m/s^2",
        channel or (names[0] if names else "acc"),
    )
