"""Is a navigation filter told the right IMU noise? A consistency check on a moving vehicle:
the truth's navigation errors are driven by an IMU with known noise, a filter given other
noise values estimates them from position fixes, and its normalised estimation error squared
(NEES) and innovation squared (NIS) say whether its covariance is the errors' (Bar-Shalom, Li
& Kirubarajan 2001, *Estimation with Applications to Tracking and Navigation*, sec. 5.4).

The vehicle drives at a constant speed, level, its heading swinging as A sin(2 pi t / T); the
errors follow the phi-angle model of :mod:`._error_model` along it, the sensor errors entering
through C_b^n. Both truth and filter use the same linear model, stepped at the IMU's rate with
A_k = I + F_k dt + (F_k dt)^2 / 2, so that the only difference between them is the noise:

- the truth's sensor errors are the samples of :class:`~bayescal.NoiseModel` (white noise,
  bias instability, rate random walk, an output filter, Gauss-Markov: whatever it is given),
  plus a turn-on bias drawn per axis, each sample entering as e_k dt;
- the filter's states are the seven navigation errors and three gyro and three accelerometer
  biases, each bias a random walk of density K, the sensors' white noise of density N (the
  values under test); its transition and process noise over a fix interval are the exact
  products and sums of the per-sample steps.

The filter sees a position fix (north, east; sd ``fix_sd_m``) every ``fix_interval_s``. Per run,
the NEES of the navigation states averaged over the fixes, and the NIS averaged likewise. Under
a consistent filter the innovations are independent, so the run's mean NIS is chi^2(2 J) / J
exactly (J fixes); the NEES at successive fixes are correlated, so its band is the 2.5-97.5 %
range of the mean NEES over runs whose truth is the filter's own model (:func:`nees_band`).
"""

import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ..classical._gravity import normal_gravity
from ..models._noise_model import NoiseModel
from ._error_model import error_dynamics
from ._frames import dcm_from_euler
from ._kalman import StateSpace, kalman_filter

NAV = 7
STATES = NAV + 6


@dataclass(frozen=True)
class Scenario:
    """The drive, the fixes and the filter's prior."""

    duration_s: float = 600.0
    rate_hz: float = 100.0
    fix_interval_s: float = 1.0
    fix_sd_m: float = 1.0
    speed_m_s: float = 10.0
    turn_period_s: float = 60.0
    turn_amplitude_deg: float = 90.0
    latitude_deg: float = 45.0
    position_sd_m: float = 1.0
    velocity_sd_m_s: float = 0.1
    level_sd_rad: float = 2e-3
    heading_sd_rad: float = 2e-2

    @property
    def steps_per_fix(self) -> int:
        return round(self.fix_interval_s * self.rate_hz)

    @property
    def fixes(self) -> int:
        return round(self.duration_s / self.fix_interval_s)


@dataclass(frozen=True)
class Grade:
    """An IMU's true noise (SI: rad/s, m/s^2; NoiseModel parameters) and turn-on bias sds."""

    gyro: dict
    accel: dict
    gyro_bias_sd: float
    accel_bias_sd: float
    vibration: tuple[float, float] = (0.0, 0.0)
    """The (gyro, accelerometer) white density the vehicle's vibration adds while it moves
    (SI /sqrt(Hz)): it enters before the sensor's output filter, as the white noise does."""

    def moving(self, axis: int) -> dict:
        """The NoiseModel parameters of sensor ``axis`` (0-2 gyros, 3-5 accelerometers) on
        the moving vehicle: its static noise with the vibration's density added."""
        parameters = self.gyro if axis < 3 else self.accel
        extra = self.vibration[0 if axis < 3 else 1]
        return {**parameters, "N": math.hypot(parameters["N"], extra)}


def _dynamics(scenario: Scenario):
    """Per IMU sample: the nav error model F (n, 7, 7) and the sensor input matrices."""
    n = scenario.fixes * scenario.steps_per_fix
    t = (np.arange(n) + 0.5) / scenario.rate_hz
    amplitude = math.radians(scenario.turn_amplitude_deg)
    heading = amplitude * np.sin(2 * np.pi * t / scenario.turn_period_s)
    velocity = scenario.speed_m_s * np.stack(
        [np.cos(heading), np.sin(heading), np.zeros(n)], axis=-1
    )
    attitude = dcm_from_euler(jnp.zeros(n), jnp.zeros(n), jnp.asarray(heading))
    latitude = math.radians(scenario.latitude_deg)
    gravity = normal_gravity(scenario.latitude_deg, 0.0)
    return error_dynamics(jnp.full(n, latitude), 0.0, velocity, attitude, gravity)


def _steps(dynamics, dt: float):
    return jnp.eye(dynamics.shape[-1]) + dynamics * dt + dynamics @ dynamics * (dt * dt / 2)


@jax.jit
def _truth_scan(steps, inputs, sensor, x0):
    """Navigation errors at every fix: ``steps`` (J, m, 7, 7), ``inputs`` (J, m, 7, 6) the
    sensor input matrices times dt, ``sensor`` (runs, J, m, 6) the sensor errors, ``x0``
    (runs, 7)."""

    def interval(x, data):
        a, b, e = data

        def step(x, inner):
            a_k, b_k, e_k = inner
            return a_k @ x + b_k @ e_k, None

        x, _ = jax.lax.scan(step, x, (a, b, e))
        return x, x

    def run(x, errors):
        _, xs = jax.lax.scan(interval, x, (steps, inputs, errors))
        return jnp.concatenate([x[None], xs])

    return jax.vmap(run)(x0, sensor)


@jax.jit
def _filter_model(steps, inputs, white, walk, dt):
    """The filter's transition and process noise over each fix interval (J, 13, 13): the
    per-sample steps of the augmented model multiplied and their noise summed."""
    m = steps.shape[1]

    def augmented(a, b):
        top = jnp.concatenate([a, b], axis=1)
        bottom = jnp.concatenate([jnp.zeros((6, NAV)), jnp.eye(6)], axis=1)
        return jnp.concatenate([top, bottom], axis=0)

    def interval(a, b):
        def step(carry, inner):
            phi, q = carry
            a_k, b_k = inner
            full = augmented(a_k, b_k)
            g = jnp.zeros((STATES, 12)).at[:NAV, :6].set(b_k / dt).at[NAV:, 6:].set(jnp.eye(6))
            noise = jnp.diag(jnp.concatenate([white**2, walk**2])) * dt
            return (full @ phi, full @ q @ full.T + g @ noise @ g.T), None

        start = (jnp.eye(STATES), jnp.zeros((STATES, STATES)))
        (phi, q), _ = jax.lax.scan(step, start, (a, b))
        return phi, 0.5 * (q + q.T)

    del m
    return jax.vmap(interval)(steps, inputs)


def _prior(scenario: Scenario, grade: Grade) -> np.ndarray:
    return np.array(
        [scenario.position_sd_m] * 2
        + [scenario.velocity_sd_m_s] * 2
        + [scenario.level_sd_rad] * 2
        + [scenario.heading_sd_rad]
        + [grade.gyro_bias_sd] * 3
        + [grade.accel_bias_sd] * 3
    )


@dataclass(frozen=True)
class Setup:
    """A scenario's per-sample model, shared by every run."""

    scenario: Scenario
    steps: jax.Array
    """(J, m, 7, 7)"""
    inputs: jax.Array
    """(J, m, 7, 6): the gyro and accelerometer input matrices times dt."""


def setup(scenario: Scenario) -> Setup:
    """The per-sample steps of the drive, grouped by fix interval."""
    dynamics, gyro, accel = _dynamics(scenario)
    dt = 1.0 / scenario.rate_hz
    shape = (scenario.fixes, scenario.steps_per_fix)
    steps = _steps(dynamics, dt).reshape(*shape, NAV, NAV)
    inputs = (jnp.concatenate([gyro, accel], axis=-1) * dt).reshape(*shape, NAV, 6)
    return Setup(scenario, steps, inputs)


def filter_model(
    prepared: Setup, grade: Grade, white: tuple[float, float], walk: tuple[float, float]
):
    """The filter's state-space model (scaled to unit prior sds) and the scale: ``white``
    and ``walk`` are the (gyro, accelerometer) N and K it is told, SI."""
    scenario = prepared.scenario
    dt = 1.0 / scenario.rate_hz
    white_v = jnp.repeat(jnp.asarray(white, dtype=float), 3)
    walk_v = jnp.repeat(jnp.asarray(walk, dtype=float), 3)
    phi, q = _filter_model(prepared.steps, prepared.inputs, white_v, walk_v, dt)
    count = scenario.fixes + 1
    transition = jnp.concatenate([jnp.eye(STATES)[None], phi])
    process = jnp.concatenate([jnp.zeros((1, STATES, STATES)), q])
    observation = jnp.broadcast_to(jnp.eye(2, STATES), (count, 2, STATES))
    noise = jnp.broadcast_to(jnp.eye(2) * scenario.fix_sd_m**2, (count, 2, 2))
    scale = _prior(scenario, grade)
    return StateSpace(transition, process, observation, noise).scaled(scale), scale


@jax.jit
def _scores(model: StateSpace, observations, truth):
    """Mean NEES of the navigation states and mean NIS per run (truth scaled, (runs, J, 7))."""

    def one(y, x):
        filtered = kalman_filter(model, y, jnp.zeros(STATES), jnp.eye(STATES))
        error = x - filtered.mean[:, :NAV]
        covariance = filtered.covariance[:, :NAV, :NAV]
        nees = jnp.einsum("ki,ki->k", error, jnp.linalg.solve(covariance, error[..., None])[..., 0])
        return jnp.mean(nees), jnp.mean(filtered.normalized_innovation)

    return jax.vmap(one)(observations, truth)


def simulate_runs(prepared: Setup, grade: Grade, runs: int, seed: int):
    """Truth navigation errors at every fix (runs, J, 7) and the fixes (runs, J, 2), from the
    IMU of ``grade`` (its NoiseModel per axis on the moving vehicle, :meth:`Grade.moving`,
    plus a turn-on bias)."""
    scenario = prepared.scenario
    n = scenario.fixes * scenario.steps_per_fix
    rng = np.random.default_rng(seed)
    keys = jax.random.split(jax.random.PRNGKey(seed), runs * 6)
    sensor = np.empty((runs, n, 6))
    for run in range(runs):
        for axis in range(6):
            turn_on = grade.gyro_bias_sd if axis < 3 else grade.accel_bias_sd
            model = NoiseModel(rate_hz=scenario.rate_hz, **grade.moving(axis))
            sensor[run, :, axis] = turn_on * rng.standard_normal() + model.simulate(
                n, keys[6 * run + axis]
            )
    prior = _prior(scenario, grade)[:NAV]
    x0 = prior * rng.standard_normal((runs, NAV))
    shaped = sensor.reshape(runs, scenario.fixes, scenario.steps_per_fix, 6)
    truth = np.asarray(_truth_scan(prepared.steps, prepared.inputs, shaped, x0))
    fixes = truth[..., :2] + scenario.fix_sd_m * rng.standard_normal((*truth.shape[:2], 2))
    return truth, fixes


def scores(model: StateSpace, scale, truth, fixes) -> tuple[np.ndarray, np.ndarray]:
    """Each run's mean NEES (navigation states) and mean NIS under the filter ``model``."""
    nees, nis = _scores(model, jnp.asarray(fixes), jnp.asarray(truth / scale[:NAV]))
    return np.asarray(nees), np.asarray(nis)


def nees_band(model: StateSpace, runs: int, seed: int, level: float = 0.95) -> tuple:
    """The range of a run's mean NEES that holds ``level`` of the runs of a consistent filter:
    quantiles over ``runs`` runs whose truth is the filter's own model (scaled)."""
    rng = np.random.default_rng(seed)
    transition = np.asarray(model.transition)
    process = np.asarray(model.process)
    values, vectors = np.linalg.eigh(process)
    roots = vectors * np.sqrt(np.clip(values, 0.0, None))[:, None, :]
    count = transition.shape[0]
    x = rng.standard_normal((runs, STATES))
    truth = np.empty((runs, count, STATES))
    truth[:, 0] = x
    for k in range(1, count):
        x = x @ transition[k].T + rng.standard_normal((runs, STATES)) @ roots[k].T
        truth[:, k] = x
    sd = math.sqrt(float(model.observation_noise[0, 0, 0]))
    # The scaled model's observation matrix reads the position in metres.
    observation = np.asarray(model.observation[0])
    fixes = truth @ observation.T + sd * rng.standard_normal((runs, count, 2))
    nees, _ = _scores(model, jnp.asarray(fixes), jnp.asarray(truth[..., :NAV]))
    tail = (1 - level) / 2
    return tuple(float(v) for v in np.quantile(np.asarray(nees), [tail, 1 - tail]))
