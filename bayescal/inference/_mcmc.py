"""Posterior sampling with emcee and the health checks every posterior must pass.

Any model with a batched log-posterior uses :func:`sample_ensemble` and :func:`diagnose`:
walkers start from the Laplace approximation at the MAP, move by differential evolution
(ter Braak 2006; on a fleet's 3-D bias population its autocorrelation times were 13-33
steps against the stretch move's 39-53), and run until the chain is longer than
AUTOCORR_MULTIPLE autocorrelation times by the estimates at two successive checks and its
R-hat and bulk ESS pass: a run long enough by its autocorrelation whose R-hat or ESS is short
of the bar is borderline, and runs on rather than failing, to RUN_ON times the length at which
it was first long enough (or the step limit): a run that has not mixed by then fails its
checks, at a bounded cost, instead of spending the whole step limit. The
checks come after FIRST_CHUNK steps, then after each eighth of the run so far. The checks
(Vehtari et al. 2021 for R-hat and ESS; emcee's guidance for the rest): that criterion, bulk
ESS >= MIN_ESS for every parameter, R-hat <= MAX_RHAT across RHAT_GROUPS groups of walkers,
mean acceptance within ACCEPTANCE_RANGE, and a converged MAP.

A run that is stuck — its acceptance below the range, or walkers stranded far below the
others' log density (a start from a Laplace approximation that does not hold: a ridge, a
second mode) — is restarted before a failure is declared, at most MAX_RESTARTS times: the
walkers start again from the mean and covariance of the unstranded walkers' second half,
with the steps that are left. A run still below the acceptance range after its last restart
stops there (running it on to the step limit would not make it explore).
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
from ._traced import persistent_jit

MAX_RHAT = 1.01
MIN_ESS = 400
ACCEPTANCE_RANGE = (0.1, 0.8)
AUTOCORR_MULTIPLE = 50
RHAT_GROUPS = 4
MAX_STORED_DRAWS = 2000
MAX_RESTARTS = 2
"""Restarts of a run that is stuck (:func:`sample_ensemble`) before a failure is declared."""
RESTART_AFTER = (1000, 0.1)
"""A run is judged stuck no sooner than this many steps, or this share of the most steps."""
STRAGGLER_LOG_DENSITY = 20.0
"""A walker whose log density stays this far (plus the ensemble's own spread) below the
median is stuck away from the posterior."""
FIRST_CHUNK = 250
"""Steps before the first convergence check (:func:`sample_ensemble`)."""
RUN_ON = 10
"""A run long enough by its autocorrelation but short of its R-hat or ESS runs on to at most
this many times the length at which it was first long enough (:func:`sample_ensemble`)."""
CHECK_SHARE = 8
"""A single run's later checks come after this share (1/8) of the run so far, and at least
half the first chunk apart: a run stops at most an eighth past where it met its criterion."""


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
    restarts: int = 0
    """Times the run was restarted, stuck, before these checks (:func:`sample_ensemble`)."""

    def as_dict(self) -> dict:
        return {
            field: (list(value) if isinstance(value, tuple) else value)
            for field, value in vars(self).items()
        }


@persistent_jit
def _walker_log_densities(log_density, model, theta):
    return jax.vmap(lambda walker: log_density(model, walker))(theta)


@persistent_jit
def _grouped_log_densities(log_density, models, theta):
    """Walkers (groups x walkers each, dimension), group g's of model g of the stack
    ``models`` (arrays with a leading axis of groups): vmap over the groups of vmap over
    their walkers."""
    groups = jax.tree.leaves(models)[0].shape[0]
    by_group = theta.reshape(groups, -1, theta.shape[-1])
    return jax.vmap(
        lambda model, walkers: jax.vmap(lambda walker: log_density(model, walker))(walkers)
    )(models, by_group).reshape(-1)


def batch_log_density(log_density, model, grouped: bool = False):
    """``theta (walkers, dimension) -> (walkers,)`` log densities ``log_density(model,
    theta)`` as numpy, for emcee: every walker in one compiled call per step.

    ``log_density`` must be a module-level function (it keys the compilation cache). The
    function is traced, or loaded from the trace cache (:mod:`._traced`), at the first call,
    and the model's arrays are moved to the device once: each of the sampler's thousands of
    calls passes only the walkers' positions. ``grouped``: ``model`` is a stack of models
    (a leading axis of groups) and the walkers come in as many equal groups, in order, each
    of its own model (:class:`~bayescal.inference._batched.GroupedDEMove`).
    """
    require_x64()
    over = _grouped_log_densities if grouped else _walker_log_densities
    specialised = {}

    def batch(theta):
        theta = np.asarray(theta, dtype=float)
        if theta.shape not in specialised:
            function, leaves = over.specialised(log_density, model, theta)
            fixed = [jax.device_put(leaf) for leaf in leaves[:-1]]
            specialised[theta.shape] = partial(function, *fixed)
        return np.asarray(specialised[theta.shape](theta))

    return batch


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
    """Run emcee from the Laplace approximation N(start, covariance) until converged (the
    autocorrelation criterion at two successive checks, R-hat and bulk ESS passing: module
    docstring) or ``max_steps``.

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
    sampler = ensemble(log_posterior_batch, n_walkers, dimension, rng)
    state = laplace_start(start, covariance, rng, n_walkers)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(
            total=max_steps, desc="posterior (emcee)", unit="step", leave=False, file=sys.stderr
        )
    longer_before, converged, chunk = False, False, FIRST_CHUNK
    converged_at = None
    restarts, used = 0, 0
    judge_after = max(RESTART_AFTER[0], int(RESTART_AFTER[1] * max_steps))
    while used + sampler.iteration < max_steps:
        steps = min(chunk, max_steps - used - sampler.iteration)
        state = sampler.run_mcmc(state, steps)
        if bar is not None:
            bar.update(steps)
        tau = sampler.get_autocorr_time(tol=0)
        longer = long_enough(tau, sampler.iteration)
        converged = longer and longer_before
        # Long enough, but R-hat or the ESS short of its bar: a borderline run (a biquad's
        # R-hat 1.017 against 1.01, on a chain that differed from a passing one only in its
        # rounding) runs on, for more steps settle it, rather than failing its checks.
        if converged:
            converged_at = converged_at or sampler.iteration
            if _mixed(sampler, tau) or sampler.iteration >= RUN_ON * converged_at:
                break
        longer_before = longer
        chunk = max(FIRST_CHUNK // 2, sampler.iteration // CHECK_SHARE)
        if sampler.iteration >= judge_after and _stuck(sampler):
            if restarts == MAX_RESTARTS:
                break  # still stuck after the last restart: it would not explore
            restarts += 1
            used += sampler.iteration
            state = _restart(sampler, rng)
            sampler = ensemble(log_posterior_batch, n_walkers, dimension, rng)
            longer_before, chunk, converged_at = False, FIRST_CHUNK, None
    if bar is not None:
        bar.close()
    sampler.restarts = restarts  # read by diagnose()
    return sampler, converged


def laplace_start(start, covariance, rng, n_walkers: int) -> np.ndarray:
    """``n_walkers`` starting points drawn from the Laplace approximation N(start,
    covariance)."""
    spread = np.linalg.cholesky(covariance + 1e-12 * np.eye(start.size))
    return start + rng.standard_normal((n_walkers, start.size)) @ spread.T


def long_enough(tau, steps: int) -> bool:
    """Whether a chain of ``steps`` is longer than AUTOCORR_MULTIPLE autocorrelation times
    ``tau`` (every parameter's, all finite)."""
    return bool(np.all(np.isfinite(tau)) and steps > AUTOCORR_MULTIPLE * np.max(tau))


def ensemble(log_posterior_batch, n_walkers: int, dimension: int, rng, move=None):
    """emcee's ensemble, its log densities vectorised, seeded from ``rng``: with
    differential-evolution moves, or ``move`` (a grouped one,
    :class:`~bayescal.inference._batched.GroupedDEMove`)."""
    sampler = emcee.EnsembleSampler(
        n_walkers,
        dimension,
        log_posterior_batch,
        vectorize=True,
        moves=emcee.moves.DEMove() if move is None else move,
    )
    # emcee wraps the log density to print a traceback of any exception it raises before
    # passing it on: an interruption (Ctrl-C, the command line's SIGTERM) is to end the run
    # quietly. With no extra arguments the wrapper adds nothing else, so it is left out.
    sampler.log_prob_fn = log_posterior_batch
    sampler.random_state = np.random.RandomState(rng.integers(2**31)).get_state()
    return sampler


def _stranded(sampler) -> np.ndarray:
    """Walkers whose log density over the second half of the run stays far below the
    median's (by :data:`STRAGGLER_LOG_DENSITY` plus the spread a posterior's own walkers
    have, sqrt(d / 2))."""
    half = sampler.iteration // 2
    recent = np.mean(sampler.get_log_prob(discard=half), axis=0)
    spread = math.sqrt(sampler.ndim / 2)
    return recent < np.median(recent) - STRAGGLER_LOG_DENSITY - 5 * spread


def _stuck(sampler) -> bool:
    """Whether a run is stuck: its acceptance below the range, or walkers stranded."""
    return bool(
        np.mean(sampler.acceptance_fraction) < ACCEPTANCE_RANGE[0] or _stranded(sampler).any()
    )


def _restart(sampler, rng) -> np.ndarray:
    """A fresh start for a stuck run: from the normal of the mean and covariance of the
    unstranded walkers' positions over the run's second half."""
    chain = sampler.get_chain(discard=sampler.iteration // 2)  # (steps, walkers, dim)
    kept = chain[:, ~_stranded(sampler)].reshape(-1, sampler.ndim)
    mean = kept.mean(axis=0)
    covariance = np.cov(kept, rowvar=False).reshape(sampler.ndim, sampler.ndim)
    spread = np.linalg.cholesky(covariance + 1e-12 * np.eye(sampler.ndim))
    return mean + rng.standard_normal((sampler.nwalkers, sampler.ndim)) @ spread.T


def _mixing(sampler, tau) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """The burn-in (twice the longest autocorrelation time ``tau``, at most half the run),
    the chain after it (walkers, steps, dim), and per parameter its bulk ESS over the walkers
    and R-hat across RHAT_GROUPS groups of them. Kept on the sampler for its iteration: the
    stopping rule (:func:`sample_ensemble`) and :func:`diagnose` read the same (the ESS and
    R-hat cost some 20 ms)."""
    kept = getattr(sampler, "mixing", None)
    if kept is not None and kept[0] == sampler.iteration:
        return kept[1:]
    burn_in = math.ceil(2 * np.max(tau)) if np.all(np.isfinite(tau)) else sampler.iteration // 2
    burn_in = min(burn_in, sampler.iteration // 2)
    by_walker = np.moveaxis(sampler.get_chain(discard=burn_in), 0, 1)
    groups = by_walker.reshape(RHAT_GROUPS, -1, by_walker.shape[2])
    dimensions = range(by_walker.shape[2])
    ess = [array_stats.ess(by_walker[..., i], chain_axis=0, draw_axis=1) for i in dimensions]
    rhat = [array_stats.rhat(groups[..., i], chain_axis=0, draw_axis=1) for i in dimensions]
    kept = (burn_in, by_walker, np.asarray(ess, dtype=float), np.asarray(rhat, dtype=float))
    sampler.mixing = (sampler.iteration, *kept)
    return kept


def _mixed(sampler, tau) -> bool:
    """Whether the run's bulk ESS and R-hat pass their checks (:func:`diagnose`)."""
    _, _, ess, rhat = _mixing(sampler, tau)
    return bool(np.all(ess >= MIN_ESS) and np.all(rhat <= MAX_RHAT))


def diagnose(sampler, names, converged: bool, map_converged: bool):
    """The health checks of an emcee run, and the draws kept from it, (walkers, draws, dim):
    the same number for every run, so that functions of them compile once."""
    tau = sampler.get_autocorr_time(tol=0)
    burn_in, by_walker, ess_of, rhat_of = _mixing(sampler, tau)
    steps = by_walker.shape[1]
    kept = np.unique(np.linspace(0, steps - 1, MAX_STORED_DRAWS // by_walker.shape[0]).round())
    ess = {name: float(ess_of[i]) for i, name in enumerate(names)}
    rhat = {name: float(rhat_of[i]) for i, name in enumerate(names)}
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
    restarts = getattr(sampler, "restarts", 0)
    if not ACCEPTANCE_RANGE[0] <= float(np.mean(acceptance)) <= ACCEPTANCE_RANGE[1]:
        after = f" after {restarts} restart(s)" if restarts else ""
        failures.append(
            f"acceptance fraction {np.mean(acceptance):.2f} outside {ACCEPTANCE_RANGE}{after}"
        )
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
        restarts=restarts,
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
