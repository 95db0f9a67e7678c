"""The thermal bias of a gyro: fit a calibration, update it in the field, compensate with it.

A calibration (:class:`ThermalCalibration`) is the posterior of the coefficients c_0..c_d of
bias(T) = sum_j c_j (T - T0)^j beside the channel's noise (the model of
:mod:`bayescal.models._thermal`), with the classical bin-means answer beside it. Its file
(JSON, ``schema: bayescal.thermal_calibration``, ``schema_version: 1``) holds the channel and
its unit, the temperature unit, T0, the degree, the coefficients with their units and
covariance (a multivariate normal: what :meth:`ThermalCalibration.update` takes as its prior),
the temperature range the data covered, the noise model, the Earth rate taken off (if any),
and the provenance of every step. A file of another schema version, with a field missing or
malformed (checked field by field: finite numbers, sizes that match the degree, a symmetric
positive semi-definite covariance), or made for another channel, unit or temperature unit, is
refused (:func:`load_thermal_calibration`). A calibration of several channels (the three gyros
of an in-field update, :func:`save_thermal_calibrations`) is one file of the same schema and
version whose ``channels`` maps each channel's name to its fields;
:func:`load_thermal_calibration` reads one channel of it (``channel=``).

:meth:`ThermalCalibration.update` takes the calibration as the prior of the coefficients *plus
a drift since then*: ``drift="auto"`` (default) learns its scale from the alignment data, a
number fixes it (in the channel's unit: about how far the bias may have moved at T0), 0 assumes
nothing has changed. An updated calibration adds ``drift`` (the scale used or learned, with its
90 % interval) and ``offsets`` (the period offsets); both are optional keys of schema version 1.

A calibration is made by :func:`~bayescal.fit_thermal` (:mod:`._thermal_fit`); its posterior is
:mod:`bayescal.inference._thermal_posterior`, its file's schema :mod:`._thermal_file`.
"""

import datetime
from dataclasses import dataclass, field, replace
from importlib.metadata import version
from pathlib import Path

import numpy as np

from .._errors import InputError
from .._output import to_jsonable, write_json
from ..inference._sampler import Sampler, sampler_of
from ..inference._thermal_posterior import ThermalFit, calibrated_noise_prior, sample_thermal
from ..models._terms import parameter_unit
from ..models._thermal import ThermalRecord, thermal_problem
from ..models.effects._parameter import Context
from ..recording._inputs import (
    channel_and_temperature,
    check_same_length,
    samples,
    temperature_of,
)
from ..recording._recording import Channel
from ._checked import Checked
from ._thermal_file import (
    SCHEMA,
    SCHEMA_VERSION,
    channel_document,
    document_of,
    fields_of,
    read_document,
)


def _coefficient_units(unit: str, temperature_unit: str, degree: int) -> list[str]:
    return [unit] + [
        f"{unit}/{temperature_unit}" + (f"^{j}" if j > 1 else "") for j in range(1, degree + 1)
    ]


def provenance_step(step: str, *, source: str, channel: str, n_samples: int, seed, extra: dict):
    return {
        "step": step,
        "source": source,
        "channel": channel,
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "bayescal_version": version("bayescal"),
        "n_samples": n_samples,
        "seed": seed,
        **extra,
    }


@dataclass(frozen=True)
class ThermalCalibration(Checked):
    """A thermal bias calibration: the polynomial bias(T) = sum_j c_j (T - T0)^j with its
    posterior covariance, the noise beside it, and how it was made.

    Made by :func:`fit_thermal`, refreshed by :meth:`update`, read by
    :func:`load_thermal_calibration`; :meth:`bias` evaluates it, :meth:`compensate` applies it,
    :meth:`save` writes its file. ``coefficients`` are in the units of
    ``coefficient_units``.
    """

    _check_subject = "thermal calibration: posterior checks failed"

    channel: str
    """The channel it was made for."""
    unit: str
    """The channel's unit (the bias's unit)."""
    temperature_unit: str
    """The temperature's unit (degC unless the column's header said otherwise)."""
    reference: float
    """T0, in ``temperature_unit``."""
    degree: int
    """The polynomial's degree d."""
    coefficients: np.ndarray
    """Posterior mean of c_0..c_d."""
    covariance: np.ndarray
    """Posterior covariance of c_0..c_d."""
    temperature_range: tuple[float, float]
    """The temperatures the data behind it covered."""
    noise: dict
    """``terms`` and, per noise parameter, mean, q05, q95 and unit."""
    earth_rate: dict | None
    """The Earth rate taken off the channel (latitude, axis, value, unit), if any."""
    provenance: tuple
    """Every step that made it: fit, then each update."""
    bayesian: dict
    """MAP coefficients and covariance, 90 % intervals, degree scores, sampler checks."""
    classical: dict | None = None
    """The classical bin-means answer (a fit only)."""
    offsets: dict | None = None
    """The period offsets of an update (mean, sd, unit)."""
    drift: dict | None = None
    """The drift since the prior calibration that an update allowed for."""
    posterior: object = field(default=None, compare=False, repr=False)
    """The posterior this calibration was made from (None when read from a file)."""
    origin: str | None = field(default=None, compare=False)
    """The file it was read from (:func:`load_thermal_calibration`)."""

    @property
    def coefficient_units(self) -> list[str]:
        """The unit of each coefficient c_j: the channel's unit per temperature unit^j."""
        return _coefficient_units(self.unit, self.temperature_unit, self.degree)

    @property
    def summary(self) -> dict:
        """``c0`` .. ``cd`` -> ``{mean, sd, q05, q95, unit}`` (the posterior mean and sd, and
        the 90 % interval of its draws: None for a calibration that does not carry them),
        then each noise parameter -> ``{mean, q05, q95, unit}`` and, after an update,
        ``drift`` as the update used or learned it."""
        low = self.bayesian.get("coefficient_q05")
        high = self.bayesian.get("coefficient_q95")
        summary = {
            f"c{j}": {
                "mean": float(self.coefficients[j]),
                "sd": float(np.sqrt(self.covariance[j, j])),
                "q05": None if low is None else float(low[j]),
                "q95": None if high is None else float(high[j]),
                "unit": unit,
            }
            for j, unit in enumerate(self.coefficient_units)
        }
        for name, entry in self.noise.items():
            if name != "terms":
                summary[name] = {key: entry.get(key) for key in ("mean", "q05", "q95", "unit")}
        if self.drift is not None:
            summary["drift"] = dict(self.drift)
        return summary

    @property
    def passed(self) -> bool:
        """Whether the posterior behind it passed its sampler checks (False for a calibration
        that carries no record of them)."""
        return bool(self.bayesian.get("diagnostics", {}).get("passed", False))

    @property
    def failures(self) -> list[str]:
        """The failed sampler checks of the posterior behind it (empty when it passed)."""
        diagnostics = self.bayesian.get("diagnostics")
        if diagnostics is None:
            return ["the calibration carries no record of its posterior checks"]
        return list(diagnostics.get("failures", []))

    def bias(self, temperature) -> tuple[np.ndarray, np.ndarray]:
        """The thermal bias at ``temperature`` and its posterior sd.

        Parameters
        ----------
        temperature : array_like
            Temperatures, ``temperature_unit``.

        Returns
        -------
        bias, sd : numpy.ndarray
            The bias (posterior mean of the polynomial) and its posterior sd at each
            temperature, the channel's unit (the Earth rate, if taken off, not included).
        """
        temperature = np.asarray(temperature, dtype=float)
        powers = (temperature[..., None] - self.reference) ** np.arange(self.degree + 1)
        mean = powers @ self.coefficients
        sd = np.sqrt(np.einsum("...i,ij,...j->...", powers, self.covariance, powers))
        return mean, sd

    def outside_range(self, temperature) -> np.ndarray:
        """Where ``temperature`` lies outside the calibrated range (the polynomial is
        extrapolated there).

        Parameters
        ----------
        temperature : array_like
            Temperatures, ``temperature_unit``.

        Returns
        -------
        numpy.ndarray of bool
            True where it is below or above the range the calibration's data covered.
        """
        low, high = self.temperature_range
        temperature = np.asarray(temperature, dtype=float)
        return (temperature < low) | (temperature > high)

    def compensate(self, y, temperature=None) -> tuple[np.ndarray, np.ndarray]:
        """The channel ``y`` less its thermal bias (and the Earth rate, when the calibration
        took it off), with the bias's posterior sd per sample.

        Parameters
        ----------
        y : array_like or Channel
            The channel's samples, the calibration's unit.
        temperature : array_like or float, optional
            The temperature at each sample (or one for all), ``temperature_unit``; default:
            the temperature a Channel was prepared with.

        Returns
        -------
        compensated, sd : numpy.ndarray
            The compensated samples and the sd of the bias taken off each, the channel's
            unit.

        Raises
        ------
        InputError
            A Channel in another unit, no temperature, a temperature series of another
            length than ``y``.
        """
        self._check_unit(y)
        values = samples(y, "y")
        temperature = temperature_of(y, temperature)
        if temperature.ndim:
            check_same_length(("y", values), ("temperature", temperature))
        bias, sd = self.bias(temperature)
        earth = self.earth_rate["value"] if self.earth_rate else 0.0
        return values - bias - earth, sd

    def _check_unit(self, y) -> None:
        """A Channel given to this calibration must be in its unit."""
        if isinstance(y, Channel) and y.unit != self.unit:
            raise InputError(
                f"the calibration is in {self.unit} but the channel {y.channel} is in {y.unit}",
                fix=f"prepare the channel in {self.unit} (Recording.channel(name, "
                f"unit={self.unit!r}))",
            )

    def update(
        self,
        y,
        temperature=None,
        rate_hz: float | None = None,
        *,
        periods: tuple[tuple[int, int], ...] | None = None,
        offsets: list | None = None,
        drift: float | str | None = "auto",
        seed: int = 0,
        source: str | None = None,
        sampler: Sampler = Sampler(),
    ) -> "ThermalCalibration":
        """The calibration updated with alignment data taken in service.

        Parameters
        ----------
        y : array_like or Channel
            The channel (its unit); NaN marks a missing sample. The Earth rate this
            calibration took off (if any) is taken off ``y`` too. A
            :class:`~bayescal.Channel` brings its rate, source and the temperature it was
            prepared with.
        temperature : array_like or Channel, optional
            Its temperature, one value per sample (default: the Channel's).
        rate_hz : float
            Sample rate, Hz (from the channel when ``y`` is one).
        periods : tuple of (start, stop), optional
            Sample ranges of the alignment periods (default: the gap-free runs of ``y``).
        offsets : list of (value, uncertainty) or None, optional
            The common offset of each period measured separately (channel unit), or None
            where it was not: each period's offset is a parameter.
        drift : float, "auto" or None
            How far the bias may have moved since this calibration (channel unit, at T0):
            ``"auto"`` learns it, 0 or None assumes no change.
        seed : int
            Seed of the sampler.
        source : str, optional
            Where the data come from, for the provenance (a Channel's own, else
            ``<array>``).
        sampler : Sampler
            How the posterior is sampled (:class:`~bayescal.Sampler`).

        Returns
        -------
        ThermalCalibration
            The new calibration; its provenance continues this one's.

        Raises
        ------
        InputError
            A Channel in another unit, no temperature, a temperature series of another
            length than ``y``.
        """
        self._check_unit(y)
        gyro, temperature = channel_and_temperature(y, temperature, rate_hz, unit=None)
        values, rate_hz = np.asarray(gyro.values, dtype=float), gyro.rate_hz
        source = source or gyro.source
        if self.earth_rate:
            values = values - self.earth_rate["value"]
        periods = periods or gap_free_runs(values)
        offsets = list(offsets) if offsets is not None else [None] * len(periods)
        record = ThermalRecord(values, temperature, rate_hz, tuple(periods))
        context = Context(rate_hz, values.size / rate_hz)
        noise_prior = calibrated_noise_prior(self.noise, context)
        problem = thermal_problem(
            record,
            self.degree,
            self.reference,
            noise_prior=noise_prior,
            coefficient_prior=(self.coefficients, self.covariance),
            offset_prior=offsets,
            drift=drift,
            calibrated_range=self.temperature_range,
        )
        fit = sample_thermal(
            problem, self.degree, self.reference, seed=seed, sampler=sampler_of(sampler)
        )
        present = temperature[~np.isnan(temperature)]
        low, high = self.temperature_range
        if drift == "auto":
            mean, q05, q95 = fit.drift
            drift_entry = {
                "scale": mean,
                "q05": q05,
                "q95": q95,
                "unit": self.unit,
                "learned": True,
            }
        else:
            value = drift or 0.0
            drift_entry = {"scale": value, "q05": value, "q95": value, "unit": self.unit}
            drift_entry["learned"] = False
        step = provenance_step(
            "update",
            source=source,
            channel=self.channel,
            n_samples=int(np.count_nonzero(~np.isnan(values))),
            seed=seed,
            extra={
                "prior": self.origin or "a calibration in memory",
                "periods": [list(p) for p in periods],
                "offset_measurements": offsets,
                "drift": drift,
            },
        )
        return replace(
            with_posterior(self, fit),
            temperature_range=(min(low, float(present.min())), max(high, float(present.max()))),
            provenance=(*self.provenance, step),
            classical=None,
            offsets={"mean": fit.offset_mean, "sd": fit.offset_sd, "unit": self.unit},
            drift=drift_entry,
        )

    def to_document(self) -> dict:
        """The calibration file's content (schema ``bayescal.thermal_calibration``, version 1).

        Returns
        -------
        dict
            Channel, units, T0, degree, coefficients with units and covariance, the range
            covered, the noise model, the Earth rate taken off, the provenance of every step;
            arrays as NumPy arrays, written as lists.
        """
        return document_of(self)

    def save(self, path) -> Path:
        """Write the calibration file (atomically: a failure leaves no partial file).

        Parameters
        ----------
        path : str or Path
            The JSON file to write.

        Returns
        -------
        Path
            ``path``.
        """
        path = Path(path)
        write_json(path, self.to_document())
        return path

    @classmethod
    def from_document(cls, document: dict, source: str = "<document>") -> "ThermalCalibration":
        """A calibration from its file's content, checked field by field against the schema
        (:func:`load_thermal_calibration`); a field that is missing, of the wrong type, not
        finite, of the wrong size, or a covariance that is not symmetric positive
        semi-definite raises :class:`InputError` naming it.

        Parameters
        ----------
        document : dict
            The file's content (:meth:`to_document`).
        source : str
            Where it comes from, named in messages.

        Returns
        -------
        ThermalCalibration
            The calibration (without the posterior it was made from).

        Raises
        ------
        InputError
            A field missing, of the wrong type, not finite or of the wrong size; another
            schema or schema version; a covariance that is not symmetric positive
            semi-definite.
        """
        return cls(**fields_of(document, source))


def gap_free_runs(values: np.ndarray, minimum: int = 16) -> tuple[tuple[int, int], ...]:
    """[start, stop) of each run of at least ``minimum`` samples without NaN."""
    present = ~np.isnan(values)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], present.astype(np.int8), [0]))))
    return tuple(
        (int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a >= minimum
    )


def with_posterior(base: ThermalCalibration, fit: ThermalFit) -> ThermalCalibration:
    """``base`` with the posterior ``fit`` in place of its own."""
    noise = {
        "terms": base.noise["terms"],
        **{
            name: {"mean": m, "q05": lo, "q95": hi, "unit": parameter_unit(name, base.unit)}
            for name, (m, lo, hi) in fit.noise.items()
        },
    }
    bayesian = {
        "map_coefficients": fit.map_coefficients,
        "map_covariance": fit.map_covariance,
        "coefficient_q05": np.quantile(fit.coefficient_draws, 0.05, axis=0),
        "coefficient_q95": np.quantile(fit.coefficient_draws, 0.95, axis=0),
        "degree_scores": {
            str(d): {"elpd": e, "se_difference": se} for d, (e, se) in fit.degree_scores.items()
        },
        "diagnostics": fit.diagnostics.as_dict(),
    }
    if fit.coefficient_mixture_sd is not None:
        bayesian["coefficient_mixture_sd"] = fit.coefficient_mixture_sd
    return replace(
        base,
        degree=fit.degree,
        reference=fit.reference,
        coefficients=fit.coefficient_mean,
        covariance=fit.coefficient_covariance,
        noise=noise,
        bayesian=to_jsonable(bayesian),
        posterior=fit,
    )


def load_thermal_calibration(
    path,
    *,
    unit: str | None = None,
    channel: str | None = None,
    temperature_unit: str | None = None,
) -> ThermalCalibration:
    """Read a calibration file written by :meth:`ThermalCalibration.save` (or ``bayescal
    thermal fit``), checked field by field against its schema; with ``unit``, ``channel``
    and ``temperature_unit``, also that it was made for a channel of that name and unit and
    for temperatures in that unit.

    Parameters
    ----------
    path : str or Path
        The calibration file (JSON, schema ``bayescal.thermal_calibration``).
    unit : str, optional
        The unit of the channel it must have been made for.
    channel : str, optional
        The channel it must have been made for.
    temperature_unit : str, optional
        The temperature unit it must use.

    Returns
    -------
    ThermalCalibration
        The calibration, with ``origin`` the file.

    Raises
    ------
    InputError
        No such file, not JSON, another schema or version, a field missing or malformed,
        another channel, unit or temperature unit.
    """
    source = str(path)
    document = channel_document(read_document(path), channel, source)
    calibration = replace(ThermalCalibration.from_document(document, source), origin=source)
    if channel is not None and calibration.channel != channel:
        raise InputError(
            f"the calibration was made for channel '{calibration.channel}', not '{channel}'",
            source=source,
            fix=f"use the calibration of '{channel}' (or name the channel "
            f"'{calibration.channel}' if it is the same sensor axis)",
        )
    if unit is not None and calibration.unit != unit:
        raise InputError(
            f"the calibration is in {calibration.unit} but the channel is in {unit}",
            source=source,
            fix="prepare the channel in its unit, or refit in this unit",
        )
    if temperature_unit is not None and calibration.temperature_unit != temperature_unit:
        raise InputError(
            f"the calibration's temperatures are in {calibration.temperature_unit} but the "
            f"temperature column is in {temperature_unit}",
            source=source,
            fix=f"give the temperature in {calibration.temperature_unit} (write the unit in the "
            "header, e.g. temperature[degF]), or refit",
        )
    return calibration


def save_thermal_calibrations(calibrations, path) -> Path:
    """Write the calibrations of several channels as one file (atomically), which
    :func:`load_thermal_calibration` reads channel by channel.

    Parameters
    ----------
    calibrations : iterable of ThermalCalibration or mapping of name to ThermalCalibration
        One calibration per channel, each channel once.
    path : str or Path
        The JSON file to write.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    InputError
        No calibration, or a channel given twice.

    Examples
    --------
    >>> import bayescal as bc
    >>> x = bc.ThermalCalibration.from_document(
    ...     {
    ...         "schema": "bayescal.thermal_calibration", "schema_version": 1,
    ...         "channel": "gyro_x", "unit": "deg/s", "temperature_unit": "degC",
    ...         "reference_temperature": 30.0, "degree": 0, "coefficients": [1e-5],
    ...         "covariance": [[1e-12]], "temperature_range": [20.0, 40.0],
    ...         "noise": {"terms": ["white"]}, "provenance": [],
    ...     }
    ... )
    >>> y = bc.ThermalCalibration.from_document({**x.to_document(), "channel": "gyro_y"})
    >>> path = bc.save_thermal_calibrations([x, y], "imu.json")
    >>> bc.load_thermal_calibration(path, channel="gyro_y").channel
    'gyro_y'
    """
    values = list(calibrations.values()) if isinstance(calibrations, dict) else list(calibrations)
    names = [calibration.channel for calibration in values]
    if not values or len(set(names)) != len(names):
        raise InputError(
            f"save_thermal_calibrations needs one calibration per channel, got {names}",
            fix="give each channel's calibration once",
        )
    channels = {}
    for calibration in values:
        document = calibration.to_document()
        del document["schema"], document["schema_version"]
        channels[calibration.channel] = document
    path = Path(path)
    write_json(path, {"schema": SCHEMA, "schema_version": SCHEMA_VERSION, "channels": channels})
    return path
