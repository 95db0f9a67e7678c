"""Coverage of the fleet population's 90 % intervals, and the error of the shrunk per-unit
estimates against the units' own fits, over simulated fleets with a known population.

Each fleet: 8-40 units (log-uniform), 1-3 runs per unit (uniform), the units' N and K drawn
from a log-normal population and their turn-on biases from the two-level normal population
(unit mean, then run), every recording simulated with bayescal's own simulator
(``NoiseModel(...).simulate``, 2^12 samples at 100 Hz, 41 s) and written as NPZ to a temporary
folder with its manifest, then ``bc.fit_fleet`` (white noise + rate random walk per
recording) on one local Dask cluster shared by all fleets. The population's parameters differ
from fleet to fleet (drawn from the ranges below), so the coverage is not that of one point.

Printed per fleet: each interval's hit or miss, with the side of a miss (``MISS below``: the
truth below the interval). Printed at the end: for each population parameter (median and
log-sd of N and K; the bias's mean, unit-to-unit and run-to-run sd), how often its 90 %
interval holds the truth, with an exact 95 % binomial interval, and all of them pooled (the
target: 86-94 %); the root-mean-square error of each unit's estimate (ln N, ln K, mean
turn-on bias) shrunk toward the population, over that of its own fit (its runs alone),
pooled over units and fleets; for ln N and ln K beside it the same ratio for the plain mean of
the unit's shrunk draws, which picks one of its points per population draw and so carries
that picking's Monte Carlo noise (``PopulationPosterior.unit_log_means`` averages it out).

    python benchmarks/fleet_coverage.py [--fleets 100] [--workers 2] [--seed 0] [--units 8,40]

B is left out: records short enough for a study of thousands of fits do not resolve it; the
population treats it as it treats N and K.
"""

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

import bayescal as bc

RATE_HZ = 100.0
SAMPLES = 2**12
TERMS = "white,rate_random_walk"
RANGES = {
    "median_N": (0.002, 0.006),  # deg/s/sqrt(Hz), log-uniform
    "median_K": (0.003, 0.008),  # deg/s*sqrt(Hz), log-uniform (resolved by 41 s records)
    "log_sd": (0.1, 0.4),  # of N and of K, uniform
    "bias_mean": (-0.5, 0.5),  # deg/s, uniform
    "unit_sd": (0.02, 0.1),  # deg/s, uniform
    "run_sd": (0.005, 0.05),  # deg/s, uniform
}
UNITS = (8, 40)
RUNS = (1, 3)


def draw_population(rng) -> bc.FleetPopulation:
    def log_uniform(low, high):
        return float(math.exp(rng.uniform(math.log(low), math.log(high))))

    return bc.FleetPopulation(
        median={"N": log_uniform(*RANGES["median_N"]), "K": log_uniform(*RANGES["median_K"])},
        log_sd={"N": rng.uniform(*RANGES["log_sd"]), "K": rng.uniform(*RANGES["log_sd"])},
        bias_mean=rng.uniform(*RANGES["bias_mean"]),
        bias_unit_sd=rng.uniform(*RANGES["unit_sd"]),
        bias_run_sd=rng.uniform(*RANGES["run_sd"]),
    )


def write_fleet(folder: Path, population, runs, seed: int, samples: int = SAMPLES):
    """Simulate a fleet's recordings (NPZ, ``gyro_x`` in deg/s, no time column) and write
    its manifest; returns the manifest's path and the units' true parameters."""
    folder.mkdir(parents=True, exist_ok=True)
    units = population.simulate(runs, seed=seed)
    lines = ["path,unit,run,rate"]
    for u, unit in enumerate(units):
        for r, bias in enumerate(unit["bias"]):
            noise = {p: unit[p] for p in population.median}
            model = bc.NoiseModel(rate_hz=RATE_HZ, bias=float(bias), **noise)
            name = f"unit{u:02d}_run{r + 1}.npz"
            values = model.simulate(samples, seed=int(seed * 10_000 + 10 * u + r))
            np.savez(folder / name, **{"gyro_x[deg/s]": values})
            lines.append(f"{name},SN{u:02d},{r + 1},{RATE_HZ:g}")
    manifest = folder / "fleet.csv"
    manifest.write_text("\n".join(lines) + "\n")
    return manifest, units


def truths(population) -> dict:
    return {
        "median_N": population.median["N"],
        "log_sd_N": population.log_sd["N"],
        "median_K": population.median["K"],
        "log_sd_K": population.log_sd["K"],
        "bias_mean": population.bias_mean,
        "bias_unit_sd": population.bias_unit_sd,
        "bias_run_sd": population.bias_run_sd,
    }


def intervals(fleet) -> dict:
    """The 90 % intervals of the population's parameters, as in the JSON document."""
    population = fleet.summary["population"]
    found = {}
    for p in ("N", "K"):
        if p in population:
            found[f"median_{p}"] = population[p]["median"]
            found[f"log_sd_{p}"] = population[p]["log_sd"]
    bias = population["bias"]
    found["bias_mean"] = bias["mean"]
    found["bias_unit_sd"] = bias["unit_to_unit_sd"]
    found["bias_run_sd"] = bias["run_to_run_sd"]
    return {name: (entry["q05"], entry["q95"]) for name, entry in found.items()}


def unit_errors(fleet, units) -> dict:
    """Squared errors of each unit's estimates: shrunk (for ln N and ln K the posterior mean of
    the log, Rao-Blackwellised: ``unit_log_means``), shrunk as the mean of the unit's shrunk
    draws (one point picked per population draw), and its own fit's; for the mean turn-on
    bias the first two are both the mean of its shrunk draws."""
    posterior = fleet.population
    errors = {}
    for u, name in enumerate(posterior.units):
        truth = units[int(name.removeprefix("SN"))]
        own = posterior.own[u]
        for p in fleet.parameters:
            log_truth = math.log(truth[p])
            errors.setdefault(p, []).append(
                (
                    (posterior.unit_log_means[name][p] - log_truth) ** 2,
                    (float(np.mean(posterior.unit_draws[name][p])) - log_truth) ** 2,
                    (own[p]["log_mean"] - log_truth) ** 2,
                )
            )
        shrunk = (float(np.mean(posterior.unit_draws[name]["bias"])) - truth["unit_bias"]) ** 2
        errors.setdefault("bias", []).append(
            (shrunk, shrunk, (own["bias"]["mean"] - truth["unit_bias"]) ** 2)
        )
    return errors


def fleet_study(
    fleets: int, seed: int, client, *, units=UNITS, runs=RUNS, samples=SAMPLES, log=print
):
    """Fit ``fleets`` simulated fleets; returns per-parameter hits, unit errors, and checks."""
    rng = np.random.default_rng(seed)
    hits, errors, failures = {}, {}, []
    with tempfile.TemporaryDirectory(prefix="bayescal-fleet-coverage-") as folder:
        for index in range(fleets):
            population = draw_population(rng)
            count = round(math.exp(rng.uniform(math.log(units[0]), math.log(units[1] + 0.5))))
            count = min(max(count, units[0]), units[1])
            per_unit = rng.integers(runs[0], runs[1] + 1, count)
            manifest, truth_units = write_fleet(
                Path(folder) / f"fleet{index:03d}",
                population,
                per_unit,
                seed * 1000 + index,
                samples,
            )
            started = time.perf_counter()
            fleet = bc.fit_fleet(
                manifest, "gyro_x", terms=TERMS, seed=seed * 1000 + index, scheduler=client
            )
            left_out = [f"{Path(f.source).name} ({f.kind}): {f.message}" for f in fleet.failed]
            if not fleet.passed or fleet.failed:
                failures.append((index, fleet.failures, left_out))
            found = intervals(fleet)
            truth = truths(population)
            line = []
            for name, (low, high) in found.items():
                if low is None:
                    continue
                hit = low <= truth[name] <= high
                hits.setdefault(name, []).append(hit)
                # A miss says on which side the truth lay: "below" (the interval too high).
                side = "ok" if hit else ("MISS below" if truth[name] < low else "MISS above")
                line.append(f"{name} {side}")
            squared = unit_errors(fleet, truth_units)
            for name, triples in squared.items():
                errors.setdefault(name, []).extend(triples)
            # Sums of squared errors (shrunk / own / shrunk draws' mean), so that a study cut
            # short can be pooled.
            for name, triples in squared.items():
                shrunk, drawn, own = np.sum(triples, axis=0)
                line.append(f"SSE {name} {shrunk:.4g}/{own:.4g}/{drawn:.4g}")
            log(
                f"fleet {index:3d}: {count:2d} units, {per_unit.sum():3d} recordings, "
                f"{time.perf_counter() - started:5.0f} s, passed {fleet.passed}, "
                f"{len(fleet.failed)} left out; " + ", ".join(line)
            )
            for reason in (*fleet.failures, *left_out):
                log(f"    {reason}")
    return hits, errors, failures


def clopper_pearson(hits: int, total: int, level: float = 0.95) -> tuple[float, float]:
    from scipy import stats

    alpha = 1 - level
    low = stats.beta.ppf(alpha / 2, hits, total - hits + 1) if hits else 0.0
    high = stats.beta.ppf(1 - alpha / 2, hits + 1, total - hits) if hits < total else 1.0
    return float(low), float(high)


def report(hits, errors, failures, log=print) -> None:
    log("\ncoverage of the 90 % intervals (exact 95 % binomial interval):")
    pooled = []
    for name, values in hits.items():
        low, high = clopper_pearson(sum(values), len(values))
        log(f"  {name:<14} {np.mean(values):6.1%} of {len(values):4d}  [{low:.1%}, {high:.1%}]")
        pooled += values
    low, high = clopper_pearson(sum(pooled), len(pooled))
    verdict = "within" if 0.86 <= np.mean(pooled) <= 0.94 else "OUTSIDE"
    log(
        f"  {'all':<14} {np.mean(pooled):6.1%} of {len(pooled):4d}  [{low:.1%}, {high:.1%}]"
        f"  ({verdict} the 86-94 % target)"
    )
    log("\nper-unit error, shrunk toward the population / the unit's own fit (RMS ratio):")
    for name, squared in errors.items():
        shrunk, drawn, own = np.sqrt(np.mean(squared, axis=0))
        what = "mean turn-on bias, deg/s" if name == "bias" else f"ln {name}"
        log(
            f"  {name:<5} {shrunk / own:.3f}  (RMS {shrunk:.4g} vs {own:.4g}, {what}, "
            f"{len(squared)} units; the shrunk draws' mean {drawn / own:.3f})"
        )
    log(f"\nfleets whose population failed its checks or left recordings out: {len(failures)}")
    for index, population_failures, left_out in failures:
        log(f"  fleet {index}: {'; '.join(population_failures)} {'; '.join(left_out)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fleets", type=int, default=100)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--units",
        default=f"{UNITS[0]},{UNITS[1]}",
        help="fewest and most units of a fleet (default 8,40: the issue's range)",
    )
    args = parser.parse_args()
    units = tuple(int(n) for n in args.units.split(","))
    from distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=args.workers, threads_per_worker=1, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        started = time.perf_counter()
        hits, errors, failures = fleet_study(args.fleets, args.seed, client, units=units)
    report(hits, errors, failures)
    print(f"\n{args.fleets} fleets in {(time.perf_counter() - started) / 60:.0f} min")


if __name__ == "__main__":
    main()
