"""A noise term's parameter: its unit, whether datasheets quote it, and the one coordinate
it is sampled in, whose bounds are the parameter's allowed range everywhere bayescal uses it
(the noise fit, discovery, the thermal fit, a calibration's file).

Every parameter is sampled unconstrained: its value is ``offset + span * g(x)`` with ``g``
one of exp (a positive scale), the logistic function (a fraction of a range), tanh (a
coefficient in a symmetric range) or the identity (an unbounded value such as the ramp),
or ``exp(offset + span * logistic(x))`` (a time constant within a range of decades). A draw is
therefore always inside the range, and so is every quantile of the draws, and the delta method
(:meth:`Coordinates.slope`) carries a Laplace sd from the coordinate to the value.

Where the range depends on the record (a cutoff below half the sample rate, a correlation
time between a sample period and the record's length, the ramp's scale set by its prior),
``span`` names what it is read from (:class:`Context`).
"""

import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ...recording._units import DATASHEET_UNITS, time_scaled_unit

LINKS = ("log", "logit", "tanh", "linear", "log_logit")
"""The coordinates a parameter may be sampled in (module docstring)."""


@dataclass(frozen=True)
class Context:
    """What a parameter's range may depend on: the record's sample rate and length, and the
    natural scale its prior gives a linear coordinate (the length and the scale may be traced
    JAX values, so that records of any length share one compiled likelihood)."""

    rate_hz: float
    duration_s: object = math.inf
    linear_scale: object = 1.0


@dataclass(frozen=True)
class Parameter:
    """One parameter of a noise term (module docstring).

    Attributes
    ----------
    name : str
        Its symbol, as the posterior and the summary name it (IEEE Std 952's where the
        standard has one: ``N``, ``B`` ...; else a name such as ``filter_cutoff``).
    meaning : str
        What it is, in a few words, for tables.
    time_power : float or None
        Its unit is the channel's times s^time_power (IEEE Std 952: 1/2 for a density, -1/2
        for a random walk ...); None when ``unit`` is fixed.
    unit : str
        Its fixed unit where ``time_power`` is None (``1``, ``s``, ``Hz``, ``samples``).
    link : str
        Its coordinate, one of :data:`LINKS`.
    offset : float
        The coordinate's offset (the lower end of a range; the log of it for ``log_logit``).
    span : float or str
        The coordinate's scale, or where it is read from: ``"half_rate"`` (fs / 2),
        ``"record"`` (the decades between a sample period and the record's length, for
        ``log_logit``), ``"linear_scale"`` (the prior's scale of a linear coordinate).
    prior : tuple of float or None
        (location, sd) of the normal prior of its coordinate; None: log-normal around the
        level the Allan curve allows for the term (its reference scale), sd
        ``PRIOR_LOG_SD`` in the log.
    datasheet : bool
        Whether IMU datasheets quote it: it is then also shown in their units
        (:data:`~bayescal.recording._units.DATASHEET_UNITS` of its time power: deg/sqrt(h),
        deg/h, µg/sqrt(Hz) ...).
    """

    name: str
    meaning: str
    time_power: float | None = 0.0
    unit: str = ""
    link: str = "log"
    offset: float = 0.0
    span: float | str = 1.0
    prior: tuple[float, float] | None = None
    datasheet: bool = False

    def __post_init__(self):
        if self.link not in LINKS:
            raise ValueError(f"{self.name}: link={self.link!r} is not one of {LINKS}")
        if (self.time_power is None) == (not self.unit):
            raise ValueError(f"{self.name}: give either time_power or a fixed unit")
        power = math.nan if self.time_power is None else float(self.time_power)
        if self.datasheet and power not in DATASHEET_UNITS:
            raise ValueError(
                f"{self.name}: a datasheet figure has a time_power among {list(DATASHEET_UNITS)}"
            )

    def unit_for(self, channel_unit: str) -> str:
        """Its unit for a channel in ``channel_unit`` (ASCII, e.g. ``deg/s/sqrt(Hz)``)."""
        if self.time_power is None:
            return self.unit
        return time_scaled_unit(channel_unit, self.time_power)

    def affine(self, context: Context) -> tuple:
        """(offset, span) of its coordinate for a record (:class:`Context`; its fields may be
        traced JAX values)."""
        if self.span == "half_rate":
            return self.offset, 0.5 * context.rate_hz
        if self.span == "linear_scale":
            return self.offset, context.linear_scale
        if self.span == "record":
            low = -jnp.log(context.rate_hz)
            return low, jnp.log(context.duration_s * context.rate_hz)
        return self.offset, float(self.span)

    def bounds(self, context: Context) -> tuple[float, float]:
        """Its allowed range (open) for a record."""
        offset, span = (float(v) for v in self.affine(context))
        return {
            "log": (offset, math.inf),
            "logit": (offset, offset + span),
            "tanh": (offset - span, offset + span),
            "linear": (-math.inf, math.inf),
            "log_logit": (math.exp(offset), math.exp(offset + span)),
        }[self.link]

    def natural(self, x, context: Context):
        """The value at coordinate ``x`` (JAX; arrays broadcast)."""
        offset, span = self.affine(context)
        if self.link == "log":
            return offset + span * jnp.exp(x)
        if self.link == "logit":
            return offset + span * jax.nn.sigmoid(x)
        if self.link == "tanh":
            return offset + span * jnp.tanh(x)
        if self.link == "linear":
            return offset + span * x
        return jnp.exp(offset + span * jax.nn.sigmoid(x))

    def coordinate(self, value: float, context: Context) -> float:
        """The coordinate of ``value`` (the inverse of :meth:`natural`).

        Raises
        ------
        ValueError
            ``value`` outside the parameter's range.
        """
        low, high = self.bounds(context)
        if not low < value < high:
            raise ValueError(f"{self.name}={value!r} lies outside its range ({low:g}, {high:g})")
        offset, span = (float(v) for v in self.affine(context))
        if self.link == "log":
            return math.log((value - offset) / span)
        if self.link == "logit":
            fraction = (value - offset) / span
            return math.log(fraction / (1.0 - fraction))
        if self.link == "tanh":
            return math.atanh((value - offset) / span)
        if self.link == "linear":
            return (value - offset) / span
        fraction = (math.log(value) - offset) / span
        return math.log(fraction / (1.0 - fraction))

    def slope(self, value, context: Context):
        """d value / d coordinate at ``value``: the delta method's factor."""
        offset, span = (float(v) for v in self.affine(context))
        if self.link == "log":
            return value - offset
        if self.link == "logit":
            return (value - offset) * (offset + span - value) / span
        if self.link == "tanh":
            return span * (1.0 - ((value - offset) / span) ** 2)
        if self.link == "linear":
            return span
        fraction = (np.log(value) - offset) / span
        return value * span * fraction * (1.0 - fraction)

    def interval(self, value: float, sd: float, context: Context, z: float) -> tuple[float, float]:
        """The Laplace interval value -/+ z sd taken in the coordinate (sd carried there by
        :meth:`slope`) and mapped back: inside the parameter's range, however wide."""
        slope = float(self.slope(value, context))
        center = self.coordinate(value, context)
        width = z * sd / slope if slope > 0 else math.inf
        low, high = self.bounds(context)
        ends = []
        for end in (center - width, center + width):
            ends.append(float(self.natural(end, context)) if math.isfinite(end) else None)
        return (low if ends[0] is None else ends[0]), (high if ends[1] is None else ends[1])
