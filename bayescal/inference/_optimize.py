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
    density there, whether its optimisation converged, and the log density there."""

    theta: np.ndarray
    hessian: np.ndarray
    converged: bool
    log_density: float
    """The log density at ``theta`` (as the optimiser evaluated it; -inf where not finite)."""

    @property
    def covariance(self) -> np.ndarray:
        """The Laplace covariance: the (pseudo-)inverse of the Hessian."""
        return np.linalg.pinv(self.hessian)


def _solve(log_density, model, starts):
    """The best of BFGS's optima from ``starts``, the Hessian there, whether it converged and
    the log density there (traced: :func:`_minimise` compiles it for one model,
    :func:`_minimise_each` for a stack)."""

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
    hessian = jax.hessian(lambda theta: objective(theta, None))(best)
    return best, hessian, converged, -jnp.min(values)


_minimise = persistent_jit(_solve)


@persistent_jit
def _minimise_each(log_density, models, starts):
    """:func:`_solve` of each of a stack of models (arrays with a leading axis, one per
    model) from its own starts: one compiled call (optimistix's solves map with ``vmap``,
    each keeping its own steps and convergence)."""
    return jax.vmap(lambda model, own: _solve(log_density, model, own))(models, starts)


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
    best, hessian, converged, value = _minimise(
        log_density, model, tuple(jnp.asarray(s) for s in starts)
    )
    return Mode(np.asarray(best), np.asarray(hessian), bool(converged), float(value))


def maximum_a_posteriori_each(log_density: Callable, models, starts: tuple) -> list[Mode]:
    """:func:`maximum_a_posteriori` of each of a stack of models (their arrays stacked on a
    leading axis, :func:`~bayescal.inference._batched.stack_problems`) from its own starts
    (a tuple of (models, dimension) arrays), in one compiled call; each keeps its own
    convergence status."""
    require_x64()
    solved = _minimise_each(log_density, models, tuple(jnp.asarray(s) for s in starts))
    best, hessian, converged, value = (np.asarray(array) for array in solved)
    return [
        Mode(best[i], hessian[i], bool(converged[i]), float(value[i])) for i in range(best.shape[0])
    ]
