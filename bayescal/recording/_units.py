"""Units of IMU channels and of the noise parameters derived from them.

A channel's unit U is either one bayescal knows (angular rate, acceleration, angle, velocity,
temperature, time) or an opaque label such as ``LSB``; opaque units are carried through
unchanged and never converted. Noise-parameter units follow IEEE Std 952 / ../shared/DESIGN.md:
Q in U·s, N in U/√Hz, B in U, K in U·√Hz, R in U/s (written in ASCII, e.g. ``deg/s/sqrt(Hz)``).
"""

import math
import re
from dataclasses import dataclass

STANDARD_GRAVITY = 9.80665  # m/s^2, CGPM 1901 (the unit "g")
DEG = math.pi / 180.0
FLICKER_ALLAN_FACTOR = 2 * math.log(2) / math.pi
"""Allan variance of flicker noise per unit B^2 (IEEE Std 952, eq. C.9)."""
BIAS_INSTABILITY_FACTOR = math.sqrt(FLICKER_ALLAN_FACTOR)
"""0.664: the floor of the Allan deviation per unit B, IEEE Std 952 eq. (C.9)."""


@dataclass(frozen=True)
class Unit:
    """A unit by canonical name, the quantity it measures and its factor to SI."""

    name: str
    quantity: str
    to_si: float

    @property
    def known(self) -> bool:
        return self.quantity != "unknown"


_KNOWN = (
    Unit("deg/s", "angular_rate", DEG),
    Unit("rad/s", "angular_rate", 1.0),
    Unit("deg/h", "angular_rate", DEG / 3600.0),
    Unit("mrad/s", "angular_rate", 1e-3),
    Unit("m/s^2", "acceleration", 1.0),
    Unit("g", "acceleration", STANDARD_GRAVITY),
    Unit("mg", "acceleration", 1e-3 * STANDARD_GRAVITY),
    Unit("µg", "acceleration", 1e-6 * STANDARD_GRAVITY),
    Unit("deg", "angle", DEG),
    Unit("rad", "angle", 1.0),
    Unit("m/s", "velocity", 1.0),
    Unit("degC", "temperature", 1.0),
    # Temperature units are compared, never converted (their zero points differ).
    Unit("degF", "temperature", 5.0 / 9.0),
    Unit("K", "temperature", 1.0),
    Unit("s", "time", 1.0),
    Unit("ms", "time", 1e-3),
    Unit("us", "time", 1e-6),
    Unit("ns", "time", 1e-9),
    Unit("min", "time", 60.0),
    Unit("h", "time", 3600.0),
)
_BY_NAME = {unit.name: unit for unit in _KNOWN}
_ALIASES = {
    "dps": "deg/s",
    "deg/sec": "deg/s",
    "°/s": "deg/s",
    "degree/s": "deg/s",
    "degrees/s": "deg/s",
    "rad/sec": "rad/s",
    "rads": "rad/s",
    "dph": "deg/h",
    "deg/hr": "deg/h",
    "°/h": "deg/h",
    "m/s2": "m/s^2",
    "m/s²": "m/s^2",
    "m/s/s": "m/s^2",
    "mps2": "m/s^2",
    "m s^-2": "m/s^2",
    "m/s**2": "m/s^2",
    "ug": "µg",
    "μg": "µg",
    "micro-g": "µg",
    "milli-g": "mg",
    "°c": "degC",
    "c": "degC",
    "degc": "degC",
    "deg c": "degC",
    "celsius": "degC",
    "°f": "degF",
    "degf": "degF",
    "deg f": "degF",
    "fahrenheit": "degF",
    "kelvin": "K",
    "sec": "s",
    "µs": "us",
    "μs": "us",
}
# Unit suffixes seen in column names such as ``gyro_x_dps`` or ``acc_x_mps2``.
_CASELESS = {name.lower(): name for name in _BY_NAME if name not in ("g", "mg", "µg")}
_NAME_SUFFIXES = {
    "dps": "deg/s",
    "degs": "deg/s",
    "rads": "rad/s",
    "mps2": "m/s^2",
    "g": "g",
    "ms2": "m/s^2",
    "c": "degC",
    "degc": "degC",
    "s": "s",
    "ms": "ms",
    "us": "us",
}

_INTEGRAL = {
    "deg/s": "deg",
    "rad/s": "rad",
    "deg/h": "deg*s/h",
    "mrad/s": "mrad",
    "m/s^2": "m/s",
    "g": "g*s",
    "mg": "mg*s",
    "µg": "µg*s",
}
_PER_SECOND = {"deg/s": "deg/s^2", "rad/s": "rad/s^2", "m/s^2": "m/s^3"}

NOISE_PARAMETERS = ("Q", "N", "B", "K", "R")
# Opaque units that are expected: a converter's counts, an analog output's volts.
_COUNT_UNITS = {"lsb", "lsbs", "count", "counts", "cnt", "digits", "raw", "adc", "a.u.", "au"}
_COUNT_UNITS |= {"v", "mv", "dn"}


def is_count_unit(text: str) -> bool:
    """Whether ``text`` names raw counts (LSB, counts ...) or volts: units bayescal carries
    without converting, and without a note."""
    return text.strip().lower() in _COUNT_UNITS


def parse_unit(text: str) -> Unit:
    """Return the :class:`Unit` that ``text`` names; an unrecognised text is an opaque unit.

    Canonical names match exactly, aliases (``dps``, ``m/s2``, ``°C`` ...) in any case; ``g``
    and ``mg`` match only in lower case, since ``G`` is also the gauss.
    """
    cleaned = text.strip()
    if cleaned in _BY_NAME:
        return _BY_NAME[cleaned]
    name = _ALIASES.get(cleaned.lower()) or _CASELESS.get(cleaned.lower())
    if name is not None:
        return _BY_NAME[name]
    return Unit(cleaned, "unknown", math.nan)


def unit_from_column_suffix(column: str) -> str | None:
    """Unit named by a column's trailing ``_<unit>`` part (``gyro_x_dps`` -> ``deg/s``)."""
    head, _, suffix = column.rpartition("_")
    if not head:
        return None
    return _NAME_SUFFIXES.get(suffix.lower())


def integral_unit(unit: str) -> str:
    """Unit of the time integral of a quantity in ``unit`` (deg/s -> deg)."""
    return _INTEGRAL.get(unit, f"{unit}*s")


def noise_parameter_unit(parameter: str, unit: str) -> str:
    """Unit of noise parameter Q, N, B, K or R for a rate signal in ``unit`` (IEEE Std 952),
    or of the output filter coefficient F."""
    match parameter:
        case "Q":
            return integral_unit(unit)
        case "N":
            return f"{unit}/sqrt(Hz)"
        case "B" | "bias":
            return unit
        case "K":
            return f"{unit}*sqrt(Hz)"
        case "R":
            return _PER_SECOND.get(unit, f"{unit}/s")
        case "F":
            return "1"  # the output filter's coefficient is a pure number
    raise ValueError(f"unknown noise parameter {parameter!r}; expected one of {NOISE_PARAMETERS}")


# Conventional display units: per quantity and parameter, (unit label, factor from SI).
_DISPLAY = {
    "angular_rate": {
        "N": (("deg/sqrt(h)", 60.0 / DEG),),
        "B": (("deg/h", 3600.0 / DEG),),
        "K": (("deg/h/sqrt(h)", 3600.0**1.5 / DEG),),
        "Q": (("arcsec", 3600.0 / DEG),),
        "R": (("deg/h^2", 3600.0**2 / DEG),),
    },
    "acceleration": {
        "N": (("µg/sqrt(Hz)", 1e6 / STANDARD_GRAVITY), ("m/s/sqrt(h)", 60.0)),
        "B": (("µg", 1e6 / STANDARD_GRAVITY),),
        "K": (("µg*sqrt(Hz)", 1e6 / STANDARD_GRAVITY),),
        "Q": (("m/s", 1.0),),
        "R": (("µg/s", 1e6 / STANDARD_GRAVITY),),
    },
}


def display_values(parameter: str, value: float, unit: str) -> dict[str, float]:
    """The value of noise parameter ``parameter`` in the units IMU datasheets use.

    ``value`` is in :func:`noise_parameter_unit` of ``unit``; the result maps each
    conventional unit (deg/sqrt(h), deg/h, µg/sqrt(Hz) ...) to the converted value and is
    empty for units bayescal does not know.
    """
    parsed = parse_unit(unit)
    table = _DISPLAY.get(parsed.quantity, {}).get(parameter, ())
    return {label: value * parsed.to_si * factor for label, factor in table}


# Units sensor cards (datasheets) give noise parameters in -> factor to SI parameter units
# (rad/s or m/s^2 based; sqrt(Hz) = 1/sqrt(s)).
_CARD_UNITS = {
    "N": {
        "deg/s/sqrt(Hz)": DEG,
        "mdps/sqrt(Hz)": 1e-3 * DEG,
        "rad/s/sqrt(Hz)": 1.0,
        "deg/h/sqrt(Hz)": DEG / 3600.0,
        "deg/sqrt(h)": DEG / 60.0,
        "ug/sqrt(Hz)": 1e-6 * STANDARD_GRAVITY,
        "mg/sqrt(Hz)": 1e-3 * STANDARD_GRAVITY,
        "m/s^2/sqrt(Hz)": 1.0,
        "m/s/sqrt(h)": 1.0 / 60.0,
        "ft/s/sqrt(h)": 0.3048 / 60.0,
    },
    "B": {
        "deg/h": DEG / 3600.0,
        "deg/s": DEG,
        "mg": 1e-3 * STANDARD_GRAVITY,
        "ug": 1e-6 * STANDARD_GRAVITY,
        "m/s^2": 1.0,
    },
    "K": {
        "deg/h/sqrt(h)": DEG / 3600.0**1.5,
        "deg/s*sqrt(Hz)": DEG,
        "ug*sqrt(Hz)": 1e-6 * STANDARD_GRAVITY,
        "m/s^2*sqrt(Hz)": 1.0,
    },
}


def card_value_in(parameter: str, value: float, card_unit: str, channel_unit: str) -> float:
    """A datasheet value of noise parameter N, B or K, converted to the parameter's unit for
    a channel in ``channel_unit`` (:func:`noise_parameter_unit`)."""
    factors = _CARD_UNITS[parameter]
    if card_unit not in factors:
        raise ValueError(
            f"unit '{card_unit}' is not one a sensor card may give {parameter} in; "
            f"use one of {', '.join(factors)}"
        )
    channel = parse_unit(channel_unit)
    if not channel.known:
        raise ValueError(f"the channel's unit '{channel_unit}' is not a physical unit")
    return value * factors[card_unit] / channel.to_si


_NUMBER = r"[-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?"
_MEASUREMENT = re.compile(rf"\s*({_NUMBER})\s*(?:(?:±|\+-|\+/-)\s*({_NUMBER}))?\s*")


def parse_measurement(text: str) -> tuple[float, float | None]:
    """'VALUE±U' (also written VALUE+-U or VALUE+/-U) -> (value, uncertainty or None)."""
    match = _MEASUREMENT.fullmatch(text)
    if match is None:
        raise ValueError(f"{text!r} is not VALUE or VALUE±UNCERTAINTY")
    return float(match[1]), float(match[2]) if match[2] is not None else None
