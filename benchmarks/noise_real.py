"""The default ``noise`` on real recordings: N beside the Allan curve's reading, the terms the
record chose, the spectral lines it holds (how many; the three strongest, frequency and
amplitude in the channel's unit), whether the model fits, and what discovery names.

    python benchmarks/noise_real.py [--samples 262144] [--no-discover] [--skip ROWS]

Recordings (../shared/data, each folder's SOURCE.txt says where from):

- ADIS16405 at 100 Hz (SMAC imudata, imu1, the first 2^18 samples: 44 min), gyro x and
  accelerometer x, on the part's LSB grid (0.05 deg/s, 3.33 mg);
- ADIS16405 at about 816 Hz on a rocket's pad (PSAS Launch-12, the quiet window before
  liftoff), gyro x and accelerometer x;
- MPU-6050 at 99.3 Hz (sunsided, set-2, 10 min unmoved), gyro x and accelerometer x;
- flight computers on the pad (ISSUIUC TARS mk2, 2021-10-30, and TARS mk3.1, 2022-10-29: the
  window before liftoff, 5.8 s and 3.1 s at 100 Hz; the second is not quiet), gyro x and
  accelerometer x.

The table in docs/methods/validation.md ("Real recordings") is this script's output.
"""

import argparse
import sys
import time
from pathlib import Path

import h5py
import numpy as np

import bayescal as bc

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"


def smac(samples: int):
    counts = np.load(SHARED / "smac_imudata_adis16405" / "adis_16405_imu1-6_counts.npz")
    rate = float(counts["fs_hz"])
    run = counts["imu1_counts"][:samples]
    yield (
        "ADIS16405 100 Hz (SMAC)",
        "gyro_x",
        run[:, 0] * float(counts["gyro_lsb_dps"]),
        rate,
        "deg/s",
    )
    yield "ADIS16405 100 Hz (SMAC)", "acc_x", run[:, 3] * float(counts["acc_lsb_g"]), rate, "g"


def pad(label: str, path: Path, units: dict, time_unit: str | None = None):
    """The quiet window before liftoff of each channel in ``units`` (name -> unit, None for
    the header's)."""
    recording = bc.load_recording(path)
    window = bc.find_pad_window(recording, time_unit=time_unit)
    for name, unit in units.items():
        try:
            channel = recording.channel(
                name,
                unit=unit,
                time_unit=time_unit,
                start=window.start_s,
                stop=window.stop_s,
                gaps="split",
            )
        except bc.InputError as error:  # the loader's refusal is that row's result
            channel = error
        yield label, name, channel, None, None


def mpu6050():
    folder = SHARED / "sunsided_mpu6050/data/set-2/unmoved-with-x-pointing-forward-10min"
    gyro = h5py.File(folder / "mpu6050_gyroscope.mat")["gyroBuffer"][()].T
    accelerometer = h5py.File(folder / "mpu6050_accelerometer.mat")
    accelerometer = accelerometer[next(iter(accelerometer.keys()))][()].T
    # Irregular time stamps: evenly spaced at their mean rate.
    rate = float((gyro.shape[0] - 1) / (gyro[-1, 0] - gyro[0, 0]))
    yield "MPU-6050 99.3 Hz (sunsided)", "gyro_x", gyro[:, 1], rate, "deg/s"
    yield "MPU-6050 99.3 Hz (sunsided)", "acc_x", accelerometer[:, 1], rate, "g"


def records(samples: int):
    yield from smac(samples)
    yield from pad(
        "ADIS16405 816 Hz pad (PSAS L-12)",
        SHARED / "psas_adis16405/Launch-12/telemetry_ADIS_decoded.csv",
        {"gyro_x_dps": None, "acc_x_mps2": None},
    )
    yield from mpu6050()
    yield from pad(
        "flight computer pad (TARS mk2)",
        SHARED / "issuiuc_rocket_flights/20211030/flight_computer_trimmed.csv",
        # Millisecond stamps and units the log does not write (the TARS firmware's deg/s, g).
        {"gx": "deg/s", "ax": "g"},
        time_unit="ms",
    )
    yield from pad(
        "flight computer pad (TARS mk3.1)",
        SHARED / "issuiuc_rocket_flights/20221029/flight_computer.csv",
        {"gx": "deg/s", "ax": "g"},
        time_unit="ms",
    )


def lines_column(fit) -> str:
    """The lines found: how many, and the three strongest (frequency, amplitude; broadened,
    aliased)."""
    if fit.lines is None or not fit.lines.lines:
        return "none"
    found = sorted(fit.lines.lines, key=lambda line: -line.amplitude["mean"])
    shown = []
    for line in found[:3]:
        kind = " broadened" if line.broadened else ""
        kind += " aliased" if line.aliased else ""
        shown.append(f"{line.frequency_hz['mean']:.5g} Hz {line.amplitude['mean']:.2g}{kind}")
    more = f", +{len(found) - 3}" if len(found) > 3 else ""
    return f"{len(found)}: " + ", ".join(shown) + more


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=2**18)
    parser.add_argument("--no-discover", action="store_true")
    parser.add_argument(
        "--skip", type=int, default=0, help="leave out the first rows (resume a cut-short run)"
    )
    args = parser.parse_args()
    print(
        "| recording | channel | N (noise, 90 %) | N (Allan reading) | terms chosen | lines | "
        "fit | discovery names | time |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for index, (label, name, values, rate, unit) in enumerate(records(args.samples)):
        if index < args.skip:
            continue
        started = time.perf_counter()
        try:
            if isinstance(values, bc.InputError):
                raise values
            fit = bc.fit_noise(values, rate, unit=unit, channel=name, seed=0)
        except bc.BayescalError as error:
            print(f"| {label} | {name} | refused: {error} | | | | | | |")
            continue
        n = fit.summary["N"]
        reading = fit.classical.slope_readings["N"]
        shown = f"{reading.value:.4g}" if reading.kind == "reading" else f"<= {reading.ci_high:.4g}"
        terms = (
            ", ".join(term for term in fit.terms if term not in ("white", "spectral_lines"))
            or "white only"
        )
        shown_lines = lines_column(fit)
        if fit.lsb > 0:
            terms += f"; LSB {fit.lsb:.3g}"
        verdict = "fits" if fit.fits else "MISFIT: " + "; ".join(fit.misfits)
        if not fit.diagnostics.passed:
            verdict += " (sampler: " + "; ".join(fit.diagnostics.failures) + ")"
        named = ""
        if not args.no_discover:
            options = {} if rate is None else {"rate_hz": rate, "unit": unit, "channel": name}
            found = bc.discover(values, posterior=False, **options)
            named = ", ".join(effect.name for effect in found.effects) or "nothing"
            if found.unexplained:
                named += f" (unexplained: {found.unexplained['where']})"
        elapsed = time.perf_counter() - started
        print(
            f"| {label} | {name} | {n['mean']:.4g} [{n['q05']:.4g}, {n['q95']:.4g}] "
            f"{n['unit']} | {shown} | {terms} | {shown_lines} | {verdict} | {named} | "
            f"{elapsed:.0f} s |"
        )
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
