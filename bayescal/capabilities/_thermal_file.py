"""A thermal calibration's file (JSON, ``schema: bayescal.thermal_calibration``,
``schema_version: 1``; :mod:`._thermal` describes its fields): its layout
(:func:`document_of`, :func:`fields_of`), its reading (:func:`read_document`) and its schema,
checked field by field before a calibration is made of it (:func:`check_document`: finite
numbers, sizes that match the degree, a symmetric positive semi-definite covariance, a
temperature unit). A field that fails raises :class:`~bayescal.InputError` naming it and the
file; a missing file, one that is also a :class:`FileNotFoundError`."""

import json
import math
from pathlib import Path

import numpy as np

from .._errors import InputError, MissingFileError
from .._output import to_jsonable
from ..models._terms import PARAMETERS, TERMS, term_parameters
from ..models._thermal import MAX_DEGREE
from ..models.effects._parameter import Context
from ..recording._units import parse_unit

SCHEMA = "bayescal.thermal_calibration"
SCHEMA_VERSION = 1


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
    unknown = [term for term in terms if term not in TERMS]
    if unknown:
        raise _field_error(source, "noise.terms", f"names an unknown term {unknown[0]!r}")
    for name in (p for p in term_parameters(tuple(terms)) if p in noise):
        entry = noise[name]
        if not isinstance(entry, dict):
            raise _field_error(source, f"noise.{name}", "must be an object with mean, q05, q95")
        for key in ("mean", "q05", "q95"):
            value = entry.get(key)
            if not _is_number(value) or not math.isfinite(value):
                raise _field_error(
                    source, f"noise.{name}.{key}", f"must be a finite number, not {value!r}"
                )
            low, high = _free_bounds(name)
            if not low < value < high:
                raise _field_error(
                    source, f"noise.{name}.{key}", f"must lie in ({low:g}, {high:g}), not {value!r}"
                )
        if not entry["q05"] <= entry["q95"]:
            raise _field_error(source, f"noise.{name}", "has q05 above q95")


def _free_bounds(name: str) -> tuple[float, float]:
    """A noise parameter's range where it does not depend on the record (F in (0, 1), a
    scale positive); the widest range where it does."""
    parameter = PARAMETERS[name]
    if isinstance(parameter.span, str):
        return (0.0 if parameter.link in ("log", "log_logit") else -math.inf), math.inf
    return parameter.bounds(Context(1.0))


def check_document(document, source: str) -> None:
    """The schema of a calibration file, field by field (see the module's docstring).

    About 80 lines: one check per field, in the order of the module's docstring.
    """
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


def read_document(path) -> dict:
    """The JSON content of the calibration file ``path``; a file that is missing, a folder,
    unreadable or not JSON raises an error naming it."""
    source = str(path)
    try:
        return json.loads(Path(path).read_text(encoding="utf-8-sig"))
    except FileNotFoundError:
        raise MissingFileError("no such calibration file", source=source) from None
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


def channel_document(document, channel: str | None, source: str):
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
        held = ", ".join(repr(str(name)) for name in channels)
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


def document_of(calibration) -> dict:
    """The file's content of a :class:`~bayescal.ThermalCalibration` (the layout of schema
    version 1; arrays as NumPy arrays, written as lists)."""
    document = {
        "schema": SCHEMA,
        "schema_version": SCHEMA_VERSION,
        "channel": calibration.channel,
        "unit": calibration.unit,
        "temperature_unit": calibration.temperature_unit,
        "reference_temperature": calibration.reference,
        "degree": calibration.degree,
        "coefficients": calibration.coefficients,
        "coefficient_units": calibration.coefficient_units,
        "covariance": calibration.covariance,
        "temperature_range": list(calibration.temperature_range),
        "noise": calibration.noise,
        "earth_rate": calibration.earth_rate,
        "provenance": list(calibration.provenance),
        "bayesian": calibration.bayesian,
    }
    for key in ("classical", "offsets", "drift"):
        if getattr(calibration, key) is not None:
            document[key] = getattr(calibration, key)
    return to_jsonable(document)


def fields_of(document: dict, source: str) -> dict:
    """The fields of a :class:`~bayescal.ThermalCalibration` from the file's content
    ``document``, checked field by field first (:func:`check_document`)."""
    check_document(document, source)
    return dict(
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
