"""Thermal bias: recovery beside a random walk, the in-field update against its closed form,
the calibration file, compensation, and bad input."""

import json

import jax
import numpy as np
import pytest

import bayescal as bc
from bayescal._noise_fit import NoisePrior
from bayescal._noise_model import NoiseModel
from bayescal._thermal import ThermalRecord, sample_thermal, thermal_problem

RATE = 10.0
TRUTH = (0.5, 0.01)  # bias(T) = c0 + c1 (T - 35)


def warm_up(seed, n=2**14, walk=3e-4):
    """27 minutes warming from 25 to 45 degC, a linear thermal bias, white noise and a rate
    random walk."""
    t = np.arange(n) / RATE
    temperature = 45 - 20 * np.exp(-t / 400)
    noise = NoiseModel(rate_hz=RATE, N=0.005, K=walk).simulate(jax.random.PRNGKey(seed), n)
    return TRUTH[0] + TRUTH[1] * (temperature - 35) + np.asarray(noise), temperature


def test_thermal_slope_recovered_beside_a_random_walk():
    values, temperature = warm_up(0)
    record = ThermalRecord(values, temperature, RATE, ((0, values.size),))
    problem = thermal_problem(
        record,
        1,
        35.0,
        noise_terms=("white", "rate_random_walk"),
        allan=bc.allan_deviation(values, RATE),
    )
    fit = sample_thermal(problem, 1, 35.0, seed=0)
    assert fit.diagnostics.passed, fit.diagnostics.failures
    low, high = np.quantile(fit.coefficient_draws[:, 1], [0.05, 0.95])
    assert low <= TRUTH[1] <= high
    # A model blind to the random walk (white noise only) is far more confident than the data
    # allow: its interval is several times narrower.
    white = thermal_problem(
        record, 1, 35.0, noise_terms=("white",), allan=bc.allan_deviation(values, RATE)
    )
    naive = sample_thermal(white, 1, 35.0, seed=0)
    assert np.sqrt(fit.coefficient_covariance[1, 1]) > 3 * np.sqrt(
        naive.coefficient_covariance[1, 1]
    )


def test_update_with_white_noise_matches_the_closed_form():
    """Known white noise, Gaussian prior on the coefficients, one measured offset per period:
    the posterior is Gaussian; the sampler's mixture must reproduce the sample-level closed
    form (independent computation with numpy)."""
    rng = np.random.default_rng(3)
    noise_sd = 0.005 * np.sqrt(RATE)
    periods, values, temperature, start = [], [], [], 0
    for centre, offset in ((30.0, 0.002), (33.0, -0.001), (38.0, 0.003)):
        n = 1200
        t_period = centre + 0.8 * np.sin(np.arange(n) / 200)
        values.append(
            TRUTH[0] + TRUTH[1] * (t_period - 35) + offset + noise_sd * rng.standard_normal(n)
        )
        temperature.append(t_period)
        periods.append((start, start + n))
        start += n
    values, temperature = np.concatenate(values), np.concatenate(temperature)
    prior_mean, prior_cov = np.array([0.49, 0.011]), np.diag([0.01**2, 0.001**2])
    measured = [(0.002, 0.001), (-0.001, 0.001), (0.003, 0.001)]
    record = ThermalRecord(values, temperature, RATE, tuple(periods))
    tight = NoisePrior(
        np.array([np.log(0.005)]), np.array([1e-4]), np.asarray(1.0), ("N",), "known"
    )
    problem = thermal_problem(
        record,
        1,
        35.0,
        noise_terms=(),
        allan=None,
        coefficient_prior=(prior_mean, prior_cov),
        offset_prior=measured,
        noise_prior=tight,
    )
    fit = sample_thermal(problem, 1, 35.0, seed=1)

    design = np.zeros((values.size, 5))
    design[:, 0], design[:, 1] = 1.0, temperature - 35
    for p, (a, b) in enumerate(periods):
        design[a:b, 2 + p] = 1.0
    prior_precision = np.zeros((5, 5))
    prior_precision[:2, :2] = np.linalg.inv(prior_cov)
    prior_precision[2:, 2:] = np.diag([1 / u**2 for _, u in measured])
    mean0 = np.concatenate([prior_mean, [m for m, _ in measured]])
    precision = prior_precision + design.T @ design / noise_sd**2
    covariance = np.linalg.inv(precision)
    mean = covariance @ (prior_precision @ mean0 + design.T @ values / noise_sd**2)
    sd = np.sqrt(np.diag(covariance))[:2]
    assert np.all(np.abs(fit.coefficient_mean - mean[:2]) < 0.1 * sd)
    np.testing.assert_allclose(np.sqrt(np.diag(fit.coefficient_covariance)), sd, rtol=0.05)
    draws_sd = fit.coefficient_draws.std(axis=0)
    np.testing.assert_allclose(draws_sd, sd, rtol=0.1)


def write(path, columns, header):
    np.savetxt(
        path, np.column_stack(columns), delimiter=",", header=header, comments="", fmt="%.7f"
    )
    return path


@pytest.fixture(scope="module")
def calibration(tmp_path_factory):
    folder = tmp_path_factory.mktemp("thermal")
    values, temperature = warm_up(4, n=2**13, walk=1e-4)
    recording = write(
        folder / "warmup.csv",
        [np.arange(values.size) / RATE, values, temperature],
        "time,gyro_z[deg/s],temperature",
    )
    return folder, recording


def test_fit_writes_a_versioned_calibration_and_compensate_uses_it(run_cli, calibration):
    folder, recording = calibration
    path = folder / "cal.json"
    code, _stdout, stderr = run_cli(
        "thermal",
        "fit",
        recording,
        "--channel",
        "gyro_z",
        "--degree",
        "1",
        "--json",
        path,
        "--quiet",
    )
    assert code == 0, stderr
    document = json.loads(path.read_text())
    assert document["schema"] == "bayescal.thermal_calibration" and document["schema_version"] == 1
    assert document["coefficient_units"] == ["deg/s", "deg/s/degC"]
    assert np.asarray(document["covariance"]).shape == (2, 2)
    slope_sd = np.sqrt(document["covariance"][1][1])
    assert abs(document["coefficients"][1] - TRUTH[1]) < 4 * slope_sd
    assert document["provenance"][0]["step"] == "fit" and "classical" in document

    out = folder / "compensated.csv"
    code, _, stderr = run_cli(
        "thermal",
        "compensate",
        recording,
        "--channel",
        "gyro_z",
        "--calibration",
        path,
        "--out",
        out,
    )
    assert code == 0, stderr
    header = out.read_text().splitlines()[0].split(",")
    assert header[-2:] == ["gyro_z_compensated", "gyro_z_compensated_sd"]
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    # Compensated: the thermal trend is gone; what remains is the noise and the random walk.
    slope = np.polyfit(table[:, 2], table[:, 3], 1)[0]
    assert abs(slope) < 0.1 * TRUTH[1]


def test_bad_input(run_cli, calibration, tmp_path):
    folder, recording = calibration
    values, _temperature = warm_up(5, n=2000)
    time = np.arange(values.size) / RATE
    no_temperature = write(tmp_path / "a.csv", [time, values], "time,gyro_z[deg/s]")
    constant = write(
        tmp_path / "b.csv",
        [time, values, np.full(values.size, 25.0)],
        "time,gyro_z[deg/s],temperature",
    )
    code, _, stderr = run_cli(
        "thermal", "fit", no_temperature, "--channel", "gyro_z", "--json", tmp_path / "o.json"
    )
    assert code == 2 and "no temperature column" in stderr and "--temperature" in stderr
    code, _, stderr = run_cli(
        "thermal", "fit", constant, "--channel", "gyro_z", "--json", tmp_path / "o.json"
    )
    assert code == 2 and "temperature is constant at 25" in stderr
    assert not (tmp_path / "o.json").exists()

    cal = folder / "cal.json"
    run_cli(
        "thermal",
        "fit",
        recording,
        "--channel",
        "gyro_z",
        "--degree",
        "1",
        "--json",
        cal,
        "--quiet",
    )
    document = json.loads(cal.read_text())
    old = tmp_path / "old.json"
    old.write_text(json.dumps({**document, "schema_version": 0}))
    code, _, stderr = run_cli(
        "thermal",
        "compensate",
        recording,
        "--channel",
        "gyro_z",
        "--calibration",
        old,
        "--out",
        tmp_path / "c.csv",
    )
    assert code == 2 and "schema version 0" in stderr
    code, _, stderr = run_cli(
        "thermal",
        "compensate",
        recording,
        "--channel",
        "gyro_z",
        "--unit",
        "rad/s",
        "--calibration",
        cal,
        "--out",
        tmp_path / "c.csv",
    )
    assert code == 2 and "calibration is in deg/s but the channel is in rad/s" in stderr

    hot = write(
        tmp_path / "hot.csv",
        [time, values, np.linspace(50, 60, values.size)],
        "time,gyro_z[deg/s],temperature",
    )
    code, _, stderr = run_cli(
        "thermal",
        "compensate",
        hot,
        "--channel",
        "gyro_z",
        "--calibration",
        cal,
        "--out",
        tmp_path / "c.csv",
    )
    assert code == 0 and "outside the calibrated range" in stderr and "by up to" in stderr
