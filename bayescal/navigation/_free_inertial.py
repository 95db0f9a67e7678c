"""What a gyro calibration's residual costs in free inertial navigation (claim 1 of US 5,527,003,
steps p-q; ../shared/NAVIGATION.md, "Why it matters"): the horizontal position error after a
flight, as a linear map of the residual bias of each body gyro.

The next mission of a system whose gyros are compensated by a calibration with residual bias
eps^b (calibration minus truth, rad/s, constant over the flight): it aligns at rest where it
stands (attitude C_park), levelled (the accelerometers' part is left out: this is the gyros'
cost) and gyrocompassed, so its heading settles where the east residual balances the Earth
rate, eps_E = -Omega cos L psi, i.e. phi_D = eps_E / (Omega cos L) (NAVIGATION.md; psi =
computed - true heading = -phi_D). It then navigates free inertially, either parked or along a
flight at constant speed whose heading turns by ``turn_deg`` every ``leg_s`` (a closed square at
90 deg and a quarter of the hour), and its errors follow the phi-angle model of
:mod:`._error_model` with the residual as a constant input, taken exactly over each
``step_s`` (:func:`~._error_model.discretize`). The model is held at the departure's latitude
(a closed square of 15-minute legs at 250 m/s strays about 2 deg from it).

Parked, the balanced pair (psi, eps_E) cancels and only the north and vertical residuals show;
in motion the heading error turns the velocity and the pair shows (NAVIGATION.md).
"""

import math

import jax.numpy as jnp
import numpy as np

from ..classical._gravity import normal_gravity
from ._earth import earth_rate_n
from ._error_model import TILT, discretize, error_dynamics
from ._frames import dcm_from_euler, euler_from_dcm

FLIGHT_S = 3600.0
"""The free-inertial flight of the check, s."""
LEG_S = 900.0
"""How long each straight leg of the flight lasts, s."""
TURN_DEG = 90.0
"""The heading change between legs, deg."""
STEP_S = 10.0
"""The error model's step, s (exact for a model constant over it; the turns fall on steps)."""


def position_error_map(
    latitude_deg: float,
    park_attitude,
    *,
    speed: float = 0.0,
    duration_s: float = FLIGHT_S,
    leg_s: float = LEG_S,
    turn_deg: float = TURN_DEG,
    step_s: float = STEP_S,
    height: float = 0.0,
) -> np.ndarray:
    """The (2, 3) matrix that turns the body gyros' residual biases (x, y, z; rad/s) into the
    horizontal position error (north, east; m) after ``duration_s`` of free inertial navigation
    from a gyrocompass alignment at ``park_attitude`` (C_b^n) (module docstring); parked when
    ``speed`` (m/s) is 0, else along a flight at that speed that starts along the park's heading
    and turns by ``turn_deg`` (deg) every ``leg_s`` (s), level at the park's roll and pitch."""
    latitude = math.radians(latitude_deg)
    park_attitude = np.asarray(park_attitude, dtype=float)
    roll, pitch, heading = (float(a) for a in euler_from_dcm(park_attitude))
    count = round(duration_s / step_s)
    middle = (np.arange(count) + 0.5) * step_s
    if speed > 0:
        headings = heading + np.radians(turn_deg) * np.floor(middle / leg_s)
        attitude = np.stack([np.asarray(dcm_from_euler(roll, pitch, h)) for h in headings])
        velocity = speed * np.stack([np.cos(headings), np.sin(headings), np.zeros(count)], axis=-1)
    else:
        attitude = np.broadcast_to(park_attitude, (count, 3, 3))
        velocity = np.zeros((count, 3))
    gravity = normal_gravity(latitude_deg, height)
    dynamics, gyro, _ = error_dynamics(
        jnp.full(count, latitude), height, velocity, attitude, gravity
    )
    # The residual rides along as three constant states.
    augmented = jnp.zeros((count, 10, 10)).at[:, :7, :7].set(dynamics).at[:, :7, 7:].set(gyro)
    transitions, _ = discretize(augmented, jnp.zeros((count, 10, 10)), step_s)
    total = np.eye(10)
    for transition in np.asarray(transitions):
        total = transition @ total
    start = np.zeros((10, 3))
    horizontal_earth = float(earth_rate_n(latitude)[0])
    start[TILT.stop - 1] = park_attitude[1] / horizontal_earth
    start[7:] = np.eye(3)
    return (total @ start)[:2]
