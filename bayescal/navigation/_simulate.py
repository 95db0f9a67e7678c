"""The strapdown scenario simulator: a parked vehicle on the rotating Earth, seen by an IMU whose
gyro biases follow a thermal polynomial that has aged since its calibration.

The vehicle stands at latitude L, height h, with roll, pitch and heading fixed. A still body
on the Earth turns at the Earth rate and feels normal gravity, so its ideal readings are
constant: w_ib^b = C_n^b Omega^n and f^b = -C_n^b g^n (g from
:func:`bayescal.classical._gravity.normal_gravity`). Each sample is the average over its period
(as :class:`~bayescal.NoiseModel` samples are), in deg/s and m/s^2.

Sensor errors, per axis:

- gyros: bias_i(T) = sum_j c_ij (T - T0_i)^j, a thermal polynomial (the true one: a calibration's
  coefficients plus its own error, drawn from its covariance, plus aging since, s =
  ``aging`` times the calibration's sd of c_0, in one of AGING_SHAPES: ``"drift"``, the drift
  model of :mod:`bayescal.models._thermal`, delta_j ~ N(0, (s / h^j)^2) on every coefficient;
  ``"level"``, the bias level alone, delta_0 ~ N(0, s^2), the slope and curvature as
  calibrated), then white noise and bias instability (and a rate random walk if asked) from
  :class:`~bayescal.NoiseModel`;
- accelerometers: a constant bias drawn per axis, white noise and bias instability;
- temperature: a warm-up T(t) = T_inf - (T_inf - T_start) exp(-t / tau), T_inf set so that the
  park ends at ``warmup[1]``, read without noise; one column for all gyros.

The taxi (:class:`Taxi`, optional) follows the park: the vehicle accelerates along the park's
heading, turns onto each leg's heading at a constant rate and holds it, at a constant speed once
reached. About the planned path it wanders sideways: the cross-track offset w is a second-order
Gauss-Markov process (d2w/dt2 = -2 zeta omega dw/dt - omega^2 w + noise, zeta = 1/sqrt(2),
omega = 1 / the wander's time constant; Gelb 1974, table 3.8-1), stationary with sd
``wander_sd``, faded in with the speed below WANDER_SPEED (a standing vehicle does not wander):
the true velocity is V t(chi) + d(r(V) w)/dt n(chi), t and n the along- and cross-track unit
vectors, r a smooth step from 0 at rest to 1 at WANDER_SPEED. The body points along the planned
path (the wander is a sideways translation: it leaves the body rates smooth). The ideal readings
are the exact inverse of the mechanization's discrete step (:mod:`._strapdown`: the rotation
vector and velocity increment of each sample, coning and sculling included, solved for the
raw increments), so that mechanizing them returns the true trajectory to rounding; the specific
force's vertical part is the one that holds the vehicle on the held height against gravity. A
GNSS receiver, when asked, reports the true position with white noise (``gnss_sd`` m, north and
east, one fix a second held until the next), as columns ``gnss_latitude`` and
``gnss_longitude`` (deg).
"""

import math
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._errors import InputError
from ..classical._gravity import normal_gravity
from ..models._noise_model import NoiseModel
from ..models._thermal import _drift_shape
from ..recording._recording import Recording
from ..recording._units import DEG
from ._earth import check_latitude, curvature, earth_rate_n, radii
from ._error_model import discretize
from ._frames import dcm_from_euler, rotation_matrix, skew
from ._taxi import WANDER_SD, WANDER_TIME_S, wander_fade, wander_model, wrap_deg

GYROS = ("gyro_x", "gyro_y", "gyro_z")
ACCELEROMETERS = ("acc_x", "acc_y", "acc_z")
DEG_PER_H = 1 / 3600.0
"""deg/s per deg/h."""
NAVIGATION_GRADE_GYRO = {"N": 0.002 / 60.0, "B": 0.0005 * DEG_PER_H}
"""Navigation-grade gyro noise, deg/s: angle random walk 0.002 deg/sqrt(h) (N in
deg/s/sqrt(Hz) is that over 60), bias instability 0.0005 deg/h."""
NAVIGATION_GRADE_ACCEL = {"N": 2e-4, "B": 1e-5}
"""Navigation-grade accelerometer noise, m/s^2: 20 ug/sqrt(Hz) white, 1 ug bias instability."""
ACCEL_BIAS_SD = 5e-4
"""sd of the accelerometers' constant biases, m/s^2 (50 ug)."""
AGING_SHAPES = ("drift", "level")
"""How the simulated aging moves a gyro's polynomial: every coefficient by the update's own
drift model, or the bias level c_0 alone (a navigation gyro's year-to-year change is mostly its
level). Both draw the same normals, so c_0's aging is the same under either for one seed."""


@dataclass(frozen=True)
class ParkSimulation:
    """A simulated park: the recording an INS would log, and the truth behind it.

    Attributes
    ----------
    recording : Recording
        Columns ``time`` (s), ``gyro_x..z`` (deg/s), ``acc_x..z`` (m/s^2) and
        ``temperature`` (degC), with their units in the header.
    truth : dict
        Latitude, longitude, height, roll, pitch, heading (deg, m), the attitude C_b^n, the
        true thermal polynomial of each gyro (``coefficients``, ``reference``, deg/s per
        degC^j), the aging scale s (deg/s), the accelerometer biases (m/s^2), the noise
        parameters, the park's length ``park_s`` (s), the ``taxi`` and, with a taxi, the true
        ``trajectory`` at every sample's start and end: ``time`` (s), ``latitude``,
        ``longitude`` and ``heading`` (deg), ``velocity`` (north, east, down, m/s) and the
        ``wander`` about the centre line (m).
    """

    recording: Recording
    truth: dict = field(repr=False)

    def gyro_bias(self, channel: str, temperature) -> np.ndarray:
        """The true thermal bias of a gyro at ``temperature``.

        Parameters
        ----------
        channel : str
            ``gyro_x``, ``gyro_y`` or ``gyro_z``.
        temperature : array_like
            Temperatures, degC.

        Returns
        -------
        numpy.ndarray
            The bias, deg/s (noise not included).
        """
        polynomial = self.truth["thermal"][channel]
        powers = np.asarray(temperature, dtype=float)[..., None] - polynomial["reference"]
        return powers ** np.arange(len(polynomial["coefficients"])) @ polynomial["coefficients"]


@dataclass(frozen=True)
class Taxi:
    """A taxi after the park, for :func:`simulate_park`: straight legs of known heading joined
    by turns, with the vehicle's wander about the centre line and, optionally, GNSS.

    Parameters
    ----------
    legs : sequence of (float, float)
        Each leg's track heading (deg from north) and how long it is held (s). The vehicle
        starts along the park's heading, turning first if the first leg's differs.
    speed : float
        The cruising speed, m/s.
    acceleration : float
        The acceleration from rest to ``speed``, m/s^2.
    turn_rate : float
        The rate of each turn between legs, deg/s.
    wander_sd, wander_time_s : float
        sd (m) and time constant (s) of the cross-track wander (:mod:`._taxi`).
    gnss_sd : float, optional
        sd of a GNSS position's north and east error, m; None: no GNSS columns.

    Examples
    --------
    >>> import bayescal as bc
    >>> taxi = bc.Taxi(legs=((30.0, 300.0), (120.0, 270.0)), speed=10.0)
    >>> round(taxi.duration_s(30.0), 1)
    600.0
    """

    legs: tuple = ((30.0, 600.0),)
    speed: float = 10.0
    acceleration: float = 0.5
    turn_rate: float = 3.0
    wander_sd: float = WANDER_SD
    wander_time_s: float = WANDER_TIME_S
    gnss_sd: float | None = None

    def __post_init__(self):
        try:
            legs = tuple((float(h), float(d)) for h, d in self.legs)
        except (TypeError, ValueError):
            legs = ()
        if not legs or any(not (d > 0 and math.isfinite(h)) for h, d in legs):
            raise InputError(
                f"taxi legs {self.legs!r}",
                fix="give one or more (heading deg, duration s) pairs with positive durations",
            )
        for name in ("speed", "acceleration", "turn_rate", "wander_sd", "wander_time_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0 < value < math.inf):
                raise InputError(f"taxi {name} {value!r}", fix="give a positive number")
        if self.gnss_sd is not None and not (0 < self.gnss_sd < math.inf):
            raise InputError(f"taxi gnss_sd {self.gnss_sd!r}", fix="give a positive sd in m")
        object.__setattr__(self, "legs", legs)

    def duration_s(self, park_heading: float) -> float:
        """How long the taxi lasts from a park at ``park_heading`` (deg): the legs and the
        turns between them.

        Parameters
        ----------
        park_heading : float
            The heading the vehicle starts from, deg.

        Returns
        -------
        float
            Seconds.
        """
        return float(self.schedule(park_heading)[-1][1])

    def schedule(self, park_heading: float) -> list[tuple[float, float, float, float]]:
        """Each leg's (start, stop) in s from the taxi's start, after the turn onto it, with
        the heading it turns from and its own, deg.

        Parameters
        ----------
        park_heading : float
            The heading the vehicle starts from, deg.

        Returns
        -------
        list of (float, float, float, float)
            (start s, stop s, heading before the turn deg, leg heading deg) per leg.
        """
        found, clock, heading = [], 0.0, float(park_heading)
        for leg_heading, duration in self.legs:
            turn = float(wrap_deg(leg_heading - heading))
            clock += abs(turn) / self.turn_rate
            found.append((clock, clock + duration, heading, heading + turn))
            clock += duration
            heading += turn
        return found

    def heading_at(self, time, park_heading: float) -> np.ndarray:
        """The planned heading (deg, unwrapped) at ``time`` s from the taxi's start.

        Parameters
        ----------
        time : array_like
            Seconds from the taxi's start.
        park_heading : float
            The heading the vehicle starts from, deg.

        Returns
        -------
        numpy.ndarray
            Degrees.
        """
        time = np.asarray(time, dtype=float)
        heading = np.full(time.shape, float(park_heading))
        for start, _, before, after in self.schedule(park_heading):
            turn_start = start - abs(after - before) / self.turn_rate
            progress = np.clip((time - turn_start) / max(start - turn_start, 1e-12), 0.0, 1.0)
            heading = np.where(time >= turn_start, before + (after - before) * progress, heading)
        return heading

    def speed_at(self, time) -> np.ndarray:
        """The planned speed (m/s) and its rate (m/s^2) at ``time`` s from the taxi's start.

        Parameters
        ----------
        time : array_like
            Seconds from the taxi's start.

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            The speed, m/s, and its rate, m/s^2.
        """
        time = np.asarray(time, dtype=float)
        speed = np.clip(self.acceleration * time, 0.0, self.speed)
        rate = np.where((time > 0) & (speed < self.speed), self.acceleration, 0.0)
        return speed, rate


def _wander(taxi: Taxi, count: int, rate_hz: float, rng) -> np.ndarray:
    """The cross-track offset and its rate at ``count`` samples, from the stationary
    second-order process of :mod:`._taxi`, exact at the sample period."""
    dynamics, noise, stationary = wander_model(taxi.wander_sd, taxi.wander_time_s)
    transition, process = (
        np.asarray(x)[0]
        for x in discretize(jnp.asarray(dynamics)[None], jnp.asarray(noise)[None], 1 / rate_hz)
    )
    factor = np.linalg.cholesky(process + 1e-30 * np.eye(2))
    shocks = rng.standard_normal((count, 2)) @ factor.T
    state = np.linalg.cholesky(stationary) @ rng.standard_normal(2)

    def step(state, shock):
        return transition @ state + shock, state

    return np.asarray(jax.lax.scan(step, jnp.asarray(state), jnp.asarray(shocks))[1])


def _log_rotation(matrix):
    """The rotation vector of a small rotation matrix (the antisymmetric part, scaled by
    angle / sin angle)."""
    vector = 0.5 * jnp.stack(
        [matrix[2, 1] - matrix[1, 2], matrix[0, 2] - matrix[2, 0], matrix[1, 0] - matrix[0, 1]]
    )
    sine = jnp.sqrt(jnp.sum(vector**2))
    factor = jnp.where(sine < 1e-6, 1 + sine**2 / 6, jnp.arcsin(jnp.minimum(sine, 1.0)) / sine)
    return vector * factor


@jax.jit
def _inverse_mechanization(latitude, longitude, height, velocity, attitude, gravity, dt):
    """The raw rotation and velocity increments per sample that :func:`._strapdown.mechanize`
    turns into the trajectory (``velocity`` (n + 1, 3), ``attitude`` (n + 1, 3, 3)), solved
    step by step (the coning and sculling terms are linear in the sample's own increments);
    the vertical velocity increment is the one that holds the height against ``gravity``.
    Returns the increments and the latitude and longitude of every state."""

    def step(carry, inputs):
        lat, lon, theta_before, dv_before, first = carry
        v, v_new, c, c_new = inputs
        earth = earth_rate_n(lat)
        to_rate = curvature(lat, height)
        frame_rate = earth + to_rate @ v
        mean_v = 0.5 * (v + v_new)
        mean_rate = earth + to_rate @ mean_v
        rotation = _log_rotation(c.T @ rotation_matrix(mean_rate * dt) @ c_new)
        before = jnp.where(first, rotation, theta_before)
        theta = jnp.linalg.solve(jnp.eye(3) + skew(before) / 12, rotation)
        target = v_new - v + dt * jnp.cross(earth + frame_rate, v)
        target = target.at[2].set(dt * jnp.cross(earth + frame_rate, v)[2] - gravity * dt)
        dv_n = jnp.linalg.solve(jnp.eye(3) - 0.5 * dt * skew(frame_rate), target)
        delta_v = c.T @ dv_n
        before_v = jnp.where(first, jnp.zeros(3), dv_before)
        system = jnp.eye(3) + jnp.where(
            first, 0.5 * skew(theta), skew(before) / 12 + 0.5 * skew(theta)
        )
        dv = jnp.linalg.solve(system, delta_v - jnp.cross(before_v, theta) / 12)
        lat_new = lat + (-(to_rate @ mean_v)[1]) * dt
        lon_new = lon + (to_rate @ mean_v)[0] / jnp.cos(lat) * dt
        return (lat_new, lon_new, theta, dv, False), (theta, dv, lat_new, lon_new)

    start = (latitude, longitude, jnp.zeros(3), jnp.zeros(3), True)
    inputs = (velocity[:-1], velocity[1:], attitude[:-1], attitude[1:])
    _, (theta, dv, lat, lon) = jax.lax.scan(step, start, inputs)
    return (
        theta,
        dv,
        jnp.concatenate([latitude[None], lat]),
        jnp.concatenate([longitude[None], lon]),
    )


def _taxi_motion(
    taxi, park_s, count, rate_hz, latitude, height, roll, pitch, heading, gravity, rng
):
    """The ideal body rates (rad/s) and specific forces (m/s^2) of the park and the taxi, and
    the true trajectory at every sample's start and end (n + 1 states)."""
    time = np.arange(count + 1) / rate_hz - park_s
    speed, speed_rate = taxi.speed_at(time)
    planned = np.radians(taxi.heading_at(time, heading))
    wander = _wander(taxi, count + 1, rate_hz, rng)
    fade, fade_rate = wander_fade(speed)
    cross = fade * wander[:, 1] + fade_rate * speed_rate * wander[:, 0]
    along = np.stack([np.cos(planned), np.sin(planned)], axis=1)
    across = np.stack([-np.sin(planned), np.cos(planned)], axis=1)
    velocity = np.zeros((count + 1, 3))
    velocity[:, :2] = speed[:, None] * along + cross[:, None] * across
    attitude = np.asarray(
        dcm_from_euler(
            np.full(count + 1, math.radians(roll)), np.full(count + 1, math.radians(pitch)), planned
        )
    )
    theta, dv, lat, lon = (
        np.asarray(x)
        for x in _inverse_mechanization(
            jnp.asarray(math.radians(latitude)),
            jnp.asarray(0.0),
            float(height),
            jnp.asarray(velocity),
            jnp.asarray(attitude),
            float(gravity),
            1 / rate_hz,
        )
    )
    trajectory = {
        "time": time + park_s,
        "latitude": np.degrees(lat),
        "longitude": np.degrees(lon),
        "velocity": velocity,
        "heading": np.degrees(planned),
        "wander": fade * wander[:, 0],
    }
    return theta * rate_hz, dv * rate_hz, trajectory


def _gnss(trajectory, sd: float, rate_hz: float, height: float, rng) -> dict:
    """GNSS latitude and longitude (deg) at the samples' starts: the truth plus a north and
    east error of ``sd`` m drawn once a second and held until the next fix."""
    count = trajectory["latitude"].size - 1
    per_fix = max(1, round(rate_hz))
    fixes = -(-count // per_fix)
    error = np.repeat(sd * rng.standard_normal((fixes, 2)), per_fix, axis=0)[:count]
    latitude = np.radians(trajectory["latitude"][:count])
    meridian, transverse = (np.asarray(r) for r in radii(latitude))
    return {
        "gnss_latitude": trajectory["latitude"][:count]
        + np.degrees(error[:, 0] / (meridian + height)),
        "gnss_longitude": trajectory["longitude"][:count]
        + np.degrees(error[:, 1] / ((transverse + height) * np.cos(latitude))),
    }


def _true_polynomial(calibration, aging: float, rng, aging_shape: str = "drift") -> dict:
    """A calibration's coefficients plus its own error and the aging since, in
    ``aging_shape`` (module docstring)."""
    mean = np.asarray(calibration.coefficients, dtype=float)
    covariance = np.asarray(calibration.covariance, dtype=float)
    own = rng.multivariate_normal(np.zeros(mean.size), covariance, method="eigh")
    scale = aging * math.sqrt(covariance[0, 0])
    if aging_shape == "drift":
        shape = _drift_shape(mean.size - 1, calibration.reference, calibration.temperature_range)
    else:
        shape = np.eye(1, mean.size)[0]
    # Every coefficient's normal is drawn under either shape: the generator's later draws (the
    # next gyro's, the accelerometers') stay the same.
    drift = scale * shape * rng.standard_normal(mean.size)
    return {
        "coefficients": mean + own + drift,
        "reference": float(calibration.reference),
        "aging_scale": scale,
        "aging_shape": aging_shape,
    }


def simulate_park(
    calibration,
    *,
    latitude: float = 45.0,
    heading: float = 30.0,
    roll: float = 0.5,
    pitch: float = -0.8,
    height: float = 0.0,
    duration_s: float = 1200.0,
    rate_hz: float = 100.0,
    warmup: tuple[float, float] = (20.0, 38.6),
    warmup_time_constant_s: float = 600.0,
    aging: float = 4.0,
    aging_shape: str = "drift",
    gyro_noise: dict | None = None,
    accel_noise: dict | None = None,
    accel_bias_sd: float = ACCEL_BIAS_SD,
    taxi: Taxi | None = None,
    seed: int = 0,
) -> ParkSimulation:
    """Simulate an IMU in a parked vehicle warming up, then taxiing if asked: the recording
    and its truth.

    Parameters
    ----------
    calibration : mapping
        Channel name (``gyro_x``, ``gyro_y``, ``gyro_z``) -> its thermal calibration (a
        :class:`~bayescal.ThermalCalibration` in deg/s and degC, or anything with
        ``coefficients``, ``covariance``, ``reference`` and ``temperature_range``): the
        old calibration the true biases start from.
    latitude, heading, roll, pitch : float
        Where the vehicle stands and how, degrees.
    height : float
        Height above the ellipsoid, m.
    duration_s, rate_hz : float
        Length of the record, s, and its sample rate, Hz.
    warmup : (float, float)
        Temperature at the start and at the end of the record, degC.
    warmup_time_constant_s : float
        Time constant of the warm-up, s.
    aging : float
        How far each gyro's bias has moved since the calibration: the drift scale s in
        multiples of the calibration's sd of c_0.
    aging_shape : {"drift", "level"}
        What has aged: ``"drift"`` every coefficient, c_j by N(0, (s / h^j)^2) (h the calibrated
        range's farthest point from T0: the update's own drift model); ``"level"`` the bias
        level c_0 alone, by N(0, s^2).
    gyro_noise, accel_noise : dict, optional
        :class:`~bayescal.NoiseModel` parameters (``N``, ``B``, ``K``) in deg/s and m/s^2
        (default: navigation grade, ARW 0.002 deg/sqrt(h)).
    accel_bias_sd : float
        sd of the accelerometers' constant biases, m/s^2.
    taxi : Taxi, optional
        A taxi after the park (the module docstring): the record then lasts ``duration_s``
        plus the taxi, and the truth holds the trajectory.
    seed : int
        The same seed gives the same record and truth.

    Returns
    -------
    ParkSimulation
        The recording and the truth.

    Raises
    ------
    InputError
        A calibration missing for a gyro, a latitude beyond +-85 deg, an unknown
        ``aging_shape``.

    Examples
    --------
    >>> import numpy as np
    >>> import bayescal as bc
    >>> old = {
    ...     name: bc.ThermalCalibration.from_document(
    ...         {
    ...             "schema": "bayescal.thermal_calibration", "schema_version": 1,
    ...             "channel": name, "unit": "deg/s", "temperature_unit": "degC",
    ...             "reference_temperature": 30.0, "degree": 1,
    ...             "coefficients": [1e-5, 5e-7], "covariance": [[5e-13, 0], [0, 5e-15]],
    ...             "temperature_range": [20.0, 40.0], "noise": {"terms": ["white"]},
    ...             "provenance": [],
    ...         }
    ...     )
    ...     for name in ("gyro_x", "gyro_y", "gyro_z")
    ... }
    >>> park = bc.simulate_park(old, duration_s=60.0, seed=1)
    >>> sorted(park.recording.columns)[:3]
    ['acc_x', 'acc_y', 'acc_z']
    >>> round(float(park.recording.columns["temperature"][-1]), 1)
    38.6
    """
    missing = [name for name in GYROS if name not in calibration]
    if missing:
        raise InputError(
            f"the calibration lacks {', '.join(missing)}",
            fix="give one thermal calibration per gyro (gyro_x, gyro_y, gyro_z)",
        )
    if aging_shape not in AGING_SHAPES:
        raise InputError(
            f"aging shape {aging_shape!r}", fix=f"give one of {', '.join(AGING_SHAPES)}"
        )
    latitude = check_latitude(latitude)
    gyro_noise = NAVIGATION_GRADE_GYRO if gyro_noise is None else gyro_noise
    accel_noise = NAVIGATION_GRADE_ACCEL if accel_noise is None else accel_noise
    n = round(duration_s * rate_hz)
    park_n = n
    if taxi is not None:
        n += round(taxi.duration_s(heading) * rate_hz)
    time = np.arange(n) / rate_hz
    start, end = warmup
    rise = (end - start) / (1 - math.exp(-duration_s / warmup_time_constant_s))
    temperature = start + rise * (1 - np.exp(-(time + 1 / rate_hz) / warmup_time_constant_s))
    rng = np.random.default_rng(seed)
    attitude = np.asarray(dcm_from_euler(*np.radians([roll, pitch, heading])))
    gravity = normal_gravity(latitude, height)
    rate = attitude.T @ np.asarray(earth_rate_n(math.radians(latitude))) / DEG
    force = attitude.T @ np.array([0.0, 0.0, -gravity])
    keys = jax.random.split(jax.random.PRNGKey(seed), 6)
    thermal = {name: _true_polynomial(calibration[name], aging, rng, aging_shape) for name in GYROS}
    accel_bias = accel_bias_sd * rng.standard_normal(3)
    columns = {"time": time}
    trajectory = None
    if taxi is not None:
        # The taxi's own draws come from a generator of their own: the park's stay as they
        # were without it.
        taxi_rng = np.random.default_rng([seed, 1])
        rates, forces, trajectory = _taxi_motion(
            taxi, duration_s, n, rate_hz, latitude, height, roll, pitch, heading, gravity, taxi_rng
        )
        rate = rates / DEG
        force = forces
    for axis, name in enumerate(GYROS):
        noise = NoiseModel(rate_hz=rate_hz, **gyro_noise).simulate(n, keys[axis])
        powers = (temperature[:, None] - thermal[name]["reference"]) ** np.arange(
            len(thermal[name]["coefficients"])
        )
        columns[name] = rate[..., axis] + powers @ thermal[name]["coefficients"] + noise
    for axis, name in enumerate(ACCELEROMETERS):
        noise = NoiseModel(rate_hz=rate_hz, **accel_noise).simulate(n, keys[3 + axis])
        columns[name] = force[..., axis] + accel_bias[axis] + noise
    columns["temperature"] = temperature
    if taxi is not None and taxi.gnss_sd is not None:
        columns |= _gnss(trajectory, taxi.gnss_sd, rate_hz, height, taxi_rng)
    units = {"time": "s", **dict.fromkeys(GYROS, "deg/s"), **dict.fromkeys(ACCELEROMETERS, "m/s^2")}
    units["temperature"] = "degC"
    units |= {name: "deg" for name in columns if name.startswith("gnss_")}
    truth = {
        "latitude": latitude,
        "longitude": 0.0,
        "height": height,
        "roll": roll,
        "pitch": pitch,
        "heading": heading,
        "attitude": attitude,
        "thermal": thermal,
        "accel_bias": accel_bias,
        "gyro_noise": dict(gyro_noise),
        "accel_noise": dict(accel_noise),
        "gravity": gravity,
        "park_s": park_n / rate_hz,
        "taxi": taxi,
        "trajectory": trajectory,
    }
    source = f"<simulated park, seed {seed}: latitude {latitude:g} deg, heading {heading:g} deg>"
    return ParkSimulation(Recording(source, columns, units), truth)
