"""The navigation layer against an independent strapdown library (pyins, `python-ins`, the
test oracle), against closed forms, and against the physics of ../shared/NAVIGATION.md: the
mechanization and the error model over a 20-minute park, the balanced (heading, east bias)
pair, the Kalman filter's likelihood and smoother against dense Gaussian algebra, the drift's
closed-form evidence against rerunning the filter, and the filter's step."""

import math

import jax.numpy as jnp
import numpy as np
import pytest

from bayescal.classical._gravity import normal_gravity
from bayescal.navigation._alignment import (
    GyroPrior,
    coarse_alignment,
    drift_problem,
    fine_alignment,
)
from bayescal.navigation._earth import EARTH_RATE, earth_rate_n
from bayescal.navigation._error_model import discretize, error_dynamics
from bayescal.navigation._frames import dcm_from_euler, euler_from_dcm
from bayescal.navigation._kalman import StateSpace, kalman_filter, rts_smoother
from bayescal.navigation._strapdown import mechanize


def _oracle(name: str):
    """A module of the oracle, pyins (the test extra's python-ins): its tests skip without it,
    the rest of this file does not need it."""
    return pytest.importorskip(f"pyins.{name}")


GYROS = ("gyro_x", "gyro_y", "gyro_z")
PARK = {"lla": (45.0, 10.0, 0.0), "rph": (1.0, -2.0, 30.0)}
GYRO_BIAS = np.array([1e-7, -2e-7, 3e-8])  # rad/s, about 0.02 deg/h
ACCEL_BIAS = np.array([1e-4, -2e-4, 3e-4])  # m/s^2


def _park_imu(dt: float, duration: float):
    time = np.arange(round(duration / dt) + 1) * dt
    lla = np.tile(PARK["lla"], (time.size, 1))
    rph = np.tile(PARK["rph"], (time.size, 1))
    return _oracle("sim").generate_imu(time, lla, rph, sensor_type="increment")


def test_the_mechanization_agrees_with_pyins_over_a_20_minute_park():
    """The same increments (a park with gyro and accelerometer biases and a 0.05 deg heading
    error) integrated by pyins and by bayescal at 100 Hz for 20 minutes: velocity within 1e-6
    of its largest value (about 1 m/s), attitude and position as close. The simulator's ideal
    readings of a still body are pyins's mean readings to 1e-10."""
    pyins_strapdown, pyins_transform = _oracle("strapdown"), _oracle("transform")
    dt = 0.01
    trajectory, imu = _park_imu(dt, 1200.0)
    gyro_cols, accel_cols = ["gyro_x", "gyro_y", "gyro_z"], ["accel_x", "accel_y", "accel_z"]
    attitude = np.asarray(dcm_from_euler(*np.radians(PARK["rph"])))
    latitude = math.radians(PARK["lla"][0])
    ideal_rate = attitude.T @ np.asarray(earth_rate_n(latitude))
    ideal_force = attitude.T @ np.array([0.0, 0.0, -normal_gravity(PARK["lla"][0])])
    # pyins builds its readings from splines, whose wiggles (2e-6 g) average out: its means
    # are the still body's readings the simulator gives.
    mean_rate = imu[gyro_cols].values[1:].mean(axis=0) / dt
    mean_force = imu[accel_cols].values[1:].mean(axis=0) / dt
    assert np.abs(mean_rate - ideal_rate).max() < 1e-10 * EARTH_RATE
    assert np.abs(mean_force - ideal_force).max() < 1e-10 * 9.8

    imu[gyro_cols] += GYRO_BIAS * dt
    imu[accel_cols] += ACCEL_BIAS * dt
    start = trajectory.iloc[0].copy()
    start["heading"] += 0.05
    oracle = pyins_strapdown.Integrator(start, with_altitude=False).integrate(
        pyins_strapdown.compute_increments_from_imu(imu, "increment")
    )
    ours = mechanize(
        imu[gyro_cols].values[1:] / dt,
        imu[accel_cols].values[1:] / dt,
        1 / dt,
        latitude=latitude,
        longitude=math.radians(PARK["lla"][1]),
        attitude=np.asarray(
            dcm_from_euler(*np.radians(start[["roll", "pitch", "heading"]].values))
        ),
    )
    velocity = oracle[["VN", "VE"]].values
    scale = np.abs(velocity).max()
    assert scale > 0.5  # the errors grew: the comparison is not of zeros
    assert np.abs(ours.velocity[:, :2] - velocity).max() < 1e-6 * scale
    angles = pyins_transform.mat_to_rph(ours.attitude)
    assert np.abs(angles - oracle[["roll", "pitch", "heading"]].values).max() < 1e-8  # deg
    north = np.radians(np.degrees(ours.latitude) - oracle["lat"].values) * 6.4e6
    assert (
        np.abs(north).max()
        < 1e-6 * np.abs(np.radians(oracle["lat"].values - PARK["lla"][0]) * 6.4e6).max()
    )


def test_the_error_model_is_pyins_model_and_propagates_as_pyins_does():
    """The continuous model (F and the sensor errors' input matrices) equals pyins's
    InsErrorModel (held height) along a moving trajectory; over a 20-minute park, bayescal's
    exact (Van Loan) propagation of an initial error and constant sensor biases agrees to 1e-6
    with pyins's first-order propagation extrapolated to a zero step (Richardson: its error
    falls as the step)."""
    pyins_sim, pyins_error_model = _oracle("sim"), _oracle("error_model")
    trajectory, _ = pyins_sim.generate_sine_velocity_motion(
        0.1, 300, [50, 60, 0], [3, -4, 0], velocity_change_amplitude=[2, 3, 0]
    )
    trajectory = trajectory.iloc[::50]
    model = pyins_error_model.InsErrorModel(with_altitude=False)
    expected = model.system_matrices(trajectory)
    velocity = trajectory[["VN", "VE", "VD"]].values.copy()
    velocity[:, 2] = 0.0
    gravity = np.array([normal_gravity(lat) for lat in trajectory.lat])
    ours = error_dynamics(
        np.radians(trajectory.lat.values),
        0.0,
        velocity,
        np.asarray(dcm_from_euler(*np.radians(trajectory[["roll", "pitch", "heading"]].values.T))),
        gravity,
    )
    for theirs, mine in zip(expected, ours, strict=True):
        # WGS-84's constants as each library rounds them: gravity agrees to 4e-12.
        np.testing.assert_allclose(np.asarray(mine), theirs, rtol=1e-10, atol=1e-15)

    initial = np.array([0.0, 0.0, 0.0, 0.0, 1e-4, -2e-4, 3e-3])  # dr, dv, phi
    runs = []
    for dt in (0.1, 0.05):
        park, _ = _park_imu(dt, 1200.0)
        error = pyins_error_model.InsErrorModel(with_altitude=False)
        pva_error = error.transform_to_output(park.iloc[0]) @ initial
        _, internal = pyins_error_model.propagate_errors(
            park,
            pva_error=_as_series(pva_error),
            gyro_error=GYRO_BIAS,
            accel_error=ACCEL_BIAS,
            with_altitude=False,
        )
        runs.append(internal.values[:: round(1 / dt)])
    extrapolated = 2 * runs[1] - runs[0]
    attitude = np.asarray(dcm_from_euler(*np.radians(PARK["rph"])))
    dynamics, gyro_in, accel_in = (
        np.asarray(x)
        for x in error_dynamics(
            math.radians(PARK["lla"][0]), 0.0, np.zeros(3), attitude, normal_gravity(PARK["lla"][0])
        )
    )
    augmented = np.zeros((8, 8))
    augmented[:7, :7] = dynamics
    augmented[:7, 7] = gyro_in @ GYRO_BIAS + accel_in @ ACCEL_BIAS
    transition, _ = discretize(jnp.asarray(augmented[None]), jnp.zeros((1, 8, 8)), 1.0)
    state, mine = np.append(initial, 1.0), [initial]
    for _ in range(1200):
        state = np.asarray(transition[0]) @ state
        mine.append(state[:7])
    mine = np.array(mine)
    scale = np.abs(extrapolated).max(axis=0)
    assert np.all(np.abs(mine - extrapolated).max(axis=0) < 1e-6 * scale)
    assert np.abs(runs[0] - extrapolated).max() > 1e-4 * scale.max()  # the step does matter


def _as_series(values):
    import pandas as pd

    return pd.Series(values, index=_oracle("util").TRAJECTORY_ERROR_COLS)


@pytest.mark.parametrize("sign, bound", [(1, "below"), (-1, "above")])
def test_a_balanced_heading_and_east_bias_leave_the_parked_velocity_still(sign, bound):
    """NAVIGATION.md: at rest a heading error psi (computed - true) and an east gyro bias
    eps_E = -Omega cos L psi cancel; 1 mrad at 45 deg leaves the computed velocity below 1e-4
    m/s after 600 s, while the opposite sign gives more than 0.1 m/s."""
    latitude, heading, psi = math.radians(45.0), math.radians(30.0), 1e-3
    attitude = np.asarray(dcm_from_euler(0.0, 0.0, heading))
    rate = attitude.T @ np.asarray(earth_rate_n(latitude))
    force = attitude.T @ np.array([0.0, 0.0, -normal_gravity(45.0)])
    east_bias = -sign * EARTH_RATE * math.cos(latitude) * psi
    gyro = np.tile(rate + attitude.T @ np.array([0.0, east_bias, 0.0]), (60_000, 1))
    run = mechanize(
        gyro,
        np.tile(force, (60_000, 1)),
        100.0,
        latitude=latitude,
        attitude=np.asarray(dcm_from_euler(0.0, 0.0, heading + psi)),
    )
    speed = np.abs(run.velocity[-1, :2]).max()
    assert speed < 1e-4 if bound == "below" else speed > 0.1


def test_coarse_alignment_recovers_the_attitude_of_a_still_body():
    latitude = math.radians(-33.0)
    truth = np.asarray(dcm_from_euler(*np.radians([2.0, -1.5, 250.0])))
    rate = truth.T @ np.asarray(earth_rate_n(latitude))
    force = truth.T @ np.array([0.0, 0.0, -9.8])
    angles = np.degrees(np.asarray(euler_from_dcm(coarse_alignment(rate, force))))
    np.testing.assert_allclose(angles, [2.0, -1.5, 250.0 - 360.0], atol=1e-9)


def _random_model(rng, steps=30, n=4, m=2):
    transition = np.eye(n) + 0.1 * rng.standard_normal((steps, n, n))
    factor = 0.3 * rng.standard_normal((steps, n, n))
    process = factor @ np.swapaxes(factor, 1, 2) + 0.01 * np.eye(n)
    observation = rng.standard_normal((steps, m, n))
    noise = 0.2 * np.eye(m) + 0.05 * np.ones((m, m))
    space = StateSpace(
        jnp.asarray(transition),
        jnp.asarray(process),
        jnp.asarray(observation),
        jnp.asarray(np.broadcast_to(noise, (steps, m, m))),
    )
    return space, transition, process, observation, noise


def test_the_kalman_filter_and_smoother_are_the_dense_gaussian_posterior():
    """A random linear-Gaussian model of 30 steps, some measurements missing: the filter's
    log-likelihood is the joint Gaussian density of all measurements, and the smoother's
    means and covariances are the batch posterior of every state given all of them."""
    rng = np.random.default_rng(7)
    space, transition, process, observation, noise = _random_model(rng)
    steps, n = transition.shape[:2]
    y = rng.standard_normal((steps, 2))
    y[3, 0] = y[10] = np.nan
    mean0, cov0 = rng.standard_normal(n), np.eye(n) * 0.5
    # The states' joint prior: x_k = Phi_k x_{k-1} + w_k, stacked.
    big = steps * n
    mapping = np.zeros((big, big + n))  # x = A [x_0; w_1..w_K-1]
    block = np.eye(n)
    for k in range(steps):
        if k:
            block = transition[k] @ block
        mapping[k * n : (k + 1) * n, :n] = block
        for j in range(1, k + 1):
            product = np.eye(n)
            for i in range(j + 1, k + 1):
                product = transition[i] @ product
            mapping[k * n : (k + 1) * n, n + j * n - n : n + j * n] = product
    sources = np.zeros((big + n, big + n))
    sources[:n, :n] = cov0
    for j in range(1, steps):
        sources[n + (j - 1) * n : n + j * n, n + (j - 1) * n : n + j * n] = process[j]
    prior_mean = mapping[:, :n] @ mean0
    prior_cov = mapping @ sources @ mapping.T
    rows, values, noises = [], [], []
    for k in range(steps):
        for i in range(2):
            if np.isfinite(y[k, i]):
                row = np.zeros(big)
                row[k * n : (k + 1) * n] = observation[k, i]
                rows.append(row)
                values.append(y[k, i])
                noises.append((k, i))
    design = np.array(rows)
    measurement_cov = np.array(
        [[noise[i, j] if k == other else 0.0 for (other, j) in noises] for (k, i) in noises]
    )
    total = design @ prior_cov @ design.T + measurement_cov
    residual = np.array(values) - design @ prior_mean
    _, log_det = np.linalg.slogdet(total)
    expected = -0.5 * (residual @ np.linalg.solve(total, residual) + log_det)
    expected -= 0.5 * len(values) * math.log(2 * math.pi)
    filtered = kalman_filter(space, jnp.asarray(y), mean0, cov0)
    assert float(filtered.log_likelihood) == pytest.approx(expected, rel=1e-10)
    gain = prior_cov @ design.T @ np.linalg.inv(total)
    posterior_mean = prior_mean + gain @ residual
    posterior_cov = prior_cov - gain @ design @ prior_cov
    means, covariances = rts_smoother(space, filtered)
    np.testing.assert_allclose(np.asarray(means).ravel(), posterior_mean, atol=1e-9)
    for k in range(steps):
        window = slice(k * n, (k + 1) * n)
        np.testing.assert_allclose(covariances[k], posterior_cov[window, window], atol=1e-9)


@pytest.fixture(scope="module")
def small_alignment():
    """A 6-minute park at 20 Hz (compensated gyros with a residual thermal bias, biased
    accelerometers) and its fine-alignment model."""
    rng = np.random.default_rng(0)
    rate_hz, n = 20.0, 7200
    latitude = math.radians(40.0)
    truth = np.asarray(dcm_from_euler(*np.radians([0.3, -0.4, 120.0])))
    temperature = 20 + 15 * (1 - np.exp(-np.arange(n) / rate_hz / 300))
    residual = np.array([4e-8, -3e-8, 2e-8])[None] * (1 + 0.02 * (temperature[:, None] - 30))
    gyro = truth.T @ np.asarray(earth_rate_n(latitude)) + residual
    gyro = gyro + 1e-7 * math.sqrt(rate_hz) * rng.standard_normal((n, 3))
    accel = truth.T @ np.array([0.0, 0.0, -normal_gravity(40.0)]) + np.array([1e-4, -2e-4, 0])
    accel = accel + 2e-4 * math.sqrt(rate_hz) * rng.standard_normal((n, 3))
    shape = np.array([1.0, 1 / 10, 1 / 100])
    priors = tuple(
        GyroPrior(
            powers=(temperature[:, None] - 30) ** np.arange(3),
            covariance=np.diag((1e-8 * shape) ** 2),
            drift_shape=shape,
            instability=1e-20,
        )
        for _ in range(3)
    )
    options = {"latitude": latitude, "height": 0.0, "accel_instability": 1e-5}
    return gyro, accel, rate_hz, priors, options


def test_the_drift_evidence_in_closed_form_is_the_filter_rerun(small_alignment):
    """log p(y | s) from one filter run at a reference s (DriftProblem) differs between two
    drift scales by what two filter runs at those scales give, and its coefficient posterior
    at a new s is the filter's at that s."""
    gyro, accel, rate_hz, priors, options = small_alignment
    reference = 5e-8
    alignment = fine_alignment(gyro, accel, rate_hz, priors, reference_drift=reference, **options)
    filtered = alignment.model.filter(reference)
    problem = drift_problem(alignment, filtered, reference, math.log(1e-8))
    block = alignment.layout.all_coefficients
    values = {}
    for s in (2e-8, 2e-7):
        run = alignment.model.filter(s)
        prior = math.log(s) - math.log1p((s / 1e-8) ** 2)  # half-Cauchy, per log s
        values[s] = (
            float(run.log_likelihood) + prior,
            float(problem.log_posterior(jnp.array([math.log(s)]))),
        )
        mean, covariance = problem.conditional(jnp.array([math.log(s)]))
        # Scaled units (prior sd about 1): the two routes' rounding differs by ~1e-7.
        np.testing.assert_allclose(mean, run.mean[-1][block], atol=1e-5)
        np.testing.assert_allclose(covariance, run.covariance[-1][block, block], atol=1e-5)
    rerun = values[2e-7][0] - values[2e-8][0]
    closed = values[2e-7][1] - values[2e-8][1]
    assert closed == pytest.approx(rerun, abs=1e-6)
    assert abs(rerun) > 0.1  # the scale matters to the data


def test_a_measurement_each_second_loses_nothing_against_ten(small_alignment):
    """The filter on velocities sub-sampled at 1 Hz (the process noise integrated over the
    second) gives the coefficients the filter at 10 Hz gives: means within 5 % of their sd and
    sds within 2 % (measured: 3.7 % and 0.3 %; the difference is the white measurement noise,
    taken ten times as often)."""
    gyro, accel, rate_hz, priors, options = small_alignment
    results = []
    for step in (1.0, 0.1):
        alignment = fine_alignment(
            gyro, accel, rate_hz, priors, reference_drift=3e-8, step_s=step, **options
        )
        run = alignment.model.filter(3e-8)
        scale = np.asarray(alignment.model.scale)
        block = alignment.layout.all_coefficients
        results.append(
            (
                np.asarray(run.mean[-1])[block] * scale[block],
                np.sqrt(np.diag(np.asarray(run.covariance[-1]))[block]) * scale[block],
            )
        )
    (mean_1, sd_1), (mean_10, sd_10) = results
    assert np.all(np.abs(mean_1 - mean_10) < 0.05 * sd_10)
    np.testing.assert_allclose(sd_1, sd_10, rtol=0.02)


def test_the_taxi_readings_mechanize_back_into_the_taxi_and_the_wander_stays_bounded():
    """The simulator's taxi (park, acceleration, two turns) is the exact inverse of the
    mechanization: mechanizing its readings (their thermal and accelerometer biases taken off,
    the noise a millionth of navigation grade) returns the true velocity, position and heading
    to rounding; the wander's offset about the centre line has the sd it was given (within
    50 %: a few time constants of one path); standing, the vehicle reads the Earth rate and
    gravity; the GNSS columns scatter about the truth with their sd."""
    import bayescal as bc

    old = {
        name: bc.ThermalCalibration.from_document(
            {
                "schema": "bayescal.thermal_calibration",
                "schema_version": 1,
                "channel": name,
                "unit": "deg/s",
                "temperature_unit": "degC",
                "reference_temperature": 30.0,
                "degree": 1,
                "coefficients": [1e-5, 5e-7],
                "covariance": [[5e-13, 0], [0, 5e-15]],
                "temperature_range": [20.0, 40.0],
                "noise": {"terms": ["white"]},
                "provenance": [],
            }
        )
        for name in ("gyro_x", "gyro_y", "gyro_z")
    }
    taxi = bc.Taxi(legs=((30.0, 120.0), (120.0, 90.0), (75.0, 90.0)), wander_sd=0.4, gnss_sd=2.0)
    rate, park_s = 20.0, 30.0
    quiet = {"N": 1e-12, "B": 0.0}
    park = bc.simulate_park(
        old,
        duration_s=park_s,
        rate_hz=rate,
        taxi=taxi,
        gyro_noise=quiet,
        accel_noise=quiet,
        seed=4,
    )
    columns, truth = park.recording.columns, park.truth
    rates = np.stack(
        [columns[g] - park.gyro_bias(g, columns["temperature"]) for g in GYROS], axis=1
    )
    forces = np.stack([columns[a] for a in ("acc_x", "acc_y", "acc_z")], axis=1)
    forces = forces - truth["accel_bias"]
    attitude = np.asarray(dcm_from_euler(*np.radians([0.5, -0.8, 30.0])))
    computed = mechanize(
        np.radians(rates), forces, rate, latitude=math.radians(45.0), attitude=attitude
    )
    trajectory = truth["trajectory"]
    assert columns["gyro_x"].size == round((park_s + taxi.duration_s(30.0)) * rate)
    assert np.abs(computed.velocity - trajectory["velocity"]).max() < 1e-6
    north = np.degrees(computed.latitude) - trajectory["latitude"]
    assert np.abs(north).max() * 111e3 < 1e-4
    heading = np.degrees(np.asarray(euler_from_dcm(computed.attitude)[2]))
    assert np.abs((heading - trajectory["heading"] + 180) % 360 - 180).max() < 1e-6
    assert abs(np.hypot(*trajectory["velocity"][-1, :2]) - taxi.speed) < 0.2
    moving = trajectory["time"] > park_s + 30
    assert 0.5 * 0.4 < trajectory["wander"][moving].std() < 1.5 * 0.4
    assert abs(np.linalg.norm(forces[0]) - truth["gravity"]) < 1e-6
    assert abs(np.linalg.norm(np.radians(rates[0])) - EARTH_RATE) < 1e-10
    error = (columns["gnss_latitude"] - trajectory["latitude"][:-1]) * 111e3
    assert 1.0 < error.std() < 3.0


def test_a_balanced_east_residual_costs_nothing_parked_and_shows_in_flight():
    """The free-inertial check's map (steps p-q): after a gyrocompass alignment an east-only
    residual of 0.01 deg/h is balanced by the heading it causes, so parked for 1 h it moves
    the position by under 1 m, while at 250 m/s with 90 deg turns it costs hundreds of metres
    (the heading error turns the velocity: 0.94 mrad at 250 m/s is 0.23 m/s); a north-only
    residual of the same size costs about a kilometre parked (NAVIGATION.md: about 1.35 km
    for 0.01 deg/h of level residual)."""
    from bayescal.navigation._free_inertial import position_error_map

    attitude = np.asarray(dcm_from_euler(*np.radians([0.5, -0.8, 30.0])))
    size = math.radians(0.01) / 3600
    east, north = attitude.T @ [0.0, size, 0.0], attitude.T @ [size, 0.0, 0.0]
    parked = position_error_map(45.0, attitude)
    flying = position_error_map(45.0, attitude, speed=250.0)
    assert np.hypot(*(parked @ east)) < 1.0
    assert np.hypot(*(flying @ east)) > 300.0
    assert 500.0 < np.hypot(*(parked @ north)) < 2000.0


def test_the_classical_interpolation_weighs_old_and_new_by_their_covariances():
    """Step o, classically: points on a polynomial with tiny sds give that polynomial; points
    with huge sds leave the old one; equal information lands half-way. Steps m-n take the
    heading error's Earth-rate equivalent off each east point."""
    from bayescal.navigation._tilt_rates import heading_corrected, interpolate_calibration

    temperature = np.linspace(20.0, 38.0, 10)
    new = np.array([1.0, 0.1])
    bias = new[0] + new[1] * (temperature - 30.0)
    old, covariance = np.array([0.0, 0.0]), np.diag([1.0, 0.01])
    tight, _ = interpolate_calibration(temperature, bias, np.full(10, 1e-6), old, covariance, 30.0)
    np.testing.assert_allclose(tight, new, atol=1e-8)
    loose, _ = interpolate_calibration(temperature, bias, np.full(10, 1e6), old, covariance, 30.0)
    np.testing.assert_allclose(loose, old, atol=1e-8)
    one, one_covariance = interpolate_calibration([30.0], [2.0], [1.0], [0.0], [[1.0]], 30.0)
    np.testing.assert_allclose([one[0], one_covariance[0, 0]], [1.0, 0.5])
    row = heading_corrected([{"east_less_heading": 0.0}], 1e-3, math.radians(45.0))[0]
    assert row["east"] == pytest.approx(-EARTH_RATE * math.cos(math.radians(45.0)) * 1e-3)
