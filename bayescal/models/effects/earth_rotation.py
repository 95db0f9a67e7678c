"""Earth rotation: a static gyro sees the Earth's rate projected on its axis."""

import math
from typing import ClassVar

import numpy as np

from ..._errors import InputError
from ...recording._units import parse_unit
from ._base import Effect

EARTH_RATE = 7.2921150e-5  # rad/s (15.041 deg/h), IERS
_AXES = {
    "up": (0, 0, 1),
    "down": (0, 0, -1),
    "north": (0, 1, 0),
    "south": (0, -1, 0),
    "east": (1, 0, 0),
    "west": (-1, 0, 0),
}


def earth_rate_on_axis(latitude_deg: float, axis: str, unit: str) -> float:
    """The Earth's rotation rate seen by a gyro axis pointing along ``axis`` (up, down, north,
    south, east, west, or east,north,up components), in the channel's ``unit``."""
    if not -90 <= latitude_deg <= 90:
        raise InputError(f"--latitude {latitude_deg} must lie between -90 and 90 degrees")
    if axis in _AXES:
        direction = np.array(_AXES[axis], dtype=float)
    else:
        try:
            direction = np.array([float(part) for part in axis.split(",")])
        except ValueError:
            direction = np.zeros(0)
        if direction.size != 3 or not np.linalg.norm(direction) > 0:
            raise InputError(
                f"--axis {axis!r}",
                fix="give up, down, north, south, east, west, "
                "or the axis direction as east,north,up components",
            )
        direction /= np.linalg.norm(direction)
    parsed = parse_unit(unit)
    if parsed.quantity != "angular_rate":
        raise InputError(
            f"the Earth rate needs an angular-rate channel, not '{unit}'",
            fix="pass --unit deg/s (or rad/s) or leave out --latitude",
        )
    latitude = math.radians(latitude_deg)
    earth = EARTH_RATE * np.array([0.0, math.cos(latitude), math.sin(latitude)])
    return float(earth @ direction) / parsed.to_si


class EarthRotation(Effect):
    """The Earth's rate, 15.041 deg/h, projected on the gyro's axis: a constant offset a
    static record cannot tell from the bias (:func:`earth_rate_on_axis` takes it off when
    the latitude and the axis are known)."""

    name: ClassVar[str] = "earth_rotation"
    explanation: ClassVar[str] = (
        "A static gyro measures the Earth's rotation, 15.041 deg/h projected on its axis: an "
        "offset set by the latitude and the axis's direction."
    )
    located_by: ClassVar[str] = "residual_time"
    band: ClassVar[str] = "low"

    def simulate(self, n: int, latitude_deg: float, axis: str, unit: str) -> np.ndarray:
        """The Earth rate a static gyro along ``axis`` at ``latitude_deg`` reads, ``n`` times."""
        return np.full(n, earth_rate_on_axis(latitude_deg, axis, unit))
