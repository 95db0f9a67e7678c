"""Discovery on real recordings: what does the baseline leave out?

    python benchmarks/discovery_real.py

- MPU-6050 (sunsided sensor-fusion, set-2, 10 min unmoved, with temperature; irregular time
  stamps taken as evenly spaced at their mean rate);
- ADIS16405 (SMAC imudata, imu1, the first hour of 2.78 h at 100 Hz, gyro x and z);
- ADIS16405 on the pad (PSAS Launch-12, the quiet window before liftoff, about 816 Hz).

For each: the effects found in order, their log Bayes factors and key parameters, and the
checks that failed before and after; the SMAC records also from a baseline with the sensor's
output filter.
"""

import itertools
import sys
import time
from pathlib import Path

import h5py
import numpy as np

import bayescal as bc

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"


def mpu6050():
    folder = SHARED / "sunsided_mpu6050/data/set-2/unmoved-with-x-pointing-forward-10min"
    gyro = h5py.File(folder / "mpu6050_gyroscope.mat")["gyroBuffer"][()].T
    temperature = h5py.File(folder / "mpu6050_temperature.mat")["temperatureBuffer"][()].T
    rate = (gyro.shape[0] - 1) / (gyro[-1, 0] - gyro[0, 0])
    # The temperature buffer has its own clock: put it on the gyro's samples.
    on_gyro = np.interp(gyro[:, 0], temperature[:, 0], temperature[:, 1])
    for axis, name in enumerate(("gyro_x", "gyro_y", "gyro_z"), start=1):
        yield (
            "MPU-6050 set-2 10 min",
            {
                "y": gyro[:, axis],
                "rate_hz": float(rate),
                "channel": name,
                "unit": "deg/s",
                "temperature": on_gyro,
            },
        )


def adis_smac():
    counts = np.load(SHARED / "smac_imudata_adis16405" / "adis_16405_imu1-6_counts.npz")
    scale, rate = float(counts["gyro_lsb_dps"]), float(counts["fs_hz"])
    hour = int(3600 * rate)  # the first of the 2.78 h, to keep the run short
    for axis, name in enumerate(("gyro_x", "gyro_z")):
        column = 0 if axis == 0 else 2
        yield (
            "ADIS16405 SMAC imu1, first hour",
            {
                "y": counts["imu1_counts"][:hour, column] * scale,
                "rate_hz": rate,
                "channel": name,
                "unit": "deg/s",
            },
        )


def adis_pad():
    path = SHARED / "psas_adis16405" / "Launch-12" / "telemetry_ADIS_decoded.csv"
    recording = bc.load_recording(path)
    pad = bc.find_pad_window(recording)
    for name in ("gyro_x_dps", "gyro_z_dps"):
        channel = recording.channel(name, start=pad.start_s, stop=pad.stop_s, gaps="split")
        yield f"ADIS16405 Launch-12 pad ({pad.stop_s - pad.start_s:.0f} s)", {"y": channel}


WHITE = ("white",)
FILTERED = ("white", "output_filter")
"""The ADIS16405 smooths its samples with its own output filter, not a catalogue effect: its
records are also run from a baseline that has it."""


def main() -> int:
    print("discovery on real recordings")
    for source, baselines in (
        (mpu6050, [WHITE]),
        (adis_pad, [WHITE]),
        (adis_smac, [WHITE, FILTERED]),
    ):
        try:
            recordings = list(source())
        except (OSError, KeyError, StopIteration, ValueError) as error:
            print(f"  {source.__name__}: skipped ({error})")
            continue
        for (label, data), baseline in itertools.product(recordings, baselines):
            started = time.perf_counter()
            found = bc.discover(**data, baseline=baseline, seed=0)
            print(
                f"\n  {label}, {found.channel}, baseline bias + {' + '.join(baseline)}: "
                f"{round(found.duration_s * found.rate_hz)} samples at {found.rate_hz:.4g} Hz "
                f"({time.perf_counter() - started:.0f} s)"
            )
            failed = [check.name for check in found.checks if not check.passed_before]
            print(f"    baseline checks failed: {', '.join(failed) or 'none'}")
            for effect in found.effects:
                shown = "; ".join(
                    f"{name} {value['mean']:.4g} [{value['q05']:.4g}, {value['q95']:.4g}] "
                    f"{value['unit']}"
                    for name, value in effect.parameters.items()
                    if "q05" in value
                )
                factor = effect.evidence["log_bayes_factor"]
                evidence = "on a grid" if factor is None else f"log BF {factor:.1f}"
                print(f"    + {effect.name}: {evidence}; {shown}")
            still = [check.name for check in found.checks if not check.passed_after]
            print(f"    final checks failed: {', '.join(still) or 'none'}")
            if not found.passed:
                print(f"    POSTERIOR HEALTH: {'; '.join(found.posterior.diagnostics.failures)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
