"""The posterior of a multi-position calibration (the model of
:mod:`bayescal.models._multi_position`): the MAP, emcee from its Laplace approximation
(checked like every posterior), and g_local drawn from its prior for each draw."""

import math
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ..classical._multi_position import ClassicalCalibration, Poses
from ..models._multi_position import MultiPositionProblem, multi_position_problem
from ._mcmc import (
    Diagnostics,
    batch_log_density,
    diagnose,
    sample_ensemble,
    walker_count,
)
from ._optimize import maximum_a_posteriori
from ._sampler import Sampler


@dataclass(frozen=True)
class BayesianCalibration:
    """The posterior of a multi-position calibration: draws, MAP with Laplace sds, checks."""

    names: tuple[str, ...]
    """The calibration parameters, then pose_scatter and g_local."""
    draws: dict
    """name -> (walkers, draws) posterior draws."""
    map_values: dict
    map_sd: dict
    """Laplace (Hessian) standard deviations at the MAP, by the delta method, gravity's
    uncertainty included in the scales and the pose scatter."""
    diagnostics: Diagnostics


def bayesian_multi_position(
    poses: Poses,
    classical: ClassicalCalibration,
    *,
    seed: int = 0,
    sampler: Sampler = Sampler(),
) -> BayesianCalibration:
    """Posterior of the calibration parameters, the pose scatter sigma_p (m/s^2) and g_local,
    with its MAP and health checks. The same inputs and ``seed`` give the same result."""
    problem = multi_position_problem(poses, classical)
    gravity = classical.gravity
    names = (*classical.names, "pose_scatter")
    n_calibration = len(classical.names)
    rng = np.random.default_rng(seed)
    mode = maximum_a_posteriori(
        MultiPositionProblem.log_posterior, problem, jnp.zeros_like(problem.location)
    )
    best, map_converged, covariance = mode.theta, mode.converged, mode.covariance
    ensemble, converged = sample_ensemble(
        batch_log_density(MultiPositionProblem.log_posterior, problem),
        np.asarray(best),
        covariance,
        rng,
        walker_count(len(names), sampler.n_walkers),
        sampler.max_steps,
        sampler.progress,
    )
    diagnostics, kept = diagnose(ensemble, names, converged, bool(map_converged))
    u = np.asarray(problem.location) + np.asarray(problem.step) * kept
    g = gravity.value + gravity.uncertainty * rng.standard_normal(u.shape[:-1])

    def physical(u, g):
        """Calibration parameters, pose scatter and g from coordinates u in units of g."""
        values = np.concatenate(
            [g[..., None] * np.exp(u[..., :3]), u[..., 3:n_calibration]], axis=-1
        )
        scatter = g * np.exp(u[..., n_calibration])
        return {
            **{name: values[..., i] for i, name in enumerate(classical.names)},
            "pose_scatter": scatter,
            "g_local": g,
        }

    draws = physical(u, g)
    u_map = np.asarray(problem.location) + np.asarray(problem.step) * np.asarray(best)
    map_values = {
        name: float(value) for name, value in physical(u_map, np.asarray(gravity.value)).items()
    }
    u_sd = np.asarray(problem.step) * np.sqrt(np.maximum(np.diag(covariance), 0.0))
    relative_g = gravity.uncertainty / gravity.value
    map_sd = {"g_local": gravity.uncertainty}
    for i, name in enumerate(names):
        if i < 3 or name == "pose_scatter":
            map_sd[name] = map_values[name] * math.hypot(u_sd[i], relative_g)
        else:
            map_sd[name] = float(u_sd[i])
    return BayesianCalibration((*names, "g_local"), draws, map_values, map_sd, diagnostics)
