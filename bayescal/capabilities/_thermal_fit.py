"""Fit a thermal bias calibration (:func:`fit_thermal`): the posterior of the polynomial's
coefficients beside the channel's noise (:mod:`bayescal.inference._thermal_posterior`), its
degree chosen by predictive density, and the classical bin-means answer beside it; the
calibration it makes is :class:`~bayescal.ThermalCalibration` (:mod:`._thermal`)."""

import numpy as np

from .._caches import release_compiled_code
from .._errors import InputError
from .._output import to_jsonable
from ..classical._allan import allan_deviation
from ..classical._thermal import classical_thermal
from ..inference._priors import default_prior
from ..inference._sampler import Sampler, sampler_of
from ..inference._thermal_posterior import choose_degree, sample_thermal
from ..models._terms import AUTO, check_terms, parse_terms
from ..models._thermal import MAX_DEGREE, ThermalRecord, check_temperature, thermal_problem
from ..models.effects.earth_rotation import earth_rate_on_axis
from ..recording._inputs import channel_and_temperature
from ._thermal import ThermalCalibration, provenance_step, with_posterior

NOISE_TERMS = ("white", "bias_instability", "rate_random_walk")


def fit_thermal(
    y,
    temperature=None,
    rate_hz: float | None = None,
    *,
    degree: int | str = "auto",
    reference: float | None = None,
    terms=NOISE_TERMS,
    unit: str | None = None,
    temperature_unit: str = "degC",
    channel: str | None = None,
    latitude: float | None = None,
    axis: str = "up",
    confidence: float = 0.95,
    seed: int = 0,
    source: str | None = None,
    temperature_name: str = "temperature",
    sampler: Sampler = Sampler(),
) -> ThermalCalibration:
    """Fit a thermal bias calibration of a gyro channel.

    Parameters
    ----------
    y : array_like or Channel
        The gyro channel (``unit``), NaN where a sample is missing; a
        :class:`~bayescal.Channel` brings its rate, unit, name, source and the temperature
        it was prepared with (``Recording.channel(name, temperature=COLUMN)``).
    temperature : array_like or Channel, optional
        Its temperature on the same grid, one value per sample (``temperature_unit``); it
        must change. Default: the Channel's.
    rate_hz : float
        Sample rate, Hz (from the channel when ``y`` is one).
    degree : int or "auto"
        Polynomial degree 0..4, or chosen by one-block-ahead predictive density.
    reference : float, optional
        T0 (default: the middle of the temperature range, to 0.1).
    terms : str or tuple of str
        Noise terms beside the thermal bias (as :func:`fit_noise`; no ramp: a ramp cannot
        be told from a thermal drift).
    unit : str, optional
        The channel's unit, written into the calibration (a Channel's own, else deg/s).
    temperature_unit : str
        The temperature's unit, written into the calibration.
    channel : str, optional
        The channel's name, written into the calibration (a Channel's own, else gyro).
    latitude : float, optional
        Take the Earth rate off the channel first (degrees), with ``axis`` the gyro axis's
        direction (up, down, north, south, east, west, or east,north,up components).
    confidence : float
        Confidence of the classical intervals.
    seed : int
        Seed of the sampler: the same inputs and seed give the same calibration.
    source : str, optional
        Where the data come from, for the provenance (a Channel's own, else ``<array>``).
    temperature_name : str
        The temperature's name, for the messages.
    sampler : Sampler
        How the posterior is sampled (:class:`~bayescal.Sampler`).

    Returns
    -------
    ThermalCalibration
        The calibration, its classical answer and its posterior's checks
        (:meth:`~ThermalCalibration.check`).

    Raises
    ------
    InputError
        No temperature, one of another length than ``y`` or constant, an unknown term, a
        ramp among the terms, a degree out of range, too few blocks for the degree.

    Examples
    --------
    >>> import numpy as np
    >>> import bayescal as bc
    >>> t = np.arange(2**13) / 10.0
    >>> temperature = 45 - 20 * np.exp(-t / 400)
    >>> noise = bc.NoiseModel(rate_hz=10.0, N=0.005).simulate(t.size, seed=1)
    >>> y = 0.5 + 0.01 * (temperature - 35) + noise
    >>> calibration = bc.fit_thermal(y, temperature, 10.0, degree=1, reference=35.0)
    >>> calibration.coefficients.round(2)
    array([0.5 , 0.01])
    """
    release_compiled_code()
    sampler = sampler_of(sampler)
    noise_terms = parse_terms(terms) if isinstance(terms, str) else check_terms(tuple(terms))
    if noise_terms == AUTO:
        raise InputError(
            'terms="auto": a thermal calibration takes its noise terms as given',
            fix=f"name them (default: {','.join(NOISE_TERMS)})",
        )
    if "rate_ramp" in noise_terms:
        raise InputError(
            f"terms={terms!r}: a ramp cannot be told from a thermal drift; leave it out"
        )
    if degree != "auto" and not (
        isinstance(degree, (int, np.integer)) and 0 <= degree <= MAX_DEGREE
    ):
        raise InputError(f"degree={degree!r}", fix=f"give 'auto' or a whole number 0..{MAX_DEGREE}")
    gyro, temperature = channel_and_temperature(
        y,
        temperature,
        rate_hz,
        unit=unit,
        channel=channel,
        default_unit="deg/s",
        default_channel="gyro",
    )
    values = np.asarray(gyro.values, dtype=float)
    rate_hz, unit, channel = gyro.rate_hz, gyro.unit, gyro.channel
    source = source or gyro.source
    check_temperature(temperature, source, temperature_name)
    earth = None
    if latitude is not None:
        value = earth_rate_on_axis(latitude, axis, unit)
        earth = {"latitude_deg": latitude, "axis": axis, "value": value, "unit": unit}
        values = values - value
    present = temperature[~np.isnan(temperature)]
    if reference is None:
        reference = float(round((present.min() + present.max()) / 2, 1))
    record = ThermalRecord(values, temperature, rate_hz, ((0, values.size),))
    allan = allan_deviation(values, rate_hz)
    noise_prior = default_prior(noise_terms, allan)
    if degree == "auto":
        chosen, scores = choose_degree(record, reference, noise_prior=noise_prior)
    else:
        chosen, scores = int(degree), {}
    problem = thermal_problem(record, chosen, reference, noise_prior=noise_prior)
    fit = sample_thermal(
        problem, chosen, reference, seed=seed, sampler=sampler, degree_scores=scores
    )
    base = ThermalCalibration(
        channel=channel,
        unit=unit,
        temperature_unit=temperature_unit,
        reference=reference,
        degree=chosen,
        coefficients=fit.coefficient_mean,
        covariance=fit.coefficient_covariance,
        temperature_range=(float(present.min()), float(present.max())),
        noise={"terms": list(noise_terms)},
        earth_rate=earth,
        provenance=(
            provenance_step(
                "fit",
                source=source,
                channel=channel,
                n_samples=int(np.count_nonzero(~np.isnan(values))),
                seed=seed,
                extra={"degree_chosen": degree == "auto"},
            ),
        ),
        bayesian={},
        classical=to_jsonable(
            classical_thermal(values, temperature, chosen, reference, confidence)
        ),
    )
    return with_posterior(base, fit)
