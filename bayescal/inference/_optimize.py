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


def _optimum(log_density, model, starts):
    """The best of BFGS from each start, the Hessian there and whether that run converged."""

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


_minimise = persistent_jit(_optimum)


@persistent_jit
def _minimise_each(log_density, model, positions, varying, starts):
    """:func:`_optimum` of ``model`` with its array leaves at ``positions`` taken in turn from
    ``varying`` (each stacked along a first axis): one batched solve."""
    dynamic, static = eqx.partition(model, eqx.is_array)
    leaves, treedef = jax.tree_util.tree_flatten(dynamic)

    def one(own):
        mine = list(leaves)
        for position, leaf in zip(positions, own, strict=True):
            mine[position] = leaf
        return _optimum(
            log_density, eqx.combine(jax.tree_util.tree_unflatten(treedef, mine), static), starts
        )

    return jax.vmap(one)(varying)


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


def maxima_a_posteriori(
    log_density: Callable, models: list, starts: tuple[jax.Array, ...]
) -> list[Mode]:
    """:func:`maximum_a_posteriori` of each of ``models`` — of one structure, differing in a
    few arrays (a term search's masks) — in one batched solve (``jax.vmap``): one compiled
    call instead of one per model, where each solve's many small steps cost more in their
    overhead than in arithmetic (on a GPU, far more). The arrays the models share are passed
    once. Each model's optimum is its own: the batch runs until every one has converged."""
    require_x64()
    if len(models) == 1:
        return [maximum_a_posteriori(log_density, models[0], starts)]
    flat = [jax.tree_util.tree_leaves(eqx.filter(model, eqx.is_array)) for model in models]
    first = flat[0]
    positions = tuple(
        index
        for index, leaf in enumerate(first)
        if not all(other[index] is leaf or np.array_equal(other[index], leaf) for other in flat[1:])
    )
    varying = tuple(jnp.stack([leaves[index] for leaves in flat]) for index in positions)
    best, hessian, converged = _minimise_each(
        log_density, models[0], positions, varying, tuple(jnp.asarray(s) for s in starts)
    )
    best, hessian, converged = (np.asarray(a) for a in (best, hessian, converged))
    return [
        Mode(best[index], hessian[index], bool(converged[index])) for index in range(len(models))
    ]
