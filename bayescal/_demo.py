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
import sys
from pathlib import Path

import numpy as np

from ._noise_model import NoiseModel

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
DISCOVERY_BASELINE = ("white", "bias_instability")
"""What a MEMS gyro is expected to hold (its datasheet gives N and B): discovery looks for
what goes beyond it."""


def demo_recording(seed: int = 0, minutes: float = 25.0) -> tuple[dict, dict]:
    """The simulated recording (column -> values, header names with units) and the truth."""
    import jax

    n = round(minutes * 60 * RATE_HZ)
    if n < 1024:
        raise ValueError(f"minutes={minutes}: the demo needs at least {1024 / RATE_HZ / 60:.2f}")
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
        columns[name] = np.asarray(model.simulate(key, n), dtype=float)
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
                    for parameter, unit in _parameter_units(units[name]).items()
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


def _parameter_units(unit: str) -> dict[str, str]:
    from ._units import noise_parameter_unit

    return {parameter: noise_parameter_unit(parameter, unit) for parameter in ("N", "B", "K")}


def write_csv(path: Path, columns: dict) -> None:
    """Atomic CSV with one header row (names with units in brackets)."""
    import os
    import tempfile

    import pyarrow as pa
    import pyarrow.csv as pa_csv

    descriptor, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    os.close(descriptor)
    try:
        pa_csv.write_csv(pa.table(columns), temporary)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def run_demo(args) -> int:
    from ._cli import _output_folder
    from ._output import write_json
    from ._recording import load_table
    from ._report_command import _health_exit, readable_by_all, report_recording, summary_text

    folder = _output_folder(args.out)
    folder.mkdir(exist_ok=True)
    columns, truth = demo_recording(args.seed, args.minutes)
    csv_path = folder / "demo_imu.csv"
    write_csv(csv_path, columns)
    write_json(folder / "demo_truth.json", truth)
    readable_by_all(csv_path)
    readable_by_all(folder / "demo_truth.json")
    table = load_table(csv_path)
    from ._discover_command import findings_for_report

    def discoveries(table, data):
        """Discovery on every gyro: the hidden effect must be found where it is, and nothing
        where nothing is."""
        if not data.channel.startswith("gyro"):
            return None
        return findings_for_report(table, data, seed=args.seed, baseline=DISCOVERY_BASELINE)

    outcome = report_recording(
        table,
        list(DEMO_CHANNELS),
        folder,
        stem="demo_imu",
        title="bayescal demo: simulated 6-axis MEMS IMU (MPU-6050 class), 100 Hz",
        sensor=DEMO_SENSOR,
        seed=args.seed,
        discoveries=discoveries,
        progress=not args.quiet and sys.stderr.isatty(),
    )
    print(f"bayescal demo: simulated recording {csv_path} (truth in {folder / 'demo_truth.json'})")
    print(summary_text(outcome))
    print(f"open {outcome.html.resolve().as_uri()}")
    return _health_exit(outcome, "demo")
