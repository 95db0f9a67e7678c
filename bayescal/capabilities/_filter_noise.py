"""The noise a navigation filter should be told (``bayescal export-filter``): from a static
record's noise posterior, each channel's white noise and bias random walk in the convention of
a named estimator (:mod:`._estimators`), every number made of stated contributions.

Contributions ("items"), each a continuous-time density in SI units, added in quadrature:

``posterior_quantile``
    N and K at the posterior's upper ``quantile`` (0.95 by default): a filter told the
    posterior mean is overconfident half the time for a record of finite length. A model
    without K (the record holds no evidence of it) gives K's classical upper bound off the
    Allan curve instead, said so.
``bias_instability``
    Every fitted term that moves the bias without being a random walk (bias instability,
    Gauss-Markov, a ramp: :func:`~bayescal.models._terms.bias_terms`) as the random walk that
    stands for it over the horizon H (:func:`~bayescal.models._terms.bounding_walk_variance`:
    q^2 = 9 sigma_A^2(H / 3) / H, for flicker 9 (2 ln 2 / pi) B^2 / H), at the term's upper
    quantile over the draws. A filter whose bias walk is K alone believes a flicker-dominated
    bias is constant (Kalibr issue 345).

The horizon is the filter's: the time over which its estimate of the bias averages. Given
(``horizon``, a sliding window's length), it serves every channel; otherwise each channel's
follows from the filter's aiding (``aiding``, :class:`~bayescal.Aiding`; by default
:data:`DEFAULT_AIDING`, position fixes of 1 m every second) and the sensor's own bias: the
span over which the aiding reveals a bias as large as the bias wanders
(:func:`~bayescal.navigation._aiding.aided_horizon`), so that a smaller bias is bounded over a
longer span.
``vibration``
    From a second recording with the motors running: the extra two-sided density in the
    filter's band, mean over (0, f/2] of the vibration record's Welch spectrum less N^2,
    added to N.
``thermal``
    From a thermal calibration and an expected temperature excursion dT over the horizon: the
    variance of the compensated bias's change over dT (g^T Sigma g, g_j = dT^j, the
    calibration's coefficient covariance Sigma), as a random walk reaching it at the horizon,
    added to K.

The sample rate: N and K are densities and do not depend on it; an estimator whose numbers are
per-sample sds (VINS, PX4) gets them at the rate its filter steps at (``filter_rate_hz``:
the recording's rate for VINS, the EKF's 100 Hz for PX4), sqrt(c) N sqrt(f). A stream the
sensor low-passes (a fitted output filter) has samples whose sd is below N sqrt(f): N is the
density the filter keeps at low frequency, which is what integrates into the navigation
error, so the export uses it and says by how much the samples' own sd would understate it.
"""

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from .._caches import release_compiled_code
from .._errors import InputError
from ..models._terms import (
    BOUNDING_FRACTION,
    FILTER_SHAPE_OF_TERM,
    PARAMETERS_OF_TERM,
    TERMS,
    bias_terms,
    bounding_walk_variance,
)
from ..navigation._aiding import Aiding, aided_horizon
from ..recording._inputs import channel_input
from ..recording._units import parse_unit
from ._checked import Checked
from ._estimators import SENSORS, SI, Estimator, sensor_of_unit
from ._estimators import estimator as find_estimator
from ._noise import NoiseFit

QUANTILE = 0.95
"""The posterior's upper quantile the exported N and K are read at."""
ITEMS = ("posterior_quantile", "bias_instability", "vibration", "thermal")
"""The contributions of an exported number, in order."""
MIN_GAIN = 0.25
"""A vibration record's density is read where the fitted output filter keeps at least this
share of the power (dividing by a smaller gain would amplify its noise)."""
DEFAULT_AIDING = Aiding("position", 1.0, 1.0)
"""The aiding assumed when neither a horizon nor an aiding is given: GNSS-class position
fixes, 1 m sd every second."""


@dataclass(frozen=True)
class Item:
    """One contribution to N or K, a continuous-time density in SI units."""

    parameter: str
    """``N`` (white noise) or ``K`` (the bias's random walk)."""
    value: float
    unit: str
    how: str
    """How it was made, in words."""


@dataclass(frozen=True)
class ChannelNoise:
    """What one channel's export is made of (:func:`filter_noise`)."""

    channel: str
    sensor: str
    """``gyroscope`` or ``accelerometer``."""
    source: str
    rate_hz: float
    """The recording's rate, Hz."""
    horizon_s: float
    """The horizon its bias terms and thermal change are bounded over, s."""
    items: dict
    """Item name (:data:`ITEMS`) -> tuple of :class:`Item` (empty when it does not apply)."""
    missing: dict
    """Item name -> why it has no contribution (only those that have none)."""
    density: dict
    """``N`` and ``K``: the items added in quadrature, continuous-time, SI."""
    values: dict
    """The estimator's parameter names for this channel's sensor -> value in its units."""
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class FilterNoise(Checked):
    """The noise values of a navigation filter (:func:`filter_noise`)."""

    estimator: Estimator
    """The estimator's convention (:mod:`bayescal.capabilities._estimators`)."""
    horizon_s: float | None
    """The horizon given, s; None when each channel's follows from :attr:`aiding`."""
    aiding: Aiding | None
    """The aiding the channels' horizons follow from; None when a horizon was given."""
    quantile: float
    """The posterior's upper quantile the items are read at."""
    filter_rate_hz: float
    """The rate per-sample values are per, Hz."""
    channels: dict
    """Channel name -> :class:`ChannelNoise`."""
    values: dict
    """The estimator's parameter -> {value, unit, channel}: one value per sensor, the largest
    of its channels (one value covers three axes; Kalibr's wiki advises erring high)."""
    failures: tuple[str, ...] = ()
    """The posteriors' failed checks, by channel."""
    notes: tuple[str, ...] = ()
    """What was noticed across channels (rates that differ ...)."""

    @property
    def summary(self) -> dict:
        """channel -> {sensor, values, items}: the estimator's values (its names and units)
        and each item's contributions with their units (None with the reason where an item
        does not apply)."""
        summary = {}
        for name, channel in self.channels.items():
            items = {}
            for item in ITEMS:
                if channel.items[item]:
                    items[item] = {
                        c.parameter: {"value": c.value, "unit": c.unit, "how": c.how}
                        for c in channel.items[item]
                    }
                else:
                    items[item] = {"value": None, "reason": channel.missing[item]}
            summary[name] = {
                "sensor": channel.sensor,
                "values": {
                    self.estimator.keys[channel.sensor, p]: {
                        "value": channel.values[self.estimator.keys[channel.sensor, p]],
                        "unit": self.estimator.unit(channel.sensor, p),
                    }
                    for p in ("N", "K")
                },
                "horizon_s": channel.horizon_s,
                "items": items,
                "density": {
                    p: {"value": v, "unit": _density_unit(channel.sensor, p)}
                    for p, v in channel.density.items()
                },
                "notes": list(channel.notes),
            }
        return summary


def _density_unit(sensor: str, parameter: str) -> str:
    return find_estimator("kalibr").unit(sensor, parameter)


def _quantile(draws, q: float) -> float:
    return float(np.quantile(np.ravel(draws), q))


def _posterior_items(fit: NoiseFit, si: float, sensor: str, q: float) -> tuple[list, list]:
    """N and K at the posterior's upper quantile. Without K in the model: nothing when a bias
    term is there (the record holds no evidence of a random walk beside it, and the term's
    bounding walk stands for the bias's motion), else K's classical upper bound off the Allan
    curve (a filter needs some walk of its bias)."""
    items, notes = [], []
    for parameter in ("N", "K"):
        unit = _density_unit(sensor, parameter)
        if parameter in fit.draws:
            value = _quantile(fit.draws[parameter], q) * si
            items.append(
                Item(
                    parameter, value, unit, f"the posterior's {100 * q:g} % quantile of {parameter}"
                )
            )
            continue
        if bias_terms(fit.terms):
            notes.append(
                f"{parameter} is not in the fitted model ({', '.join(fit.terms)}): the bias's "
                "walk is its bias terms' alone"
            )
            continue
        reading = fit.classical.slope_readings.get(parameter)
        bound = None if reading is None else (reading.ci_high or reading.value)
        if bound is None or not math.isfinite(bound):
            notes.append(f"{parameter} is neither fitted nor bounded by the Allan curve: 0")
            bound = 0.0
        how = (
            f"not in the fitted model ({', '.join(fit.terms)}): the Allan curve's upper bound "
            f"of {parameter}"
        )
        items.append(Item(parameter, bound * si, unit, how))
    return items, notes


def _bias_items(fit: NoiseFit, si: float, sensor: str, q: float, horizon: float) -> list:
    """Each bias term as the random walk that bounds it over the horizon."""
    items = []
    draws = fit.draws
    for term in bias_terms(fit.terms):
        names = PARAMETERS_OF_TERM[term]
        count = np.ravel(draws[names[0]]).size
        walks = [
            bounding_walk_variance(
                term, {p: float(np.ravel(draws[p])[i]) for p in names}, horizon, fit.rate_hz
            )
            for i in range(0, count, max(1, count // 400))
        ]
        value = math.sqrt(max(float(np.quantile(walks, q)), 0.0)) * si
        described = ", ".join(f"{p} {fit.parameters[p].mean:.3g}" for p in names)
        items.append(
            Item(
                "K",
                value,
                _density_unit(sensor, "K"),
                f"{TERMS[term].name} ({described}, {fit.unit} units) as the random walk whose "
                f"Allan variance equals its own at a third of the {horizon:g} s horizon, "
                f"q^2 = 9 sigma_A^2(H/3) / H, at the draws' {100 * q:g} % quantile",
            )
        )
    return items


def _vibration_item(fit: NoiseFit, vibration, si: float, sensor: str, rate_hz: float) -> Item:
    """The extra white density of a vibration record in the filter's band."""
    from scipy.signal import welch

    data = channel_input(
        vibration,
        None if hasattr(vibration, "rate_hz") else fit.rate_hz,
        unit=None if hasattr(vibration, "rate_hz") else fit.unit,
        channel=None,
        argument="vibration",
    )
    sensor_vib, si_vib = sensor_of_unit(data.unit, data.channel, data.source)
    if sensor_vib != sensor:
        raise InputError(
            f"vibration: {data.channel} is a {sensor_vib}'s channel, {fit.channel} a {sensor}'s",
            fix="give the vibration record's channel of the same sensor",
        )
    values = np.asarray(data.values, dtype=float) * si_vib
    values = values[np.isfinite(values)]
    if values.size < 256:
        raise InputError(
            f"vibration: {data.channel} has {values.size} samples; the spectrum needs 256",
            fix="record the motors running for longer",
        )
    frequency, one_sided = welch(
        values, fs=data.rate_hz, nperseg=min(values.size, 4096), detrend="linear"
    )
    band = (frequency > 0) & (frequency <= min(rate_hz, data.rate_hz) / 2)
    density = one_sided / 2  # two-sided, as N^2
    shape = _filter_shape(fit)
    through = ""
    if shape is not None and data.rate_hz == fit.rate_hz:
        # The vibration passes the sensor's output filter as the static noise does: compare
        # the densities before it, where the filter keeps enough of the band to divide by.
        gain = np.asarray(_filter_gain(fit, shape, frequency / fit.rate_hz))
        band &= gain >= MIN_GAIN
        density = density / np.where(gain > 0, gain, 1.0)
        through = f", divided by the fitted {shape}'s gain (where it is >= {MIN_GAIN:g})"
    elif shape is not None:
        through = (
            f", not divided by the fitted {shape}'s gain (the record's rate, "
            f"{data.rate_hz:g} Hz, is not the fit's): an upper part of the band the filter "
            "lowers reads low"
        )
    level = float(np.mean(density[band]))
    static = (fit.parameters["N"].mean * si) ** 2
    extra = math.sqrt(max(level - static, 0.0))
    return Item(
        "N",
        extra,
        _density_unit(sensor, "N"),
        f"vibration record {data.source} ({data.channel}): its mean two-sided density over "
        f"(0, {min(rate_hz, data.rate_hz) / 2:g}] Hz{through}, {math.sqrt(level):.3e}, less "
        "the static N",
    )


def _thermal_change(fit: NoiseFit, thermal) -> tuple[float, str]:
    """The variance (SI) of the compensated bias's change over the expected temperature
    excursion, and how it was made."""
    try:
        calibration, excursion = thermal
        excursion = float(excursion)
        covariance = np.asarray(calibration.covariance, dtype=float)
    except (TypeError, ValueError, AttributeError):
        raise InputError(
            f"thermal: {fit.channel} needs (ThermalCalibration, excursion in degC)",
            fix="give thermal={channel: (calibration, 10.0)}",
        ) from None
    if not (math.isfinite(excursion) and excursion >= 0):
        raise InputError(f"thermal: the excursion of {fit.channel} must be degrees C >= 0")
    cal_si = parse_unit(calibration.unit).to_si
    powers = excursion ** np.arange(covariance.shape[0], dtype=float)
    powers[0] = 0.0  # the level cancels in a change
    variance = float(powers @ covariance @ powers) * cal_si**2
    sensor, _ = sensor_of_unit(fit.unit, fit.channel, fit.source)
    how = (
        f"thermal calibration of {calibration.channel}: the compensated bias's sd of change "
        f"over {excursion:g} degC, {math.sqrt(variance):.3e} {SI[sensor]}, as a walk "
        "reaching it at the horizon"
    )
    return variance, how


def _channel_horizon(
    fit: NoiseFit, sensor: str, si: float, aiding: Aiding, thermal_variance: float
) -> float:
    """The span over which ``aiding`` reveals the channel's bias as well as its bias terms
    (posterior means) and thermal change wander (:func:`aided_horizon`)."""
    terms = bias_terms(fit.terms)
    values = {p: fit.parameters[p].mean for t in terms for p in PARAMETERS_OF_TERM[t]}

    def deviation(tau: float) -> float:
        variance = sum(float(TERMS[t].allan_variance(tau, values, fit.rate_hz)) for t in terms)
        return math.sqrt(max(variance, 0.0) * si**2 + thermal_variance)

    return aided_horizon(aiding, sensor, deviation, shortest_s=BOUNDING_FRACTION / fit.rate_hz)


def _filter_shape(fit: NoiseFit) -> str | None:
    """The fitted output filter's term, if the model holds one."""
    return next((t for t in fit.terms if t in FILTER_SHAPE_OF_TERM), None)


def _filter_gain(fit: NoiseFit, shape: str, nu):
    """The fitted filter's power gain at frequencies ``nu`` (cycles per sample)."""
    values = {p: fit.parameters[p].mean for p in fit.parameters}
    return TERMS[shape].gain(nu, values, fit.rate_hz)


def _output_filter_note(fit: NoiseFit, estimator: Estimator, rate_hz: float) -> str | None:
    """How much a per-sample sd measured on the stream would understate N sqrt(f)."""
    shape = _filter_shape(fit)
    if shape is None:
        return None
    nu = (np.arange(4096) + 0.5) / 8192
    kept = float(np.mean(np.asarray(_filter_gain(fit, shape, nu))))
    return (
        f"the sensor's output filter ({shape}) leaves the samples' sd at "
        f"{math.sqrt(kept):.2f} of N sqrt(f): the export uses N, the density the filter keeps "
        "at low frequency"
        + (
            f"; {estimator.title}'s per-sample values are N sqrt(f) at {rate_hz:g} Hz, not the "
            "stream's sample sd"
            if estimator.per_sample
            else ""
        )
    )


def _fits(fit) -> dict:
    if isinstance(fit, NoiseFit):
        return {fit.channel: fit}
    if isinstance(fit, Mapping):
        found = dict(fit)
    else:
        try:
            found = {f.channel: f for f in fit}
        except TypeError:
            found = {}
    if not found or not all(isinstance(f, NoiseFit) for f in found.values()):
        raise InputError(
            "fit: give a NoiseFit, or several (a list, or channel -> NoiseFit)",
            fix="fit each channel with bc.fit_noise first",
        )
    return found


def filter_noise(
    fit,
    *,
    estimator: str,
    horizon: float | None = None,
    aiding: Aiding | None = None,
    quantile: float = QUANTILE,
    filter_rate_hz: float | None = None,
    vibration: Mapping | None = None,
    thermal: Mapping | None = None,
) -> FilterNoise:
    """The noise values of a navigation filter, in the convention of ``estimator``, each
    made of stated contributions (module docstring).

    Parameters
    ----------
    fit : NoiseFit, sequence of NoiseFit or mapping
        Static records' noise fits (:func:`~bayescal.fit_noise`), one per channel (gyros
        and accelerometers; a mapping names them).
    estimator : str
        ``kalibr``, ``openvins``, ``orbslam3``, ``vins``, ``gtsam`` or ``px4``
        (:mod:`bayescal.capabilities._estimators` gives each one's convention).
    horizon : float, optional
        Seconds over which the bias terms (instability, Gauss-Markov) are bounded by a
        random walk, for every channel: the time the filter's bias estimate averages over
        (a sliding window's length). Not with ``aiding``.
    aiding : Aiding, optional
        The filter's aiding (position or velocity fixes, their sd and interval): each
        channel's horizon is the span over which it reveals that channel's bias (module
        docstring). Default, when no ``horizon`` is given: :data:`DEFAULT_AIDING`.
    quantile : float
        The posterior's upper quantile N, K and the bias terms are read at, in (0.5, 1).
    filter_rate_hz : float, optional
        The rate the filter steps at, Hz, for per-sample values (default: PX4's 100 Hz EKF,
        else the recording's rate).
    vibration : mapping, optional
        Channel name -> the same channel recorded with the motors running (a
        :class:`~bayescal.Channel`, or an array at the fit's rate and unit).
    thermal : mapping, optional
        Channel name -> (its :class:`~bayescal.ThermalCalibration`, the temperature excursion
        expected over the horizon in degC).

    Returns
    -------
    FilterNoise
        Per channel its items and values; per sensor the value written (the largest of its
        channels).

    Raises
    ------
    InputError
        An unknown estimator, a horizon or quantile out of range, both a horizon and an
        aiding, a channel that is neither
        a gyro nor an accelerometer, a vibration or thermal input for an unknown channel.

    Examples
    --------
    >>> import bayescal as bc
    >>> y = bc.NoiseModel(rate_hz=100.0, N=0.0035, K=4e-5).simulate(2**14, seed=3)
    >>> fit = bc.fit_noise(y, 100.0, terms="white,rrw", unit="deg/s", channel="gyro_x")
    >>> noise = bc.filter_noise(fit, estimator="vins", horizon=600.0)
    >>> sorted(noise.values)  # VINS: per-sample sds at the IMU's rate
    ['gyr_n', 'gyr_w']
    >>> noise.values["gyr_n"]["unit"]
    'rad/s'
    """
    release_compiled_code()
    chosen = find_estimator(estimator)
    fits = _fits(fit)
    if horizon is not None:
        if aiding is not None:
            raise InputError(
                "horizon and aiding: give one (the horizon, or the aiding it follows from)"
            )
        if not (isinstance(horizon, (int, float)) and math.isfinite(horizon) and horizon > 0):
            raise InputError(f"horizon={horizon!r} must be a positive number of seconds")
    elif aiding is None:
        aiding = DEFAULT_AIDING
    elif not isinstance(aiding, Aiding):
        raise InputError(
            f"aiding={aiding!r} must be a bc.Aiding",
            fix='give e.g. bc.Aiding("position", sd=1.0, interval_s=1.0)',
        )
    if not 0.5 <= quantile < 1:
        raise InputError(f"quantile={quantile!r} must lie in [0.5, 1)")
    for argument, given in (("vibration", vibration), ("thermal", thermal)):
        unknown = sorted(set(given or {}) - set(fits))
        if unknown:
            raise InputError(
                f"{argument}: {', '.join(map(str, unknown))} is not among the fitted channels "
                f"({', '.join(fits)})"
            )
    channels, failures = {}, []
    for name, one in fits.items():
        sensor, si = sensor_of_unit(one.unit, name, one.source)
        rate_hz = filter_rate_hz or chosen.default_rate_hz or one.rate_hz
        if not one.passed:
            failures.append(f"{name}: posterior checks failed: " + "; ".join(one.failures))
        posterior, notes = _posterior_items(one, si, sensor, quantile)
        change = _thermal_change(one, thermal[name]) if thermal and name in thermal else None
        span = horizon or _channel_horizon(one, sensor, si, aiding, change[0] if change else 0.0)
        items = {item: () for item in ITEMS}
        items["posterior_quantile"] = tuple(posterior)
        items["bias_instability"] = tuple(_bias_items(one, si, sensor, quantile, span))
        if vibration and name in vibration:
            items["vibration"] = (_vibration_item(one, vibration[name], si, sensor, rate_hz),)
        if change:
            variance, how = change
            items["thermal"] = (
                Item("K", math.sqrt(variance / span), _density_unit(sensor, "K"), how),
            )
        missing = {
            "posterior_quantile": "",
            "bias_instability": "the fitted model has no bias term beside the random walk "
            f"({', '.join(one.terms)})",
            "vibration": "no vibration record given",
            "thermal": "no thermal calibration given",
        }
        missing = {item: why for item, why in missing.items() if not items[item]}
        density = {
            p: math.sqrt(
                sum(c.value**2 for group in items.values() for c in group if c.parameter == p)
            )
            for p in ("N", "K")
        }
        values = {chosen.keys[sensor, p]: chosen.value(p, density[p], rate_hz) for p in ("N", "K")}
        note = _output_filter_note(one, chosen, rate_hz)
        channels[name] = ChannelNoise(
            name,
            sensor,
            one.source,
            one.rate_hz,
            float(span),
            items,
            missing,
            density,
            values,
            (*notes, *([note] if note else [])),
        )
    written = {}
    for sensor in SENSORS:
        for p in ("N", "K"):
            candidates = [
                (c.density[p], c.channel) for c in channels.values() if c.sensor == sensor
            ]
            if not candidates:
                continue
            density, channel = max(candidates)
            rate_hz = filter_rate_hz or chosen.default_rate_hz or channels[channel].rate_hz
            written[chosen.keys[sensor, p]] = {
                "value": chosen.value(p, density, rate_hz),
                "unit": chosen.unit(sensor, p),
                "channel": channel,
            }
    rates = {c.rate_hz for c in channels.values()}
    rate = filter_rate_hz or chosen.default_rate_hz or max(rates)
    notes = []
    if len(rates) > 1 and chosen.per_sample and not (filter_rate_hz or chosen.default_rate_hz):
        notes.append(f"the channels' rates differ ({sorted(rates)} Hz): values per sample at each")
    if horizon is None:
        notes.append(
            f"each channel's horizon follows from the aiding, {aiding.describe()}"
            + (
                " (assumed: give the filter's own aiding, or the horizon of a sliding window)"
                if aiding is DEFAULT_AIDING
                else ""
            )
            + ": "
            + ", ".join(f"{c.channel} {c.horizon_s:.3g} s" for c in channels.values())
        )
    return FilterNoise(
        chosen,
        None if horizon is None else float(horizon),
        aiding,
        quantile,
        float(rate),
        channels,
        written,
        tuple(failures),
        tuple(notes),
    )
