"""The fleet population's log-sd of a noise scale against its exact posterior: coverage and
width of the 90 % interval of the units' spread in ln K, over simulated fleets.

Each fleet: 8-40 units (log-uniform), 1-3 runs each, the units' ln K drawn from a normal
population (log-sd uniform on 0.1-0.4, the ranges of ``fleet_coverage.py``); each run's
recording is reduced to an exact Gaussian posterior of ln K, 2,000 draws around a measurement
with an sd drawn from 0.15-0.30 (what the coverage study's 41 s records give), under a fitting
prior wide enough to be flat. The population is then fitted as ``fit_fleet`` fits it
(``fit_population``: points, the runs' kernel product, emcee), and its exact posterior is
integrated on a grid: each unit one Gaussian measurement (its runs combined), the median
flat, the log-sd half-Cauchy with scale 1 as in the model. Printed: how often each interval
holds the truth, with the side of each miss, and the median ratio of their widths (1 when
the pipeline draws the posterior it is given).

    python benchmarks/fleet_logsd_exact.py [--fleets 100] [--seed 3]

The study that cleared the population's arithmetic of the log-sd of K's short coverage in
``fleet_coverage.py`` (docs/methods/validation.md, "Fleets").
"""

import argparse
import math
import time

import numpy as np
from _common import stand_in_recording

from bayescal.inference._population import fit_population

DRAWS = 2000
GRID = np.exp(np.linspace(math.log(1e-3), math.log(3.0), 400))
MEDIAN_K = 0.005  # deg/s*sqrt(Hz)


def grid_interval(measured, sd) -> tuple[float, float]:
    """The exact posterior's 90 % interval of the log-sd: the median integrated analytically
    (flat prior), the log-sd on a grid (each point the middle of its cell)."""
    variance = sd[None, :] ** 2 + GRID[:, None] ** 2
    precision = 1 / variance
    centre = (precision * measured).sum(1) / precision.sum(1)
    log_post = -0.5 * (np.log(variance) + (measured - centre[:, None]) ** 2 / variance).sum(1)
    log_post += -0.5 * np.log(precision.sum(1))
    log_post += np.log(2 / np.pi / (1 + GRID**2)) + np.log(GRID)  # half-Cauchy(1), in log sd
    weight = np.exp(log_post - log_post.max())
    weight /= weight.sum()
    cumulative = np.cumsum(weight) - 0.5 * weight
    low, high = np.exp(np.interp([0.05, 0.95], cumulative, np.log(GRID)))
    return float(low), float(high)


def simulate_fleet(rng):
    """The truth's log-sd, the units' combined measurements and sds, and the recordings."""
    count = round(math.exp(rng.uniform(math.log(8), math.log(40.5))))
    count = min(max(count, 8), 40)
    log_sd = rng.uniform(0.1, 0.4)
    log_k = math.log(MEDIAN_K) + log_sd * rng.standard_normal(count)
    recordings = []
    measured, sd = np.empty(count), np.empty(count)
    for u in range(count):
        bias = 0.3 + 0.05 * rng.standard_normal()
        runs = int(rng.integers(1, 4))
        run_sd = rng.uniform(0.15, 0.30, runs)
        run_measured = log_k[u] + run_sd * rng.standard_normal(runs)
        precision = 1 / run_sd**2
        measured[u] = np.sum(precision * run_measured) / precision.sum()
        sd[u] = 1 / np.sqrt(precision.sum())
        for r in range(runs):
            recordings.append(
                stand_in_recording(
                    u,
                    r,
                    # Drawn in this order (the draws, then the bias): the seed's fleets.
                    log_draws={"K": run_measured[r] + run_sd[r] * rng.standard_normal(DRAWS)},
                    prior={"K": (math.log(MEDIAN_K), 100.0)},
                    bias_mean=np.full(DRAWS, bias + 0.003 * rng.standard_normal()),
                    bias_sd=np.full(DRAWS, 0.003),
                )
            )
    return log_sd, measured, sd, recordings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fleets", type=int, default=100)
    parser.add_argument("--seed", type=int, default=3)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    rows = []
    started = time.perf_counter()
    for index in range(args.fleets):
        truth, measured, sd, recordings = simulate_fleet(rng)
        posterior = fit_population(recordings, ("K",), seed=index)
        low, high = np.quantile(posterior.values["sigma"][:, 0], [0.05, 0.95])
        exact = grid_interval(measured, sd)
        rows.append((truth, low, high, *exact))
        print(
            f"fleet {index:3d}: {measured.size:2d} units, {len(recordings):3d} recordings, "
            f"log-sd {truth:.3f}: bayescal [{low:.3f}, {high:.3f}], grid "
            f"[{exact[0]:.3f}, {exact[1]:.3f}], passed {posterior.passed}",
            flush=True,
        )
    rows = np.array(rows)
    print(f"\n{args.fleets} fleets, {(time.perf_counter() - started) / 60:.0f} min")
    for name, (low, high) in (("bayescal", (1, 2)), ("grid", (3, 4))):
        below, above = rows[:, 0] < rows[:, low], rows[:, 0] > rows[:, high]
        print(
            f"  {name:<8} 90 % interval of the log-sd of K held the truth "
            f"{1 - np.mean(below | above):.1%}: truth below {below.sum()}, above {above.sum()}"
        )
    ratio = (rows[:, 2] - rows[:, 1]) / (rows[:, 4] - rows[:, 3])
    print(f"  width bayescal / grid: median {np.median(ratio):.3f}")


if __name__ == "__main__":
    main()
