"""Statistical efficiency of the noise estimates: RMSE over simulations divided by the
Cramér-Rao bound, for bayescal's point estimate (the MAP) and posterior mean, the IEEE 952
slope reading, and a weighted least-squares fit of the Allan variance computed with
allantools — on the same data.

    python benchmarks/noise_efficiency.py [--simulations 200] [--posterior 50] [--samples 65536]

Targets (issue 3): bayescal <= 1.15x the bound for N and K, <= 1.3x for B, and better than
both classical methods. The record: 10 Hz, white noise, bias instability and a rate random
walk, each dominating a stretch of the Allan curve. The posterior mean (a full emcee run per
record) is computed for the first --posterior records.
"""

import argparse
import time

import numpy as np
from _common import PARAMETERS, allan_wls_fit, cramer_rao_bound

import bayescal as bc
from bayescal.inference._noise_posterior import noise_mode
from bayescal.inference._priors import default_prior
from bayescal.models._noise_problem import NoiseProblem, noise_summaries
from bayescal.models._terms import CLASSICAL_TERMS

RATE = 10.0
TRUTH = {"N": 0.005, "B": 2e-3, "K": 1e-4}


def map_estimate(values: np.ndarray, classical: bc.ClassicalNoise) -> dict:
    """bayescal's point estimate: the MAP of the default model, under the default prior
    (centred on the classical Allan deviation), in the channel's units."""
    problem = NoiseProblem(
        *noise_summaries(values, RATE, CLASSICAL_TERMS),
        default_prior(CLASSICAL_TERMS, classical.allan),
    )
    mode = noise_mode(problem)
    return {name: float(value) for name, value in problem.natural(mode.theta).items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--simulations", type=int, default=200)
    parser.add_argument("--posterior", type=int, default=50)
    parser.add_argument("--samples", type=int, default=2**16)
    args = parser.parse_args()

    model = bc.NoiseModel(rate_hz=RATE, bias=0.4, **TRUTH)
    estimates = {
        method: []
        for method in (
            "bayescal MAP",
            "IEEE 952 slopes",
            "allantools AVAR WLS",
            "bayescal posterior mean",
        )
    }
    unhealthy = 0
    start = time.perf_counter()
    for seed in range(args.simulations):
        values = model.simulate(args.samples, seed=10_000 + seed)
        classical = bc.classical_noise(values, RATE)
        estimate = map_estimate(values, classical)
        estimates["bayescal MAP"].append([estimate[p] for p in PARAMETERS])
        estimates["IEEE 952 slopes"].append([classical.slope_readings[p].value for p in PARAMETERS])
        wls = allan_wls_fit(values, RATE)
        estimates["allantools AVAR WLS"].append([wls[p] for p in PARAMETERS])
        if seed < args.posterior:
            fit = bc.fit_noise(values, RATE, terms=CLASSICAL_TERMS, seed=seed)
            unhealthy += not fit.passed
            estimates["bayescal posterior mean"].append(
                [fit.parameters[p].mean for p in PARAMETERS]
            )
    elapsed = time.perf_counter() - start

    bound = cramer_rao_bound(TRUTH, RATE, args.samples)
    truth = np.array([TRUTH[p] for p in PARAMETERS])
    print(
        f"noise efficiency: {args.simulations} simulations of {args.samples} samples at "
        f"{RATE:g} Hz, truth N={TRUTH['N']} deg/s/sqrt(Hz), B={TRUTH['B']} deg/s, "
        f"K={TRUTH['K']} deg/s*sqrt(Hz); {elapsed:.0f} s; {unhealthy} of {args.posterior} "
        "posteriors failed their health checks"
    )
    print("  Cramer-Rao bound (sd): " + ", ".join(f"{p} {bound[p]:.3g}" for p in PARAMETERS))
    print(
        f"  {'method':<25}{'records':>8}"
        + "".join(f"{'RMSE/CRB ' + p:>13}{'bias/CRB ' + p:>13}" for p in PARAMETERS)
    )
    for method, rows in estimates.items():
        found = np.array(rows)
        rmse = np.sqrt(np.mean((found - truth) ** 2, axis=0))
        bias = np.mean(found, axis=0) - truth
        row = "".join(
            f"{rmse[i] / bound[p]:>13.3f}{bias[i] / bound[p]:>13.3f}"
            for i, p in enumerate(PARAMETERS)
        )
        print(f"  {method:<25}{len(found):>8}{row}")
    print(
        f"  (relative standard error of an RMSE over R records: about 1/sqrt(2R), "
        f"{1 / np.sqrt(2 * args.simulations):.2f} for {args.simulations})"
    )


if __name__ == "__main__":
    main()
