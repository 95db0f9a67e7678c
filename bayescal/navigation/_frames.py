"""Rotations between the body frame (x forward, y right, z down) and the local navigation frame
(north, east, down): direction cosine matrices C_b^n, the skew matrix of a vector, the
rotation vector's matrix (Rodrigues), and roll, pitch and heading (the aerospace z-y-x
sequence, C_b^n = R_z(heading) R_y(pitch) R_x(roll); Titterton & Weston 2004, sec. 3.6).
Functions of JAX arrays, usable inside ``jax.lax.scan``.
"""

import jax.numpy as jnp

from .. import _x64  # noqa: F401  (float64 before any JAX array)

# Below this squared angle (rad^2) Rodrigues' coefficients come from their Taylor series: the
# closed forms lose every digit as the angle goes to zero (a strapdown step turns by ~1e-6 rad).
_SMALL_ANGLE_SQUARED = 1e-6


def skew(vector):
    """[v x]: the matrix whose product with w is the cross product v x w."""
    x, y, z = vector[..., 0], vector[..., 1], vector[..., 2]
    zero = jnp.zeros_like(x)
    return jnp.stack(
        [
            jnp.stack([zero, -z, y], axis=-1),
            jnp.stack([z, zero, -x], axis=-1),
            jnp.stack([-y, x, zero], axis=-1),
        ],
        axis=-2,
    )


def rotation_matrix(rotation_vector):
    """The rotation matrix of a rotation vector (Rodrigues' formula), exact to double precision
    for small angles as for large ones."""
    squared = jnp.sum(rotation_vector**2, axis=-1)
    small = squared < _SMALL_ANGLE_SQUARED
    safe = jnp.where(small, 1.0, squared)
    angle = jnp.sqrt(safe)
    sine = jnp.where(small, 1 - squared / 6 + squared**2 / 120, jnp.sin(angle) / angle)
    versine = jnp.where(small, 0.5 - squared / 24 + squared**2 / 720, (1 - jnp.cos(angle)) / safe)
    cross = skew(rotation_vector)
    identity = jnp.eye(3)
    return identity + sine[..., None, None] * cross + versine[..., None, None] * (cross @ cross)


def dcm_from_euler(roll, pitch, heading):
    """C_b^n from roll, pitch and heading, radians (z-y-x: heading, then pitch, then roll)."""
    cr, sr = jnp.cos(roll), jnp.sin(roll)
    cp, sp = jnp.cos(pitch), jnp.sin(pitch)
    ch, sh = jnp.cos(heading), jnp.sin(heading)
    return jnp.stack(
        [
            jnp.stack([cp * ch, -cr * sh + sr * sp * ch, sr * sh + cr * sp * ch], axis=-1),
            jnp.stack([cp * sh, cr * ch + sr * sp * sh, -sr * ch + cr * sp * sh], axis=-1),
            jnp.stack([-sp, sr * cp, cr * cp], axis=-1),
        ],
        axis=-2,
    )


def euler_from_dcm(dcm):
    """Roll, pitch and heading (radians; heading in (-pi, pi]) of C_b^n."""
    roll = jnp.arctan2(dcm[..., 2, 1], dcm[..., 2, 2])
    pitch = -jnp.arcsin(jnp.clip(dcm[..., 2, 0], -1.0, 1.0))
    heading = jnp.arctan2(dcm[..., 1, 0], dcm[..., 0, 0])
    return roll, pitch, heading
