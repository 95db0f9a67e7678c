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

import numpy as np

import bayescal as bc

RATE, SECTION, GAP = 100.0, 6000, 1000
G, SCALE, OFFSET = 9.80123, 1.002, 0.05


def session(seed):
    """The whole session as one continuous noise record, so the random walk links the
    sections; the turn-over in between is dropped."""
    noise = bc.NoiseModel(rate_hz=RATE, N=4e-4, K=2e-4).simulate(
        2 * SECTION + GAP, seed=30_000 + seed
    )
    up = OFFSET + G / SCALE + noise[:SECTION]
    down = OFFSET - G / SCALE + noise[SECTION + GAP :]
    return up, down


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--simulations", type=int, default=100)
    args = parser.parse_args()
    gravity = bc.LocalGravity.measured(G, 0.00001)
    truth = {"scale": SCALE, "offset": OFFSET}
    inside = {(method, name): 0 for method in ("classical", "Bayesian") for name in truth}
    unhealthy = 0
    start = time.perf_counter()
    for seed in range(args.simulations):
        up, down = session(seed)
        calibration = bc.calibrate_two_position(
            bc.Section(up, 0.0, "up"),
            bc.Section(down, (SECTION + GAP) / RATE, "down"),
            RATE,
            gravity=gravity,
            gap_s=(SECTION + GAP) / RATE,
            terms=("white", "rate_random_walk"),
            confidence=0.90,
            seed=seed,
        )
        fit = calibration.bayesian
        unhealthy += not calibration.passed
        for name, value in truth.items():
            estimate, half = calibration.classical[name]
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
