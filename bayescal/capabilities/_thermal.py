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
"""

import datetime
import json
import math
from dataclasses import dataclass, field, replace
from importlib.metadata import version
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._errors import HealthCheckError, InputError
from .._output import to_jsonable, write_json
from ..classical._allan import allan_deviation
from ..classical._thermal import classical_thermal
from ..inference._mcmc import batch_log_density, diagnose, sample_ensemble, walker_count
from ..inference._optimize import maximum_a_posteriori
from ..inference._priors import default_prior
from ..models._noise_model import parameter_unit
from ..models._noise_problem import NoisePrior
from ..models._terms import AUTO, check_terms, parse_terms
from ..models._thermal import (
    MAX_DEGREE,
    ThermalProblem,
    ThermalRecord,
    _blocks,
    _identified_from,
    check_temperature,
    prequential_score,
    record_spectrum,
    thermal_problem,
)
from ..models.effects.earth_rotation import earth_rate_on_axis
from ..recording._units import parse_unit

SCHEMA = "bayescal.thermal_calibration"
SCHEMA_VERSION = 1
NOISE_TERMS = ("white", "bias_instability", "rate_random_walk")


@eqx.filter_jit
def _draw_regression(problem: ThermalProblem, theta, key):
    """For each noise draw, a draw of the regression from its Gaussian conditional; also the
    conditional means and covariances, whose mixture is the posterior."""

    def one(theta_one, key_one):
        precision, mean, _, _ = problem.conditional(theta_one)
        covariance = jnp.linalg.inv(precision)
        draw = mean + jnp.linalg.cholesky(covariance) @ jax.random.normal(key_one, mean.shape)
        return draw, mean, covariance

    keys = jax.random.split(key, theta.shape[0])
    return jax.vmap(one)(theta, keys)


@dataclass(frozen=True)
class ThermalFit:
    """Posterior of the thermal coefficients c_0..c_d (and period offsets) and the noise."""

    degree: int
    reference: float
    coefficient_mean: np.ndarray
    coefficient_covariance: np.ndarray
    coefficient_draws: np.ndarray
    """(draws, d + 1)"""
    offset_mean: np.ndarray
    offset_sd: np.ndarray
    noise: dict
    """noise parameter -> (mean, q05, q95) in the channel's units"""
    map_coefficients: np.ndarray
    map_covariance: np.ndarray
    """Conditional covariance of the coefficients at the MAP noise (the Laplace answer)."""
    diagnostics: object
    degree_scores: dict
    """degree -> (elpd, se of the difference to the best) when the degree was chosen"""
    drift: tuple[float, float, float] | None = None
    """Learned drift scale s since the prior calibration: (mean, q05, q95), channel units."""


def sample_thermal(
    problem: ThermalProblem,
    degree: int,
    reference: float,
    *,
    seed: int,
    max_steps: int = 40_000,
    progress: bool = False,
    degree_scores: dict | None = None,
) -> ThermalFit:
    """MAP and Laplace for the noise, emcee posterior, regression draws; checked."""
    mode = maximum_a_posteriori(ThermalProblem.log_posterior, problem, problem.location)
    best, converged = mode.theta, mode.converged
    start, covariance = mode.theta, mode.covariance
    rng = np.random.default_rng(seed)
    sampler, done = sample_ensemble(
        batch_log_density(ThermalProblem.log_posterior, problem),
        start,
        covariance,
        rng,
        walker_count(start.size),
        max_steps,
        progress,
    )
    names = problem.parameters
    diagnostics, kept = diagnose(sampler, names, done, bool(converged))
    flat_theta = kept.reshape(-1, kept.shape[-1])
    draws, means, covariances = (
        np.asarray(x)
        for x in _draw_regression(
            problem, jnp.asarray(flat_theta), jax.random.PRNGKey(int(rng.integers(2**31)))
        )
    )
    # The posterior of the regression is the mixture of its conditionals over the noise draws.
    mean = means.mean(axis=0)
    covariance_total = covariances.mean(axis=0) + np.cov(means.T, bias=True).reshape(
        covariances.shape[1:]
    )
    coefficients = slice(0, degree + 1)
    precision_map, mean_map, _, _ = problem.conditional(best)
    map_covariance = np.linalg.inv(np.asarray(precision_map))
    natural = {
        name: np.asarray(value) for name, value in problem.natural(jnp.asarray(flat_theta)).items()
    }
    drift = None
    if problem.learns_drift:
        scale = np.asarray(problem.drift(jnp.asarray(flat_theta)))
        drift = tuple(float(x) for x in (scale.mean(), *np.quantile(scale, [0.05, 0.95])))
    return ThermalFit(
        degree=degree,
        reference=reference,
        coefficient_mean=mean[coefficients],
        coefficient_covariance=covariance_total[coefficients, coefficients],
        coefficient_draws=draws[:, coefficients],
        offset_mean=mean[degree + 1 :],
        offset_sd=np.sqrt(np.diag(covariance_total)[degree + 1 :]),
        noise={
            name: (float(v.mean()), float(np.quantile(v, 0.05)), float(np.quantile(v, 0.95)))
            for name, v in natural.items()
        },
        map_coefficients=np.asarray(mean_map)[coefficients],
        map_covariance=map_covariance[coefficients, coefficients],
        diagnostics=diagnostics,
        degree_scores=degree_scores or {},
        drift=drift,
    )


def choose_degree(
    record: ThermalRecord, reference: float, *, noise_prior: NoisePrior
) -> tuple[int, dict]:
    """The lowest degree whose prequential ELPD is within max(4, 2 SE) of the best. Under the
    flat prior a degree has a predictive only once the blocks so far identify its
    coefficients: scoring starts where every candidate is identified, and a degree the first
    half of the blocks cannot identify is no candidate (absent from the table)."""
    blocks = _blocks(record)[0].size
    spectral = record_spectrum(record)
    problems = {}
    for degree in range(MAX_DEGREE + 1):
        problem = thermal_problem(
            record, degree, reference, noise_prior=noise_prior, spectral=spectral
        )
        if _identified_from(problem.design) > blocks // 2:
            break
        problems[degree] = problem
    skip = max(
        MAX_DEGREE + 2,
        math.ceil(0.1 * blocks),
        *(_identified_from(problem.design) for problem in problems.values()),
    )
    scores = {}
    for degree, problem in problems.items():
        mode = maximum_a_posteriori(ThermalProblem.log_posterior, problem, problem.location)
        scores[degree] = prequential_score(problem, mode.theta, skip)
    best = max(scores, key=lambda d: scores[d].sum())
    table = {}
    for degree, pointwise in scores.items():
        difference = scores[best] - pointwise
        table[degree] = (
            float(pointwise.sum()),
            float(math.sqrt(difference.size * np.var(difference))),
        )
    chosen = min(d for d, (elpd, se) in table.items() if table[best][0] - elpd < max(4.0, 2 * se))
    return chosen, table


def _coefficient_units(unit: str, temperature_unit: str, degree: int) -> list[str]:
    return [unit] + [
        f"{unit}/{temperature_unit}" + (f"^{j}" if j > 1 else "") for j in range(1, degree + 1)
    ]


def _provenance(step: str, *, source: str, channel: str, n_samples: int, seed, extra: dict):
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
class ThermalCalibration:
    """A thermal bias calibration: the polynomial bias(T) = sum_j c_j (T - T0)^j with its
    posterior covariance, the noise beside it, and how it was made.

    Made by :func:`fit_thermal`, refreshed by :meth:`update`, read by
    :func:`load_thermal_calibration`; :meth:`bias` evaluates it, :meth:`compensate` applies it,
    :meth:`save` writes its file. ``coefficients`` are in the units of
    ``coefficient_units``.
    """

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

    def check(self) -> "ThermalCalibration":
        """Raise :class:`~bayescal.HealthCheckError` naming the failed checks, if any.

        Returns
        -------
        ThermalCalibration
            This result, unchanged, when every check passed, so that the call chains
            (``result = capability(...).check()``).

        Raises
        ------
        HealthCheckError
            A check failed; the message names each.
        """
        if not self.passed:
            raise HealthCheckError(
                "thermal calibration: posterior checks failed: " + "; ".join(self.failures)
            )
        return self

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

    def compensate(self, y, temperature) -> tuple[np.ndarray, np.ndarray]:
        """The channel ``y`` less its thermal bias (and the Earth rate, when the calibration
        took it off), with the bias's posterior sd per sample.

        Parameters
        ----------
        y : array_like
            The channel's samples, the calibration's unit.
        temperature : array_like
            The temperature at each sample, ``temperature_unit``.

        Returns
        -------
        compensated, sd : numpy.ndarray
            The compensated samples and the sd of the bias taken off each, the channel's
            unit.
        """
        bias, sd = self.bias(temperature)
        earth = self.earth_rate["value"] if self.earth_rate else 0.0
        return np.asarray(y, dtype=float) - bias - earth, sd

    def update(
        self,
        y,
        temperature,
        rate_hz: float,
        *,
        periods: tuple[tuple[int, int], ...] | None = None,
        offsets: list | None = None,
        drift: float | str | None = "auto",
        seed: int = 0,
        source: str = "<array>",
        progress: bool = False,
    ) -> "ThermalCalibration":
        """The calibration updated with alignment data taken in service.

        Parameters
        ----------
        y, temperature : array_like
            The channel (its unit) and its temperature, on one sample grid; NaN marks a
            missing sample. The Earth rate this calibration took off (if any) is taken off
            ``y`` too.
        rate_hz : float
            Sample rate, Hz.
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

        Returns
        -------
        ThermalCalibration
            The new calibration; its provenance continues this one's.
        """
        values = np.asarray(y, dtype=float)
        temperature = np.asarray(temperature, dtype=float)
        if self.earth_rate:
            values = values - self.earth_rate["value"]
        periods = periods or gap_free_runs(values)
        offsets = list(offsets) if offsets is not None else [None] * len(periods)
        record = ThermalRecord(values, temperature, rate_hz, tuple(periods))
        parameters = tuple(name for name in ("Q", "N", "F", "B", "K") if name in self.noise)
        # The noise as the calibration measured it: log-normal around its posterior mean with
        # the spread of its 90 % interval (F: normal on atanh).
        location, scale = [], []
        for name in parameters:
            mean, low, high = (self.noise[name][key] for key in ("mean", "q05", "q95"))
            if name == "F":
                location.append(math.atanh(mean))
                scale.append(max((math.atanh(high) - math.atanh(low)) / 3.29, 0.01))
            else:
                location.append(math.log(mean))
                scale.append(max(math.log(high / low) / 3.29, 0.01))
        noise_prior = NoisePrior(
            np.array(location),
            np.array(scale),
            np.asarray(1.0),
            parameters,
            # A fixed text: it is a static field of the problem, and a path in it would make
            # every calibration file compile its own likelihood (the provenance names it).
            "the noise of the prior calibration",
        )
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
        fit = sample_thermal(problem, self.degree, self.reference, seed=seed, progress=progress)
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
        step = _provenance(
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
            _from_fit(self, fit),
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
        document = {
            "schema": SCHEMA,
            "schema_version": SCHEMA_VERSION,
            "channel": self.channel,
            "unit": self.unit,
            "temperature_unit": self.temperature_unit,
            "reference_temperature": self.reference,
            "degree": self.degree,
            "coefficients": self.coefficients,
            "coefficient_units": self.coefficient_units,
            "covariance": self.covariance,
            "temperature_range": list(self.temperature_range),
            "noise": self.noise,
            "earth_rate": self.earth_rate,
            "provenance": list(self.provenance),
            "bayesian": self.bayesian,
        }
        for key in ("classical", "offsets", "drift"):
            if getattr(self, key) is not None:
                document[key] = getattr(self, key)
        return to_jsonable(document)

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
        _check_document(document, source)
        return cls(
            channel=document["channel"],
            unit=document["unit"],
            temperature_unit=document["temperature_unit"],
            reference=float(document["reference_temperature"]),
            degree=int(document["degree"]),
            coefficients=np.asarray(document["coefficients"], dtype=float),
            covariance=np.asarray(document["covariance"], dtype=float),
            temperature_range=tuple(float(t) for t in document["temperature_range"]),
            noise=document["noise"],
            earth_rate=document.get("earth_rate"),
            provenance=tuple(document["provenance"]),
            bayesian=document.get("bayesian") or {},
            classical=document.get("classical"),
            offsets=document.get("offsets"),
            drift=document.get("drift"),
        )


_FIX = "give a file written by bayescal thermal fit (or repair that field)"


def _field_error(source: str, name: str, problem: str) -> InputError:
    return InputError(f"field '{name}' {problem}", source=source, fix=_FIX)


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _finite_number(document: dict, name: str, source: str) -> float:
    value = document[name]
    if not _is_number(value) or not math.isfinite(value):
        raise _field_error(source, name, f"must be a finite number, not {value!r}")
    return float(value)


def _numbers(value, shape: tuple[int, ...], name: str, source: str) -> np.ndarray:
    """``value`` as a finite float array of ``shape``, or an error naming the field."""

    def numbers_only(item) -> bool:
        if isinstance(item, list):
            return all(numbers_only(element) for element in item)
        return _is_number(item)

    if not numbers_only(value):
        raise _field_error(source, name, f"must hold numbers only, not {value!r:.60}")
    try:
        array = np.asarray(value, dtype=float)
    except ValueError:  # ragged rows
        array = np.zeros(0)
    if array.shape != shape:
        raise _field_error(
            source, name, f"must hold {' x '.join(map(str, shape))} numbers, not {value!r:.60}"
        )
    if not np.all(np.isfinite(array)):
        raise _field_error(source, name, "holds a value that is not finite (NaN or inf)")
    return array


def _check_noise(noise, source: str) -> None:
    if not isinstance(noise, dict):
        raise _field_error(source, "noise", "must be an object")
    terms = noise.get("terms")
    if not isinstance(terms, list) or not all(isinstance(term, str) for term in terms):
        raise _field_error(source, "noise.terms", "must be a list of noise term names")
    for name in ("Q", "N", "F", "B", "K"):
        if name not in noise:
            continue
        entry = noise[name]
        if not isinstance(entry, dict):
            raise _field_error(source, f"noise.{name}", "must be an object with mean, q05, q95")
        for key in ("mean", "q05", "q95"):
            value = entry.get(key)
            if not _is_number(value) or not math.isfinite(value):
                raise _field_error(
                    source, f"noise.{name}.{key}", f"must be a finite number, not {value!r}"
                )
            inside = -1 < value < 1 if name == "F" else value > 0
            if not inside:
                what = "lie between -1 and 1" if name == "F" else "be positive"
                raise _field_error(source, f"noise.{name}.{key}", f"must {what}, not {value!r}")
        if not entry["q05"] <= entry["q95"]:
            raise _field_error(source, f"noise.{name}", "has q05 above q95")


def _check_document(document, source: str) -> None:
    """The schema of a calibration file, field by field (see the module's docstring)."""
    if not isinstance(document, dict):
        kind = {list: "a list", type(None): "null", str: "a string", bool: "a boolean"}.get(
            type(document), "a number"
        )
        raise InputError(
            f"not a bayescal thermal calibration: the file holds {kind}, not an object",
            source=source,
            fix="give a file written by bayescal thermal fit",
        )
    if document.get("schema") != SCHEMA:
        raise InputError(
            f"not a bayescal thermal calibration (schema {document.get('schema')!r})",
            source=source,
            fix="give a file written by bayescal thermal fit",
        )
    if document.get("schema_version") != SCHEMA_VERSION:
        raise InputError(
            f"calibration schema version {document.get('schema_version')!r}; this "
            f"bayescal reads version {SCHEMA_VERSION}",
            source=source,
            fix="refit with this version (bayescal thermal fit)",
        )
    required = (
        "channel",
        "unit",
        "temperature_unit",
        "reference_temperature",
        "degree",
        "coefficients",
        "covariance",
        "temperature_range",
        "noise",
        "provenance",
    )
    for name in required:
        if name not in document:
            raise _field_error(source, name, "is missing")
    for name in ("channel", "unit", "temperature_unit"):
        if not isinstance(document[name], str) or not document[name].strip():
            raise _field_error(source, name, f"must be a name, not {document[name]!r}")
    if parse_unit(document["temperature_unit"]).quantity != "temperature":
        raise _field_error(
            source,
            "temperature_unit",
            f"{document['temperature_unit']!r} is not a temperature unit",
        )
    _finite_number(document, "reference_temperature", source)
    degree = document["degree"]
    if not isinstance(degree, int) or isinstance(degree, bool) or not 0 <= degree <= MAX_DEGREE:
        raise _field_error(
            source, "degree", f"must be a whole number 0..{MAX_DEGREE}, not {degree!r}"
        )
    size = degree + 1
    _numbers(document["coefficients"], (size,), "coefficients", source)
    covariance = _numbers(document["covariance"], (size, size), "covariance", source)
    scale = float(np.max(np.abs(covariance))) or 1.0
    if not np.allclose(covariance, covariance.T, rtol=1e-8, atol=1e-12 * scale):
        raise _field_error(source, "covariance", "is not symmetric")
    if np.min(np.linalg.eigvalsh(covariance)) < -1e-9 * scale:
        raise _field_error(
            source, "covariance", "is not positive semi-definite (a variance below zero)"
        )
    low, high = _numbers(document["temperature_range"], (2,), "temperature_range", source)
    if low > high:
        raise _field_error(source, "temperature_range", "must be [lowest, highest]")
    _check_noise(document["noise"], source)
    earth = document.get("earth_rate")
    if earth is not None and (
        not isinstance(earth, dict)
        or not _is_number(earth.get("value"))
        or not math.isfinite(earth["value"])
    ):
        raise _field_error(source, "earth_rate", "must be null or an object with a finite value")
    if not isinstance(document["provenance"], list) or not all(
        isinstance(step, dict) for step in document["provenance"]
    ):
        raise _field_error(source, "provenance", "must be a list of steps (objects)")
    for name in ("bayesian", "classical", "offsets", "drift"):
        if document.get(name) is not None and not isinstance(document[name], dict):
            raise _field_error(source, name, "must be an object (or absent)")


def gap_free_runs(values: np.ndarray, minimum: int = 16) -> tuple[tuple[int, int], ...]:
    """[start, stop) of each run of at least ``minimum`` samples without NaN."""
    present = ~np.isnan(values)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], present.astype(np.int8), [0]))))
    return tuple(
        (int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a >= minimum
    )


def _from_fit(base: ThermalCalibration, fit: ThermalFit) -> ThermalCalibration:
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


def fit_thermal(
    y,
    temperature,
    rate_hz: float,
    *,
    degree: int | str = "auto",
    reference: float | None = None,
    terms=NOISE_TERMS,
    unit: str = "deg/s",
    temperature_unit: str = "degC",
    channel: str = "gyro",
    latitude: float | None = None,
    axis: str = "up",
    confidence: float = 0.95,
    seed: int = 0,
    source: str = "<array>",
    temperature_name: str = "temperature",
    progress: bool = False,
) -> ThermalCalibration:
    """Fit a thermal bias calibration of a gyro channel.

    Parameters
    ----------
    y : array_like
        The gyro channel (``unit``), NaN where a sample is missing.
    temperature : array_like
        Its temperature on the same grid (``temperature_unit``); it must change.
    rate_hz : float
        Sample rate, Hz.
    degree : int or "auto"
        Polynomial degree 0..4, or chosen by one-block-ahead predictive density.
    reference : float, optional
        T0 (default: the middle of the temperature range, to 0.1).
    terms : str or tuple of str
        Noise terms beside the thermal bias (as :func:`fit_noise`; no ramp: a ramp cannot
        be told from a thermal drift).
    unit, temperature_unit, channel : str
        Units and the channel's name, written into the calibration.
    latitude : float, optional
        Take the Earth rate off the channel first (degrees), with ``axis`` the gyro axis's
        direction (up, down, north, south, east, west, or east,north,up components).
    confidence : float
        Confidence of the classical intervals.
    seed : int
        Seed of the sampler: the same inputs and seed give the same calibration.
    source, temperature_name : str
        Where the data come from, for the provenance and the messages.

    Returns
    -------
    ThermalCalibration
        The calibration, its classical answer and its posterior's checks
        (:meth:`~ThermalCalibration.check`).

    Raises
    ------
    InputError
        A constant temperature, an unknown term, a ramp among the terms, a degree out of
        range, too few blocks for the degree.

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
    noise_terms = parse_terms(terms) if isinstance(terms, str) else check_terms(tuple(terms))
    if noise_terms == AUTO:
        raise InputError(
            "--terms auto: a thermal calibration takes its noise terms as given",
            fix=f"name them (default: {','.join(NOISE_TERMS)})",
        )
    if "rate_ramp" in noise_terms:
        raise InputError("--terms: a ramp cannot be told from a thermal drift; leave it out")
    if degree != "auto" and not (
        isinstance(degree, (int, np.integer)) and 0 <= degree <= MAX_DEGREE
    ):
        raise InputError(f"--degree {degree!r}", fix=f"give auto or a whole number 0..{MAX_DEGREE}")
    values = np.asarray(y, dtype=float)
    temperature = np.asarray(temperature, dtype=float)
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
        problem, chosen, reference, seed=seed, progress=progress, degree_scores=scores
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
            _provenance(
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
    return _from_fit(base, fit)


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
    try:
        document = json.loads(Path(path).read_text(encoding="utf-8-sig"))
    except FileNotFoundError:
        raise InputError("no such calibration file", source=source, fix="check the path") from None
    except IsADirectoryError:
        raise InputError(
            "is a folder, not a calibration file", source=source, fix="check the path"
        ) from None
    except PermissionError:
        raise InputError("cannot be read (permission denied)", source=source) from None
    except UnicodeDecodeError:
        raise InputError(
            "not a JSON calibration file (it is not text)",
            source=source,
            fix="give a file written by bayescal thermal fit",
        ) from None
    except json.JSONDecodeError as error:
        raise InputError(
            f"not a JSON calibration file: {error}",
            source=source,
            fix="give a file written by bayescal thermal fit",
        ) from None
    document = _channel_document(document, channel, source)
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
            fix="pass --unit to match, or refit in this unit",
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


def _channel_document(document, channel: str | None, source: str):
    """The fields of one channel: the document itself, or, for a file of several channels, the
    one named ``channel`` (the only one when there is one)."""
    if not (
        isinstance(document, dict) and document.get("schema") == SCHEMA and "channels" in document
    ):
        return document
    channels = document["channels"]
    if not isinstance(channels, dict) or not channels:
        raise _field_error(source, "channels", "must map each channel's name to its calibration")
    if channel is None and len(channels) == 1:
        channel = next(iter(channels))
    if channel not in channels:
        held = ", ".join(map(str, channels))
        raise InputError(
            f"the file holds the calibrations of {held}"
            + ("" if channel is None else f", not of '{channel}'"),
            source=source,
            fix="name one of its channels"
            if channel is None
            else f"use a calibration of '{channel}'",
        )
    entry = channels[channel]
    if not isinstance(entry, dict):
        raise _field_error(source, f"channels.{channel}", "must be an object")
    return {"schema": SCHEMA, "schema_version": document.get("schema_version"), **entry}


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
