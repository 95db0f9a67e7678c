"""Units of IMU channels, and the algebra that converts the units derived from them.

A channel's unit U is either one bayescal knows (angular rate, acceleration, angle, velocity,
temperature, time) or an opaque label such as ``LSB``; opaque units are carried through
unchanged and never converted. A noise parameter's unit is U times a power of time (IEEE Std
952 / ../shared/DESIGN.md; :func:`time_scaled_unit`, written in ASCII, e.g.
``deg/s/sqrt(Hz)``); which power is the noise term's to say
(:mod:`bayescal.models.effects`), and :func:`convert` turns a value between any two units of
one dimension (a datasheet's ``deg/h/sqrt(h)``, a display's ``deg/sqrt(h)``).
"""

import math
import re
from dataclasses import dataclass

STANDARD_GRAVITY = 9.80665  # m/s^2, CGPM 1901 (the unit "g")
DEG = math.pi / 180.0


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


def per_second_unit(unit: str) -> str:
    """Unit of the time derivative of a quantity in ``unit`` (deg/s -> deg/s^2)."""
    return _PER_SECOND.get(unit, f"{unit}/s")


def time_scaled_unit(unit: str, time_power: float) -> str:
    """The unit ``unit`` times s^``time_power``, written as IEEE Std 952 writes noise
    parameters for a rate in ``unit``: s^1 the integral (deg/s -> deg), s^(1/2) a density
    (deg/s/sqrt(Hz)), s^0 the unit itself, s^(-1/2) deg/s*sqrt(Hz), s^-1 the derivative
    (deg/s^2).

    Raises
    ------
    ValueError
        A power other than those five.
    """
    named = {
        1.0: integral_unit,
        0.5: lambda u: f"{u}/sqrt(Hz)",
        0.0: lambda u: u,
        -0.5: lambda u: f"{u}*sqrt(Hz)",
        -1.0: per_second_unit,
    }
    if float(time_power) not in named:
        raise ValueError(f"time_power={time_power!r}: one of 1, 1/2, 0, -1/2, -1")
    return named[float(time_power)](unit)


DATASHEET_UNITS = {
    1.0: {"angular_rate": ("arcsec",), "acceleration": ("m/s",)},
    0.5: {"angular_rate": ("deg/sqrt(h)",), "acceleration": ("µg/sqrt(Hz)", "m/s/sqrt(h)")},
    0.0: {"angular_rate": ("deg/h",), "acceleration": ("µg",)},
    -0.5: {"angular_rate": ("deg/h/sqrt(h)",), "acceleration": ("µg*sqrt(Hz)",)},
    -1.0: {"angular_rate": ("deg/h^2",), "acceleration": ("µg/s",)},
}
"""The units IMU datasheets quote a noise figure in, by the figure's time power
(:func:`time_scaled_unit`) and the quantity of the channel: angle random walk in deg/sqrt(h),
bias instability in deg/h, rate random walk in deg/h/sqrt(h); velocity random walk in
µg/sqrt(Hz) and m/s/sqrt(h) ..."""


def datasheet_values(value: float, channel_unit: str, time_power: float) -> dict[str, float]:
    """``value``, a noise figure in ``time_scaled_unit(channel_unit, time_power)``, in each of
    the :data:`DATASHEET_UNITS` of a channel of that quantity: unit -> value; empty for a
    channel whose unit bayescal does not know."""
    quantity = parse_unit(channel_unit).quantity
    labels = DATASHEET_UNITS[float(time_power)].get(quantity, ())
    unit = time_scaled_unit(channel_unit, time_power)
    return {label: convert(value, unit, label) for label in labels}


# The unit algebra: every unit a noise figure is written in (a datasheet's, a display's, a
# channel's) as a factor to SI and the powers of its dimensions (angle, length, time), so
# that any two units of one dimension convert and two of different dimensions are refused.
# Angle is a dimension here (SI makes it a number): deg/h and 1/h must not convert.
_ANGLE, _LENGTH, _TIME = (1, 0, 0), (0, 1, 0), (0, 0, 1)
_ACCELERATION = (0, 1, -2)
_ATOMS = {
    "rad": (1.0, _ANGLE),
    "mrad": (1e-3, _ANGLE),
    "deg": (DEG, _ANGLE),
    "arcmin": (DEG / 60.0, _ANGLE),
    "arcsec": (DEG / 3600.0, _ANGLE),
    "s": (1.0, _TIME),
    "sec": (1.0, _TIME),
    "ms": (1e-3, _TIME),
    "us": (1e-6, _TIME),
    "min": (60.0, _TIME),
    "h": (3600.0, _TIME),
    "hr": (3600.0, _TIME),
    "Hz": (1.0, (0, 0, -1)),
    "m": (1.0, _LENGTH),
    "ft": (0.3048, _LENGTH),
    "g": (STANDARD_GRAVITY, _ACCELERATION),
    "mg": (1e-3 * STANDARD_GRAVITY, _ACCELERATION),
    "ug": (1e-6 * STANDARD_GRAVITY, _ACCELERATION),
    "µg": (1e-6 * STANDARD_GRAVITY, _ACCELERATION),
    "μg": (1e-6 * STANDARD_GRAVITY, _ACCELERATION),
    "dps": (DEG, (1, 0, -1)),
    "mdps": (1e-3 * DEG, (1, 0, -1)),
    "1": (1.0, (0, 0, 0)),
}
_TOKEN = re.compile(r"\s*(sqrt\(|[A-Za-zµμ]+|[0-9.]+|[*/^()])")


def _tokens(text: str) -> list[str]:
    tokens, position = [], 0
    text = text.strip()
    while position < len(text):
        match = _TOKEN.match(text, position)
        if match is None:
            raise ValueError(f"unit {text!r}: cannot read {text[position:]!r}")
        tokens.append(match[1])
        position = match.end()
    return tokens


def _dimensioned(text: str) -> tuple[float, tuple[float, float, float]]:
    """(factor to SI, powers of angle, length and time) of a unit written with names,
    ``*``, ``/``, ``^`` and ``sqrt(...)`` (``deg/h/sqrt(h)``, ``µg*sqrt(Hz)``, ``m/s^2``);
    ``/`` and ``*`` associate to the left, ``^`` binds a name or a bracket."""
    tokens = _tokens(text)

    def power(factor, dims, exponent):
        return factor**exponent, tuple(d * exponent for d in dims)

    def atom(index):
        token = tokens[index] if index < len(tokens) else ""
        if token in ("(", "sqrt("):
            factor, dims, index = product(index + 1)
            if index >= len(tokens) or tokens[index] != ")":
                raise ValueError(f"unit {text!r}: a bracket is not closed")
            index += 1
            if token == "sqrt(":
                factor, dims = power(factor, dims, 0.5)
        elif token in _ATOMS:
            (factor, dims), index = _ATOMS[token], index + 1
        else:
            raise ValueError(f"unit {text!r}: unknown unit {token!r}")
        if index < len(tokens) and tokens[index] == "^":
            if index + 1 >= len(tokens):
                raise ValueError(f"unit {text!r}: a power without its exponent")
            factor, dims = power(factor, dims, float(tokens[index + 1]))
            index += 2
        return factor, dims, index

    def product(index):
        factor, dims, index = atom(index)
        while index < len(tokens) and tokens[index] in ("*", "/"):
            sign = 1.0 if tokens[index] == "*" else -1.0
            other, other_dims, index = atom(index + 1)
            factor *= other**sign
            dims = tuple(a + sign * b for a, b in zip(dims, other_dims, strict=True))
        return factor, dims, index

    factor, dims, index = product(0)
    if index != len(tokens):
        raise ValueError(f"unit {text!r}: unexpected {tokens[index]!r}")
    return factor, dims


def convert(value: float, from_unit: str, to_unit: str) -> float:
    """``value`` in ``from_unit`` expressed in ``to_unit`` (``deg/s/sqrt(Hz)`` to
    ``deg/sqrt(h)``: times 60); the units are read by their parts, so any two of one
    dimension convert.

    Raises
    ------
    ValueError
        A unit that cannot be read, or two units of different dimensions (the message names
        both).
    """
    (a, a_dims), (b, b_dims) = _dimensioned(from_unit), _dimensioned(to_unit)
    if any(abs(x - y) > 1e-9 for x, y in zip(a_dims, b_dims, strict=True)):
        raise ValueError(f"'{from_unit}' and '{to_unit}' measure different quantities")
    return value * a / b


_NUMBER = r"[-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?"
_MEASUREMENT = re.compile(rf"\s*({_NUMBER})\s*(?:(?:±|\+-|\+/-)\s*({_NUMBER}))?\s*")


def parse_measurement(text: str) -> tuple[float, float | None]:
    """'VALUE±U' (also written VALUE+-U or VALUE+/-U) -> (value, uncertainty or None)."""
    match = _MEASUREMENT.fullmatch(text)
    if match is None:
        raise ValueError(f"{text!r} is not VALUE or VALUE±UNCERTAINTY")
    return float(match[1]), float(match[2]) if match[2] is not None else None
