"""The strapdown mechanization: attitude, velocity and position from body rates and specific
forces, in the local navigation frame (north, east, down) at a fixed height.

Equations (Savage 1998, J. Guidance 21(1-2); Groves 2013, sec. 5.4; Titterton & Weston 2004,
ch. 3):

    dC_b^n/dt = C_b^n [w_ib^b x] - [w_in^n x] C_b^n,   w_in^n = w_ie^n + w_en^n
    dv^n/dt   = C_b^n f^b - (2 w_ie^n + w_en^n) x v^n + g^n
    dL/dt = v_N / (R_N + h),   dlambda/dt = v_E / ((R_E + h) cos L)

The inputs are increments, as an IMU delivers its samples: each sample is the average rate (or
specific force) over its sample period, so theta_k = w_k dt and dv_k = f_k dt. Each step takes
the two-sample coning and sculling corrections (theta_{k-1} x theta_k / 12 and
(theta_{k-1} x dv_k + dv_{k-1} x theta_k) / 12) and the rotation compensation theta x dv / 2
(Savage 1998, part 1 eq. 33 and part 2 eq. 27, for rates varying linearly over two periods),
turns the body by the corrected rotation vector and the navigation frame by -w_in^n dt, adds
the velocity increment rotated into the navigation frame less half the frame's turn during the
step, the Coriolis and transport terms, and integrates the position with the mean velocity of
the step (trapezoid).

The vertical channel is held: height and vertical velocity stay as given (a parked or taxiing
vehicle, or a height aid), which leaves out the vertical channel's instability and needs no
gravity in the loop. One ``jax.lax.scan`` over the samples: 120 000 steps take well under a
second.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ._earth import curvature, earth_rate_n
from ._frames import rotation_matrix


class Trajectory(eqx.Module):
    """The navigation solution at the start and after every sample (n + 1 states)."""

    time: np.ndarray
    """s, from the first sample's start."""
    latitude: np.ndarray
    """rad"""
    longitude: np.ndarray
    """rad"""
    height: float
    """m above the ellipsoid (held)."""
    velocity: np.ndarray
    """(n + 1, 3) north, east, down, m/s (down held at zero)."""
    attitude: np.ndarray
    """(n + 1, 3, 3) C_b^n."""


def increments(gyro, accel, dt: float):
    """Rotation vectors and velocity increments per sample, coning and sculling included, from
    average rates (rad/s) and specific forces (m/s^2), each (n, 3); the first sample's
    predecessor is taken as itself."""
    theta = jnp.asarray(gyro) * dt
    dv = jnp.asarray(accel) * dt
    theta_before = jnp.concatenate([theta[:1], theta[:-1]])
    dv_before = jnp.concatenate([dv[:1], dv[:-1]])
    coning = jnp.cross(theta_before, theta) / 12
    sculling = (jnp.cross(theta_before, dv) + jnp.cross(dv_before, theta)) / 12
    return theta + coning, dv + sculling + 0.5 * jnp.cross(theta, dv)


@jax.jit
def _integrate(latitude, longitude, height, velocity, attitude, theta, dv, dt):
    def step(state, inputs):
        lat, lon, v, c = state
        rotation, delta_v = inputs
        earth = earth_rate_n(lat)
        to_rate = curvature(lat, height)
        frame_rate = earth + to_rate @ v
        dv_n = c @ delta_v
        turn = -0.5 * jnp.cross(frame_rate, dv_n) - jnp.cross(earth + frame_rate, v)
        v_new = v + dv_n + turn * dt
        v_new = v_new.at[2].set(0.0)
        mean_v = 0.5 * (v + v_new)
        mean_rate = earth + to_rate @ mean_v
        lat_new = lat + (-(to_rate @ mean_v)[1]) * dt
        lon_new = lon + (to_rate @ mean_v)[0] / jnp.cos(lat) * dt
        c_new = rotation_matrix(-mean_rate * dt) @ c @ rotation_matrix(rotation)
        new = (lat_new, lon_new, v_new, c_new)
        return new, new

    start = (latitude, longitude, velocity, attitude)
    _, (lat, lon, v, c) = jax.lax.scan(step, start, (theta, dv))
    return (
        jnp.concatenate([latitude[None], lat]),
        jnp.concatenate([longitude[None], lon]),
        jnp.concatenate([velocity[None], v]),
        jnp.concatenate([attitude[None], c]),
    )


def mechanize(
    gyro,
    accel,
    rate_hz: float,
    *,
    latitude: float,
    longitude: float = 0.0,
    height: float = 0.0,
    attitude,
    velocity=(0.0, 0.0, 0.0),
) -> Trajectory:
    """Integrate a strapdown system's body rates and specific forces into a trajectory.

    ``gyro`` (rad/s) and ``accel`` (m/s^2) are (n, 3) average rates per sample in the body
    frame; ``latitude`` and ``longitude`` in radians, ``height`` in m (held); ``attitude`` the
    initial C_b^n; ``velocity`` the initial north, east, down velocity (m/s; down is held at
    zero).
    """
    dt = 1.0 / rate_hz
    theta, dv = increments(gyro, accel, dt)
    velocity = jnp.asarray(velocity, dtype=float).at[2].set(0.0)
    lat, lon, v, c = _integrate(
        jnp.asarray(latitude, dtype=float),
        jnp.asarray(longitude, dtype=float),
        float(height),
        velocity,
        jnp.asarray(attitude, dtype=float),
        theta,
        dv,
        dt,
    )
    return Trajectory(
        time=np.arange(lat.shape[0]) * dt,
        latitude=np.asarray(lat),
        longitude=np.asarray(lon),
        height=float(height),
        velocity=np.asarray(v),
        attitude=np.asarray(c),
    )
