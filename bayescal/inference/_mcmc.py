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
import jax.numpy as jnp
import numpy as np
from arviz_stats.base import array_stats
from emcee.moves import DEMove
from emcee.state import State

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
STEP_BLOCK = 25
"""Sampler steps made in one compiled call (:func:`advance`): a divisor of the first chunk's
steps and of its half, the checks' least interval."""
INVALID_STEP = "a proposal was not finite, or its log probability NaN"
"""emcee's moves raise on either; so do :class:`GroupedDEMove` and :func:`advance`."""
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


def _densities(log_density, model, grouped: bool, theta):
    """``log_density(model, walker)`` of each walker of ``theta`` (walkers, dimension), vmapped.
    ``grouped``: ``model`` is a stack of models (arrays with a leading axis of groups) and the
    walkers come in as many equal groups, in order, group g's of model g: vmap over the groups
    of vmap over their walkers."""
    if not grouped:
        return jax.vmap(lambda walker: log_density(model, walker))(theta)
    groups = jax.tree.leaves(model)[0].shape[0]
    by_group = theta.reshape(groups, -1, theta.shape[-1])
    return jax.vmap(
        lambda own, walkers: jax.vmap(lambda walker: log_density(own, walker))(walkers)
    )(model, by_group).reshape(-1)


@persistent_jit
def _batch_densities(log_density, model, grouped, theta):
    return _densities(log_density, model, grouped, theta)


@persistent_jit
def _de_block(log_density, model, grouped, coords, log_probs, index, pairs, gamma, log_u, live):
    """:data:`STEP_BLOCK` steps of :class:`GroupedDEMove` (:func:`de_halves`) in one compiled
    call: each step's halves gathered by ``index`` (steps, 2, groups, half), moved by its
    random numbers, scattered back; a step not ``live`` (the block's padding) leaves the
    ensemble as it was. Returns each step's positions, log densities and which walkers moved,
    and whether any live step's proposal was not finite or its log density NaN."""

    def step(carry, numbers):
        coords, log_probs = carry
        index, pairs, gamma, log_u, live = numbers
        halves, halves_log_probs, moved, invalid = de_halves(
            jnp,
            lambda theta: _densities(log_density, model, grouped, theta),
            coords[index],
            log_probs[index],
            pairs,
            gamma,
            log_u,
        )
        coords = jnp.where(live, coords.at[index].set(halves), coords)
        log_probs = jnp.where(live, log_probs.at[index].set(halves_log_probs), log_probs)
        accepted = jnp.zeros(log_probs.shape, dtype=bool).at[index].set(moved & live)
        return (coords, log_probs), (coords, log_probs, accepted, invalid & live)

    _, (coords, log_probs, accepted, invalid) = jax.lax.scan(
        step, (coords, log_probs), (index, pairs, gamma, log_u, live)
    )
    return coords, log_probs, accepted, jnp.any(invalid)


class _BatchLogDensity:
    """``theta (walkers, dimension) -> (walkers,)`` log densities as numpy, for emcee, and
    :meth:`de_block`, :data:`STEP_BLOCK` steps of :class:`GroupedDEMove` in one compiled call
    (:func:`batch_log_density`)."""

    def __init__(self, log_density, model, grouped: bool):
        self._arguments = (log_density, model, grouped)
        self._specialised = {}

    def _function(self, over, arrays):
        """``over`` specialised to these arrays' shapes, the model's arrays bound (moved to
        the device once: each of the sampler's thousands of calls passes only the walkers)."""
        key = (over.__name__, *(np.shape(array) for array in arrays))
        if key not in self._specialised:
            function, leaves = over.specialised(*self._arguments, *arrays)
            fixed = [jax.device_put(leaf) for leaf in leaves[: -len(arrays)]]
            self._specialised[key] = partial(function, *fixed)
        return self._specialised[key]

    def __call__(self, theta):
        theta = np.asarray(theta, dtype=float)
        return np.asarray(self._function(_batch_densities, (theta,))(theta))

    def de_block(self, coords, log_probs, index, pairs, gamma, log_u, live):
        """:func:`_de_block` of these arrays (numpy in, numpy out) in one compiled call."""
        arrays = (coords, log_probs, index, pairs, gamma, log_u, live)
        # One transfer of the four results, not one each.
        return jax.device_get(self._function(_de_block, arrays)(*arrays))


def batch_log_density(log_density, model, grouped: bool = False):
    """``theta (walkers, dimension) -> (walkers,)`` log densities ``log_density(model,
    theta)`` as numpy, for emcee: every walker in one compiled call, and :data:`STEP_BLOCK`
    steps of :class:`GroupedDEMove` in one compiled call (:func:`advance`).

    ``log_density`` must be a module-level function (it keys the compilation cache). The
    functions are traced, or loaded from the trace cache (:mod:`._traced`), at their first
    call, and the model's arrays are moved to the device once: each of the sampler's
    calls passes only the walkers' positions (and the steps' random numbers).
    ``grouped``: ``model`` is a stack of models (a leading axis of groups) and the walkers
    come in as many equal groups, in order, each of its own model (:class:`GroupedDEMove`).
    """
    require_x64()
    return _BatchLogDensity(log_density, model, grouped)


def de_halves(xp, log_density, halves, log_probs, pairs, gamma, log_u):
    """One step of emcee's red-blue differential-evolution move (ter Braak 2006;
    :class:`emcee.moves.DEMove` in :class:`emcee.moves.RedBlueMove`) on an ensemble split into
    ``groups`` of two halves, written once for numpy and JAX (``xp``).

    ``halves`` (2, groups, half, dimension) and their ``log_probs`` (2, groups, half): the
    first half of each group moves, each walker to ``x + gamma (x_j - x_i)`` with ``x_i`` and
    ``x_j`` two distinct walkers of its group's other half, numbered there by ``pairs[0, 0]``
    and ``pairs[0, 1]`` (pairs: 2 halves, 2, groups, half), ``gamma`` (2, groups, half) its
    scale, and is accepted where its log density rose by more than ``log_u[0]``, the log of a
    uniform (Metropolis: the proposal is symmetric); then the second half moves the same way,
    its differences taken from the first half as updated. ``log_density`` maps (walkers,
    dimension) to (walkers,), the walkers group by group. Returns the halves, their log
    densities, which walkers moved (2, groups, half), and whether any proposal was not
    finite or any log density NaN (emcee raises on either).
    """
    halves, log_probs, accepted = list(halves), list(log_probs), []
    invalid = False
    for moving in (0, 1):
        other = halves[1 - moving]
        first = xp.take_along_axis(other, pairs[moving, 0][..., None], axis=1)
        second = xp.take_along_axis(other, pairs[moving, 1][..., None], axis=1)
        proposal = halves[moving] + gamma[moving][..., None] * (second - first)
        density = log_density(proposal.reshape(-1, proposal.shape[-1])).reshape(proposal.shape[:-1])
        moved = density - log_probs[moving] > log_u[moving]
        halves[moving] = xp.where(moved[..., None], proposal, halves[moving])
        log_probs[moving] = xp.where(moved, density, log_probs[moving])
        accepted.append(moved)
        invalid = invalid | xp.any(xp.isnan(density)) | ~xp.all(xp.isfinite(proposal))
    return xp.stack(halves), xp.stack(log_probs), xp.stack(accepted), invalid


class GroupedDEMove(DEMove):
    """emcee's differential-evolution move (ter Braak 2006; :class:`emcee.moves.DEMove`,
    gamma ~ gamma0 (1 + sigma z)) within groups: the ensemble is ``groups`` equal groups of
    walkers, in order, and each group is split at random into two halves, a walker's proposal
    taking the difference of two distinct walkers of its own group's other half; the first
    halves move, then the second from the first as updated (:func:`de_halves`). Each group's
    update is the red-blue update of emcee's move on that group alone (a valid
    Metropolis-Hastings update of each walker given the others), so that groups sampling
    different posteriors never mix; one group is emcee's ``DEMove`` itself (its proposal
    distribution and acceptance; its random numbers are drawn in another order).

    The random numbers are drawn from emcee's generator (``model.random``) as numpy arrays
    (:meth:`draw`). emcee's own loop (``run_mcmc``) calls :meth:`propose` once a step, the log
    density once a half; :func:`advance` makes the same steps, from the same random numbers,
    :data:`STEP_BLOCK` at a time in one compiled call where the log density is
    :func:`batch_log_density`'s.

    Parameters
    ----------
    groups : int
        The number of groups; the walkers must divide into them, at least four a group.
    sigma : float
        The relative spread of gamma (emcee's default).
    gamma0 : float, optional
        The mean of gamma; default 2.38 / sqrt(2 dimension).
    """

    def __init__(self, groups: int = 1, sigma: float = 1e-5, gamma0: float | None = None):
        super().__init__(sigma=sigma, gamma0=gamma0)
        self.groups = groups

    def draw(self, random, coords: np.ndarray) -> tuple[np.ndarray, ...]:
        """One step's random numbers for an ensemble at ``coords`` (walkers, dimension), from
        ``random`` (a numpy ``RandomState``): which walkers form each group's two halves
        (2, groups, half: indices into the ensemble), the two walkers of the other half whose
        difference each moves by (2, 2, groups, half: indices into that half), the scales
        gamma and the logs of the acceptance uniforms (2, groups, half)."""
        walkers = coords.shape[0]
        size = walkers // self.groups
        if size * self.groups != walkers or size < 4 or size % 2:
            raise ValueError(
                f"{walkers} walkers do not divide into {self.groups} groups of an even "
                "number of at least four"
            )
        self.setup(coords)
        half, shape = size // 2, (2, self.groups, size // 2)
        # Each group's walkers in a random order, its halves each in the ensemble's order.
        order = np.argsort(random.rand(self.groups, size), axis=1)
        offset = (np.arange(self.groups) * size)[:, None]
        index = np.stack([np.sort(order[:, :half], axis=1), np.sort(order[:, half:], axis=1)])
        # Two distinct walkers of the other half: emcee's pairs off the diagonal, uniformly.
        first = random.randint(half, size=shape)
        second = (first + 1 + random.randint(half - 1, size=shape)) % half
        gamma = self.g0 * (1.0 + self.sigma * random.randn(*shape))
        log_u = np.log(random.rand(*shape))
        return index + offset, np.stack([first, second], axis=1), gamma, log_u

    def propose(self, model, state):
        """Move each group's two halves in turn; returns the state and which walkers moved."""
        index, pairs, gamma, log_u = self.draw(model.random, state.coords)

        def densities(theta):
            return np.asarray(model.log_prob_fn(theta), dtype=float)

        halves, log_probs, moved, invalid = de_halves(
            np, densities, state.coords[index], state.log_prob[index], pairs, gamma, log_u
        )
        if invalid:  # as emcee's own moves
            raise ValueError(INVALID_STEP)
        coords, log_prob = state.coords.copy(), state.log_prob.copy()
        coords[index] = halves
        log_prob[index] = log_probs
        accepted = np.zeros(coords.shape[0], dtype=bool)
        accepted[index] = moved
        return State(coords, log_prob=log_prob, blobs=state.blobs), accepted


def advance(sampler, state, steps: int):
    """``sampler.run_mcmc(state, steps)``: ``steps`` more steps of an emcee ensemble, the
    steps stored in its backend as emcee stores them; returns the last state.

    Where the ensemble is moved by :class:`GroupedDEMove` alone and its log density is
    :func:`batch_log_density`'s, the steps are made :data:`STEP_BLOCK` at a time in one
    compiled call each (:func:`_de_block`), not one call and emcee's Python a step (a later
    2^20 noise fit's posterior stage: 0.43 s before, 0.26 s after). The same steps from the
    same random numbers, drawn from emcee's generator in emcee's order (one uniform for its
    choice of move, then the move's), to the rounding of the compiled arithmetic (which may
    fuse a proposal's multiply-add: a difference of 1e-15 that differential evolution
    carries on, so a long chain is emcee's in distribution, not to the bit). A fresh start
    is checked by emcee (walkers linearly independent, no NaN log density): its loop makes
    the first step."""
    moves, block = sampler._moves, getattr(sampler.log_prob_fn, "de_block", None)
    if block is None or len(moves) != 1 or not isinstance(moves[0], GroupedDEMove):
        return sampler.run_mcmc(state, steps)
    if not isinstance(state, State):
        state, steps = sampler.run_mcmc(state, 1), steps - 1
    move, random = moves[0], np.random.RandomState()
    random.set_state(sampler.random_state)
    coords, log_probs = state.coords, state.log_prob
    backend = sampler.backend
    backend.grow(steps, None)
    for first in range(0, steps, STEP_BLOCK):
        live = np.arange(STEP_BLOCK) < steps - first
        numbers = []
        for _ in range(int(live.sum())):
            random.random_sample()  # emcee's choice among its (one) moves
            numbers.append(move.draw(random, coords))
        # The block's padding: steps that move nothing (each walker's difference is one
        # walker less itself) and are not kept.
        padding = (numbers[0][0], *(np.zeros_like(array) for array in numbers[0][1:]))
        numbers += [padding] * (STEP_BLOCK - len(numbers))
        stacked = [np.stack(arrays) for arrays in zip(*numbers, strict=True)]
        chain, chain_log_probs, accepted, invalid = block(coords, log_probs, *stacked, live)
        if invalid:  # as emcee's own moves
            raise ValueError(INVALID_STEP)
        random_state = random.get_state()
        for step in range(int(live.sum())):
            saved = State(chain[step], log_prob=chain_log_probs[step], random_state=random_state)
            backend.save_step(saved, accepted[step])
        coords, log_probs = chain[live][-1], chain_log_probs[live][-1]
    sampler.random_state = random.get_state()
    return State(coords, log_prob=log_probs, random_state=sampler.random_state)


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
        state = advance(sampler, state, steps)
        if bar is not None:
            bar.update(steps)
        tau = autocorrelation_time(sampler.get_chain())
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


def autocorrelation_time(chain: np.ndarray) -> np.ndarray:
    """Each parameter's integrated autocorrelation time over ``chain`` (steps, walkers, dim):
    emcee's estimate (``integrated_time``, no tolerance), NaN where a parameter has not moved
    (its autocorrelation is 0 / 0: a stuck run, which :func:`long_enough` reads as not long
    enough and the restart judges), without numpy's warning of it on the user's terminal."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return emcee.autocorr.integrated_time(chain, tol=0)


def long_enough(tau, steps: int) -> bool:
    """Whether a chain of ``steps`` is longer than AUTOCORR_MULTIPLE autocorrelation times
    ``tau`` (every parameter's, all finite)."""
    return bool(np.all(np.isfinite(tau)) and steps > AUTOCORR_MULTIPLE * np.max(tau))


def ensemble(log_posterior_batch, n_walkers: int, dimension: int, rng, groups: int = 1):
    """emcee's ensemble, its log densities vectorised, seeded from ``rng``, moved by
    differential evolution (:class:`GroupedDEMove`, within ``groups`` groups of walkers): a
    step one compiled call where ``log_posterior_batch`` is :func:`batch_log_density`'s."""
    sampler = emcee.EnsembleSampler(
        n_walkers, dimension, log_posterior_batch, vectorize=True, moves=GroupedDEMove(groups)
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
    tau = autocorrelation_time(sampler.get_chain())
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
