"""A fleet's noise fits batched over recordings (bayescal.inference._batched, fit_fleet
``batch=True``): the grouped move keeps each recording's walkers to themselves and samples a
known posterior; a structure that differs is named; a small simulated fleet (white noise and
a rate random walk, known truth; the seeded small version of benchmarks/fleet_batched.py) gives
each recording's posterior and the population's as one Dask task per recording does, within
Monte Carlo error; a recording of another length is fitted in its own batch; the same seed
gives the same draws."""

import math

import emcee
import numpy as np
import pytest
from _benchmarks import load_benchmark

import bayescal as bc
from bayescal._errors import InputError
from bayescal.capabilities._noise import prepare_noise
from bayescal.inference._batched import sample_noise_each, stack_problems
from bayescal.inference._mcmc import GroupedDEMove

RECORDINGS = 6
SAMPLES = 4096
SHIFT_TOLERANCE = 0.35
"""Largest difference of two paths' posterior means, in posterior sds: each mean's Monte Carlo
sd is at most sd / sqrt(400) (every posterior passed ESS >= 400), their difference's
sqrt(2 / 400) sd = 0.071 sd; 0.35 is five of these."""


def test_the_grouped_move_pairs_walkers_only_within_their_group():
    """Three groups of 16 walkers, each on its own normal N(10^6 g, 1): every proposal of a
    walker of group g stays by group g's centre (a pair across groups would jump 10^6), and
    each group's draws have its normal's mean and variance (5,000 steps: the mean's Monte
    Carlo sd is about 0.01, the variance's about 0.02; tolerances 0.1 and 0.15)."""
    groups, walkers = 3, 16
    centres = 1e6 * np.arange(groups)
    proposals = []

    def log_prob(theta):
        by_group = theta.reshape(groups, -1)
        proposals.append(by_group.copy())
        return (-0.5 * (by_group - centres[:, None]) ** 2).reshape(-1)

    rng = np.random.default_rng(0)
    start = (centres[:, None] + rng.standard_normal((groups, walkers))).reshape(-1, 1)
    sampler = emcee.EnsembleSampler(
        groups * walkers, 1, log_prob, vectorize=True, moves=GroupedDEMove(groups)
    )
    sampler.random_state = np.random.RandomState(1).get_state()
    sampler.run_mcmc(start, 5000)
    for by_group in proposals:
        assert np.all(np.abs(by_group - centres[:, None]) < 100.0)
    chain = sampler.get_chain(discard=500)[..., 0]  # (steps, walkers)
    for g in range(groups):
        own = chain[:, g * walkers : (g + 1) * walkers] - centres[g]
        assert abs(own.mean()) < 0.1 and abs(own.var() - 1.0) < 0.15, (g, own.mean(), own.var())


def test_walkers_that_do_not_divide_into_the_groups_are_refused():
    sampler = emcee.EnsembleSampler(12, 1, lambda t: -0.5 * t[:, 0] ** 2, vectorize=True)
    sampler._moves = [GroupedDEMove(4)]
    with pytest.raises(ValueError, match="12 walkers do not divide into 4 groups"):
        sampler.run_mcmc(np.random.default_rng(0).standard_normal((12, 1)), 1)


def _problem(length: int, terms: str = "white,rrw", seed: int = 0, rate_hz: float = 100.0):
    y = bc.NoiseModel(rate_hz=rate_hz, bias=0.3, N=0.004, K=2e-3).simulate(length, seed=seed)
    return prepare_noise(y, rate_hz, terms=terms, unit="deg/s").problem


def test_a_structure_that_differs_is_named():
    same = _problem(SAMPLES)
    with pytest.raises(InputError, match=r"b\.npz: its terms \('white', 'bias_instability'"):
        stack_problems([same, _problem(SAMPLES, "white,b")], ["a.npz", "b.npz"])
    with pytest.raises(InputError, match=r"c\.npz: its rate, length .* from a\.npz's"):
        stack_problems([same, same, _problem(SAMPLES, rate_hz=200.0)], ["a.npz", "b.npz", "c.npz"])
    with pytest.raises(InputError, match=r"c\.npz: its summaries' shapes differ from a\.npz's"):
        stack_problems([same, same, _problem(3 * SAMPLES)], ["a.npz", "b.npz", "c.npz"])


def test_the_same_seeds_give_the_same_posteriors():
    problems = [_problem(SAMPLES, seed=s) for s in (1, 2)]
    first, again = (
        sample_noise_each(
            problems, names=["a", "b"], terms=("white", "rate_random_walk"), seeds=[5, 6]
        )
        for _ in range(2)
    )
    for one, other in zip(first, again, strict=True):
        assert np.array_equal(one.draws["N"], other.draws["N"])
        assert np.array_equal(one.draws["bias"], other.draws["bias"])


@pytest.fixture(scope="module")
def fleets(tmp_path_factory):
    """The small fleet fitted batched (in process) and as one Dask task per recording, with
    a seventh recording of another length."""
    benchmark = load_benchmark("fleet_batched")
    folder = tmp_path_factory.mktemp("fleet")
    lengths = [SAMPLES] * RECORDINGS + [SAMPLES + 1000]
    manifest, truths = benchmark.write_fleet(folder, RECORDINGS + 1, SAMPLES, 3, lengths)
    batched = bc.fit_fleet(manifest, "gyro_x", terms="white,rrw", seed=4, batch=True)
    single = bc.fit_fleet(manifest, "gyro_x", terms="white,rrw", seed=4, batch=False, workers=2)
    return batched, single, truths


def test_the_batched_fleet_gives_each_recordings_posterior(fleets):
    """Each recording's posterior mean of N, K and the bias: the same from both paths within
    SHIFT_TOLERANCE posterior sds; each path's posterior of N holds its truth (90 %
    interval, within 10 %)."""
    batched, single, truths = fleets
    assert len(batched.recordings) == len(single.recordings) == RECORDINGS + 1
    assert "batches of 6, 1 recordings" in batched.compute["cluster"]
    for one, other in zip(batched.recordings, single.recordings, strict=True):
        assert one.row == other.row and one.checks["n_walkers"] == other.checks["n_walkers"]
        for p in ("N", "K"):
            mean, reference = one.log_draws[p].mean(), other.log_draws[p].mean()
            assert abs(mean - reference) <= SHIFT_TOLERANCE * other.log_draws[p].std(), (
                one.row,
                p,
            )
        assert abs(one.bias_mean.mean() - other.bias_mean.mean()) <= SHIFT_TOLERANCE * math.sqrt(
            np.var(other.bias_mean) + np.mean(other.bias_sd**2)
        )
        truth = truths[one.row - 1]["N"]
        assert abs(np.exp(one.log_draws["N"].mean()) / truth - 1) < 0.1


def test_the_batched_fleet_gives_the_populations_summary(fleets):
    """The population's median N and K: the same from both paths within SHIFT_TOLERANCE of
    its posterior sd (from the 90 % interval's width, 3.29 sd)."""
    batched, single, _ = fleets
    for p in ("N", "K"):
        one = batched.summary["population"][p]["median"]
        other = single.summary["population"][p]["median"]
        sd = (math.log(other["q95"]) - math.log(other["q05"])) / 3.29
        assert abs(math.log(one["mean"] / other["mean"])) <= SHIFT_TOLERANCE * sd, p


def test_batched_fits_refuse_a_cluster(tmp_path, run_cli):
    benchmark = load_benchmark("fleet_batched")
    manifest, _ = benchmark.write_fleet(tmp_path, 2, 512, 0)
    code, _, stderr = run_cli(
        "fleet", manifest, "--channel", "gyro_x", "--batch", "--workers", "2", "--quiet"
    )
    assert code == 2 and "--scheduler and --workers are for one task per recording" in stderr
    assert "Traceback" not in stderr
