"""Real data: the population of the six ADIS16405 runs of SMAC's imudata (6 static runs of
1,000,000 samples at 100 Hz, gyro in deg/s on the part's 0.05 deg/s LSB), read in place from
../shared/data/smac_imudata_adis16405 (its SOURCE.txt: the source does not say whether the
runs are six units or one unit powered up six times).

Both readings are fitted:

- six units, one run each: the spread of ln N, ln B, ln K across units and the bias's
  unit-to-unit sd (which then holds any run-to-run spread too);
- one unit, six runs: the unit's N, B, K and its turn-on bias repeatability (run-to-run sd);
  no spread across units can be estimated.

The bayescal readers take one recording per file and the shared data keep the six runs in one
array file (and in R's .rda), so each run's gyro channel is written as NPZ to a temporary
folder, with the fleet's manifest beside it; nothing is written into the repository.

    python benchmarks/fleet_adis16405.py [--channel gyro_x] [--samples 1000000]
        [--terms white,output_filter,bias_instability,rate_random_walk] [--workers 2]

The data are licensed CC BY-NC-SA 4.0.
"""

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

import bayescal as bc

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "smac_imudata_adis16405"
COLUMNS = ("gyro_x", "gyro_y", "gyro_z")
RUNS = 6


def write_runs(folder: Path, channel: str, samples: int, layout: str) -> Path:
    counts = np.load(SHARED / "adis_16405_imu1-6_counts.npz")
    lsb, rate = float(counts["gyro_lsb_dps"]), float(counts["fs_hz"])
    column = COLUMNS.index(channel)
    lines = ["path,unit,run,rate"]
    for run in range(1, RUNS + 1):
        name = f"imu{run}.npz"
        if not (folder / name).exists():
            values = counts[f"imu{run}_counts"][:samples, column].astype(float) * lsb
            np.savez(folder / name, **{f"{channel}[deg/s]": values})
        unit, index = ("imu1", run) if layout == "one" else (f"imu{run}", 1)
        lines.append(f"{name},{unit},{index},{rate:g}")
    manifest = folder / f"fleet_{layout}.csv"
    manifest.write_text("\n".join(lines) + "\n")
    return manifest


def show(label: str, fleet) -> None:
    from bayescal.report._fleet import fleet_text

    print(f"\n=== {label} ===")
    print(fleet_text(fleet))
    for failure in fleet.failed:
        print(f"  left out: {failure.source} ({failure.kind}): {failure.message}")
    print(f"  population checks: {'passed' if fleet.passed else fleet.failures}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--channel", default="gyro_x", choices=COLUMNS)
    parser.add_argument("--samples", type=int, default=1_000_000)
    parser.add_argument("--terms", default="white,output_filter,bias_instability,rate_random_walk")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    from distributed import Client, LocalCluster

    with (
        tempfile.TemporaryDirectory(prefix="bayescal-fleet-adis-") as folder,
        LocalCluster(
            n_workers=args.workers, threads_per_worker=1, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        for layout, label in (("six", "six units, one run each"), ("one", "one unit, six runs")):
            manifest = write_runs(Path(folder), args.channel, args.samples, layout)
            started = time.perf_counter()
            fleet = bc.fit_fleet(
                manifest, args.channel, terms=args.terms, seed=args.seed, scheduler=client
            )
            show(
                f"ADIS16405 {args.channel}, {args.samples} samples per run, terms {args.terms}: "
                f"{label} ({time.perf_counter() - started:.0f} s)",
                fleet,
            )


if __name__ == "__main__":
    main()
