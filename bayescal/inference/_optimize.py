"""The maximum a posteriori point and its Laplace approximation: one routine for every model.

BFGS (optimistix) minimises the negative log density from each of a few starts; the best
optimum is kept with the Hessian of the negative log density there (the Laplace
approximation's precision) and whether that run converged. Models whose terms a record may
not hold start twice — at the prior centre and well below it, where the absent terms sit —
because the log density has a second basin there.
"""

from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from .._x64 import require_x64  # float64 before any JAX array
from ._traced import persistent_jit

RTOL = ATOL = 1e-9
MAX_STEPS = 2000


class Mode(eqx.Module):
    """The maximum a posteriori point: the coordinates, the Hessian of the negative log
    density there, and whether its optimisation converged."""

    theta: np.ndarray
    hessian: np.ndarray
    converged: bool

    @property
    def covariance(self) -> np.ndarray:
        """The Laplace covariance: the (pseudo-)inverse of the Hessian."""
        return np.linalg.pinv(self.hessian)


@persistent_jit
def _minimise(log_density, model, starts):
    def objective(theta, _):
        return -log_density(model, theta)

    solver = optx.BFGS(rtol=RTOL, atol=ATOL)
    solutions = [
        optx.minimise(objective, solver, start, max_steps=MAX_STEPS, throw=False)
        for start in starts
    ]
    values = jnp.stack([objective(solution.value, None) for solution in solutions])
    values = jnp.where(jnp.isfinite(values), values, jnp.inf)
    pick = jnp.argmin(values)
    best, converged = solutions[0].value, solutions[0].result == optx.RESULTS.successful
    for index, solution in enumerate(solutions[1:], start=1):
        best = jnp.where(pick == index, solution.value, best)
        converged = jnp.where(pick == index, solution.result == optx.RESULTS.successful, converged)
    return best, jax.hessian(lambda theta: objective(theta, None))(best), converged


def maximum_a_posteriori(
    log_density: Callable, model, starts: tuple[jax.Array, ...] | jax.Array
) -> Mode:
    """Maximise ``log_density(model, theta)`` from each start (one array, or a tuple of them).

    ``log_density`` must be a function defined once (a module-level function or a method of
    the model's class): it keys the compilation cache, so every model of the same structure
    reuses one compiled optimiser.
    """
    require_x64()
    starts = (starts,) if not isinstance(starts, (tuple, list)) else tuple(starts)
    best, hessian, converged = _minimise(log_density, model, tuple(jnp.asarray(s) for s in starts))
    return Mode(np.asarray(best), np.asarray(hessian), bool(converged))
