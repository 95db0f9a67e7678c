"""The fleet population's turn-on bias, alone, against its exact posterior: coverage and width of
the 90 % intervals of the bias's mean, unit-to-unit sd and run-to-run sd, over simulated fleets.

Each fleet: 8-40 units (log-uniform), 1-3 runs each, the population drawn from the ranges of
``fleet_coverage.py``; each run's recording is reduced to what the population reads of its
bias, a Gaussian measurement of the run's turn-on bias with an sd drawn from ``--sd`` (0.001-
0.006 deg/s: what the coverage study's 41 s records give). No noise parameter enters, so the
population has three coordinates and its posterior can be integrated on a grid: the mean bias
analytically (flat prior), the two sds on a 150 x 150 grid of their logs, with the same
half-Cauchy priors. Printed, over the fleets: how often bayescal's intervals (emcee, as
``fit_fleet`` samples them) and the grid's hold the truth, and the median ratio of their widths
(1 when the sampler draws the posterior it is given).

    python benchmarks/fleet_bias_exact.py [--fleets 200] [--seed 2] [--sd 0.001,0.006]

This study found emcee's snooker move narrowing every posterior (docs/methods/noise-model.md,
"Fit"): with it, bayescal's interval of the mean bias was 7 % narrower than the grid's.
"""

import argparse
import math
import time

import numpy as np
from fleet_coverage import RUNS, UNITS, clopper_pearson, draw_population
from scipy import stats

from bayescal.inference._population import (
    RecordingDraws,
    bias_prior_scale,
    fleet_data,
    sample_population,
)

DRAWS = 500
GRID = 150


def simulate_fleet(rng, sd_range, seed):
    """A population, and one RecordingDraws per run: its bias measured with a known sd."""
    population = draw_population(rng)
    count = round(math.exp(rng.uniform(math.log(UNITS[0]), math.log(UNITS[1] + 0.5))))
    count = min(max(count, UNITS[0]), UNITS[1])
    per_unit = rng.integers(RUNS[0], RUNS[1] + 1, count)
    recordings = []
    for u, unit in enumerate(population.simulate(per_unit, seed=seed)):
        for r, bias in enumerate(unit["bias"]):
            sd = rng.uniform(*sd_range)
            measured = bias + sd * rng.standard_normal()
            recordings.append(
                RecordingDraws(
                    source=f"unit{u}-run{r}",
                    unit=f"SN{u:02d}",
                    run=str(r + 1),
                    channel="gyro_x",
                    channel_unit="deg/s",
                    rate_hz=100.0,
                    n_samples=4096,
                    terms=("white",),
                    log_draws={},
                    prior_location={},
                    prior_scale={},
                    bias_mean=np.full(DRAWS, measured),
                    bias_sd=np.full(DRAWS, sd),
                )
            )
    return population, recordings


def grid_intervals(recordings, prior_scale) -> dict:
    """The exact posterior's 90 % intervals: the unit and run levels integrated in closed form
    (as ``models/_population.py`` writes them), the mean bias analytically, the sds on a grid."""
    units: dict[str, list] = {}
    for r in recordings:
        units.setdefault(r.unit, []).append((r.bias_mean[0], r.bias_sd[0] ** 2))
    log_sd = np.linspace(math.log(5e-4), math.log(0.5), GRID)
    tau_unit, tau_run = np.meshgrid(np.exp(log_sd), np.exp(log_sd), indexing="ij")
    log_post, precision, weighted = (np.zeros(tau_unit.shape) for _ in range(3))
    for runs in units.values():
        m, v = (np.array(column)[:, None, None] for column in zip(*runs, strict=True))
        s2 = v + tau_run**2
        total = np.sum(1 / s2, 0)
        centre = np.sum(m / s2, 0) / total
        log_post += np.sum(-0.5 * np.log(2 * np.pi * s2) - 0.5 * (m - centre) ** 2 / s2, 0)
        log_post += 0.5 * np.log(2 * np.pi / total)
        spread = 1 / total + tau_unit**2
        precision += 1 / spread
        weighted += centre / spread
        log_post += -0.5 * np.log(2 * np.pi * spread) - 0.5 * centre**2 / spread
    log_post += 0.5 * weighted**2 / precision + 0.5 * np.log(2 * np.pi / precision)

    def half_cauchy_of_log(tau):
        return np.log(2 / np.pi * prior_scale / (prior_scale**2 + tau**2)) + np.log(tau)

    log_post += half_cauchy_of_log(tau_unit)
    if max(len(runs) for runs in units.values()) > 1:
        log_post += half_cauchy_of_log(tau_run)
    weight = np.exp(log_post - log_post.max())
    weight /= weight.sum()
    mean, sd = weighted / precision, np.sqrt(1 / precision)
    centre = float(np.sum(weight * mean))
    axis = np.linspace(centre - 0.3, centre + 0.3, 1201)
    cdf = np.array([np.sum(weight * stats.norm.cdf((x - mean) / sd)) for x in axis])
    found = {"bias_mean": tuple(np.interp([0.05, 0.95], cdf, axis))}
    for name, summed in (("bias_unit_sd", 1), ("bias_run_sd", 0)):
        cumulative = np.cumsum(weight.sum(axis=summed))
        found[name] = tuple(np.exp(np.interp([0.05, 0.95], cumulative, log_sd)))
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fleets", type=int, default=200)
    parser.add_argument("--seed", type=int, default=2)
    parser.add_argument("--sd", default="0.001,0.006", help="range of each run's bias sd, deg/s")
    args = parser.parse_args()
    sd_range = tuple(float(x) for x in args.sd.split(","))
    rng = np.random.default_rng(args.seed)
    keys = {"bias_mean": "mu_bias", "bias_unit_sd": "tau_unit", "bias_run_sd": "tau_run"}
    hits = {name: {"bayescal": [], "grid": []} for name in keys}
    widths = {name: [] for name in keys}
    started = time.perf_counter()
    for index in range(args.fleets):
        population, recordings = simulate_fleet(rng, sd_range, args.seed * 1000 + index)
        exact = grid_intervals(recordings, bias_prior_scale(recordings))
        posterior = sample_population(fleet_data(recordings, (), seed=index), seed=index)
        truth = {
            "bias_mean": population.bias_mean,
            "bias_unit_sd": population.bias_unit_sd,
            "bias_run_sd": population.bias_run_sd,
        }
        line = []
        for name, key in keys.items():
            low, high = np.quantile(posterior.values[key], [0.05, 0.95])
            hits[name]["bayescal"].append(low <= truth[name] <= high)
            hits[name]["grid"].append(exact[name][0] <= truth[name] <= exact[name][1])
            widths[name].append((high - low) / (exact[name][1] - exact[name][0]))
            line.append(f"{name} {'ok' if hits[name]['bayescal'][-1] else 'MISS'}")
        print(f"fleet {index:3d}: {len(recordings):2d} recordings; " + ", ".join(line), flush=True)
    print(f"\n{args.fleets} fleets, {(time.perf_counter() - started) / 60:.0f} min")
    print("90 % intervals holding the truth (exact 95 % binomial interval), width bayescal/grid:")
    for name in keys:
        row = []
        for source in ("bayescal", "grid"):
            held = hits[name][source]
            low, high = clopper_pearson(sum(held), len(held))
            row.append(f"{source} {np.mean(held):6.1%} [{low:.1%}, {high:.1%}]")
        print(f"  {name:<13} " + "  ".join(row) + f"  width {np.median(widths[name]):.3f}")


if __name__ == "__main__":
    main()
