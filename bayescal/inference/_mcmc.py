"""Posterior sampling with emcee and the health checks every posterior must pass.

Any model with a batched log-posterior uses :func:`sample_ensemble` and :func:`diagnose`:
walkers start from the Laplace approximation at the MAP, move by differential evolution
(ter Braak 2006; on a fleet's 3-D bias population its autocorrelation times were 13-33
steps against the stretch move's 39-53), and run until the chain is longer than
AUTOCORR_MULTIPLE autocorrelation times by the estimates at two successive checks. The checks
(Vehtari et al. 2021 for R-hat and ESS; emcee's guidance for the rest): that criterion, bulk
ESS >= MIN_ESS for every parameter, R-hat <= MAX_RHAT across RHAT_GROUPS groups of walkers,
mean acceptance within ACCEPTANCE_RANGE, and a converged MAP.
"""

import math
import sys
from functools import partial

import emcee
import equinox as eqx
import jax
import numpy as np
from arviz_stats.base import array_stats

from .._x64 import require_x64  # float64 before any JAX array

MAX_RHAT = 1.01
MIN_ESS = 400
ACCEPTANCE_RANGE = (0.1, 0.8)
AUTOCORR_MULTIPLE = 50
RHAT_GROUPS = 4
MAX_STORED_DRAWS = 2000


class Diagnostics(eqx.Module):
    passed: bool
    failures: tuple[str, ...]
    converged: bool
    n_walkers: int
    n_steps: int
    burn_in: int
    thin: int
    """Steps between the posterior draws kept (about)."""
    autocorr_time: dict
    ess_bulk: dict
    rhat: dict
    acceptance_fraction: float
    min_walker_acceptance: float
    map_converged: bool

    def as_dict(self) -> dict:
        return {
            field: (list(value) if isinstance(value, tuple) else value)
            for field, value in vars(self).items()
        }


@partial(jax.jit, static_argnames=("log_density", "treedef"))
def _walker_log_densities(log_density, treedef, leaves, theta):
    model = jax.tree_util.tree_unflatten(treedef, leaves)
    return jax.vmap(lambda walker: log_density(model, walker))(theta)


def batch_log_density(log_density, model):
    """``theta (walkers, dimension) -> (walkers,)`` log densities ``log_density(model,
    theta)`` as numpy, for emcee.

    ``log_density`` must be a module-level function (it keys the compilation cache). The model
    travels as its array leaves and tree structure: one compilation serves every model of the
    same structure and shapes, and a plain list of arrays costs about half as much to pass on
    each of the sampler's thousands of calls as the module through ``eqx.filter_jit``.
    """
    require_x64()
    leaves, treedef = jax.tree_util.tree_flatten(model)
    return lambda theta: np.asarray(_walker_log_densities(log_density, treedef, leaves, theta))


def walker_count(dimension: int, requested: int = 32) -> int:
    """At least twice the dimension plus two, and a multiple of the R-hat groups."""
    count = max(requested, 2 * dimension + 2)
    return count + -count % RHAT_GROUPS


def sample_ensemble(
    log_posterior_batch,
    start,
    covariance,
    rng,
    n_walkers: int,
    max_steps: int,
    progress: bool = False,
):
    """Run emcee from the Laplace approximation N(start, covariance) until converged.

    ``log_posterior_batch`` maps a (walkers, dimension) array to (walkers,) numpy log
    densities (see :func:`batch_log_density`).
    Returns the sampler and whether the autocorrelation criterion was met.
    """
    dimension = start.size
    # Differential evolution alone. emcee's snooker move (DESnookerMove, up to release 3.1.6)
    # does not leave the posterior invariant: it scales its step by the distance to the
    # anchor walker instead of a unit vector (fixed on emcee's main branch, PR #531, not yet
    # released). A fifth of snooker moves made every posterior's sd 2-3 % too small, and a
    # hierarchical population's intervals 7 % too narrow (tests/test_mcmc.py measures it).
    sampler = emcee.EnsembleSampler(
        n_walkers, dimension, log_posterior_batch, vectorize=True, moves=emcee.moves.DEMove()
    )
    # emcee wraps the log density to print a traceback of any exception it raises before
    # passing it on: an interruption (Ctrl-C, the command line's SIGTERM) is to end the run
    # quietly. With no extra arguments the wrapper adds nothing else, so it is left out.
    sampler.log_prob_fn = log_posterior_batch
    sampler.random_state = np.random.RandomState(rng.integers(2**31)).get_state()
    spread = np.linalg.cholesky(covariance + 1e-12 * np.eye(dimension))
    state = start + rng.standard_normal((n_walkers, dimension)) @ spread.T
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(
            total=max_steps, desc="posterior (emcee)", unit="step", leave=False, file=sys.stderr
        )
    longer_before, converged, chunk = False, False, 250
    while sampler.iteration < max_steps:
        steps = min(chunk, max_steps - sampler.iteration)
        state = sampler.run_mcmc(state, steps)
        if bar is not None:
            bar.update(steps)
        tau = sampler.get_autocorr_time(tol=0)
        longer = bool(
            np.all(np.isfinite(tau)) and sampler.iteration > AUTOCORR_MULTIPLE * np.max(tau)
        )
        if longer and longer_before:
            converged = True
            break
        longer_before = longer
        chunk = max(chunk, int(sampler.iteration // 4))
    if bar is not None:
        bar.close()
    return sampler, converged


def diagnose(sampler, names, converged: bool, map_converged: bool):
    """The health checks of an emcee run, and the draws kept from it, (walkers, draws, dim):
    the same number for every run, so that functions of them compile once."""
    tau = sampler.get_autocorr_time(tol=0)
    burn_in = math.ceil(2 * np.max(tau)) if np.all(np.isfinite(tau)) else sampler.iteration // 2
    burn_in = min(burn_in, sampler.iteration // 2)
    by_walker = np.moveaxis(sampler.get_chain(discard=burn_in), 0, 1)
    steps = by_walker.shape[1]
    kept = np.unique(np.linspace(0, steps - 1, MAX_STORED_DRAWS // by_walker.shape[0]).round())
    groups = by_walker.reshape(RHAT_GROUPS, -1, by_walker.shape[2])
    ess, rhat = {}, {}
    for i, name in enumerate(names):
        ess[name] = float(array_stats.ess(by_walker[..., i], chain_axis=0, draw_axis=1))
        rhat[name] = float(array_stats.rhat(groups[..., i], chain_axis=0, draw_axis=1))
    acceptance = sampler.acceptance_fraction
    failures = []
    if not converged:
        failures.append(
            f"autocorrelation-time criterion not met in {sampler.iteration} steps "
            f"(needs {AUTOCORR_MULTIPLE} x tau = {AUTOCORR_MULTIPLE * np.max(tau):.0f})"
        )
    for name in names:
        if not ess[name] >= MIN_ESS:
            failures.append(f"effective sample size of {name} is {ess[name]:.0f} (< {MIN_ESS})")
        if not rhat[name] <= MAX_RHAT:
            failures.append(
                f"R-hat of {name} across walker groups is {rhat[name]:.3f} (> {MAX_RHAT})"
            )
    if not ACCEPTANCE_RANGE[0] <= float(np.mean(acceptance)) <= ACCEPTANCE_RANGE[1]:
        failures.append(f"acceptance fraction {np.mean(acceptance):.2f} outside {ACCEPTANCE_RANGE}")
    if not map_converged:
        failures.append("the MAP optimisation did not converge")
    diagnostics = Diagnostics(
        passed=not failures,
        failures=tuple(failures),
        converged=converged,
        n_walkers=acceptance.size,
        n_steps=int(sampler.iteration),
        burn_in=burn_in,
        thin=max(1, steps // kept.size),
        autocorr_time={name: float(t) for name, t in zip(names, tau, strict=True)},
        ess_bulk=ess,
        rhat=rhat,
        acceptance_fraction=float(np.mean(acceptance)),
        min_walker_acceptance=float(np.min(acceptance)),
        map_converged=map_converged,
    )
    return diagnostics, by_walker[:, kept.astype(int)]


def summarize(draws, unit: str, map_value: float | None = None, map_sd: float | None = None):
    """Mean, sd, 5 % and 95 % quantiles of posterior draws (any shape), with the unit, and the
    MAP with its Laplace sd when given: the layout of every ``parameters`` block in the JSON."""
    draws = np.ravel(draws)
    summary = {
        "mean": float(draws.mean()),
        "sd": float(draws.std(ddof=1)),
        "q05": float(np.quantile(draws, 0.05)),
        "q95": float(np.quantile(draws, 0.95)),
    }
    if map_value is not None:
        summary.update(map=map_value, map_sd=map_sd)
    summary["unit"] = unit
    return summary
