"""The sampler leaves the posterior invariant: its stored draws of a known distribution have
that distribution's variances (the check that caught emcee's snooker move, whose draws were
2-3 % too narrow in sd); its move, made a block of steps in one compiled call, samples a known
Gaussian with its mean and covariance, and makes the steps emcee's own loop makes."""

import emcee
import numpy as np
import pytest
from emcee.autocorr import integrated_time

from bayescal.inference import _mcmc
from bayescal.inference._mcmc import batch_log_density, diagnose, ensemble, sample_ensemble

COVARIANCE = np.array(
    [
        [1.0, 0.0, 0.0, 0.8],
        [0.0, 4.0, 0.0, 0.0],
        [0.0, 0.0, 0.25, 0.0],
        [0.8, 0.0, 0.0, 1.0],
    ]
)
PRECISION = np.linalg.inv(COVARIANCE)
RUNS = 8


def _gaussian(model, x):
    """The log density of N(mean, precision^-1) at one walker ``x``, ``model`` (mean,
    precision): traced, as the library's log densities are."""
    mean, precision = model
    return -0.5 * (x - mean) @ precision @ (x - mean)


def gaussian_log_density(x):
    return -0.5 * np.einsum("...i,ij,...j->...", x, PRECISION, x)


TARGET_MEAN = np.array([1.0, -2.0])
TARGET_COVARIANCE = np.array([[1.0, 1.2], [1.2, 4.0]])
GROUPS, GROUP_WALKERS, STEPS = 64, 4, 3000


def test_the_compiled_move_samples_a_known_gaussian():
    """64 groups of 4 walkers, each group an ensemble of its own on one correlated 2-D Gaussian
    (the move's smallest groups, where a wrong step shows most), 3,000 steps, a block of them in
    one compiled call (:func:`~bayescal.inference._mcmc.advance`): the draws after the first
    tenth have the target's mean (within 0.02 sd), variances (ratio within 0.03 of 1) and
    correlation 0.6 (within 0.015).

    About 66,000 effective draws a coordinate (autocorrelation time 10-11 steps): the mean's
    Monte Carlo sd is 0.004 sd, the variance ratio's and the correlation's about 0.005; the
    tolerances are some five of these, and five seeds gave |mean| <= 0.008 sd, ratios
    0.999-1.005, correlations 0.596-0.601. Mutated, it fails: the second half proposing from
    the first half's walkers before their update gave variance ratios 1.07-1.09; the
    acceptance with the log densities of rejected proposals kept 1.25-1.31, with half the log
    density ratio 1.99-2.02 (three seeds each)."""
    models = (
        np.tile(TARGET_MEAN, (GROUPS, 1)),
        np.tile(np.linalg.inv(TARGET_COVARIANCE), (GROUPS, 1, 1)),
    )
    rng = np.random.default_rng(0)
    walkers = GROUPS * GROUP_WALKERS
    sampler = ensemble(
        batch_log_density(_gaussian, models, grouped=True), walkers, 2, rng, groups=GROUPS
    )
    start = (
        TARGET_MEAN + rng.standard_normal((walkers, 2)) @ np.linalg.cholesky(TARGET_COVARIANCE).T
    )
    _mcmc.advance(sampler, start, STEPS)
    chain = sampler.get_chain(discard=STEPS // 10)
    draws = chain.reshape(-1, 2)
    sd = np.sqrt(np.diag(TARGET_COVARIANCE))
    covariance = np.cov(draws, rowvar=False)
    assert np.all(np.abs(draws.mean(axis=0) - TARGET_MEAN) / sd < 0.02), draws.mean(axis=0)
    ratio = np.diag(covariance) / np.diag(TARGET_COVARIANCE)
    assert np.all(np.abs(ratio - 1.0) < 0.03), ratio
    correlation = covariance[0, 1] / np.sqrt(covariance[0, 0] * covariance[1, 1])
    assert abs(correlation - 0.6) < 0.015, correlation
    assert np.all(integrated_time(chain, tol=0) < 15)  # the effective draws assumed above


@pytest.mark.parametrize("groups", [1, 3])
def test_the_compiled_blocks_make_emcees_own_steps(groups):
    """``advance`` against emcee's ``run_mcmc`` from the same seed, on a correlated 2-D
    Gaussian: a fresh start then a run on from the state (37 steps, not a whole number of
    blocks: the last block padded), one group and three. The same steps from the same random
    numbers: the same positions, the same walkers accepted, log densities equal to rounding,
    and the generator left where emcee's leaves it. The walkers start on the integers and move
    by gamma = 1 (sigma 0: its normals are drawn all the same), so that every proposal is
    exact in any arithmetic (a compiled block may fuse the proposal's multiply-add, 1e-15 off
    numpy's, which differential evolution amplifies step by step). Mutated, it fails: without
    the uniform emcee draws for its choice of move each step, the chains part at once."""
    models = (
        np.tile(TARGET_MEAN, (groups, 1)),
        np.tile(np.linalg.inv(TARGET_COVARIANCE), (groups, 1, 1)),
    )
    walkers, runs = groups * 8, []
    start = np.random.default_rng(4).integers(-4, 5, size=(walkers, 2)).astype(float)
    for run in (lambda sampler, state, steps: sampler.run_mcmc(state, steps), _mcmc.advance):
        log_density = batch_log_density(_gaussian, models, grouped=True)
        sampler = emcee.EnsembleSampler(
            walkers,
            2,
            log_density,
            vectorize=True,
            moves=_mcmc.GroupedDEMove(groups, sigma=0.0, gamma0=1.0),
        )
        sampler.log_prob_fn = log_density  # unwrapped, as ``ensemble`` leaves it
        sampler.random_state = np.random.RandomState(7).get_state()
        run(sampler, run(sampler, start, 60), 37)
        runs.append(sampler)
    emcee_run, blocks = runs
    assert blocks.iteration == emcee_run.iteration == 97
    np.testing.assert_array_equal(blocks.get_chain(), emcee_run.get_chain())
    np.testing.assert_allclose(blocks.get_log_prob(), emcee_run.get_log_prob(), rtol=1e-12)
    np.testing.assert_array_equal(blocks.backend.accepted, emcee_run.backend.accepted)
    assert 0.1 < np.mean(blocks.acceptance_fraction) < 0.9  # the walkers did move
    assert str(blocks.random_state) == str(emcee_run.random_state)


def _nan_beyond_two(model, x):
    """A log density that is NaN where the first coordinate passes 2."""
    return _gaussian(model, x) + (x[0] > 2.0) * np.nan


def test_a_nan_log_density_stops_a_block_as_it_stops_emcee():
    """Walkers that meet a NaN region after their first step: ``advance`` raises emcee's
    error as emcee's loop does, rather than storing steps through it."""
    model = (np.zeros(2), np.eye(2))
    start = np.random.default_rng(0).normal(0.0, 0.3, size=(16, 2))
    for run in (lambda sampler, state, steps: sampler.run_mcmc(state, steps), _mcmc.advance):
        sampler = ensemble(
            batch_log_density(_nan_beyond_two, model), 16, 2, np.random.default_rng(1)
        )
        with pytest.raises(ValueError, match="NaN"):
            run(sampler, start, 500)
        assert sampler.iteration >= 1  # not emcee's first step: a block's


def test_stored_draws_have_the_target_variances():
    """Eight seeded runs to convergence on a correlated 4-D Gaussian, each its 2,000 stored
    draws: their variance over the true one, pooled over runs and coordinates, is within
    0.03 of 1. Each run's draws carry about 2,000 effective samples, so the pooled ratio's sd
    is about 0.008 (0.03 is 3.7 sd); the snooker move gave 0.95."""
    ratios = []
    for seed in range(RUNS):
        sampler, converged = sample_ensemble(
            batch_log_density(_gaussian, (np.zeros(4), PRECISION)),
            np.zeros(4),
            COVARIANCE,
            np.random.default_rng(seed),
            n_walkers=32,
            max_steps=20_000,
        )
        diagnostics, kept = diagnose(sampler, ("a", "b", "c", "d"), converged, True)
        assert diagnostics.passed, diagnostics.failures
        draws = kept.reshape(-1, 4)
        ratios.append(np.var(draws, axis=0) / np.diag(COVARIANCE))
    pooled = float(np.mean(ratios))
    assert abs(pooled - 1.0) < 0.03, (pooled, np.mean(ratios, axis=0))


def _ridge(theta):
    """A thin curved ridge (b = 5 a^2, 0.01 wide): differential evolution cannot explore it."""
    a, b = theta[:, 0], theta[:, 1]
    return -0.5 * a**2 - 0.5 * ((b - 5 * a**2) / 0.01) ** 2


@pytest.mark.filterwarnings("error::RuntimeWarning")  # a stuck chain's 0 / 0, not on screen
def test_a_run_that_cannot_explore_is_restarted_then_stops_early():
    """Stuck (acceptance below 0.1), a run is restarted from its unstranded walkers twice;
    still stuck, it stops long before the step limit, and its failure says so. Measured:
    acceptance 0.007-0.009, 2440 steps of the last run, of 20,000 allowed."""
    sampler, converged = sample_ensemble(
        _ridge, np.zeros(2), 0.01 * np.eye(2), np.random.default_rng(0), 32, 20_000
    )
    diagnostics, _ = diagnose(sampler, ("a", "b"), converged, True)
    assert not converged and diagnostics.restarts == 2
    assert diagnostics.n_steps < 5000
    assert any("after 2 restart(s)" in failure for failure in diagnostics.failures)


def test_a_healthy_run_is_never_restarted():
    sampler, converged = sample_ensemble(
        gaussian_log_density, np.zeros(4), COVARIANCE, np.random.default_rng(1), 32, 40_000
    )
    diagnostics, _ = diagnose(sampler, tuple("abcd"), converged, True)
    assert converged and diagnostics.passed and diagnostics.restarts == 0


def test_a_run_long_enough_but_short_of_its_r_hat_runs_on(monkeypatch):
    """Where the autocorrelation criterion is met but R-hat or the ESS is short of its bar
    (made so here at the first such check), the run goes on, a check at a time, and stops
    once they pass: a borderline chain is run longer, not reported failed."""
    checked = []
    mixed = _mcmc._mixed

    def short_at_first(sampler, tau):
        checked.append(sampler.iteration)
        return len(checked) > 1 and mixed(sampler, tau)

    monkeypatch.setattr(_mcmc, "_mixed", short_at_first)
    sampler, converged = sample_ensemble(
        gaussian_log_density, np.zeros(4), COVARIANCE, np.random.default_rng(1), 32, 40_000
    )
    diagnostics, _ = diagnose(sampler, ("a", "b", "c", "d"), converged, True)
    assert converged and len(checked) >= 2 and diagnostics.passed, diagnostics.failures
    assert sampler.iteration == checked[-1] > checked[0]
    # Each check after an eighth of the run so far, at least half the first chunk.
    assert checked[1] - checked[0] == max(_mcmc.FIRST_CHUNK // 2, checked[0] // 8)


def test_a_run_that_never_mixes_runs_on_a_bounded_stretch_then_fails(monkeypatch):
    """A run long enough by its autocorrelation whose R-hat or ESS never passes (made so
    here) runs on to RUN_ON times the length where the criterion was first met — not to the
    step limit — and stops there, its checks left to fail."""
    checked = []

    def never(sampler, tau):
        checked.append(sampler.iteration)
        return False

    monkeypatch.setattr(_mcmc, "_mixed", never)
    sampler, converged = sample_ensemble(
        gaussian_log_density, np.zeros(4), COVARIANCE, np.random.default_rng(1), 32, 40_000
    )
    assert converged
    assert _mcmc.RUN_ON * checked[0] <= sampler.iteration < _mcmc.RUN_ON * checked[0] * 1.2
    assert sampler.iteration < 40_000 // 4
