"""Two-position calibration under correlated noise: how often the classical 90 % intervals
(Student-t means, RMS span) and the Bayesian 90 % intervals contain the true scale factor and
offset, over simulated sessions of one accelerometer axis.

    python benchmarks/two_position_coverage.py [--simulations 100]

Each session: 60 s up, a 10 s turn-over, 60 s down, at 100 Hz, in m/s^2; white noise
(velocity random walk 0.0004 m/s^2/sqrt(Hz)) and a rate random walk of the bias
(K = 2e-4 m/s^2*sqrt(Hz)) that runs through both sections; gravity known to 1e-5 m/s^2.
"""

import argparse
import time

import jax
import numpy as np

from bayescal._gravity import local_gravity
from bayescal._noise_model import NoiseModel
from bayescal._two_position import Section, bayesian_two_position, classical_two_position

RATE, SECTION, GAP = 100.0, 6000, 1000
G, SCALE, OFFSET = 9.80123, 1.002, 0.05


def session(seed):
    """The whole session as one continuous noise record, so the random walk links the
    sections; the turn-over in between is dropped."""
    noise = np.asarray(
        NoiseModel(rate_hz=RATE, N=4e-4, K=2e-4).simulate(
            jax.random.PRNGKey(30_000 + seed), 2 * SECTION + GAP
        )
    )
    up = OFFSET + G / SCALE + noise[:SECTION]
    down = OFFSET - G / SCALE + noise[SECTION + GAP :]
    return up, down


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--simulations", type=int, default=100)
    args = parser.parse_args()
    gravity = local_gravity(given=f"{G}±0.00001")
    truth = {"scale": SCALE, "offset": OFFSET}
    inside = {(method, name): 0 for method in ("classical", "Bayesian") for name in truth}
    unhealthy = 0
    start = time.perf_counter()
    for seed in range(args.simulations):
        up, down = session(seed)
        classical = classical_two_position(up, down, gravity, 0.90)
        fit = bayesian_two_position(
            Section(up, 0.0, "up"),
            Section(down, (SECTION + GAP) / RATE, "down"),
            RATE,
            gravity,
            terms=("white", "rate_random_walk"),
            gap_s=(SECTION + GAP) / RATE,
            seed=seed,
        )
        unhealthy += not fit.noise.diagnostics.passed
        for name, value in truth.items():
            estimate, half = classical[name]
            inside["classical", name] += abs(estimate - value) <= half
            low, high = np.quantile(fit.draws[name], [0.05, 0.95])
            inside["Bayesian", name] += low <= value <= high
    elapsed = time.perf_counter() - start
    print(
        f"two-position coverage: {args.simulations} simulated sessions, white noise and a "
        f"rate random walk; {elapsed:.0f} s; {unhealthy} posterior(s) failed their checks"
    )
    for (method, name), count in inside.items():
        print(
            f"  {method:<10} 90 % interval of {name:<7} contains the truth "
            f"{count / args.simulations:.3f}"
        )


if __name__ == "__main__":
    main()
