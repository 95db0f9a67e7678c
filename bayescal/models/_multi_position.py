"""The Bayesian multi-position calibration model (the classical one and the geometry it
shares: :mod:`bayescal.classical._multi_position`).

**Bayesian** answer: every scale factor and the pose scatter are proportional to g in both
models (the residuals, their variances and the Jacobian of the change of variables all scale
with it), so the data say nothing about g. The posterior is sampled in units of g — the
calibration parameters with the scales k' = k / g and the pose scatter sigma_p' = sigma_p / g —
and g_local is drawn from its prior (the local gravity model) for each draw, k = g k'. The
likelihood of each pose mean is Gaussian with the covariance of a mean of white noise (per-axis
variance / count) plus an isotropic pose scatter sigma_p in the calibrated frame that absorbs
what white noise leaves out (correlated noise, tilted faces, misfit). For free poses it is the
likelihood of the pose means with each orientation uniform on the sphere and integrated out: to
first order in noise / g, the magnitude residual ||T K (m_i - b)|| - g is Gaussian with variance
n^T A C_i A^T n + sigma_p^2 (A = T K, n the calibrated unit vector), times |det A| from the change
of variables. For six faces it is the full linear-Gaussian likelihood of each pose mean.
Priors: scales log-normal around the classical value with sd 1 in the log; misalignment angles
N(0, 0.1 rad); mounting rotation N(0, 0.3 rad); offsets normal around the classical value with an
sd of 1 g in the raw unit; sigma_p log-normal with its median at the classical residual RMS and
sd 3 in the log. MAP by optimistix BFGS with its Laplace covariance, posterior by emcee
(:mod:`bayescal._mcmc`), checked.
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from scipy.spatial.transform import Rotation

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ..classical._multi_position import (
    ClassicalCalibration,
    Poses,
    _calibration_matrix,
    _split,
    rotation_matrix,
)

ANGLE_PRIOR_SD = 0.1  # rad
# rad: weak across the mounting rotations the face tolerance admits (17 deg is one sd).
ROTATION_PRIOR_SD = 0.3
SCALE_PRIOR_LOG_SD = 1.0
SCATTER_PRIOR_LOG_SD = 3.0


def simulate_poses(
    rng: np.random.Generator,
    values,
    directions,
    g: float,
    *,
    six_face: bool = False,
    samples: int = 200,
    noise_sd=1.0,
) -> Poses:
    """Poses of a sensor with calibration ``values`` (in the order of FREE_PARAMETERS, or
    SIX_FACE_PARAMETERS) held so that gravity points along the unit ``directions`` (N, 3) —
    of the body frame for free poses, of the fixture frame for six faces — each pose the mean
    of ``samples`` readings with white noise of sd ``noise_sd`` (raw unit, per axis)."""
    values = np.asarray(values, dtype=float)
    scales, angles, rotation, offsets = _split(values, six_face)
    matrix = np.asarray(_calibration_matrix(jnp.asarray(scales), jnp.asarray(angles)))
    body = np.asarray(directions, dtype=float)
    if six_face:
        body = body @ Rotation.from_rotvec(rotation).as_matrix()  # R^T f, row by row
    readings = np.linalg.solve(matrix, g * body.T).T + offsets
    noise_sd = np.broadcast_to(np.asarray(noise_sd, dtype=float), (3,))
    return Poses.from_samples(
        [level + noise_sd * rng.standard_normal((samples, 3)) for level in readings]
    )


def _gaussian_terms(covariance, error):
    """e^T S^-1 e and log det S of a batch of symmetric 3x3 matrices S, by cofactors (several
    times faster on a CPU than batched LAPACK calls on matrices this small)."""
    a, b, c = covariance[:, 0, 0], covariance[:, 0, 1], covariance[:, 0, 2]
    d, e, f = covariance[:, 1, 1], covariance[:, 1, 2], covariance[:, 2, 2]
    adjugate = (
        d * f - e**2,
        a * f - c**2,
        a * d - b**2,
        c * e - b * f,
        b * e - c * d,
        b * c - a * e,
    )
    determinant = a * adjugate[0] + b * adjugate[3] + c * adjugate[4]
    x, y, z = error[:, 0], error[:, 1], error[:, 2]
    form = (
        adjugate[0] * x**2
        + adjugate[1] * y**2
        + adjugate[2] * z**2
        + 2 * (adjugate[3] * x * y + adjugate[4] * x * z + adjugate[5] * y * z)
    )
    return form / determinant, jnp.log(determinant)


class MultiPositionProblem(eqx.Module):
    """Log-posterior of the calibration in units of g. Sampled coordinates z map to
    u = location + step z = (log k', angles, [rotation vector], offsets, log sigma_p')."""

    mean: jax.Array
    variance: jax.Array
    """(N, 3) variance of each pose mean from white noise."""
    faces: jax.Array
    location: jax.Array
    step: jax.Array
    prior_mean: jax.Array
    prior_sd: jax.Array
    six_face: bool = eqx.field(static=True)

    def natural(self, z):
        return self.location + self.step * z

    def log_likelihood(self, u):
        n_calibration = 12 if self.six_face else 9
        _, angles, rotation, offsets = _split(u, self.six_face)
        scales = jnp.exp(u[:3])
        matrix = _calibration_matrix(scales, angles)
        scatter2 = jnp.exp(2 * u[n_calibration])
        calibrated = (self.mean - offsets) @ matrix.T
        log_det = jnp.sum(u[:3])
        if not self.six_face:
            magnitude = jnp.linalg.norm(calibrated, axis=1)
            direction = calibrated / magnitude[:, None]
            projected = direction @ matrix
            variance = jnp.sum(projected**2 * self.variance, axis=1) + scatter2
            return (
                jnp.sum(
                    -0.5 * (magnitude - 1) ** 2 / variance - 0.5 * jnp.log(2 * jnp.pi * variance)
                )
                + self.mean.shape[0] * log_det
            )
        error = calibrated - self.faces @ rotation_matrix(rotation)
        covariance = jnp.einsum("ij,nj,kj->nik", matrix, self.variance, matrix)
        quadratic, log_det_cov = _gaussian_terms(covariance + scatter2 * jnp.eye(3), error)
        return (
            jnp.sum(-0.5 * quadratic - 0.5 * log_det_cov - 1.5 * jnp.log(2 * jnp.pi))
            + self.mean.shape[0] * log_det
        )

    def log_posterior(self, z):
        u = self.natural(z)
        prior = -0.5 * jnp.sum(((u - self.prior_mean) / self.prior_sd) ** 2)
        value = prior + self.log_likelihood(u)
        return jnp.where(jnp.isfinite(value), value, -jnp.inf)


def multi_position_problem(poses: Poses, classical: ClassicalCalibration) -> MultiPositionProblem:
    """The posterior of :mod:`this model <bayescal._multi_position>`, centred on (and its
    coordinates scaled by) the classical answer."""
    g, six_face = classical.gravity.value, classical.six_face
    values = classical.values
    n_calibration = values.size
    relative = values[:3] / g
    sd = np.sqrt(np.diag(classical.covariance))
    # The classical residual RMS in g: magnitudes (free) or raw components (six-face).
    scatter = classical.residual_rms * (float(np.mean(relative)) if six_face else 1 / g)
    n_angles = n_calibration - 6  # misalignment, and the mounting rotation of six faces
    location = np.concatenate([np.log(relative), values[3:], [math.log(scatter)]])
    prior_mean = np.concatenate(
        [np.log(relative), np.zeros(n_angles), values[-3:], [math.log(scatter)]]
    )
    prior_sd = np.concatenate(
        [
            np.full(3, SCALE_PRIOR_LOG_SD),
            np.full(3, ANGLE_PRIOR_SD),
            np.full(n_angles - 3, ROTATION_PRIOR_SD),
            1 / relative,
            [SCATTER_PRIOR_LOG_SD],
        ]
    )
    step = np.concatenate([sd[:3] / values[:3], sd[3:], [1.0]])
    # A noiseless fit (no residual at all) leaves no classical spread to scale by.
    step = np.where(step > 0, step, 1e-6 * prior_sd)
    faces = np.zeros((poses.n, 3)) if classical.faces is None else classical.faces
    return MultiPositionProblem(
        mean=jnp.asarray(poses.mean),
        variance=jnp.asarray(poses.variance_of_mean),
        faces=jnp.asarray(faces),
        location=jnp.asarray(location),
        step=jnp.asarray(step),
        prior_mean=jnp.asarray(prior_mean),
        prior_sd=jnp.asarray(prior_sd),
        six_face=six_face,
    )
