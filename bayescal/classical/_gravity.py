"""Local gravity: WGS84 normal gravity with the free-air height correction, or a user value.

Normal gravity on the ellipsoid is Somigliana's closed formula (NIMA TR8350.2, 3rd ed.,
eq. 4-1), and above it the second-order expansion in height (eq. 4-3); both are exact for the
WGS84 ellipsoid to far below a microgal. What they leave out is the gravity anomaly of the
actual place — the pull of mountains, basins and density contrasts — whose free-air values
have a global RMS of about 30 mGal (0.3 mm/s^2, EGM2008) and reach a few hundred mGal in high
mountains. That is the uncertainty given with a computed value, as one standard deviation;
where the local gravity matters more, a surveyed value goes in as :meth:`LocalGravity.measured`
(``--g-local VALUE±U`` on the command line).
The height is above the ellipsoid; a height above sea level differs from it by the geoid
undulation (within ±110 m), which moves gravity by up to 0.34 mm/s^2 at 3.086e-6 s^-2 per
metre — within the stated uncertainty.
"""

import math
from dataclasses import dataclass

from .._errors import InputError

# WGS84 defining and derived constants (NIMA TR8350.2, tables 3.1-3.3).
SEMI_MAJOR_AXIS = 6378137.0  # m
FLATTENING = 1 / 298.257223563
EQUATORIAL_GRAVITY = 9.7803253359  # m/s^2
POLAR_GRAVITY = 9.8321849378  # m/s^2
SOMIGLIANA_K = 0.00193185265241
ECCENTRICITY_SQUARED = 6.69437999014e-3
GRAVITY_RATIO_M = 0.00344978650684  # omega^2 a^2 b / GM
ANOMALY_SD = 3e-4  # m/s^2: global RMS of free-air gravity anomalies (about 30 mGal)


# Gravity on the Earth's surface lies between 9.76 (equator, high mountains) and 9.84 m/s^2
# (poles); a value outside these bounds is a mistake (a unit, a typo), not a place.
PLAUSIBLE_GRAVITY = (9.7, 9.9)


@dataclass(frozen=True)
class LocalGravity:
    """Local gravity with its uncertainty, and where it comes from.

    Parameters
    ----------
    value : float
        Gravity in m/s^2.
    uncertainty : float
        One standard deviation, m/s^2.
    source : str
        How the value was obtained (a model, a survey).
    """

    value: float
    uncertainty: float
    source: str

    @classmethod
    def measured(cls, value: float, uncertainty: float = 0.0) -> "LocalGravity":
        """A surveyed (or otherwise known) local gravity in m/s^2 with its one-sd
        uncertainty.

        Parameters
        ----------
        value : float
            Gravity, m/s^2.
        uncertainty : float
            One standard deviation, m/s^2 (0: taken as exact).

        Returns
        -------
        LocalGravity
            The value, its uncertainty, and a source that says it was given.

        Raises
        ------
        InputError
            The value is not a gravity on the Earth (9.7 to 9.9 m/s^2) or the uncertainty is
            negative.

        Examples
        --------
        >>> import bayescal as bc
        >>> bc.LocalGravity.measured(9.80123, 2e-5).source
        'given: 9.80123 ± 2e-05 m/s^2'
        """
        low, high = PLAUSIBLE_GRAVITY
        if not low < value < high:
            raise InputError(
                f"local gravity {value!r} is not a gravity in m/s^2 ({low} to {high})",
                fix="give it in m/s^2, like 9.80123±0.00002",
            )
        if not uncertainty >= 0:
            raise InputError(
                f"local gravity uncertainty {uncertainty!r} must be zero or positive",
                fix="give one standard deviation in m/s^2",
            )
        return cls(
            float(value), float(uncertainty), f"given: {value:.10g} ± {uncertainty:.3g} m/s^2"
        )


def normal_gravity(latitude_deg: float, height_m: float = 0.0) -> float:
    """WGS84 normal gravity (m/s^2) at geodetic latitude and height above the ellipsoid."""
    sin2 = math.sin(math.radians(latitude_deg)) ** 2
    surface = (
        EQUATORIAL_GRAVITY * (1 + SOMIGLIANA_K * sin2) / math.sqrt(1 - ECCENTRICITY_SQUARED * sin2)
    )
    linear = 2 / SEMI_MAJOR_AXIS * (1 + FLATTENING + GRAVITY_RATIO_M - 2 * FLATTENING * sin2)
    return surface * (1 - linear * height_m + 3 * height_m**2 / SEMI_MAJOR_AXIS**2)


def local_gravity(latitude_deg: float, height_m: float = 0.0) -> LocalGravity:
    """WGS84 normal gravity at a place, with the global RMS of gravity anomalies as its
    uncertainty (module docstring).

    Parameters
    ----------
    latitude_deg : float
        Geodetic latitude, degrees (-90 to 90).
    height_m : float
        Height above the WGS84 ellipsoid, metres (-500 to 20 000).

    Returns
    -------
    LocalGravity
        Value and one-sd uncertainty in m/s^2.

    Raises
    ------
    InputError
        A latitude or height outside its range.

    Examples
    --------
    >>> import bayescal as bc
    >>> gravity = bc.local_gravity(40.1, 220.0)
    >>> round(gravity.value, 4), gravity.uncertainty
    (9.8011, 0.0003)
    """
    if not -90 <= latitude_deg <= 90:
        raise InputError(f"latitude_deg={latitude_deg} must lie between -90 and 90 degrees")
    if not -500 <= height_m <= 20_000:
        raise InputError(f"height_m={height_m} is outside -500 to 20 000 m above the ellipsoid")
    return LocalGravity(
        normal_gravity(latitude_deg, height_m),
        ANOMALY_SD,
        f"WGS84 normal gravity at latitude {latitude_deg:g} deg, height "
        f"{height_m:g} m (Somigliana with free-air correction); uncertainty: "
        "the global RMS of gravity anomalies",
    )
