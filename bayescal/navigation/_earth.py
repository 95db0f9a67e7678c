"""The Earth as a strapdown system sees it: the WGS-84 ellipsoid's radii of curvature, the
Earth rate and the transport rate resolved in the local navigation frame (north, east, down),
and normal gravity.

The constants have one home each: the Earth rate (IERS) in
:mod:`bayescal.models.effects.earth_rotation`, the ellipsoid and Somigliana's normal gravity in
:mod:`bayescal.classical._gravity` (NIMA TR8350.2). Equations: Groves (2013), *Principles of
GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed., eqs. 2.105-2.106
(radii), 2.123 (Earth rate), 5.44 (transport rate); Titterton & Weston (2004), ch. 3.
"""

import math

import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._errors import InputError
from ..classical._gravity import ECCENTRICITY_SQUARED, SEMI_MAJOR_AXIS
from ..models.effects.earth_rotation import EARTH_RATE

MAX_LATITUDE_DEG = 85.0
"""Nearer the poles the horizontal Earth rate (Omega cos L) is too small to align in heading by
gyrocompassing, and the navigation frame's east axis is ill defined."""


def check_latitude(latitude_deg) -> float:
    """The latitude as a float, or an InputError: it must be a number within +-85 degrees."""
    try:
        value = float(latitude_deg)
    except (TypeError, ValueError):
        raise InputError(f"latitude {latitude_deg!r} is not a number of degrees") from None
    if not abs(value) <= MAX_LATITUDE_DEG:
        raise InputError(
            f"latitude {value:g} deg is out of range: gyrocompassing needs the horizontal Earth "
            f"rate, Omega cos L, and works within +-{MAX_LATITUDE_DEG:g} deg",
            fix="give the geodetic latitude in degrees, north positive",
        )
    return value


def radii(latitude):
    """Meridian (north) and transverse (east) radii of curvature of the WGS-84 ellipsoid, m
    (Groves eqs. 2.105-2.106); ``latitude`` in radians."""
    sin2 = jnp.sin(latitude) ** 2
    denominator = 1 - ECCENTRICITY_SQUARED * sin2
    transverse = SEMI_MAJOR_AXIS / jnp.sqrt(denominator)
    meridian = transverse * (1 - ECCENTRICITY_SQUARED) / denominator
    return meridian, transverse


def north_east(latitude, longitude, height: float, origin=None):
    """North and east of ``origin`` (latitude, longitude; default the first point), m, of
    points at ``latitude`` and ``longitude`` (rad, arrays): the changes of each times the
    meridian and transverse radii at the origin (plus ``height``, m), flat over the few km of
    a taxi. Returns (n, 2)."""
    latitude = np.asarray(latitude, dtype=float)
    longitude = np.asarray(longitude, dtype=float)
    start = (latitude[0], longitude[0]) if origin is None else origin
    meridian, transverse = (float(r) for r in radii(start[0]))
    north = (latitude - start[0]) * (meridian + height)
    east = (longitude - start[1]) * (transverse + height) * math.cos(start[0])
    return np.stack([north, east], axis=-1)


def earth_rate_n(latitude):
    """The Earth rate resolved in north, east, down, rad/s: Omega (cos L, 0, -sin L)."""
    return EARTH_RATE * jnp.stack(
        [jnp.cos(latitude), jnp.zeros_like(latitude), -jnp.sin(latitude)], axis=-1
    )


def curvature(latitude, height):
    """The matrix that turns a velocity (or a position error) in north, east, down into the
    rotation rate of the navigation frame it causes (the transport rate rho = curvature @ v,
    Groves eq. 5.44), 1/m."""
    meridian, transverse = radii(latitude)
    east = 1 / (transverse + height)
    north = 1 / (meridian + height)
    zero = jnp.zeros_like(latitude)
    return jnp.stack(
        [
            jnp.stack([zero, east, zero], axis=-1),
            jnp.stack([-north, zero, zero], axis=-1),
            jnp.stack([zero, -east * jnp.tan(latitude), zero], axis=-1),
        ],
        axis=-2,
    )
