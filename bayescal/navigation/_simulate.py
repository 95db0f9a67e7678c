"""The strapdown scenario simulator: a parked vehicle on the rotating Earth, seen by an IMU whose
gyro biases follow a thermal polynomial that has aged since its calibration.

The vehicle stands at latitude L, height h, with roll, pitch and heading fixed. A still body
on the Earth turns at the Earth rate and feels normal gravity, so its ideal readings are
constant: w_ib^b = C_n^b Omega^n and f^b = -C_n^b g^n (g from
:func:`bayescal.classical._gravity.normal_gravity`). Each sample is the average over its period
(as :class:`~bayescal.NoiseModel` samples are), in deg/s and m/s^2.

Sensor errors, per axis:

- gyros: bias_i(T) = sum_j c_ij (T - T0_i)^j, a thermal polynomial (the true one: a calibration's
  coefficients plus its own error, drawn from its covariance, plus aging since, drawn from
  the drift model of :mod:`bayescal.models._thermal`: delta_j ~ N(0, (s / h^j)^2), s =
  ``aging`` times the calibration's sd of c_0), then white noise and bias instability (and a
  rate random walk if asked) from :class:`~bayescal.NoiseModel`;
- accelerometers: a constant bias drawn per axis, white noise and bias instability;
- temperature: a warm-up T(t) = T_inf - (T_inf - T_start) exp(-t / tau), T_inf set so that the
  record ends at ``warmup[1]``, read without noise; one column for all gyros.
"""

import math
from dataclasses import dataclass, field

import jax
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._errors import InputError
from ..classical._gravity import normal_gravity
from ..models._noise_model import NoiseModel
from ..models._thermal import _drift_shape
from ..recording._recording import Recording
from ..recording._units import DEG
from ._earth import check_latitude, earth_rate_n
from ._frames import dcm_from_euler

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
        degC^j), the aging scale s (deg/s), the accelerometer biases (m/s^2) and the noise
        parameters.
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


def _true_polynomial(calibration, aging: float, rng) -> dict:
    """A calibration's coefficients plus its own error and the aging since (module
    docstring)."""
    mean = np.asarray(calibration.coefficients, dtype=float)
    covariance = np.asarray(calibration.covariance, dtype=float)
    own = rng.multivariate_normal(np.zeros(mean.size), covariance, method="eigh")
    scale = aging * math.sqrt(covariance[0, 0])
    shape = _drift_shape(mean.size - 1, calibration.reference, calibration.temperature_range)
    drift = scale * shape * rng.standard_normal(mean.size)
    return {
        "coefficients": mean + own + drift,
        "reference": float(calibration.reference),
        "aging_scale": scale,
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
    gyro_noise: dict | None = None,
    accel_noise: dict | None = None,
    accel_bias_sd: float = ACCEL_BIAS_SD,
    seed: int = 0,
) -> ParkSimulation:
    """Simulate an IMU in a parked vehicle warming up: the recording and its truth.

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
    gyro_noise, accel_noise : dict, optional
        :class:`~bayescal.NoiseModel` parameters (``N``, ``B``, ``K``) in deg/s and m/s^2
        (default: navigation grade, ARW 0.002 deg/sqrt(h)).
    accel_bias_sd : float
        sd of the accelerometers' constant biases, m/s^2.
    seed : int
        The same seed gives the same record and truth.

    Returns
    -------
    ParkSimulation
        The recording and the truth.

    Raises
    ------
    InputError
        A calibration missing for a gyro, a latitude beyond +-85 deg.

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
    latitude = check_latitude(latitude)
    gyro_noise = NAVIGATION_GRADE_GYRO if gyro_noise is None else gyro_noise
    accel_noise = NAVIGATION_GRADE_ACCEL if accel_noise is None else accel_noise
    n = round(duration_s * rate_hz)
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
    thermal = {name: _true_polynomial(calibration[name], aging, rng) for name in GYROS}
    accel_bias = accel_bias_sd * rng.standard_normal(3)
    columns = {"time": time}
    for axis, name in enumerate(GYROS):
        noise = NoiseModel(rate_hz=rate_hz, **gyro_noise).simulate(n, keys[axis])
        powers = (temperature[:, None] - thermal[name]["reference"]) ** np.arange(
            len(thermal[name]["coefficients"])
        )
        columns[name] = rate[axis] + powers @ thermal[name]["coefficients"] + noise
    for axis, name in enumerate(ACCELEROMETERS):
        noise = NoiseModel(rate_hz=rate_hz, **accel_noise).simulate(n, keys[3 + axis])
        columns[name] = force[axis] + accel_bias[axis] + noise
    columns["temperature"] = temperature
    units = {"time": "s", **dict.fromkeys(GYROS, "deg/s"), **dict.fromkeys(ACCELEROMETERS, "m/s^2")}
    units["temperature"] = "degC"
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
    }
    source = f"<simulated park, seed {seed}: latitude {latitude:g} deg, heading {heading:g} deg>"
    return ParkSimulation(Recording(source, columns, units), truth)
