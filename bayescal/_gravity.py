"""Local gravity: WGS84 normal gravity with the free-air height correction, or a user value.

Normal gravity on the ellipsoid is Somigliana's closed formula (NIMA TR8350.2, 3rd ed.,
eq. 4-1), and above it the second-order expansion in height (eq. 4-3); both are exact for the
WGS84 ellipsoid to far below a microgal. What they leave out is the gravity anomaly of the
actual place — the pull of mountains, basins and density contrasts — whose free-air values
have a global RMS of about 30 mGal (0.3 mm/s^2, EGM2008) and reach a few hundred mGal in high
mountains. That is the uncertainty given with a computed value, as one standard deviation;
where the local gravity matters more, a surveyed value goes in with ``--g-local VALUE±U``.
The height is above the ellipsoid; a height above sea level differs from it by the geoid
undulation (within ±110 m), which moves gravity by up to 0.34 mm/s^2 at 3.086e-6 s^-2 per
metre — within the stated uncertainty.
"""

import math
from dataclasses import dataclass

from ._errors import InputError
from ._units import parse_measurement

# WGS84 defining and derived constants (NIMA TR8350.2, tables 3.1-3.3).
SEMI_MAJOR_AXIS = 6378137.0  # m
FLATTENING = 1 / 298.257223563
EQUATORIAL_GRAVITY = 9.7803253359  # m/s^2
POLAR_GRAVITY = 9.8321849378  # m/s^2
SOMIGLIANA_K = 0.00193185265241
ECCENTRICITY_SQUARED = 6.69437999014e-3
GRAVITY_RATIO_M = 0.00344978650684  # omega^2 a^2 b / GM
ANOMALY_SD = 3e-4  # m/s^2: global RMS of free-air gravity anomalies (about 30 mGal)


@dataclass(frozen=True)
class LocalGravity:
    value: float
    """m/s^2"""
    uncertainty: float
    """one standard deviation, m/s^2"""
    source: str


def normal_gravity(latitude_deg: float, height_m: float = 0.0) -> float:
    """WGS84 normal gravity (m/s^2) at geodetic latitude and height above the ellipsoid."""
    sin2 = math.sin(math.radians(latitude_deg)) ** 2
    surface = (
        EQUATORIAL_GRAVITY * (1 + SOMIGLIANA_K * sin2) / math.sqrt(1 - ECCENTRICITY_SQUARED * sin2)
    )
    linear = 2 / SEMI_MAJOR_AXIS * (1 + FLATTENING + GRAVITY_RATIO_M - 2 * FLATTENING * sin2)
    return surface * (1 - linear * height_m + 3 * height_m**2 / SEMI_MAJOR_AXIS**2)


def local_gravity(
    latitude_deg: float | None = None, height_m: float | None = None, given: str | None = None
) -> LocalGravity:
    """Local gravity from ``--g-local VALUE[±U]`` (m/s^2) or from latitude and height."""
    if given is not None:
        if latitude_deg is not None:
            raise InputError("give --g-local or --latitude/--height, not both")
        try:
            value, uncertainty = parse_measurement(given)
        except ValueError:
            value, uncertainty = math.nan, None
        uncertainty = uncertainty or 0.0
        if not 9.7 < value < 9.9:
            raise InputError(
                f"--g-local {given!r} is not a gravity in m/s^2 (9.7 to 9.9)",
                fix="write it like 9.80123±0.00002",
            )
        return LocalGravity(value, uncertainty, f"given: {given.strip()} m/s^2")
    if latitude_deg is None:
        raise InputError(
            "local gravity needed", fix="pass --latitude DEG (and --height M) or --g-local VALUE±U"
        )
    if not -90 <= latitude_deg <= 90:
        raise InputError(f"--latitude {latitude_deg} must lie between -90 and 90 degrees")
    height = height_m or 0.0
    if not -500 <= height <= 20_000:
        raise InputError(f"--height {height} m is outside -500 to 20 000 m above the ellipsoid")
    return LocalGravity(
        normal_gravity(latitude_deg, height),
        ANOMALY_SD,
        f"WGS84 normal gravity at latitude {latitude_deg:g} deg, height "
        f"{height:g} m (Somigliana with free-air correction); uncertainty: "
        "the global RMS of gravity anomalies",
    )
