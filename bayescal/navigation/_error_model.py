"""The phi-angle error model of a strapdown system whose height is held, and its discrete form.

Errors of the computed solution (Scherzinger & Reid's modified phi-angle model, as Groves
2013 sec. 14.2 and Titterton & Weston 2004 ch. 12 write the phi-angle form): delta r the
position error (north, east, m), delta v the velocity error (north, east, m/s; "modified":
against the true velocity resolved in the computed frame, which takes the specific force out of
the model), phi the tilt of the computed frame (north, east, down, rad; C_b^n computed =
(I - [phi x]) C_b^n true, so the computed heading is the true one less phi_D). With the
Earth rate Omega^n, the transport rate rho^n = K v, gravity g^n, C = C_b^n and the gyro and
accelerometer errors eps^b and nabla^b:

    d(delta r)/dt = delta v + [v x] phi
    d(delta v)/dt = -[(2 Omega + rho) x] delta v - [g x] phi + C nabla + [v x] C eps
    d(phi)/dt     = [Omega x] K delta r + K delta v + (-[(Omega + rho) x] + K [v x]) phi - C eps

with the vertical channel held (the modified vertical velocity error is then v_E phi_N -
v_N phi_E, a function of the tilt). At rest (v = 0, f^n = -g^n) it is ../shared/NAVIGATION.md's
model plus the Schuler loop (K delta v) and the Earth rate's change with the latitude error
([Omega x] K delta r):

    d(delta v_N)/dt =  g phi_E + nabla_N
    d(delta v_E)/dt = -g phi_N + nabla_E
    d(phi_N)/dt = -Omega sin L phi_E + delta v_E / R_E - eps_N
    d(phi_E)/dt =  Omega sin L phi_N + Omega cos L phi_D - delta v_N / R_N - eps_E
    d(phi_D)/dt = -Omega cos L phi_E - tan L delta v_E / R_E - eps_D

:func:`discretize` turns a continuous linear model into its transition and process noise
over an interval (Van Loan 1978, IEEE TAC 23(3): exact for a model constant over the interval).
"""

import jax
import jax.numpy as jnp

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ._earth import curvature, earth_rate_n
from ._frames import skew

NAVIGATION_STATES = ("dr_N", "dr_E", "dv_N", "dv_E", "phi_N", "phi_E", "phi_D")
POSITION = slice(0, 2)
VELOCITY = slice(2, 4)
TILT = slice(4, 7)


def error_dynamics(latitude, height, velocity, attitude, gravity):
    """The continuous error model along a trajectory held at ``height``: F (7 x 7), the gyro
    error's input matrix (7 x 3, for eps^b in rad/s) and the accelerometer error's (7 x 3, for
    nabla^b in m/s^2), in the order of NAVIGATION_STATES. ``latitude`` (rad), ``velocity``
    (north, east, down, m/s), ``attitude`` (C_b^n) and ``gravity`` (the magnitude of g, m/s^2)
    may carry leading batch axes."""
    latitude = jnp.asarray(latitude, dtype=float)
    velocity = jnp.asarray(velocity, dtype=float)
    attitude = jnp.asarray(attitude, dtype=float)
    batch = latitude.shape
    k = curvature(latitude, height)
    omega = earth_rate_n(latitude)
    rho = jnp.einsum("...ij,...j->...i", k, velocity)
    v_cross = skew(velocity)
    down = jnp.broadcast_to(jnp.asarray(gravity, dtype=float), batch)
    g_cross = skew(jnp.stack([jnp.zeros(batch), jnp.zeros(batch), down], axis=-1))
    zeros = jnp.zeros((*batch, 3, 3))
    identity = jnp.broadcast_to(jnp.eye(3), (*batch, 3, 3))
    # The full 9-state model (position, velocity, tilt; each north, east, down) ...
    position = jnp.concatenate([zeros, identity, v_cross], axis=-1)
    speed = jnp.concatenate([zeros, -skew(2 * omega + rho), -g_cross], axis=-1)
    tilt = jnp.concatenate([skew(omega) @ k, k, -skew(omega + rho) + k @ v_cross], axis=-1)
    full = jnp.concatenate([position, speed, tilt], axis=-2)
    gyro_full = jnp.concatenate([zeros, v_cross @ attitude, -attitude], axis=-2)
    accel_full = jnp.concatenate([zeros, attitude, zeros], axis=-2)
    # ... reduced to a held height: rows and columns of the vertical position and velocity
    # dropped, the modified vertical velocity error v_E phi_N - v_N phi_E put in its place.
    keep = jnp.array([0, 1, 3, 4, 6, 7, 8])
    expand = jnp.zeros((*batch, 9, 7)).at[..., keep, jnp.arange(7)].set(1.0)
    expand = expand.at[..., 5, 4].set(velocity[..., 1]).at[..., 5, 5].set(-velocity[..., 0])
    dynamics = full[..., keep, :] @ expand
    return dynamics, gyro_full[..., keep, :], accel_full[..., keep, :]


def _van_loan(dynamics, noise, dt):
    n = dynamics.shape[-1]
    block = jnp.zeros((2 * n, 2 * n))
    block = block.at[:n, :n].set(-dynamics).at[:n, n:].set(noise).at[n:, n:].set(dynamics.T)
    exponential = jax.scipy.linalg.expm(block * dt)
    transition = exponential[n:, n:].T
    process = transition @ exponential[:n, n:]
    return transition, 0.5 * (process + process.T)


@jax.jit
def discretize(dynamics, noise, dt):
    """Transition matrices and process noise covariances over intervals ``dt`` of the
    continuous model dx/dt = F x + w, E[w w^T] = ``noise`` delta(t - s), each (k, n, n) (Van
    Loan 1978); ``dt`` a scalar or (k,) in seconds."""
    dt = jnp.broadcast_to(jnp.asarray(dt, dtype=float), dynamics.shape[:1])
    return jax.vmap(_van_loan)(dynamics, noise, dt)
