"""A linear-Gaussian state-space model, its Kalman filter (with the log-likelihood of the data,
so that hyperparameters can be sampled) and its Rauch-Tung-Striebel smoother, in JAX.

Model, steps k = 0 .. K-1:

    x_k = Phi_k x_{k-1} + w_k,   w_k ~ N(0, Q_k)        (Phi_0 = I, Q_0 = 0: x_0 ~ N(m_0, P_0))
    y_k = H_k x_k + v_k,         v_k ~ N(0, R_k)

Any measurement model fits: H_k, R_k may change from step to step, and a component of y_k that
is NaN is missing (its row of H and its noise drop out of the update and of the likelihood),
so measurements of different kinds and rates share one array. The update uses Joseph's form
(Bucy & Joseph 1968), which keeps the covariance symmetric and positive definite. The
log-likelihood is the sum of the innovations' Gaussian log densities (the prediction error
decomposition, Harvey 1989 sec. 3.4). The smoother is RTS (Rauch, Tung & Striebel 1965; Sarkka
2013, *Bayesian Filtering and Smoothing*, sec. 8.2). Both are one ``jax.lax.scan``.

States of very different sizes (tilts of 1e-5 rad beside velocities of 1e-2 m/s and gyro
biases of 1e-8 rad/s) are best filtered in scaled units: :meth:`StateSpace.scaled` divides
each state by a scale (for instance its prior sd).
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import _x64  # noqa: F401  (float64 before any JAX array)


class StateSpace(eqx.Module):
    """The matrices of a linear-Gaussian state-space model over K steps (module docstring)."""

    transition: jax.Array
    """(K, n, n) Phi_k; Phi_0 is not used."""
    process: jax.Array
    """(K, n, n) Q_k; Q_0 is not used."""
    observation: jax.Array
    """(K, m, n) H_k."""
    observation_noise: jax.Array
    """(K, m, m) R_k."""

    def scaled(self, scale) -> "StateSpace":
        """The same model for the states divided by ``scale`` (n,)."""
        scale = jnp.asarray(scale, dtype=float)
        return StateSpace(
            self.transition * scale[None, None, :] / scale[None, :, None],
            self.process / jnp.outer(scale, scale)[None],
            self.observation * scale[None, None, :],
            self.observation_noise,
        )


class Filtered(eqx.Module):
    """What the Kalman filter gives at every step."""

    mean: jax.Array
    """(K, n) E[x_k | y_0..k]"""
    covariance: jax.Array
    """(K, n, n)"""
    predicted_mean: jax.Array
    """(K, n) E[x_k | y_0..k-1]"""
    predicted_covariance: jax.Array
    """(K, n, n)"""
    log_likelihood: jax.Array
    """log p(y_0..K-1), nats."""
    normalized_innovation: jax.Array
    """(K,) the innovation's squared Mahalanobis length nu^T S^-1 nu (chi^2 with as many
    degrees of freedom as components observed, when the model is right)."""
    observed: jax.Array
    """(K,) how many components of y_k were observed."""


def _update(mean, covariance, observation, noise, y):
    present = jnp.isfinite(y)
    h = jnp.where(present[:, None], observation, 0.0)
    r = jnp.where(present[:, None] & present[None, :], noise, 0.0)
    r = r + jnp.diag(jnp.where(present, 0.0, 1.0))
    innovation = jnp.where(present, y, 0.0) - h @ mean
    s = h @ covariance @ h.T + r
    factor = jax.scipy.linalg.cho_factor(s, lower=True)
    gain = jax.scipy.linalg.cho_solve(factor, h @ covariance).T
    i_kh = jnp.eye(mean.size) - gain @ h
    covariance = i_kh @ covariance @ i_kh.T + gain @ r @ gain.T
    whitened = jax.scipy.linalg.cho_solve(factor, innovation)
    quadratic = innovation @ whitened
    count = jnp.sum(present)
    log_det = 2 * jnp.sum(jnp.log(jnp.diag(factor[0])))
    log_density = -0.5 * (quadratic + log_det + count * math.log(2 * math.pi))
    return (
        mean + gain @ innovation,
        0.5 * (covariance + covariance.T),
        log_density,
        quadratic,
        count,
    )


@jax.jit
def kalman_filter(model: StateSpace, observations, mean0, covariance0) -> Filtered:
    """Filter ``observations`` (K, m; NaN where missing) from the prior N(``mean0``,
    ``covariance0``) of x_0."""

    def step(carry, inputs):
        mean, covariance = carry
        transition, process, observation, noise, y, first = inputs
        mean_p = jnp.where(first, mean, transition @ mean)
        covariance_p = jnp.where(
            first, covariance, transition @ covariance @ transition.T + process
        )
        mean_u, covariance_u, log_density, quadratic, count = _update(
            mean_p, covariance_p, observation, noise, y
        )
        return (mean_u, covariance_u), (
            mean_u,
            covariance_u,
            mean_p,
            covariance_p,
            log_density,
            quadratic,
            count,
        )

    first = jnp.arange(observations.shape[0]) == 0
    inputs = (
        model.transition,
        model.process,
        model.observation,
        model.observation_noise,
        observations,
        first,
    )
    _, (mean, covariance, mean_p, covariance_p, log_density, quadratic, count) = jax.lax.scan(
        step, (jnp.asarray(mean0, dtype=float), jnp.asarray(covariance0, dtype=float)), inputs
    )
    return Filtered(mean, covariance, mean_p, covariance_p, jnp.sum(log_density), quadratic, count)


@jax.jit
def rts_smoother(model: StateSpace, filtered: Filtered):
    """E[x_k | all y] and its covariance, (K, n) and (K, n, n)."""

    def step(carry, inputs):
        mean_s, covariance_s = carry
        mean_f, covariance_f, mean_p, covariance_p, transition = inputs
        gain = jnp.linalg.solve(covariance_p, transition @ covariance_f).T
        mean = mean_f + gain @ (mean_s - mean_p)
        covariance = covariance_f + gain @ (covariance_s - covariance_p) @ gain.T
        covariance = 0.5 * (covariance + covariance.T)
        return (mean, covariance), (mean, covariance)

    last = (filtered.mean[-1], filtered.covariance[-1])
    inputs = (
        filtered.mean[:-1],
        filtered.covariance[:-1],
        filtered.predicted_mean[1:],
        filtered.predicted_covariance[1:],
        model.transition[1:],
    )
    _, (mean, covariance) = jax.lax.scan(step, last, inputs, reverse=True)
    return (
        jnp.concatenate([mean, last[0][None]]),
        jnp.concatenate([covariance, last[1][None]]),
    )
