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

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bayescal._discover import DiscoveryData, discover, effect_parameters, sample_final
from bayescal._pad import find_pad_window
from bayescal._recording import load_table, prepare_channel

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
            DiscoveryData(
                values=gyro[:, axis],
                rate_hz=float(rate),
                channel=name,
                unit="deg/s",
                temperature=on_gyro,
            ),
        )


def adis_smac():
    counts = np.load(SHARED / "smac_imudata_adis16405" / "adis_16405_imu1-6_counts.npz")
    scale, rate = float(counts["gyro_lsb_dps"]), float(counts["fs_hz"])
    hour = int(3600 * rate)  # the first of the 2.78 h, to keep the run short
    for axis, name in enumerate(("gyro_x", "gyro_z")):
        column = 0 if axis == 0 else 2
        yield (
            "ADIS16405 SMAC imu1, first hour",
            DiscoveryData(
                values=counts["imu1_counts"][:hour, column] * scale,
                rate_hz=rate,
                channel=name,
                unit="deg/s",
            ),
        )


def adis_pad():
    path = SHARED / "psas_adis16405" / "Launch-12" / "telemetry_ADIS_decoded.csv"
    table = load_table(path)
    pad = find_pad_window(table)
    for name in ("gyro_x_dps", "gyro_z_dps"):
        data = prepare_channel(table, name, start=pad.start_s, stop=pad.stop_s, gaps="split")
        yield (
            f"ADIS16405 Launch-12 pad ({pad.stop_s - pad.start_s:.0f} s)",
            DiscoveryData(values=data.values, rate_hz=data.rate_hz, channel=name, unit=data.unit),
        )


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
            result = discover(data, baseline=baseline)
            posterior = sample_final(result.final, data, seed=0) if result.findings else None
            print(
                f"\n  {label}, {data.channel}, baseline bias + {' + '.join(baseline)}: "
                f"{data.values.size} samples at {data.rate_hz:.4g} Hz "
                f"({time.perf_counter() - started:.0f} s)"
            )
            failed = [c["name"] for c in result.baseline_checks if not c["passed"]]
            print(f"    baseline checks failed: {', '.join(failed) or 'none'}")
            for finding in result.findings:
                parameters = effect_parameters(finding.name, finding, posterior, data)
                shown = "; ".join(
                    f"{name} {value['mean']:.4g} [{value['q05']:.4g}, {value['q95']:.4g}] "
                    f"{value['unit']}"
                    for name, value in parameters.items()
                    if "q05" in value
                )
                print(f"    + {finding.name}: log BF {finding.log_bayes_factor:.1f}; {shown}")
            still = [c["name"] for c in result.final_checks if not c["passed"]]
            print(f"    final checks failed: {', '.join(still) or 'none'}")
            if posterior is not None and not posterior.diagnostics.passed:
                print(f"    POSTERIOR HEALTH: {'; '.join(posterior.diagnostics.failures)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
