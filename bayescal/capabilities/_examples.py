"""Built-in example recordings, made by bayescal's own simulator so that every command can be
tried with no data at hand."""

import numpy as np

from ..models._noise_model import NoiseModel
from ..recording._recording import Recording

# A MEMS-grade gyro axis: turn-on bias 0.4 deg/s, angle random walk 0.21 deg/sqrt(h),
# rate random walk 8.6 deg/h/sqrt(h); one hour at 100 Hz.
EXAMPLE_GYRO = NoiseModel(rate_hz=100.0, bias=0.4, N=0.0035, K=4e-5)
EXAMPLE_DURATION_S = 3600.0


def example_recording(seed: int = 0) -> Recording:
    """One hour of a static gyro axis (``gyro_x`` in deg/s) with a ``time`` column."""
    n = int(EXAMPLE_DURATION_S * EXAMPLE_GYRO.rate_hz)
    gyro = EXAMPLE_GYRO.simulate(n, seed=seed)
    time = np.arange(n) / EXAMPLE_GYRO.rate_hz
    source = (
        f"<built-in example, seed {seed}: bias {EXAMPLE_GYRO.bias} deg/s, "
        f"N {EXAMPLE_GYRO.N} deg/s/sqrt(Hz), K {EXAMPLE_GYRO.K} deg/s*sqrt(Hz)>"
    )
    return Recording(source, {"time": time, "gyro_x": gyro}, {"time": "s", "gyro_x": "deg/s"})


NAVIGATION_GRADE_SD = (0.0025, 0.0005, 0.00005)
"""sd of a navigation-grade gyro's chamber calibration: c0 deg/h, c1 deg/h/degC, c2
deg/h/degC^2 (about what ``bayescal thermal fit`` gives from a 3-hour warm-up)."""
NAVIGATION_GRADE_BIAS = {
    "gyro_x": (0.05, 0.003, 5e-5),
    "gyro_y": (-0.04, -0.002, 4e-5),
    "gyro_z": (0.03, 0.001, -3e-5),
}
"""Their coefficients, deg/h per degC^j, about T0 = 30 degC."""


def example_gyro_calibrations() -> dict:
    """The chamber calibrations of a navigation-grade IMU's three gyros (deg/s, degC; degree
    2 about 30 degC, calibrated from 20 to 40 degC; angle random walk 0.002 deg/sqrt(h), bias
    instability 0.0005 deg/h): the old calibration of the in-field examples, tests and
    benchmarks (:func:`~bayescal.simulate_park` ages it)."""
    from ._thermal import SCHEMA, SCHEMA_VERSION, ThermalCalibration

    per_hour = 1 / 3600.0
    sd = np.array(NAVIGATION_GRADE_SD) * per_hour
    noise = {"N": 0.002 / 60.0, "B": 0.0005 * per_hour}
    calibrations = {}
    for name, coefficients in NAVIGATION_GRADE_BIAS.items():
        document = {
            "schema": SCHEMA,
            "schema_version": SCHEMA_VERSION,
            "channel": name,
            "unit": "deg/s",
            "temperature_unit": "degC",
            "reference_temperature": 30.0,
            "degree": 2,
            "coefficients": (np.array(coefficients) * per_hour).tolist(),
            "covariance": np.diag(sd**2).tolist(),
            "temperature_range": [20.0, 40.0],
            "noise": {
                "terms": ["white", "bias_instability"],
                **{
                    key: {"mean": value, "q05": value, "q95": value, "unit": unit}
                    for (key, value), unit in zip(
                        noise.items(), ("deg/s/sqrt(Hz)", "deg/s"), strict=True
                    )
                },
            },
            "provenance": [{"step": "example", "source": "bayescal's example IMU"}],
        }
        calibrations[name] = ThermalCalibration.from_document(document, "<example>")
    return calibrations
