"""Fleets: the manifest's checks, the population's machinery against exact answers, one small
simulated fleet (the seeded small version of benchmarks/fleet_coverage.py) fitted on a local
Dask cluster and again through a real scheduler and worker processes on the loopback address
(the same numbers), checked against a joint fit of the same data, with a bad recording that is
reported and left out."""

import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from _benchmarks import load_benchmark

import bayescal as bc

ROOT = Path(__file__).resolve().parents[1]
POPULATION = {"N": 0.004}, {"N": 0.25}, 0.3, 0.05, 0.02
RUNS = (2, 1, 2, 1)
SCHEDULER_OPTIONS = ("--host", "127.0.0.1", "--port", "0", "--no-dashboard")
WORKER_OPTIONS = ("--nworkers", "2", "--nthreads", "1", "--no-dashboard")


# ---------------------------------------------------------------------------------------------
# The manifest: each bad field named by file, column, row and line; nothing runs (exit 2)


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


@pytest.fixture
def two_files(tmp_path):
    for name in ("a.csv", "b.csv"):
        write(tmp_path / name, "gyro_x\n1\n")
    return tmp_path


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        ("path,unit,rate_hz\na.csv,1,100\n", "unknown column 'rate_hz'"),
        ("path,run\na.csv,1\n", "no column 'unit'"),
        ("path,unit,rate\na.csv,U1,100\nb.csv,U2,fast\n", "column 'rate': data row 2 (line 3)"),
        ("path,unit,rate\na.csv,U1,-5\n", "rate -5 must be a positive sample rate"),
        ("path,unit\na.csv,U1\nmissing.csv,U2\n", "data row 2 (line 3): no such file"),
        ("path,unit\na.csv,U1\na.csv,U2\n", "already listed on data row 1"),
        ("path,unit,run\na.csv,U1,1\nb.csv,U1,1\n", "unit 'U1' run '1' is already listed"),
        ("path,unit\na.csv,\n", "column 'unit': data row 1 (line 2): empty unit"),
        ("path,unit,temperature\na.csv,U1,-300\n", "below absolute zero"),
        ("path,unit\n", "lists no recording"),
        ("path,unit\na.csv,U1,extra\n", "data row 1 (line 2) has 3 fields, the header 2"),
    ],
)
def test_a_bad_manifest_is_named_and_nothing_runs(two_files, run_cli, content, expected):
    manifest = write(two_files / "fleet.csv", content)
    out = two_files / "out.json"
    code, _, stderr = run_cli("fleet", manifest, "--channel", "gyro_x", "--json", out)
    assert code == 2, stderr
    assert str(manifest) in stderr and expected in stderr, stderr
    assert "Traceback" not in stderr and not out.exists()


def test_the_manifest_numbers_runs_in_order_and_resolves_paths(two_files):
    write(two_files / "fleet.csv", "Path , UNIT,rate\na.csv,U1,100\n b.csv ,U1,\n")
    manifest = bc.read_manifest(two_files / "fleet.csv")
    assert [row.run for row in manifest.rows] == ["1", "2"]
    assert manifest.rows[1].path == (two_files / "b.csv").resolve()
    assert (manifest.rows[0].rate_hz, manifest.rows[1].rate_hz) == (100.0, None)
    assert manifest.units == ("U1",)


@pytest.mark.parametrize(
    ("options", "expected"),
    [
        (("--scheduler", "tcp://127.0.0.1:1", "--workers", "2"), "--workers sets the size"),
        (("--terms", "auto"), "'auto' would choose them recording by recording"),
        (("--spec", "Q<3"), "spec: unknown parameter 'Q'"),
        (("--spec", "N<<3"), "is not PARAMETER<VALUE UNIT"),
        (("--spec", "K<1 deg/h/sqrt(h)"), "K is not among the fitted terms"),
        (("--spec", "NO-SUCH-PART"), "no such sensor card"),
        (("--unit", "deg/s", "--spec", "N<3 ug/sqrt(Hz)"), "is a unit of acceleration"),
    ],
)
def test_bad_options_stop_before_any_work(two_files, run_cli, options, expected):
    manifest = write(two_files / "fleet.csv", "path,unit\na.csv,U1\nb.csv,U2\n")
    code, _, stderr = run_cli(
        "fleet", manifest, "--channel", "gyro_x", "--terms", "white", *options
    )
    assert code == 2 and expected in stderr, stderr


def test_a_fleet_needs_two_recordings(two_files, run_cli):
    manifest = write(two_files / "fleet.csv", "path,unit\na.csv,U1\n")
    code, _, stderr = run_cli("fleet", manifest, "--channel", "gyro_x")
    assert code == 2 and "at least two recordings" in stderr, stderr


# ---------------------------------------------------------------------------------------------
# The population's machinery, against exact answers (no fit, no cluster)


def gaussian_run(rng, centre, sd, prior_centre, unit="U", run="1", draws=1984):
    """A recording whose posterior of (ln N, ln K) is exactly normal: the likelihood
    N(centre, sd) times the fitting prior N(prior_centre, 4)."""
    from bayescal.inference._population import RecordingDraws

    prior_sd = 4.0
    precision = 1 / sd**2 + 1 / prior_sd**2
    mean = (centre / sd**2 + prior_centre / prior_sd**2) / precision
    samples = mean + rng.standard_normal((draws, 2)) / np.sqrt(precision)
    return RecordingDraws(
        source=f"{unit}-{run}",
        unit=unit,
        run=run,
        channel="gyro_x",
        channel_unit="deg/s",
        rate_hz=100.0,
        n_samples=4096,
        terms=("white", "rate_random_walk"),
        log_draws={"N": samples[:, 0], "K": samples[:, 1]},
        prior_location={"N": prior_centre[0], "K": prior_centre[1]},
        prior_scale={"N": prior_sd, "K": prior_sd},
        bias_mean=np.full(draws, 0.3),
        bias_sd=np.full(draws, 0.002),
    )


def normal_integral(centres, sds, mean, sd):
    """log of integral prod_r N(x; centre_r, sd_r) N(x; mean, sd) dx, per coordinate, summed."""
    precision = sum(1 / s**2 for s in sds)
    centre = sum(c / s**2 for c, s in zip(centres, sds, strict=True)) / precision
    from scipy import stats

    return float(np.sum(stats.norm.logpdf(centre, mean, np.sqrt(1 / precision + sd**2))))


@pytest.mark.parametrize("runs", [1, 2, 3])
def test_a_units_points_integrate_its_likelihood_against_a_population(runs):
    """The weighted points of a unit estimate the integral of its runs' likelihood product
    against a population density (Hogg et al. 2010; the kernel product for several runs): the
    log ratio of two such integrals, for two populations, against the closed form, in 2-D,
    over 30 units. Unbiased within 3 standard errors (one run is exact up to the draws;
    several runs widen each run's likelihood by the kernel, sqrt(1 + h^2) = 1.03 in sd,
    allowed 0.03 here)."""
    from scipy import stats

    from bayescal.inference._population import unit_points

    sd = np.array([0.02, 0.3])
    near, far = (np.array([-5.5, -6.0]), np.array([0.2, 0.4])), (np.array([-5.3, -5.5]), 0.3)
    differences = []
    for seed in range(30):
        rng = np.random.default_rng(seed)
        centres = [np.array([-5.5, -6.0]) + sd * rng.standard_normal(2) for _ in range(runs)]
        recordings = [
            gaussian_run(rng, c, sd, np.array([-5.0, -5.0]), run=str(i), draws=500)
            for i, c in enumerate(centres)
        ]
        points = unit_points(recordings, ("N", "K"), rng)

        def estimate(mean, spread, points=points):
            density = stats.norm.logpdf(points["points"], mean, spread).sum(axis=1)
            return float(np.logaddexp.reduce(points["log_weight"] + density))

        def exact(mean, spread, centres=centres):
            return normal_integral(centres, [sd] * runs, mean, spread)

        differences.append((estimate(*near) - estimate(*far)) - (exact(*near) - exact(*far)))
    error = 3 * np.std(differences) / np.sqrt(len(differences))
    assert abs(np.mean(differences)) < error + (0 if runs == 1 else 0.03), differences


def test_runs_that_disagree_fail_the_check(monkeypatch):
    """Two runs of one unit whose noise differs by 30 of their posterior sds cannot be the same
    unit's: the check says so (and names the unit)."""
    from bayescal.inference._population import unit_points

    rng = np.random.default_rng(2)
    sd = np.array([0.01, 0.3])
    runs = [
        gaussian_run(rng, np.array([-5.5, -6.0]), sd, np.array([-5.0, -5.0]), run="1"),
        gaussian_run(rng, np.array([-5.2, -6.0]), sd, np.array([-5.0, -5.0]), run="2"),
    ]
    assert unit_points(runs, ("N", "K"), rng)["combined_ess"] < 20


def test_a_unit_in_the_populations_tail_gets_every_stored_draw():
    """Thirty units whose K the records pin to 0.3 in the log, all of one K, and one unit two
    of its sds off: the population is narrow, and with 256 points per unit its two worst units
    have 15.4 and 17.0 effective points (< 20; measured with this seed). Sampled again with
    all 1,984 stored draws as points, every unit has at least 20 (measured: 121) and the
    population passes."""
    from bayescal.inference._population import MAX_POINTS, MIN_POINT_ESS, fit_population

    rng = np.random.default_rng(0)
    sd = np.array([0.02, 0.3])
    recordings = []
    for u in range(30):
        truth = np.array([-5.5, -5.3]) + np.array([0.1, 0.0]) * rng.standard_normal(2)
        centre = truth + sd * rng.standard_normal(2)
        if u == 0:
            centre[1] = -5.3 - 2 * sd[1]
        recordings.append(gaussian_run(rng, centre, sd, np.array([-5.0, -5.0]), unit=f"U{u:02d}"))
    posterior = fit_population(recordings, ("N", "K"), seed=0)
    assert posterior.points_per_unit == 1984 > MAX_POINTS
    assert np.min(posterior.point_ess) >= MIN_POINT_ESS
    assert posterior.passed, posterior.importance_failures


def test_the_bias_posterior_is_the_exact_one():
    """The seeded small version of benchmarks/fleet_bias_exact.py: on three simulated fleets
    whose recordings are Gaussian measurements of their runs' biases, the population's 90 %
    intervals of the mean bias and of its two sds (emcee, as fit_fleet samples them) end
    where those of the exact posterior on a grid do, within a tenth of the interval (measured
    on these fleets: at most 0.066 of it, the 95 % quantile of a run-to-run sd)."""
    from bayescal.inference._population import bias_spread, fleet_data, sample_population
    from bayescal.models._population import BIAS_SD_PRIOR_FACTOR

    study = load_benchmark("fleet_bias_exact")
    rng = np.random.default_rng(2)
    names = {"bias_mean": "mu_bias", "bias_unit_sd": "tau_unit", "bias_run_sd": "tau_run"}
    for index in range(3):
        _, recordings = study.simulate_fleet(rng, (0.001, 0.006), 2000 + index)
        exact = study.grid_intervals(recordings, BIAS_SD_PRIOR_FACTOR * bias_spread(recordings))
        posterior = sample_population(fleet_data(recordings, (), seed=index), seed=index)
        for name, key in names.items():
            sampled = np.quantile(posterior.values[key], [0.05, 0.95])
            width = exact[name][1] - exact[name][0]
            assert np.all(np.abs(sampled - exact[name]) < 0.1 * width), (index, name, sampled)


def test_the_bias_integral_is_the_multivariate_normal_of_a_units_runs():
    import jax.numpy as jnp
    from scipy import stats

    from bayescal.models._population import PopulationModel

    means, variances = np.array([0.31, 0.28, 0.35]), np.array([1e-5, 4e-5, 2e-5])
    mu, tau_unit, tau_run = 0.3, 0.05, 0.02
    model = PopulationModel(
        log_weight=jnp.zeros((1, 1)),
        points=jnp.zeros((0, 1, 1)),
        bias_mean=jnp.asarray(means)[:, None, None],
        bias_variance=jnp.asarray(variances)[:, None, None],
        unit_mask=jnp.ones(1),
        run_mask=jnp.ones((3, 1)),
        bias_spread=jnp.asarray(0.1),
        parameters=(),
        unit_spread=True,
        run_spread=True,
    )
    theta = jnp.array([mu, math.log(tau_unit), math.log(tau_run)])
    covariance = np.diag(variances + tau_run**2) + tau_unit**2
    expected = stats.multivariate_normal(np.full(3, mu), covariance).logpdf(means)
    assert float(model.unit_log_likelihood(theta)[0]) == pytest.approx(expected, rel=1e-12)


# ---------------------------------------------------------------------------------------------
# One simulated fleet, fitted on a local cluster, again on a scheduler, and jointly


@pytest.fixture(scope="module")
def compile_cache(tmp_path_factory):
    """One JAX compilation cache for every worker process of this module's clusters."""
    folder = tmp_path_factory.mktemp("jax-cache")
    # Every compilation kept, however quick: each worker process of the second cluster then
    # loads what the first compiled instead of compiling it again.
    settings = {
        "JAX_COMPILATION_CACHE_DIR": str(folder),
        "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS": "0",
    }
    previous = {name: os.environ.get(name) for name in settings}
    os.environ.update(settings)
    yield folder
    for name, value in previous.items():
        if value is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = value


@pytest.fixture(scope="module")
def fleet_files(tmp_path_factory):
    """Four units (2, 1, 2, 1 runs) of white noise and a two-level turn-on bias, as the
    coverage benchmark simulates them, plus one unreadable recording and one the model does
    not fit in the manifest."""
    benchmark = load_benchmark("fleet_coverage")
    folder = tmp_path_factory.mktemp("fleet")
    population = bc.FleetPopulation(*POPULATION)
    manifest, units = benchmark.write_fleet(folder, population, RUNS, seed=7)
    write(folder / "broken.csv", "gyro_x\nnot a number\n")
    # A sensor that low-passes its output (a 4-tap moving average): white noise alone does not
    # fit it (lag-1 autocorrelation 0.75), whatever its sampler says.
    taps = np.random.default_rng(11).standard_normal(2**12 + 3)
    smoothed = 0.3 + np.convolve(taps, np.full(4, 0.01), "valid")
    np.savez(folder / "smoothed.npz", **{"gyro_x[deg/s]": smoothed})
    with manifest.open("a") as handle:
        handle.write("broken.csv,SN99,1,100\nsmoothed.npz,SN98,1,100\n")
    return manifest, population, units


@pytest.fixture(scope="module")
def local_fleet(fleet_files, compile_cache):
    manifest, _, _ = fleet_files
    fleet = bc.fit_fleet(manifest, "gyro_x", terms="white", spec="N<0.25 deg/sqrt(h)", workers=2)
    return fleet


def test_bad_recordings_are_reported_and_the_rest_go_on(local_fleet):
    """An unreadable recording (bad input) and one whose model does not fit it (its fit
    checks, a misfit) are each named by path with the reason; the population comes from the
    rest."""
    broken, smoothed = local_fleet.failed
    assert broken.kind == "input" and broken.source.endswith("broken.csv") and broken.unit == "SN99"
    assert smoothed.kind == "misfit" and smoothed.source.endswith("smoothed.npz"), smoothed
    assert "does not fit the record" in smoothed.message and smoothed.unit == "SN98"
    assert len(local_fleet.recordings) == sum(RUNS) and local_fleet.passed
    assert local_fleet.compute["workers"] == 2 and local_fleet.compute["tasks"] == sum(RUNS) + 2


def test_the_population_holds_the_truth(local_fleet, fleet_files):
    """The seeded small version of benchmarks/fleet_coverage.py: of the five population
    parameters' 90 % intervals at least three hold the truth (a calibrated method does so
    in 99 % of fleets; the benchmark measures the rate over 100 fleets)."""
    _, population, _ = fleet_files
    summary = local_fleet.summary["population"]
    checks = {
        "median_N": (summary["N"]["median"], population.median["N"]),
        "log_sd_N": (summary["N"]["log_sd"], population.log_sd["N"]),
        "bias_mean": (summary["bias"]["mean"], population.bias_mean),
        "unit_sd": (summary["bias"]["unit_to_unit_sd"], population.bias_unit_sd),
        "run_sd": (summary["bias"]["run_to_run_sd"], population.bias_run_sd),
    }
    held = {name: e["q05"] <= truth <= e["q95"] for name, (e, truth) in checks.items()}
    assert sum(held.values()) >= 3, checks
    for entry, _ in checks.values():
        assert entry["unit"] in ("deg/s/sqrt(Hz)", "1", "deg/s")


def test_a_units_expected_log_is_the_mean_of_its_shrunk_draws(local_fleet):
    """The Rao-Blackwellised shrunk mean of a unit's ln N (its expected value given each
    population draw, averaged) and the plain mean of its shrunk draws estimate one number:
    they agree within four Monte Carlo sds of the plain mean (the draws' sd over the square
    root of a tenth of their count: an autocorrelation time of up to ten draws)."""
    posterior = local_fleet.population
    for unit in posterior.units:
        draws = posterior.unit_draws[unit]["N"]
        tolerance = 4 * np.std(draws) / np.sqrt(draws.size / 10)
        assert abs(posterior.unit_log_means[unit]["N"] - np.mean(draws)) < tolerance, unit


def test_the_json_contract(local_fleet):
    from bayescal.report._fleet import fleet_page, fleet_result

    result = json.loads(json.dumps(fleet_result(local_fleet)))
    keys = {"mean", "q05", "q95", "unit"}
    assert keys <= set(result["population"]["N"]["median"])
    assert keys <= set(result["population"]["N"]["log_sd"])
    assert keys <= set(result["population"]["bias"]["unit_to_unit_sd"])
    assert keys <= set(result["population"]["bias"]["run_to_run_sd"])
    assert set(result["units"]) == {f"SN{u:02d}" for u in range(len(RUNS))}
    assert keys <= set(result["units"]["SN00"]["N"])
    assert {"scheduler", "workers", "tasks"} <= set(result["compute"])
    (verdict,) = result["spec"]["verdict"]
    assert verdict.startswith("P(N < 0.25 deg/sqrt(h)) = ")
    page = fleet_page(local_fleet)
    assert "Specification" in page and "broken.csv" in page and page.count("<img") == 2


def test_a_dask_scheduler_gives_the_same_numbers(local_fleet, fleet_files, tmp_path, run_cli):
    """A real scheduler and two worker processes on 127.0.0.1 (``dask scheduler``, ``dask
    worker``): the same fleet and seed give the local cluster's numbers; both bad recordings
    are named on stderr (the misfit as a failed health check) and the exit code says bad
    input (2), with the rest written."""
    from bayescal.report._fleet import fleet_result

    manifest, _, _ = fleet_files
    address_file = tmp_path / "scheduler.json"
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *sys.path])}
    command = [sys.executable, "-m", "distributed.cli.dask_scheduler", *SCHEDULER_OPTIONS]
    scheduler = subprocess.Popen(
        [*command, "--scheduler-file", str(address_file)],
        env=environment,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    worker = None
    try:
        deadline = time.monotonic() + 60
        while not address_file.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        address = json.loads(address_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        worker = subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", address, *WORKER_OPTIONS],
            env=environment,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        from distributed import Client

        with Client(address) as client:
            client.wait_for_workers(2, timeout=120)
        out = tmp_path / "fleet.json"
        code, _, stderr = run_cli(
            "fleet",
            manifest,
            "--channel",
            "gyro_x",
            "--terms",
            "white",
            "--scheduler",
            address,
            "--spec",
            "N<0.25 deg/sqrt(h)",
            "--json",
            out,
            "--quiet",
        )
    finally:
        for process in (worker, scheduler):
            if process is not None:
                process.terminate()
                process.wait(timeout=30)
    assert code == 2 and "broken.csv" in stderr and "smoothed.npz" in stderr, stderr
    remote, local = json.loads(out.read_text()), json.loads(json.dumps(fleet_result(local_fleet)))
    assert remote["compute"]["scheduler"] == address and remote["compute"]["workers"] == 2
    for key in ("population", "units", "spec", "outliers", "failed"):
        assert remote[key] == local[key], key


def test_the_reweighted_draws_agree_with_a_joint_fit(local_fleet, fleet_files):
    """The population from the recordings' stored draws (reweighted, no second pass over the
    data) against a joint fit of the raw records: every unit's ln N a parameter beside the
    population's, with the exact Whittle likelihood of each record and its bias's exact
    Gaussian likelihood (white noise: the bias's conditional mean does not depend on N, its
    variance is N^2 times that at N = 1). Means within a fifth of the joint posterior's sd,
    90 % bounds within a half.

    The tolerances are the Monte Carlo error's, measured: the fleet's 2,000 stored draws
    against the joint's whole chain, over nine pairs of seeds (fleet seeds 0-2, joint seeds
    3-5), the means' differences had an RMS of 0.044 sd (largest 0.10) and the 5 % and 95 %
    quantiles' 0.11 sd (largest 0.31, the 95 % quantile of sigma_N, RMS 0.20: a tail that
    few of a posterior's draws reach). Until 2026-11-27 every statistic had to be within a
    third, which a change of the sampler's rounding alone took past (0.38 sd, with the
    joint's 2,000 stored draws instead of its whole chain)."""
    joint = joint_fit(fleet_files[0], local_fleet)
    values = local_fleet.population.values
    hogg = {
        "mu_N": values["mu"][:, 0],
        "sigma_N": values["sigma"][:, 0],
        "mu_bias": values["mu_bias"],
        "tau_unit": values["tau_unit"],
        "tau_run": values["tau_run"],
    }
    statistics = {
        "mean": np.mean,
        "q05": lambda x: np.quantile(x, 0.05),
        "q95": lambda x: np.quantile(x, 0.95),
    }
    apart = {
        f"{name} {label}": (statistic(draws) - statistic(joint[name])) / np.std(joint[name])
        for name, draws in hogg.items()
        for label, statistic in statistics.items()
    }
    shown = ", ".join(f"{key} {gap:+.2f}" for key, gap in apart.items())
    tolerance = {"mean": 0.2, "q05": 0.5, "q95": 0.5}
    assert all(abs(gap) < tolerance[key.split()[-1]] for key, gap in apart.items()), shown


def joint_fit(manifest, fleet) -> dict:
    """emcee over every unit's ln N and the population's parameters, from the records."""
    import equinox as eqx
    import jax
    import jax.numpy as jnp

    from bayescal.inference._mcmc import (
        batch_log_density,
        diagnose,
        sample_ensemble,
        walker_count,
    )
    from bayescal.inference._optimize import maximum_a_posteriori
    from bayescal.inference._population import bias_spread
    from bayescal.models._level import bias_given_noise
    from bayescal.models._noise_problem import NoisePrior, NoiseProblem, noise_summaries
    from bayescal.models._population import PopulationModel

    recordings = fleet.recordings
    units = fleet.units
    prior = NoisePrior(np.zeros(1), np.ones(1), np.asarray(1.0), ("N",), "unused")
    problems, means, unit_variances, owner = [], [], [], []
    for recording in recordings:
        values = np.load(recording.source)["gyro_x[deg/s]"]
        problem = NoiseProblem(*noise_summaries(values, 100.0, ("white",)), prior)
        mean, variance = bias_given_noise(problem.level, problem.variances(jnp.zeros(1)))
        problems.append(problem)
        means.append(float(mean))
        unit_variances.append(float(variance))
        owner.append(units.index(recording.unit))
    hyper = PopulationModel(
        log_weight=jnp.zeros((1, 1)),
        points=jnp.zeros((1, 1, 1)),
        bias_mean=jnp.zeros((1, 1, 1)),
        bias_variance=jnp.ones((1, 1, 1)),
        unit_mask=jnp.ones(1),
        run_mask=jnp.ones((1, 1)),
        bias_spread=jnp.asarray(bias_spread(recordings)),
        parameters=("N",),
        unit_spread=True,
        run_spread=True,
    )

    class Joint(eqx.Module):
        problems: tuple
        means: jax.Array
        variances: jax.Array
        owner: tuple = eqx.field(static=True)
        hyper: PopulationModel

        def log_density(self, theta):
            count = len(units)
            log_n, population = theta[:count], theta[count:]
            values = self.hyper.unpack(population)
            total = self.hyper.log_prior(population)
            mu, sigma = values["mu"][0], values["sigma"][0]
            total += jnp.sum(-0.5 * ((log_n - mu) / sigma) ** 2 - jnp.log(sigma))
            for problem, u in zip(self.problems, self.owner, strict=True):
                total += jnp.sum(problem.pointwise_log_likelihood(log_n[u : u + 1]))
            for u in range(count):
                runs = [r for r, o in enumerate(self.owner) if o == u]
                m = self.means[jnp.array(runs)]
                v = self.variances[jnp.array(runs)] * jnp.exp(2 * log_n[u])
                covariance = jnp.diag(v + values["tau_run"] ** 2) + values["tau_unit"] ** 2
                total += jax.scipy.stats.multivariate_normal.logpdf(
                    m, jnp.full(len(runs), values["mu_bias"]), covariance
                )
            return jnp.where(jnp.isfinite(total), total, -jnp.inf)

    model = Joint(
        tuple(problems), jnp.asarray(means), jnp.asarray(unit_variances), tuple(owner), hyper
    )
    start = jnp.asarray(np.concatenate([np.zeros(len(units)) - 5.5, fleet.population.map_theta]))
    mode = maximum_a_posteriori(Joint.log_density, model, start)
    rng = np.random.default_rng(3)
    sampler, converged = sample_ensemble(
        batch_log_density(Joint.log_density, model),
        mode.theta,
        mode.covariance,
        rng,
        walker_count(mode.theta.size),
        40_000,
    )
    diagnostics, _ = diagnose(
        sampler, [f"x{i}" for i in range(mode.theta.size)], converged, mode.converged
    )
    assert diagnostics.passed, diagnostics.failures
    # The whole chain after its burn-in, not the 2,000 draws a posterior keeps: the comparison's
    # Monte Carlo error is then the fleet's alone.
    chain = sampler.get_chain(discard=diagnostics.burn_in, flat=True)
    flat = chain[:, len(units) :]
    values = {k: np.asarray(v) for k, v in hyper.unpack(jnp.asarray(flat)).items()}
    return {
        "mu_N": values["mu"][:, 0],
        "sigma_N": values["sigma"][:, 0],
        "mu_bias": values["mu_bias"],
        "tau_unit": values["tau_unit"],
        "tau_run": values["tau_run"],
    }


# ---------------------------------------------------------------------------------------------
# How each recording is read: the options every command that reads recordings shares


def _counts_task(tmp_path, **reading):
    """A raw-count gyro (131 LSB per deg/s, white noise N = 0.004 deg/s/sqrt(Hz), bias
    0.3 deg/s) logged as CSV behind two lines of logger metadata."""
    from bayescal.capabilities._fleet_tasks import RecordingTask

    values = bc.NoiseModel(rate_hz=100.0, bias=0.3, N=0.004).simulate(2**12, seed=5)
    path = tmp_path / "logger.csv"
    rows = "\n".join(f"{k / 100:.2f},{131 * v:.3f}" for k, v in enumerate(values))
    path.write_text(f"logger v2.1\nserial 0042\ntime,gyro_x\n{rows}\n")
    grid = {"unit": "deg/s", "scale": 1 / 131, "rate_hz": None, "gaps": "error"}
    return RecordingTask(
        row=1,
        path=str(path),
        unit="SN01",
        run="1",
        channel="gyro_x",
        grid={**grid, "time_column": None, "time_unit": None, "start": None, "stop": None},
        terms=("white",),
        sensor=None,
        seed=3,
        sampler=bc.Sampler(),
        reading={"skip_rows": 2, **reading},
    )


def test_a_worker_reads_a_logger_file_of_raw_counts_as_told(tmp_path):
    """skip_rows passes the logger's lines, scale turns counts into deg/s: the recording's N
    comes back in deg/s/sqrt(Hz), near the truth (a 41 s record: within 10 %)."""
    from bayescal.capabilities._fleet_tasks import fit_recording
    from bayescal.inference._population import RecordingDraws

    result = fit_recording(_counts_task(tmp_path))
    assert isinstance(result, RecordingDraws), result
    assert result.channel_unit == "deg/s", result
    n = math.exp(float(np.median(result.log_draws["N"])))
    assert n == pytest.approx(0.004, rel=0.1)
    assert float(np.mean(result.bias_mean)) == pytest.approx(0.3, abs=0.01)


def test_a_streamed_recording_refuses_the_options_of_arrays_and_bags(tmp_path, monkeypatch):
    from bayescal.capabilities._fleet_tasks import RecordingFailure, fit_recording
    from bayescal.recording import _stream

    monkeypatch.setattr(_stream, "is_long_recording", lambda path: True)
    failure = fit_recording(_counts_task(tmp_path, names=("time", "gyro_x")))
    assert isinstance(failure, RecordingFailure) and failure.kind == "input", failure
    assert "names does not apply to a long recording" in failure.message


def test_the_command_passes_the_reading_options_to_every_recording(two_files, run_cli, monkeypatch):
    from bayescal.capabilities import _fleet

    given = {}

    def stop_after_reading_the_options(manifest, channel, **options):
        given.update(options)
        raise bc.InputError("stopped by the test")

    monkeypatch.setattr(_fleet, "fit_fleet", stop_after_reading_the_options)
    manifest = write(two_files / "fleet.csv", "path,unit\na.csv,U1\nb.csv,U2\n")
    code, _, stderr = run_cli(
        "fleet",
        manifest,
        "--channel",
        "gyro_x",
        "--skip-rows",
        "3",
        "--unit",
        "deg/s",
        "--scale",
        "1/131",
        "--names",
        "t,gyro_x",
    )
    assert code == 2 and "stopped by the test" in stderr, stderr
    assert given["skip_rows"] == 3 and given["scale"] == pytest.approx(1 / 131)
    assert given["unit"] == "deg/s" and list(given["names"]) == ["t", "gyro_x"], given
