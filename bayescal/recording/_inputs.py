"""The array arguments of the public functions, checked alike: a :class:`~bayescal.Channel`
is taken wherever samples are (it brings its rate, unit, name and source, and a rate or unit
given beside it must agree), and arrays meant to lie on one sample grid must be of one length
(an error names both arguments and their lengths, where a shorter temperature series once
gave "no effect" and a warning)."""

from dataclasses import dataclass

import numpy as np

from .._errors import InputError
from ._recording import Channel


@dataclass(frozen=True)
class ChannelInput:
    """One channel's samples and what is known of them, from an array or a Channel."""

    values: object
    """The samples (a float array, or a spooled series for a long channel)."""
    rate_hz: float
    unit: str
    channel: str
    source: str = "<array>"
    notes: tuple[str, ...] = ()
    temperature: np.ndarray | None = None
    """The temperature a Channel was prepared with, on its grid (None: none)."""


def channel_input(
    y,
    rate_hz: float | None,
    *,
    unit: str | None,
    channel: str | None,
    default_unit: str = "unit",
    default_channel: str = "channel",
    argument: str = "y",
) -> ChannelInput:
    """``y`` (argument ``argument``) as one channel: a Channel brings its rate, unit, name and
    source (``rate_hz`` and ``unit``, when given, must agree with it; ``channel`` renames it);
    an array needs ``rate_hz`` and is in ``unit`` (default ``default_unit``)."""
    if isinstance(y, Channel):
        if rate_hz is not None and abs(rate_hz / y.rate_hz - 1) > 1e-9:
            raise InputError(
                f"rate_hz={rate_hz} but the channel {y.channel} is sampled at {y.rate_hz:g} Hz",
                fix="leave rate_hz out for a Channel",
            )
        if unit is not None and unit != y.unit:
            raise InputError(
                f"unit={unit!r} but the channel {y.channel} is in {y.unit}",
                fix="leave unit out for a Channel, or prepare it with that unit",
            )
        return ChannelInput(
            y.values, y.rate_hz, y.unit, channel or y.channel, y.source, y.notes, y.temperature
        )
    rate_hz = positive_rate(rate_hz)
    values = np.asarray(y, dtype=float)
    if values.ndim != 1:
        raise InputError(f"{argument}: one channel, a 1-D array (shape {values.shape})")
    return ChannelInput(values, rate_hz, unit or default_unit, channel or default_channel)


def positive_rate(rate_hz) -> float:
    """``rate_hz`` as a positive sample rate in Hz, or an error naming it."""
    try:
        rate = float(rate_hz)
    except (TypeError, ValueError):
        rate = float("nan")
    if not rate > 0 or rate == float("inf"):
        raise InputError(f"rate_hz={rate_hz!r} must be a positive sample rate in Hz")
    return rate


def samples_and_rate(y, rate_hz, *, argument: str = "y"):
    """(samples, rate in Hz) of ``y``: an array (or a spooled series) with ``rate_hz``, or a
    Channel with its own rate (``rate_hz``, when given, must agree)."""
    if isinstance(y, Channel):
        return channel_input(y, rate_hz, unit=None, channel=None, argument=argument).values, (
            y.rate_hz
        )
    return y, positive_rate(rate_hz)


def samples(x, argument: str) -> np.ndarray:
    """``x`` (argument ``argument``) as a float array: a Channel's values, or the array."""
    values = x.values if isinstance(x, Channel) else x
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{argument}: numbers expected ({type(x).__name__} given)") from None


def check_same_length(reference: tuple[str, object], *others: tuple[str, object]) -> None:
    """Each of ``others`` (name, array; None skipped) as long as ``reference`` (name, array)
    along their first axis: series on one sample grid. The error names both arguments and
    their lengths."""
    name, values = reference
    length = _length(values)
    for other, series in others:
        if series is None:
            continue
        if _length(series) != length:
            raise InputError(
                f"{other} has {_length(series)} values but {name} has {length}",
                fix=f"give {other} on the sample grid of {name}, one value per sample",
            )


def _length(values) -> int:
    """The length of ``values`` along its first axis (a list's: its items, which may differ
    in shape; a number's: 1)."""
    if isinstance(values, (list, tuple)):
        return len(values)
    shape = np.shape(values)
    return int(shape[0]) if shape else 1


def channel_and_temperature(
    y,
    temperature,
    rate_hz,
    *,
    unit: str | None,
    channel: str | None = None,
    default_unit: str = "unit",
    default_channel: str = "channel",
) -> tuple[ChannelInput, np.ndarray]:
    """The channel ``y`` (an array, or a Channel with its rate, unit, name, source and the
    temperature it was prepared with) and its temperature, one value per sample."""
    given = channel_input(
        y,
        rate_hz,
        unit=unit,
        channel=channel,
        default_unit=default_unit,
        default_channel=default_channel,
    )
    temperature = temperature_of(y, temperature)
    check_same_length(("y", given.values), ("temperature", temperature))
    return given, temperature


def temperature_of(y, temperature) -> np.ndarray:
    """``temperature`` as samples, or, when it is None, those of the Channel ``y``."""
    if temperature is None and isinstance(y, Channel):
        temperature = y.temperature
    if temperature is None:
        raise InputError(
            "temperature: none given, and y carries none",
            fix="pass temperature= (one value per sample), or give a Channel prepared with "
            "Recording.channel(name, temperature=COLUMN)",
        )
    return samples(temperature, "temperature")
