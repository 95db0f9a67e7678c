"""The one home of the navigation filters' noise conventions: for each estimator bayescal
exports to, its parameter names, what each number means (a continuous-time density, a
per-sample sd, a variance), its units and the rate it scales with. The exports
(:func:`~bayescal.filter_noise`, ``bayescal export-filter``, ``bayescal noise --export
kalibr``) read them here.

In IEEE Std 952's terms a channel's white noise is N (unit/sqrt(Hz): the angle or velocity
random walk, the two-sided density of the rate's white noise, so that a sample averaged over
1/f has variance N^2 f) and the bias's random walk is K (unit*sqrt(Hz) = unit/s/sqrt(Hz): the
bias after t has variance K^2 t). With the filter's rate f:

``kalibr``
    imu.yaml (Kalibr wiki, "IMU Noise Model"): ``*_noise_density`` = N, ``*_random_walk`` =
    K, continuous time; Kalibr discretises them itself (sigma_d = N sqrt(f), sigma_bd =
    K / sqrt(f)) with ``update_rate``.
``openvins``
    The Kalibr IMU chain file OpenVINS reads (``kalibr_imu_chain.yaml``, OpenCV
    FileStorage): the same four keys under ``imu0``, continuous time (ov_msckf
    Propagator: Q_c = sigma^2 / dt for the white noise and the bias walks).
``orbslam3``
    The settings file (OpenCV FileStorage): ``IMU.NoiseGyro``, ``IMU.NoiseAcc`` = N,
    ``IMU.GyroWalk``, ``IMU.AccWalk`` = K, ``IMU.Frequency``; continuous time (Tracking's
    ParseIMUParamFile passes N sqrt(f) and K / sqrt(f) to IMU::Calib).
``vins``
    VINS-Mono / VINS-Fusion's config (OpenCV FileStorage): ``acc_n``, ``gyr_n``, ``acc_w``,
    ``gyr_w``, discrete: integration_base.h's midPointIntegration gives each step's angle
    (velocity) increment the noise 0.5 dt (n_k + n_k+1) with n_k, n_k+1 independent of sd
    ``gyr_n``, a variance 0.5 gyr_n^2 dt^2 per step, and each bias the step dt n_w with n_w of
    sd ``gyr_w``, a variance gyr_w^2 dt^2. Equal to N^2 dt and K^2 dt: ``gyr_n`` =
    sqrt(2) N sqrt(f), ``gyr_w`` = K sqrt(f).
``gtsam``
    ``gtsam.PreintegrationCombinedParams``: ``gyroscopeCovariance`` = N^2 I,
    ``accelerometerCovariance`` = N^2 I (continuous time, unit^2/Hz: ImuFactor's
    propagation multiplies them by dt), ``biasOmegaCovariance`` = K^2 I, ``biasAccCovariance``
    = K^2 I (CombinedImuFactor adds them times dt).
``px4``
    PX4 EKF2 parameters: ``EKF2_GYR_NOISE``, ``EKF2_ACC_NOISE`` (rad/s, m/s^2) and
    ``EKF2_GYR_B_NOISE``, ``EKF2_ACC_B_NOISE`` (rad/s^2, m/s^3), discrete at the EKF's
    prediction rate (EKF2_PREDICT_US, 10 ms by default), not the IMU's: the covariance
    prediction (ekf2 covariance.cpp) takes (dt EKF2_GYR_NOISE)^2 as the variance of a delta
    angle and (dt EKF2_GYR_B_NOISE)^2 as a bias's step, which equal N^2 dt and K^2 dt:
    ``EKF2_GYR_NOISE`` = N sqrt(f_ekf), ``EKF2_GYR_B_NOISE`` = K sqrt(f_ekf).

Units are SI (rad, m, s) for all six; none of them takes degrees.
"""

import math
from dataclasses import dataclass, field

from .._errors import InputError
from ..recording._units import parse_unit

SENSORS = ("accelerometer", "gyroscope")
"""The two kinds of channel a filter takes noise for."""
_SENSOR_OF_QUANTITY = {"angular_rate": "gyroscope", "acceleration": "accelerometer"}
SI = {"gyroscope": "rad/s", "accelerometer": "m/s^2"}
"""Each sensor's rate unit in SI."""
FORMS = ("density", "sample_sd", "variance")
"""What an estimator's number is: N and K themselves (continuous-time densities), per-sample
sds at a rate (sqrt(c) N sqrt(f), K sqrt(f)), or the densities squared."""


def sensor_of_unit(unit: str, channel: str, source: str | None = None) -> tuple[str, float]:
    """The sensor a channel in ``unit`` belongs to and the factor from ``unit`` to SI.

    Raises
    ------
    InputError
        The unit is neither an angular rate nor an acceleration.
    """
    parsed = parse_unit(unit)
    sensor = _SENSOR_OF_QUANTITY.get(parsed.quantity)
    if sensor is None:
        raise InputError(
            f"a filter's noise needs an angular rate or an acceleration, but {channel} is in "
            f"'{unit}'",
            source=source,
            column=channel,
            fix="give the channel's unit (unit='deg/s', 'rad/s', 'm/s^2', 'g' ...)",
        )
    return sensor, parsed.to_si


@dataclass(frozen=True)
class Estimator:
    """One estimator's noise convention (module docstring)."""

    name: str
    """As ``estimator=`` names it."""
    title: str
    """As its users know it."""
    keys: dict
    """(sensor, parameter) -> its name for N or K of that sensor."""
    form: str
    """One of :data:`FORMS`."""
    reference: str
    """Where the convention is written (code or documentation)."""
    white_factor: float = 1.0
    """c in sqrt(c) N sqrt(f) for a per-sample white noise (2 where two samples share a step,
    as VINS's midpoint integration counts them)."""
    default_rate_hz: float | None = None
    """The rate its numbers are per, when it is the filter's own and not the IMU's (PX4's EKF
    predicts every 10 ms); None: the IMU's."""
    rate_key: str | None = None
    """The parameter that holds the IMU rate in its file, if any."""
    extra: dict = field(default_factory=dict)
    """Further settings its file needs, with their values as written."""

    @property
    def per_sample(self) -> bool:
        """Whether its numbers depend on the rate (discrete per-sample values)."""
        return self.form == "sample_sd"

    def unit(self, sensor: str, parameter: str) -> str:
        """The unit of its value of ``parameter`` (N or K) for ``sensor``, ASCII."""
        base = SI[sensor]
        walk = f"{base}/s".replace("/s/s", "/s^2").replace("s^2/s", "s^3")
        if self.form == "density":
            return f"{base if parameter == 'N' else walk}/sqrt(Hz)"
        if self.form == "sample_sd":
            return base if parameter == "N" else walk
        return f"({base if parameter == 'N' else walk})^2/Hz"

    def value(self, parameter: str, density: float, rate_hz: float) -> float:
        """Its number for ``parameter`` (N or K) from the continuous-time density in SI
        (module docstring), at the filter's ``rate_hz``."""
        if self.form == "density":
            return density
        if self.form == "variance":
            return density**2
        factor = math.sqrt(self.white_factor) if parameter == "N" else 1.0
        return factor * density * math.sqrt(rate_hz)

    def density(self, parameter: str, value: float, rate_hz: float) -> float:
        """The continuous-time density in SI from its number (the inverse of
        :meth:`value`)."""
        if self.form == "density":
            return value
        if self.form == "variance":
            return math.sqrt(value)
        factor = math.sqrt(self.white_factor) if parameter == "N" else 1.0
        return value / (factor * math.sqrt(rate_hz))

    def formula(self, parameter: str) -> str:
        """How its number is made from N or K, in words."""
        symbol = "N" if parameter == "N" else "K"
        if self.form == "density":
            return f"{symbol} (continuous-time density)"
        if self.form == "variance":
            return f"{symbol}^2 (continuous-time variance density)"
        rate = "f_ekf" if self.default_rate_hz else "f"
        if parameter == "N" and self.white_factor != 1:
            return f"sqrt({self.white_factor:g}) N sqrt({rate}) (per-sample sd)"
        return f"{symbol} sqrt({rate}) (per-sample sd)"


def _keys(gyro_n: str, gyro_k: str, accel_n: str, accel_k: str) -> dict:
    return {
        ("gyroscope", "N"): gyro_n,
        ("gyroscope", "K"): gyro_k,
        ("accelerometer", "N"): accel_n,
        ("accelerometer", "K"): accel_k,
    }


_KALIBR_KEYS = _keys(
    "gyroscope_noise_density",
    "gyroscope_random_walk",
    "accelerometer_noise_density",
    "accelerometer_random_walk",
)
ESTIMATORS = {
    e.name: e
    for e in (
        Estimator(
            "kalibr",
            "Kalibr",
            _KALIBR_KEYS,
            "density",
            "Kalibr wiki, IMU Noise Model (github.com/ethz-asl/kalibr/wiki/IMU-Noise-Model)",
            rate_key="update_rate",
        ),
        Estimator(
            "openvins",
            "OpenVINS",
            _KALIBR_KEYS,
            "density",
            "OpenVINS docs, Propagation (docs.openvins.com/propagation.html); ov_msckf "
            "Propagator::predict_and_compute",
            rate_key="update_rate",
        ),
        Estimator(
            "orbslam3",
            "ORB-SLAM3",
            _keys("IMU.NoiseGyro", "IMU.GyroWalk", "IMU.NoiseAcc", "IMU.AccWalk"),
            "density",
            "ORB-SLAM3 Tracking::ParseIMUParamFile and IMU::Calib (ImuTypes.cc)",
            rate_key="IMU.Frequency",
        ),
        Estimator(
            "vins",
            "VINS-Mono / VINS-Fusion",
            _keys("gyr_n", "gyr_w", "acc_n", "acc_w"),
            "sample_sd",
            "VINS-Mono vins_estimator/src/factor/integration_base.h, midPointIntegration "
            "(noise blocks V and the 18 x 18 noise)",
            white_factor=2.0,
        ),
        Estimator(
            "gtsam",
            "GTSAM PreintegrationCombinedParams",
            _keys(
                "gyroscopeCovariance",
                "biasOmegaCovariance",
                "accelerometerCovariance",
                "biasAccCovariance",
            ),
            "variance",
            "GTSAM navigation/PreintegrationParams.h, CombinedImuFactor.cpp "
            "(PreintegratedCombinedMeasurements::integrateMeasurement)",
        ),
        Estimator(
            "px4",
            "PX4 EKF2",
            _keys("EKF2_GYR_NOISE", "EKF2_GYR_B_NOISE", "EKF2_ACC_NOISE", "EKF2_ACC_B_NOISE"),
            "sample_sd",
            "PX4-Autopilot src/modules/ekf2/EKF/covariance.cpp (predictCovariance) and the "
            "EKF2 parameter reference",
            default_rate_hz=100.0,
        ),
    )
}
"""Every estimator by name (module docstring)."""
PX4_RANGES = {
    "EKF2_GYR_NOISE": (1e-4, 0.1),
    "EKF2_ACC_NOISE": (0.01, 1.0),
    "EKF2_GYR_B_NOISE": (0.0, 0.01),
    "EKF2_ACC_B_NOISE": (0.0, 0.01),
}
"""PX4's allowed range of each parameter (its parameter reference's min and max)."""


def estimator(name: str) -> Estimator:
    """The estimator ``name`` (case-insensitive).

    Raises
    ------
    InputError
        An unknown name; the message lists the known ones.
    """
    found = ESTIMATORS.get(str(name).strip().lower())
    if found is None:
        raise InputError(
            f"estimator={name!r} is not one bayescal exports to",
            fix=f"choose one of {', '.join(ESTIMATORS)}",
        )
    return found
