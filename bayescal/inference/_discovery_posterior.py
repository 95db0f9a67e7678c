"""The posterior of the model discovery ended with (:mod:`._discovery_search`): emcee over its
noise coordinates with the regression integrated out, then the regression coefficients from
their exact conditional normal, in the channel's units (each effect reports its own
parameters from these draws: :meth:`bayescal.models.effects._base.Effect.describe`)."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ..models._composite import (
    MAX_REGRESSORS,
    NOISE_SLOTS,
    SLOT_OF,
    SLOT_PARAMETERS,
    LevelNoise,
    ModelFit,
    ModelSpec,
    batch_profile,
    level_coefficients,
    marginal_log_posterior,
    regressor_columns,
    slot_values,
    slow_columns,
)
from ..models.effects._base import SlotTerm
from ._discovery_fit import DiscoveryData
from ._mcmc import batch_log_density, diagnose, sample_ensemble, walker_count
from ._sampler import Sampler


class FinalPosterior(eqx.Module):
    """The final model's posterior: draws and units by parameter name, and the sampler's
    checks."""

    draws: dict
    """name -> (walkers, draws) in the channel's units."""
    units: dict = eqx.field(static=True)
    diagnostics: object


def _active_noise(spec: ModelSpec) -> list[int]:
    return [SLOT_OF[type(effect)] for effect in spec.effects if isinstance(effect, SlotTerm)]


def sample_final(
    fit: ModelFit, data: DiscoveryData, *, seed: int = 0, sampler: Sampler = Sampler()
) -> FinalPosterior:
    """emcee posterior of the final model's noise coordinates (regression integrated out),
    then the regression coefficients from their exact conditional normal. Nonlinear
    parameters found by search (time constants, frequencies) are held at their values."""
    rng = np.random.default_rng(seed)
    active = _active_noise(fit.spec)
    full = np.asarray(fit.theta)

    def embed(sub):
        theta = np.broadcast_to(full, (*sub.shape[:-1], full.size)).copy()
        theta[..., active] = sub
        return theta

    hessian = fit.hessian[np.ix_(active, active)]
    covariance = np.linalg.pinv(hessian)
    names = [NOISE_SLOTS[i] for i in active]
    log_posterior = batch_log_density(marginal_log_posterior, fit.design)
    ensemble, converged = sample_ensemble(
        lambda sub: log_posterior(embed(sub)),
        full[active],
        covariance,
        rng,
        walker_count(len(active), sampler.n_walkers),
        sampler.max_steps,
        sampler.progress,
    )
    diagnostics, kept = diagnose(ensemble, names, converged, fit.converged)
    theta = embed(kept)
    flat = theta.reshape(-1, theta.shape[-1])
    beta, precision = batch_profile(fit.design, jnp.asarray(flat))
    beta, precision = np.array(beta), np.asarray(precision)
    n_regressors = fit.beta.size
    noise_draw = rng.standard_normal((flat.shape[0], MAX_REGRESSORS))
    factor = np.linalg.cholesky(np.linalg.inv(precision))
    beta = beta + np.einsum("dij,dj->di", factor, noise_draw)
    slow = slow_columns(fit.spec)
    if slow.size:
        regressors, _, _ = regressor_columns(fit.spec, data)
        level_beta, level_covariance, _ = level_coefficients(
            LevelNoise(
                fit.design.mask, fit.design.ramp_scale, fit.design.floor, fit.spec.gauss_markov_s
            ),
            fit.clean,
            regressors[:, slow],
            data.rate_hz,
            flat,
        )
        level_factor = np.linalg.cholesky(level_covariance)
        beta[:, slow] = level_beta + np.einsum(
            "dij,dj->di", level_factor, rng.standard_normal(level_beta.shape)
        )
    shape = theta.shape[:-1]
    draws, units = {}, {}
    values = slot_values(jnp.asarray(theta), np.ones(len(NOISE_SLOTS)), fit.design.ramp_scale)
    for index in active:
        parameter = SLOT_PARAMETERS[index]
        draws[parameter.name] = np.asarray(values[parameter.name])
        units[parameter.name] = parameter.unit_for(data.unit)
    _, scales, coefficient_units = regressor_columns(fit.spec, data)
    coefficient_names = fit.spec.regressor_names()
    coefficients = beta[:, :n_regressors] / np.where(scales > 0, scales, 1.0)
    for position, name in enumerate(coefficient_names):
        draws[name] = coefficients[:, position].reshape(shape)
        units[name] = coefficient_units[position]
    for term, index in fit.spec.regression_terms():
        term.derive(draws, units, index)
    return FinalPosterior(draws, units, diagnostics)
