"""``bayescal demo``: a simulated 6-axis MEMS IMU, made by bayescal's own noise model, written
as a CSV recording and analysed into the report — the whole chain on a fresh install.

The unit: an MPU-6050-class part at 100 Hz on a still bench, z up. Gyros (deg/s): white
noise N = 0.005 deg/s/sqrt(Hz) (the MPU-6050 datasheet's 0.3 deg/sqrt(h)), bias instability
B = 0.002 deg/s (7 deg/h), a small rate random walk; turn-on biases of a tenth of a deg/s.
Accelerometers (m/s^2): N = 0.003 m/s^2/sqrt(Hz) (306 µg/sqrt(Hz)), B = 4e-4 m/s^2 (41 µg),
biases of a few 10 mg, and 1 g on z. A die temperature column warms up from power-on and
follows the room's air-conditioning cycle.

The hidden effect: gyro_z's bias follows the die temperature (0.002 deg/s per degC, a
thermal_bias in the catalogue of ../shared/DESIGN.md). Its drift over the warm-up is below
the per-sample noise, so the raw signal does not show it; the stationary noise model has no
term for it and absorbs it as a random walk or bias instability, which the Allan curve and
the spectrum of gyro_z show as excess at long averaging times. Discovery (``bayescal
discover``) runs on each gyro from the baseline a MEMS datasheet describes (white noise and
bias instability) and must name it, and nothing on the other two. ``demo_truth.json`` beside
the recording gives every simulated value, the hidden one included.
"""

import math

import numpy as np

from ..models._noise_model import NoiseModel
from ..models._terms import parameter_unit

RATE_HZ = 100.0
GRAVITY = 9.80665  # m/s^2, standard gravity: the z axis points up on a still bench
GYRO_UNIT = "deg/s"
ACCEL_UNIT = "m/s^2"
THERMAL_SLOPE = 0.002  # deg/s per degC, gyro_z only (the hidden effect)
REFERENCE_TEMPERATURE = 25.0  # degC, where the thermal bias is zero
AMBIENT = 23.5  # degC at power-on
WARMUP_RISE = 14.0  # degC from power-on to the settled die temperature
WARMUP_TIME_CONSTANT = 420.0  # s
TEMPERATURE_NOISE = 0.03  # degC, sd of the temperature sensor's reading
ROOM_CYCLE = (0.8, 480.0)  # degC amplitude and period (s) of the air conditioning's cycle

DEMO_CHANNELS = {
    "gyro_x": NoiseModel(rate_hz=RATE_HZ, bias=0.12, N=0.005, B=0.002, K=2e-5),
    "gyro_y": NoiseModel(rate_hz=RATE_HZ, bias=-0.08, N=0.005, B=0.002, K=2e-5),
    "gyro_z": NoiseModel(rate_hz=RATE_HZ, bias=0.05, N=0.005, B=0.002, K=2e-5),
    "acc_x": NoiseModel(rate_hz=RATE_HZ, bias=0.06, N=0.003, B=4e-4, K=3e-5),
    "acc_y": NoiseModel(rate_hz=RATE_HZ, bias=-0.04, N=0.003, B=4e-4, K=3e-5),
    "acc_z": NoiseModel(rate_hz=RATE_HZ, bias=GRAVITY + 0.09, N=0.003, B=4e-4, K=3e-5),
}
DEMO_SENSOR = "MPU-6050"
MIN_SAMPLES = 1024
"""The demo's shortest recording (discovery and the report need more than a few blocks)."""
DISCOVERY_BASELINE = ("white", "bias_instability")
"""What a MEMS gyro is expected to hold (its datasheet gives N and B): discovery looks for
what goes beyond it."""


def demo_recording(seed: int = 0, minutes: float = 25.0) -> tuple[dict, dict]:
    """The simulated recording (column -> values, header names with units) and the truth."""
    import jax

    from .._errors import InputError

    n = round(minutes * 60 * RATE_HZ)
    if n < MIN_SAMPLES:
        raise InputError(
            f"minutes={minutes:g}: the demo needs at least {MIN_SAMPLES / RATE_HZ / 60:.2f}"
        )
    time = np.arange(n) / RATE_HZ
    keys = jax.random.split(jax.random.PRNGKey(seed), len(DEMO_CHANNELS))
    die = (
        AMBIENT
        + WARMUP_RISE * (1 - np.exp(-time / WARMUP_TIME_CONSTANT))
        + ROOM_CYCLE[0] * np.sin(2 * np.pi * time / ROOM_CYCLE[1])
    )
    rng = np.random.default_rng([seed, 7])
    temperature = die + TEMPERATURE_NOISE * rng.standard_normal(n)
    columns = {"time": time}
    for key, (name, model) in zip(keys, DEMO_CHANNELS.items(), strict=True):
        columns[name] = model.simulate(n, seed=key)
    columns["gyro_z"] = columns["gyro_z"] + THERMAL_SLOPE * (die - REFERENCE_TEMPERATURE)
    columns["temperature"] = temperature
    units = {name: GYRO_UNIT if name.startswith("gyro") else ACCEL_UNIT for name in DEMO_CHANNELS}
    units.update(time="s", temperature="degC")
    truth = {
        "rate_hz": RATE_HZ,
        "duration_s": n / RATE_HZ,
        "seed": seed,
        "simulator": "bayescal NoiseModel.simulate (each sample the average rate over its period)",
        "channels": {
            name: {
                "unit": units[name],
                "bias": {"value": float(model.bias), "unit": units[name]},
                **{
                    parameter: {"value": float(getattr(model, parameter)), "unit": unit}
                    for parameter, unit in (
                        (p, parameter_unit(p, units[name])) for p in ("N", "B", "K")
                    )
                },
            }
            for name, model in DEMO_CHANNELS.items()
        },
        "hidden_effect": {
            "name": "thermal_bias",
            "channel": "gyro_z",
            "model": "bias(T) = bias + c1 (T - T_ref), T the die temperature",
            "c1": {"value": THERMAL_SLOPE, "unit": "deg/s/degC"},
            "T_ref": {"value": REFERENCE_TEMPERATURE, "unit": "degC"},
            "temperature": {
                "model": "T(t) = T0 + rise (1 - exp(-t / tau)) + a sin(2 pi t / P) + reading noise",
                "room_cycle": {
                    "amplitude": {"value": ROOM_CYCLE[0], "unit": "degC"},
                    "period": {"value": ROOM_CYCLE[1], "unit": "s"},
                },
                "T0": {"value": AMBIENT, "unit": "degC"},
                "rise": {"value": WARMUP_RISE, "unit": "degC"},
                "tau": {"value": WARMUP_TIME_CONSTANT, "unit": "s"},
                "reading_noise_sd": {"value": TEMPERATURE_NOISE, "unit": "degC"},
            },
            "gyro_z_drift": {
                "value": THERMAL_SLOPE * float(die[-1] - die[0]),
                "unit": "deg/s",
                "per_sample_noise_sd": DEMO_CHANNELS["gyro_z"].N * math.sqrt(RATE_HZ),
            },
        },
    }
    return {f"{name}[{units[name]}]": values for name, values in columns.items()}, truth
