"""A fleet's noise fits batched over recordings on JAX's default device, against one Dask task
per recording (:func:`bayescal.fit_fleet` ``batch=True`` and ``batch=False``).

For each fleet size L of ``--recordings``: L simulated gyro recordings (one run per unit, white
noise and a rate random walk, each unit's N and K a log-normal 20 % around TRUTH, ``--samples``
each at 100 Hz, NPZ in a temporary folder) are fitted with terms white and rate random walk,
batched in this process on JAX's default device, then (up to ``--per-recording-max``
recordings) as one Dask task per recording on a LocalCluster of ``--workers`` processes, their
JAX on the CPU. Printed, and written to ``--json``: the device, each path's wall time and time
per recording, the recordings that passed, the batches, and the agreement of the posteriors:
per recording the ratio of the batched to the per-recording posterior mean of N and K (median
and extremes over the recordings) and their difference in posterior sds, each path's posterior
mean over the truth (median over the recordings), and the population's median N and K from
each path. Each path is warmed first on a small fleet of the same length (compilation is
reported apart: the first batched fit of a shape traces and compiles).

    python benchmarks/fleet_batched.py [--recordings 8,64,256] [--samples 65536] [--workers 16]
        [--per-recording-max 64] [--quick] [--json figures.json] [--seed 0]

``--quick``: --recordings 16,128 --samples 65536 --per-recording-max 16 (under 3 min on a GPU
machine with 16 cores, compilation included). On CPU keep it short: --recordings 8 --samples
16384 --workers 2.
"""

import argparse
import json
import math
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

import bayescal as bc

RATE_HZ = 100.0
TRUTH = {"N": 0.004, "K": 2e-3}  # deg/s/sqrt(Hz), deg/s*sqrt(Hz)
TERMS = "white,rrw"
UNIT_LOG_SD = 0.2


def write_fleet(folder: Path, recordings: int, samples: int, seed: int, lengths=None):
    """``recordings`` units of one run each (``lengths``: each recording's samples, default
    ``samples``); returns the manifest and each recording's true N and K."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    lines, truths = ["path,unit,run,rate"], []
    for index in range(recordings):
        noise = {p: v * math.exp(UNIT_LOG_SD * rng.standard_normal()) for p, v in TRUTH.items()}
        model = bc.NoiseModel(rate_hz=RATE_HZ, bias=0.3 + 0.05 * rng.standard_normal(), **noise)
        name = f"rec{index:04d}.npz"
        length = samples if lengths is None else lengths[index]
        values = model.simulate(length, seed=seed * 100_000 + index)
        np.savez(folder / name, **{"gyro_x[deg/s]": values})
        lines.append(f"{name},SN{index:04d},1,{RATE_HZ:g}")
        truths.append(noise)
    manifest = folder / "fleet.csv"
    manifest.write_text("\n".join(lines) + "\n")
    return manifest, truths


def posterior_means(fleet) -> dict:
    """row -> {N, K} posterior means and sds (natural units) of each recording that passed."""
    means = {}
    for record in fleet.recordings:
        draws = {p: np.exp(record.log_draws[p]) for p in ("N", "K")}
        means[record.row] = {
            **{p: float(np.mean(v)) for p, v in draws.items()},
            **{f"{p}_sd": float(np.std(v)) for p, v in draws.items()},
        }
    return means


def fit(manifest: Path, seed: int, batch: bool, workers: int) -> tuple:
    started = time.perf_counter()
    options = {"batch": True} if batch else {"batch": False, "workers": workers}
    fleet = bc.fit_fleet(manifest, "gyro_x", terms=TERMS, seed=seed, **options)
    return fleet, time.perf_counter() - started


def population_medians(fleet) -> dict:
    summary = fleet.summary["population"]
    return {p: summary[p]["median"]["mean"] for p in ("N", "K")}


def agreement(batched: dict, single: dict, truths: list) -> dict:
    """The two paths' posteriors of the recordings both passed."""
    rows = sorted(set(batched) & set(single))
    out = {"recordings_compared": len(rows)}
    for p in ("N", "K"):
        ratio = np.array([batched[r][p] / single[r][p] for r in rows])
        shift = np.array([(batched[r][p] - single[r][p]) / single[r][f"{p}_sd"] for r in rows])
        out[p] = {
            "median_ratio": float(np.median(ratio)),
            "min_ratio": float(np.min(ratio)),
            "max_ratio": float(np.max(ratio)),
            "max_abs_shift_in_sd": float(np.max(np.abs(shift))),
            "batched_over_truth": float(
                np.median([batched[r][p] / truths[r - 1][p] for r in rows])
            ),
            "per_recording_over_truth": float(
                np.median([single[r][p] / truths[r - 1][p] for r in rows])
            ),
        }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--recordings", default="8,64,256")
    parser.add_argument("--samples", type=int, default=65536)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--per-recording-max", type=int, default=64)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    if args.quick:
        args.recordings, args.samples, args.per_recording_max = "16,128", 65536, 16
    sizes = [int(size) for size in args.recordings.split(",")]

    import jax

    # The per-recording workers run JAX on the CPU: a worker process per core, each its own
    # JAX, would each claim the GPU's memory.
    os.environ["JAX_PLATFORMS"] = "cpu"
    figures = {
        "device": [str(device) for device in jax.devices()],
        "backend": jax.default_backend(),
        "jax": jax.__version__,
        "cpu_count": os.cpu_count(),
        "machine": platform.processor() or platform.machine(),
        "samples": args.samples,
        "rate_hz": RATE_HZ,
        "terms": TERMS,
        "truth": TRUTH,
        "workers": args.workers,
        "fleets": [],
    }
    print(f"JAX {jax.__version__}, default device {figures['device']}, {os.cpu_count()} CPUs")
    with tempfile.TemporaryDirectory() as folder:
        warm, _ = write_fleet(Path(folder) / "warm", 2, args.samples, args.seed + 1)
        _, batched_warm = fit(warm, args.seed, True, args.workers)
        print(f"warm-up (2 recordings, batched: tracing and compiling): {batched_warm:.1f} s")
        for size in sizes:
            manifest, truths = write_fleet(Path(folder) / f"L{size}", size, args.samples, args.seed)
            batched, batched_s = fit(manifest, args.seed, True, args.workers)
            entry = {
                "recordings": size,
                "batched": {
                    "wall_s": batched_s,
                    "per_recording_s": batched_s / size,
                    "passed": len(batched.recordings),
                    "where": batched.compute["cluster"],
                    "population_median": population_medians(batched),
                },
            }
            print(
                f"L={size}: batched {batched_s:.1f} s ({batched_s / size:.3f} s a recording), "
                f"{len(batched.recordings)}/{size} passed, {batched.compute['cluster']}"
            )
            if size <= args.per_recording_max:
                single, single_s = fit(manifest, args.seed, False, args.workers)
                entry["per_recording"] = {
                    "wall_s": single_s,
                    "per_recording_s": single_s / size,
                    "passed": len(single.recordings),
                    "workers": args.workers,
                    "population_median": population_medians(single),
                }
                entry["agreement"] = agreement(
                    posterior_means(batched), posterior_means(single), truths
                )
                print(
                    f"L={size}: per recording {single_s:.1f} s ({single_s / size:.3f} s a "
                    f"recording, {args.workers} workers, cluster start and each worker's "
                    f"compilation included), {len(single.recordings)}/{size} passed"
                )
                for p in ("N", "K"):
                    a = entry["agreement"][p]
                    print(
                        f"  {p}: batched/per-recording posterior mean, median "
                        f"{a['median_ratio']:.4f} [{a['min_ratio']:.4f}, {a['max_ratio']:.4f}], "
                        f"largest shift {a['max_abs_shift_in_sd']:.2f} posterior sd; over the "
                        f"truth {a['batched_over_truth']:.4f} (batched) "
                        f"{a['per_recording_over_truth']:.4f} (per recording); population "
                        f"median {entry['batched']['population_median'][p]:.4g} vs "
                        f"{entry['per_recording']['population_median'][p]:.4g}"
                    )
            else:
                over = [
                    float(np.mean(v[p])) / truths[r - 1][p]
                    for r, v in posterior_means(batched).items()
                    for p in ("N",)
                ]
                entry["batched"]["N_over_truth_median"] = float(np.median(over))
                print(f"  N: batched posterior mean over the truth, median {np.median(over):.4f}")
            figures["fleets"].append(entry)
    if args.json is not None:
        args.json.write_text(json.dumps(figures, indent=2) + "\n")
        print(f"figures written to {args.json}")


if __name__ == "__main__":
    main()
