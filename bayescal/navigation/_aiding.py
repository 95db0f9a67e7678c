"""How soon a navigation filter's aiding reveals a sensor bias: the horizon over which a bias
that is not a random walk (bias instability, Gauss-Markov) must be bounded by one
(:func:`~bayescal.models._terms.bounding_walk_variance`).

A constant bias b leaves in the free-inertial error a polynomial of time whose leading
coefficient is proportional to b: an accelerometer's, b t^2 / 2 of position and b t of
velocity; a horizontal gyro's, through the tilt it builds (b t) and the gravity that tilt
projects, g b t^3 / 6 of position and g b t^2 / 2 of velocity (Titterton & Weston, *Strapdown
Inertial Navigation Technology*, 2nd ed., sec. 12.3: the short-term error propagation). The
aiding's measurements over a span T (n = T / interval of them, each of sd sigma) determine
the coefficient of t^p in a least-squares polynomial to a variance C_p sigma^2 / (n T^(2p))
with C_1 = 12, C_2 = 180, C_3 = 2800 (the reciprocal of the squared norm of t^p's part
orthogonal to the lower powers on [0, 1]). The bias the aiding reveals over T therefore has
the sd

    s(T) = sqrt(C_p interval / T) sigma / (c T^p),

c the proportionality above (1/2, 1, g/6, g/2). The horizon is the span at which s(T) falls to
the size of the bias's own wander over that span, its Allan deviation sigma_b(T): shorter,
the aiding cannot see the bias move and the filter must trust its model; longer, it sees
it. The filter consistency benchmark (benchmarks/filter_consistency.py) checks the rule on a
MEMS and a tactical IMU with metre-level position fixes every second.
"""

import math
from collections.abc import Callable
from dataclasses import dataclass

from .._errors import InputError

STANDARD_GRAVITY = 9.80665
"""m/s^2: projects a gyro's tilt into acceleration (the rule is an order of magnitude)."""

ORTHOGONAL_POWER = {1: 12.0, 2: 180.0, 3: 2800.0}
"""C_p: the variance factor of the coefficient of t^p in a polynomial least-squares fit."""

_KINDS = ("position", "velocity")


@dataclass(frozen=True)
class Aiding:
    """A navigation filter's aiding: position or velocity fixes of a given sd at a given
    interval (GNSS, a motion-capture system, odometry, a camera's velocity).

    Parameters
    ----------
    kind : str
        ``position`` (sd in m) or ``velocity`` (sd in m/s).
    sd : float
        The sd of one fix, m or m/s, per horizontal axis.
    interval_s : float
        Seconds between fixes.

    Raises
    ------
    InputError
        An unknown kind, or an sd or interval that is not a positive number.
    """

    kind: str = "position"
    sd: float = 1.0
    interval_s: float = 1.0

    def __post_init__(self):
        if self.kind not in _KINDS:
            raise InputError(f"aiding kind={self.kind!r} must be one of {', '.join(_KINDS)}")
        for name in ("sd", "interval_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise InputError(f"aiding {name}={value!r} must be a positive number")

    @property
    def unit(self) -> str:
        """The unit of :attr:`sd`."""
        return "m" if self.kind == "position" else "m/s"

    def describe(self) -> str:
        """The aiding in words.

        Returns
        -------
        str
            E.g. ``position fixes of 1 m sd every 1 s``.
        """
        return f"{self.kind} fixes of {self.sd:g} {self.unit} sd every {self.interval_s:g} s"

    def revealed_bias_sd(self, sensor: str, span_s: float) -> float:
        """The sd s(T) with which the fixes over a span reveal a constant bias (module
        docstring).

        Parameters
        ----------
        sensor : str
            ``gyroscope`` (a horizontal one) or ``accelerometer``.
        span_s : float
            The span T, s.

        Returns
        -------
        float
            s(T), rad/s for a gyroscope, m/s^2 for an accelerometer.
        """
        power, factor = {
            ("position", "accelerometer"): (2, 0.5),
            ("velocity", "accelerometer"): (1, 1.0),
            ("position", "gyroscope"): (3, STANDARD_GRAVITY / 6),
            ("velocity", "gyroscope"): (2, STANDARD_GRAVITY / 2),
        }[self.kind, sensor]
        return (
            math.sqrt(ORTHOGONAL_POWER[power] * self.interval_s / span_s)
            * self.sd
            / (factor * span_s**power)
        )


def aided_horizon(
    aiding: Aiding,
    sensor: str,
    bias_allan_deviation: Callable[[float], float],
    *,
    shortest_s: float,
    longest_s: float = 1e6,
) -> float:
    """The span T (s) at which ``aiding`` reveals the bias as well as it wanders:
    :meth:`Aiding.revealed_bias_sd` (T) = ``bias_allan_deviation`` (T), found by bisection
    on log T within [``shortest_s``, ``longest_s``] (module docstring). A bias that never
    wanders as much as the aiding resolves gives ``longest_s``; one the aiding sees within
    the shortest span, ``shortest_s``.

    ``bias_allan_deviation`` maps an averaging time (s) to the bias terms' Allan deviation
    there, in SI (rad/s or m/s^2).
    """

    def excess(span: float) -> float:
        return math.log(aiding.revealed_bias_sd(sensor, span)) - math.log(
            max(bias_allan_deviation(span), 1e-300)
        )

    low, high = math.log(shortest_s), math.log(longest_s)
    if excess(shortest_s) <= 0:
        return shortest_s
    if excess(longest_s) > 0:
        return longest_s
    for _ in range(60):
        middle = (low + high) / 2
        if excess(math.exp(middle)) > 0:
            low = middle
        else:
            high = middle
    return math.exp((low + high) / 2)
