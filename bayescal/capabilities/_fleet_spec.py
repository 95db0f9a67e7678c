"""The specifications a fleet's units are assessed against (``spec`` of
:func:`~bayescal.fit_fleet`): limits such as ``"N<0.3 deg/sqrt(h)"`` or a mapping, and a sensor
card's datasheet figures, parsed and checked before any work and put into the parameter's
unit for the fleet's channel (:class:`~bayescal.inference._population.Limit`)."""

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass

from .._errors import InputError
from ..inference._population import Limit
from ..models._terms import (
    PARAMETERS_OF_TERM,
    TERM_OF_PARAMETER,
    card_values,
    display_values,
    parameter_unit,
)
from ..recording._sensor_cards import SensorCard, find_card
from ..recording._units import convert, parse_unit

SPEC_PARAMETERS = ("N", "B", "K", "bias")
_LIMIT = re.compile(r"\s*(\w+)\s*<=?\s*([-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(.*?)\s*")


@dataclass(frozen=True)
class _Requested:
    parameter: str
    value: float
    unit: str | None
    label: str


def requested_limits(spec) -> tuple[list[_Requested], SensorCard | None]:
    """Parse ``spec`` (see :func:`fit_fleet`) into limits still in the user's units and at
    most one sensor card; checked before any work."""
    if spec is None:
        return [], None
    if isinstance(spec, (str, SensorCard)):
        spec = [spec]
    items = list(spec.items()) if isinstance(spec, Mapping) else list(spec)
    limits, card = [], None
    for item in items:
        if isinstance(item, SensorCard) or (isinstance(item, str) and "<" not in item):
            if card is not None:
                raise InputError("spec: give at most one sensor card")
            card = item if isinstance(item, SensorCard) else find_card(item)
            continue
        if isinstance(item, str):
            match = _LIMIT.fullmatch(item)
            if match is None:
                raise InputError(
                    f"spec: '{item}' is not PARAMETER<VALUE UNIT",
                    fix="write it like 'N<0.3 deg/sqrt(h)', 'B<10 deg/h' or 'bias<0.5 deg/s'",
                )
            name, value, unit, label = match[1], float(match[2]), match[3] or None, item.strip()
        else:
            name, given = item
            text = str(given).strip()
            parts = text.split(maxsplit=1)
            try:
                value = float(parts[0])
            except (ValueError, IndexError):
                raise InputError(
                    f"spec: {name}={given!r} is not VALUE [UNIT]",
                    fix="give a number in the parameter's unit, or 'VALUE UNIT'",
                ) from None
            unit = parts[1] if len(parts) > 1 else None
            label = f"{name}<{text}"
        if name not in SPEC_PARAMETERS:
            raise InputError(
                f"spec: unknown parameter '{name}'",
                fix=f"limits apply to {', '.join(SPEC_PARAMETERS)}",
            )
        if not (value > 0 and math.isfinite(value)):
            raise InputError(f"spec: the limit of {name} must be a positive number ({value})")
        limits.append(_Requested(name, value, unit, label))
    return limits, card


_FAMILY = {"angle": "angular_rate", "velocity": "acceleration"}


def _check_family(unit: str, channel_unit: str) -> None:
    """A noise figure's unit (deg/sqrt(h), ug/sqrt(Hz) ...) must belong to the channel's kind
    of sensor: a gyro's limit in ug is a mistake, not a conversion."""
    base = parse_unit(re.split(r"[/*]sqrt", unit)[0])
    channel = parse_unit(channel_unit)
    if base.known and channel.known:
        quantity = _FAMILY.get(base.quantity, base.quantity)
        if quantity != channel.quantity:
            raise ValueError(
                f"'{unit}' is a unit of {quantity.replace('_', ' ')}, the channel's "
                f"{channel_unit} of {channel.quantity.replace('_', ' ')}"
            )


def limit_in(requested: _Requested, channel_unit: str) -> Limit:
    """A requested limit in the parameter's unit for the fleet's channel."""
    name = requested.parameter
    target = parameter_unit(name, channel_unit)
    value = requested.value
    if requested.unit is not None and requested.unit != target:
        try:
            if name != "bias":
                _check_family(requested.unit, channel_unit)
            value = convert(value, requested.unit, target)
        except ValueError as error:
            raise InputError(
                f"spec '{requested.label}': {error}",
                fix=f"give {name} in {target} or a datasheet unit of this kind of channel",
            ) from None
    shown = "|bias|" if name == "bias" else name
    label = f"{shown} < {requested.value:g} {requested.unit or target}"
    return Limit(name, value, target, f"given: {requested.label}", label)


def card_limits(card: SensorCard, channel_unit: str) -> list[Limit]:
    try:
        values = card_values(card, channel_unit)
    except InputError as error:
        raise InputError(f"spec {card.name}: {error.problem}", fix=error.fix) from None
    limits = []
    for p, (value, source) in values.items():
        unit = parameter_unit(p, channel_unit)
        shown = ", ".join(
            f"{v:.3g} {label}" for label, v in display_values(p, value, channel_unit).items()
        )
        limits.append(
            Limit(
                p,
                value,
                unit,
                f"{card.name} datasheet ({card.datasheet}), {source}: a typical value",
                f"{p} <= {value:.4g} {unit}" + (f" ({shown})" if shown else ""),
            )
        )
    return limits


def checked_spec(spec, terms: tuple[str, ...], unit: str | None):
    """``spec`` parsed (:func:`requested_limits`) and checked before any work: each limit's
    parameter among those of ``terms``, and, when the channel's ``unit`` is given, each
    limit's unit and the card's figures convertible to it."""
    requested, card = requested_limits(spec)
    fitted_parameters = {p for term in terms for p in PARAMETERS_OF_TERM[term]}
    for limit in requested:
        if limit.parameter != "bias" and limit.parameter not in fitted_parameters:
            raise InputError(
                f"spec '{limit.label}': {limit.parameter} is not among the fitted terms "
                f"({', '.join(terms)})",
                fix=f"add {TERM_OF_PARAMETER[limit.parameter]} to the terms, or leave it out",
            )
    if unit is not None:  # the limits' units are checked before any work when they can be
        for limit in requested:
            limit_in(limit, parse_unit(unit).name)
        if card is not None:
            card_limits(card, parse_unit(unit).name)
    return requested, card


def assessed_limits(requested, card, unit: str, parameters) -> tuple[list[Limit], list[str]]:
    """The limits in the fleet's ``unit`` (those asked for, then the card's) that the
    population can assess (a parameter it holds, or the bias), and a note for each it
    cannot."""
    limits = [limit_in(r, unit) for r in requested]
    if card is not None:
        limits += card_limits(card, unit)
    assessed = [limit for limit in limits if limit.parameter in (*parameters, "bias")]
    notes = [
        f"spec {limit.label}: {limit.parameter} has no population here (not fitted, or not "
        "resolved by the recordings): not assessed"
        for limit in limits
        if limit not in assessed
    ]
    return assessed, notes
