"""Thermal bias: recovery beside a random walk, the in-field update against its closed form,
the calibration file, compensation, and bad input."""

import json

import jax
import numpy as np
import pytest
from recording_files import write_csv

import bayescal as bc
from bayescal.inference._priors import default_prior
from bayescal.inference._thermal_posterior import sample_thermal
from bayescal.models._noise_problem import NoisePrior
from bayescal.models._thermal import ThermalRecord, _identified_from, thermal_problem

RATE = 10.0
TRUTH = (0.5, 0.01)  # bias(T) = c0 + c1 (T - 35)


def warm_up(seed, n=2**14, walk=3e-4):
    """27 minutes warming from 25 to 45 degC, a linear thermal bias, white noise and a rate
    random walk."""
    t = np.arange(n) / RATE
    temperature = 45 - 20 * np.exp(-t / 400)
    noise = bc.NoiseModel(rate_hz=RATE, N=0.005, K=walk).simulate(n, seed=seed)
    return TRUTH[0] + TRUTH[1] * (temperature - 35) + noise, temperature


def test_thermal_slope_recovered_beside_a_random_walk():
    values, temperature = warm_up(0)
    options = {"degree": 1, "reference": 35.0, "seed": 0}
    fit = bc.fit_thermal(values, temperature, RATE, terms="white,rrw", **options)
    assert fit.passed, fit.failures
    low, high = np.quantile(fit.posterior.coefficient_draws[:, 1], [0.05, 0.95])
    assert low <= TRUTH[1] <= high
    # A model blind to the random walk (white noise only) is far more confident than the data
    # allow: its interval is several times narrower.
    naive = bc.fit_thermal(values, temperature, RATE, terms="white", **options)
    assert np.sqrt(fit.covariance[1, 1]) > 3 * np.sqrt(naive.covariance[1, 1])


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
        noise_prior=tight,
        coefficient_prior=(prior_mean, prior_cov),
        offset_prior=measured,
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


def write_recording(path, values, temperature):
    time = np.arange(values.size) / RATE
    columns = {"time": time, "gyro_z[deg/s]": values, "temperature": temperature}
    return write_csv(path, columns, fmt="%.7f")


@pytest.fixture(scope="module")
def calibration(tmp_path_factory):
    folder = tmp_path_factory.mktemp("thermal")
    values, temperature = warm_up(4, n=2**13, walk=1e-4)
    recording = write_recording(folder / "warmup.csv", values, temperature)
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
    no_temperature = write_csv(tmp_path / "a.csv", {"time": time, "gyro_z[deg/s]": values})
    constant = write_recording(tmp_path / "b.csv", values, np.full(values.size, 25.0))
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

    hot = write_recording(tmp_path / "hot.csv", values, np.linspace(50, 60, values.size))
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


def test_a_record_of_40_rows(run_cli, tmp_path):
    """Too short to choose a degree by its predictive score: refused with the degrees it
    can take; with one given, fitted (its classical bins hold three samples or more, 40 over
    20 degC, where bins of 0.25 degC would hold none)."""
    rng = np.random.default_rng(2)
    temperature = np.linspace(20, 40, 40)
    values = TRUTH[0] + TRUTH[1] * (temperature - 35) + 0.01 * rng.standard_normal(40)
    path = write_recording(tmp_path / "short.csv", values, temperature)
    out = tmp_path / "cal.json"
    code, stdout, stderr = run_cli("thermal", "fit", path, "--channel", "gyro_z", "--json", out)
    assert code == 2 and stdout == "" and "\n" not in stderr.strip(), stderr
    assert "--degree auto: 40 samples make 5 block(s)" in stderr
    assert "give --degree 0..2, or record longer" in stderr
    assert not out.exists()
    code, _, stderr = run_cli(
        "thermal", "fit", path, "--channel", "gyro_z", "--degree", "1", "--json", out, "--quiet"
    )
    assert code in (0, 1), stderr
    assert len(json.loads(out.read_text())["classical"]["bins"]) >= 2


def test_learned_drift_given_its_scale_is_the_fixed_drift():
    """drift="auto" at a given s is the prior calibration with s^2 / h^(2j) added to the
    variance of c_j (h = 10: the range 25-45 about T0 = 35), its normalisation included."""
    values, temperature = warm_up(6, n=2000)
    record = ThermalRecord(values, temperature, RATE, ((0, 1000), (1000, 2000)))
    prior = (np.array([0.49, 0.011]), np.array([[1e-6, 1e-8], [1e-8, 1e-8]]))
    common = {
        "noise_prior": default_prior(("white",), bc.allan_deviation(values, RATE)),
        "coefficient_prior": prior,
        "offset_prior": [(0.0, 0.001), None],
        "calibrated_range": (25.0, 45.0),
    }
    learned = thermal_problem(record, 1, 35.0, drift="auto", **common)
    assert learned.parameters == ("N", "drift")
    scale = 0.004
    fixed = thermal_problem(record, 1, 35.0, drift=scale, **common)
    inflated = prior[1] + np.diag([scale**2, (scale / 10) ** 2])
    np.testing.assert_allclose(fixed.prior_precision[:2, :2], np.linalg.inv(inflated))
    differences = []
    for log_n in (np.log(0.004), np.log(0.006)):
        theta = np.array([log_n, np.log(scale)])
        _, precision, _ = learned.prior(theta)
        np.testing.assert_allclose(precision, fixed.prior_precision, rtol=1e-9)
        differences.append(
            float(learned.log_posterior(theta) - fixed.log_posterior(np.array([log_n])))
        )
    location, spread = learned.drift_prior
    expected = (
        -0.5 * np.linalg.slogdet(inflated)[1] - 0.5 * ((np.log(scale) - location) / spread) ** 2
    )
    np.testing.assert_allclose(differences, expected, rtol=1e-9)


def test_a_quantized_temperature_identifies_high_degrees_late():
    """A temperature sensor with 0.1 degC steps sits on one or two values for the first blocks
    of a slow warm-up: degree d needs d + 1 distinct block temperatures before its flat-prior
    predictive exists (choose_degree starts scoring there, or drops the degree)."""
    temperature = np.round(np.linspace(25.0, 26.0, 9600), 1)
    values = 0.01 * np.random.default_rng(0).standard_normal(temperature.size)
    record = ThermalRecord(values, temperature, RATE, ((0, values.size),))
    common = {"noise_prior": default_prior(("white",), bc.allan_deviation(values, RATE))}
    starts = [
        _identified_from(thermal_problem(record, degree, 25.5, **common).design)
        for degree in range(5)
    ]
    # 100 samples a block: the first 4.8 blocks all read 25.0, so a slope needs 5 blocks.
    assert starts[:2] == [1, 5] and all(np.diff(starts) > 0)


AGING = {"lab": np.array([0.50, 0.0100, -2.0e-4]), "now": np.array([0.51, 0.0108, -2.0e-4])}


def lab_calibration(rng):
    """An honest lab calibration of the quadratic bias AGING["lab"] (20-45 degC, T0 = 35): its
    coefficients drawn from its own stated covariance about the lab truth."""
    lab_temperature = 45 - 25 * np.exp(-np.linspace(0, 1800, 96) / 500)
    design = (lab_temperature[:, None] - 35) ** np.arange(3)
    covariance = 0.004**2 * np.linalg.inv(design.T @ design)
    mean = AGING["lab"] + np.linalg.cholesky(covariance) @ rng.standard_normal(3)
    return {
        "schema": "bayescal.thermal_calibration",
        "schema_version": 1,
        "channel": "gyro_z",
        "unit": "deg/s",
        "temperature_unit": "degC",
        "reference_temperature": 35.0,
        "degree": 2,
        "coefficients": mean.tolist(),
        "coefficient_units": ["deg/s", "deg/s/degC", "deg/s/degC^2"],
        "covariance": covariance.tolist(),
        "temperature_range": [20.0, 45.0],
        "noise": {"terms": ["white"], "N": {"mean": 0.005, "q05": 0.00495, "q95": 0.00505}},
        "earth_rate": None,
        "provenance": [{"step": "fit", "source": "simulated lab warm-up"}],
    }


def test_update_of_an_aged_sensor_covers_the_truth(run_cli, tmp_path):
    """The sensor has aged since its lab calibration (bias +0.01 deg/s, slope +8 %: several
    of the calibration's standard deviations, as aging is); six alignments between 30 and 36
    degC, offsets measured to 1 mdeg/s, update it. At the temperatures the alignments do not
    reach, the updated bias must beat the old calibration and its 90 % band must cover the
    truth: at least 75 % of the held-out points over three scenarios (nominal 90 %; an update
    that takes the old calibration as exact, --drift 0, covers under half of them)."""
    held_out = np.concatenate([np.linspace(20, 29, 10), np.linspace(37, 45, 9)])
    design = (held_out[:, None] - 35) ** np.arange(3)
    truth = design @ AGING["now"]
    covered, better = [], []
    for seed in range(3):
        rng = np.random.default_rng(100 + seed)
        calibration = lab_calibration(rng)
        cal = tmp_path / f"cal{seed}.json"
        cal.write_text(json.dumps(calibration))
        model = bc.NoiseModel(rate_hz=RATE, N=0.005)
        keys = jax.random.split(jax.random.PRNGKey(100 + seed), 6)
        values, temperature, periods, measured = [], [], [], []
        for p, centre in enumerate(np.linspace(30, 36, 6)):
            t_period = centre + 0.3 * np.sin(np.arange(1200) / 150 + rng.uniform(0, 6))
            offset = rng.normal(0, 0.003)
            powers = (t_period[:, None] - 35) ** np.arange(3)
            values.append(powers @ AGING["now"] + offset + np.asarray(model.sample(keys[p], 1200)))
            temperature.append(t_period)
            periods.append(f"{120 * p}:{120 * (p + 1)}")
            measured.append(f"{offset + rng.normal(0, 0.001):.6f}±0.001")
        values, temperature = np.concatenate(values), np.concatenate(temperature)
        recording = write_recording(tmp_path / f"field{seed}.csv", values, temperature)
        updated = tmp_path / f"new{seed}.json"
        code, _, stderr = run_cli(
            "thermal",
            "update",
            recording,
            "--channel",
            "gyro_z",
            "--calibration",
            cal,
            "--periods",
            ",".join(periods),
            "--offset-measurement=" + ",".join(measured),
            "--seed",
            str(seed),
            "--quiet",
            "--json",
            updated,
        )
        assert code == 0, stderr
        document = json.loads(updated.read_text())
        assert document["drift"]["learned"] and document["drift"]["scale"] > 0
        mean, covariance = np.asarray(document["coefficients"]), np.asarray(document["covariance"])
        error = design @ mean - truth
        sd = np.sqrt(np.einsum("ij,jk,ik->i", design, covariance, design))
        covered.append(np.mean(np.abs(error) <= 1.645 * sd))
        old_error = design @ np.asarray(calibration["coefficients"]) - truth
        better.append(np.sqrt(np.mean(error**2)) < np.sqrt(np.mean(old_error**2)))
    assert all(better)
    assert np.mean(covered) >= 0.75, covered
