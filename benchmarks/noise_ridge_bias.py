"""The offset of N along its ridge with white angle noise Q, by record length: why short
records with a rising high-frequency floor cover less than their nominal 90 %.

    python benchmarks/noise_ridge_bias.py [--records 30] [--samples 16384,65536]

Each record is drawn from the model itself (``NoiseModel(N, Q).simulate``, 200 Hz,
N = 0.01 deg/s/sqrt(Hz), Q such that white angle noise reaches 0.5-4x the white noise at
Nyquist, as the ``white_angle`` kind of ``noise_high_frequency.py``) and fitted with the true
terms (white + quantization), so a model-simulator mismatch cannot enter. Printed per length:
the mean and sd over records of z = (posterior mean - truth) / posterior sd for N, the mean z of
the MAP with its Laplace sd, the mean ratio of Q's posterior mean to its truth, the
correlation of N's and Q's estimates, the 90 % coverage of N and the seconds the length
took. A calibrated posterior
gives z of mean 0 and sd 1; ``--white`` draws white noise alone (Q = 0) as the contrast.
A mean z that shrinks as 1/sqrt(n) is a finite-sample bias of the likelihood, not a
mismatch.
"""

import argparse
import math
import time

import numpy as np

import bayescal as bc

RATE = 200.0
N_TRUE = 0.01


def one_record(samples: int, seed: int, white: bool) -> dict:
    """Simulate one record (white + Q, or white alone) and fit it with white + quantization:
    N's z-scores (posterior mean, MAP), whether its 90 % interval holds the truth, and the
    estimates of N and Q over their truths."""
    rng = np.random.default_rng(seed)
    ratio = rng.uniform(0.5, 4.0)
    Q = 0.0 if white else N_TRUE * math.sqrt(ratio / (4 * RATE))
    values = bc.NoiseModel(rate_hz=RATE, N=N_TRUE, Q=Q).simulate(samples, seed=seed)
    fit = bc.fit_noise(values, RATE, unit="deg/s", seed=seed, terms="white,quantization")
    white_noise, angle_noise = fit.parameters["N"], fit.parameters["Q"]
    return {
        "z_mean": (white_noise.mean - N_TRUE) / white_noise.sd,
        "z_map": (white_noise.map - N_TRUE) / white_noise.map_sd,
        "covered": white_noise.q05 <= N_TRUE <= white_noise.q95,
        "n_ratio": white_noise.mean / N_TRUE,
        "q_ratio": angle_noise.mean / Q if Q else math.nan,
    }


def main() -> None:
    """Print one line per record length (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=30)
    parser.add_argument("--samples", default="16384,65536")
    parser.add_argument("--white", action="store_true", help="Q = 0: white noise alone")
    args = parser.parse_args()
    print(
        f"N's offset with white angle noise, {args.records} records per length at {RATE:g} Hz, "
        f"fitted with white + quantization{' (simulated white alone)' if args.white else ''}"
    )
    print(
        f"{'samples':>8} {'z (mean)':>9} {'sd z':>6} {'z (MAP)':>8} {'Q/Q_true':>9} "
        f"{'corr N,Q':>9} {'cover 90%':>10} {'s':>5}"
    )
    for samples in (int(size) for size in args.samples.split(",")):
        start = time.perf_counter()
        rows = [one_record(samples, 5000 + i, args.white) for i in range(args.records)]
        z = np.array([row["z_mean"] for row in rows])
        q_ratios = np.array([row["q_ratio"] for row in rows])
        n_ratios = np.array([row["n_ratio"] for row in rows])
        correlation = math.nan if args.white else float(np.corrcoef(n_ratios, q_ratios)[0, 1])
        print(
            f"{samples:>8} {z.mean():>+9.2f} {z.std(ddof=1):>6.2f} "
            f"{np.mean([row['z_map'] for row in rows]):>+8.2f} {np.mean(q_ratios):>9.3f} "
            f"{correlation:>9.2f} {np.mean([row['covered'] for row in rows]):>10.2f} "
            f"{time.perf_counter() - start:>5.0f}",
            flush=True,
        )
    print(f"(the sd of a mean of {args.records} z's is {1 / math.sqrt(args.records):.2f})")


if __name__ == "__main__":
    main()
