"""Throughput of ``fit_fleet`` on this machine with 1 and 2 worker processes, and the arithmetic
of a production fleet (1,000 units on 50 nodes) from the measured per-task time and transfer
sizes.

A fleet of ``--recordings`` simulated gyro recordings (white noise, bias instability and rate
random walk, ``--minutes`` each at 100 Hz, NPZ in a temporary folder) is fitted with the fleet's
default terms on a ``LocalCluster`` of 1, then 2 single-threaded worker processes. Each cluster
is warmed first (one small fleet: JAX compiles once per worker process, a cost a long-lived
cluster pays once), then timed. Printed per cluster: wall time of the recordings' tasks,
recordings per minute, the mean and largest task time, the bytes each task ships back to the
client (the population's draws), the bytes each worker reads (the recording), and the
population's own time on the client.

    python benchmarks/fleet_throughput.py [--recordings 16] [--minutes 30] [--seed 0]

The scale-up is arithmetic on these numbers, not a measurement of a cluster.
"""

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

import bayescal as bc

RATE_HZ = 100.0
TRUTH = {"N": 0.004, "B": 0.002, "K": 2e-4}  # deg/s/sqrt(Hz), deg/s, deg/s*sqrt(Hz)


def write_fleet(folder: Path, recordings: int, samples: int, seed: int) -> tuple[Path, int]:
    """``recordings`` runs of units SN00, SN01 ... (two runs each); the manifest and the
    bytes of one recording."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    lines = ["path,unit,run,rate"]
    for index in range(recordings):
        if index % 2 == 0:  # a new unit: its own noise, the same in both of its runs
            noise = {p: v * math.exp(0.2 * rng.standard_normal()) for p, v in TRUTH.items()}
        model = bc.NoiseModel(rate_hz=RATE_HZ, bias=0.3 + 0.05 * rng.standard_normal(), **noise)
        name = f"rec{index:03d}.npz"
        values = model.simulate(samples, seed=seed * 1000 + index)
        np.savez(folder / name, **{"gyro_x[deg/s]": values})
        lines.append(f"{name},SN{index // 2:02d},{index % 2 + 1},{RATE_HZ:g}")
    manifest = folder / "fleet.csv"
    manifest.write_text("\n".join(lines) + "\n")
    return manifest, (folder / "rec000.npz").stat().st_size


def measure(workers: int, manifest: Path, warm: Path, seed: int) -> dict:
    from distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        started = time.perf_counter()
        bc.fit_fleet(warm, "gyro_x", seed=seed, scheduler=client)
        warmup = time.perf_counter() - started
        started = time.perf_counter()
        fleet = bc.fit_fleet(manifest, "gyro_x", seed=seed, scheduler=client)
        total = time.perf_counter() - started
    compute = fleet.compute
    return {
        "workers": workers,
        "warmup_s": warmup,
        "tasks_s": compute["wall_s"],
        "population_s": total - compute["wall_s"],
        "tasks": compute["tasks"],
        "per_minute": compute["tasks"] / compute["wall_s"] * 60,
        "task_mean_s": compute["task_s"]["mean"],
        "task_max_s": compute["task_s"]["max"],
        "result_bytes": compute["result_bytes"]["mean"],
        "failed": len(fleet.failed),
        "passed": fleet.passed,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recordings", type=int, default=16)
    parser.add_argument("--minutes", type=float, default=30.0)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    samples = int(args.minutes * 60 * RATE_HZ)
    with tempfile.TemporaryDirectory(prefix="bayescal-fleet-throughput-") as folder:
        manifest, input_bytes = write_fleet(Path(folder) / "fleet", args.recordings, samples, 1)
        warm, _ = write_fleet(Path(folder) / "warm", 4, 2**12, 2)
        print(
            f"{args.recordings} recordings of {args.minutes:g} min at {RATE_HZ:g} Hz "
            f"({samples} samples, {input_bytes / 1e6:.2f} MB each as NPZ), terms "
            "white,bias_instability,rate_random_walk"
        )
        rows = [measure(workers, manifest, warm, args.seed) for workers in (1, 2)]
    for row in rows:
        print(
            f"  {row['workers']} worker(s): {row['per_minute']:.1f} recordings/min "
            f"(tasks {row['tasks_s']:.1f} s for {row['tasks']}; task mean "
            f"{row['task_mean_s']:.1f} s, max {row['task_max_s']:.1f} s; "
            f"{row['result_bytes'] / 1e3:.0f} kB back per task; "
            f"population on the client {row['population_s']:.1f} s; warm-up "
            f"{row['warmup_s']:.1f} s; {row['failed']} left out, population passed "
            f"{row['passed']})"
        )
    one, two = rows
    print(f"  speed-up 1 -> 2 workers: {two['per_minute'] / one['per_minute']:.2f}x")
    # A task's own time is read with one worker: two on this shared 2-core machine contend
    # with each other (and with whatever else runs), which a node's cores would not.
    task, result = one["task_mean_s"], one["result_bytes"]
    units, runs, nodes, cores = 1000, 3, 50, 16
    tasks = units * runs
    print(
        f"\n{units} units x {runs} runs = {tasks} tasks on {nodes} nodes x {cores} cores "
        f"({nodes * cores} single-threaded workers), at the measured {task:.1f} s per task of "
        f"{args.minutes:g} min:"
    )
    waves = math.ceil(tasks / (nodes * cores))
    print(
        f"  compute: {tasks} x {task:.1f} s / {nodes * cores} workers = "
        f"{tasks * task / (nodes * cores) / 60:.1f} min ({waves} waves), plus one warm-up "
        f"({one['warmup_s']:.0f} s) per worker"
    )
    print(
        f"  back to the client: {tasks} x {result / 1e3:.0f} kB = {tasks * result / 1e6:.0f} MB; "
        f"read by the workers: {tasks} x {input_bytes / 1e6:.2f} MB = "
        f"{tasks * input_bytes / 1e9:.1f} GB (from a shared file system)"
    )
    print(
        "  the population (on the client) grows with the units, not the samples: measured "
        f"{one['population_s']:.1f} s for {args.recordings // 2} units here"
    )


if __name__ == "__main__":
    main()
