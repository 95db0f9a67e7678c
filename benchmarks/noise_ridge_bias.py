"""The offset of N along its ridge with white angle noise Q, by record length: why short
records with a rising high-frequency floor cover less than their nominal 90 %.

    python benchmarks/noise_ridge_bias.py [--records 30] [--samples 16384,65536]

Each record is drawn from the model itself (``NoiseModel(N, Q).simulate``, 200 Hz,
N = 0.01 deg/s/sqrt(Hz), Q such that white angle noise reaches 0.5-4x the white noise at
Nyquist, as the ``white_angle`` kind of ``noise_high_frequency.py``) and fitted with the true
terms (white + quantization), so a model-simulator mismatch cannot enter. Printed per length:
the mean and sd over records of z = (posterior mean - truth) / posterior sd for N, the same
for the MAP with its Laplace sd, the mean ratio of Q's posterior mean to its truth, the
correlation of N's and Q's estimates, and the 90 % coverage of N. A calibrated posterior
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
    rng = np.random.default_rng(seed)
    ratio = rng.uniform(0.5, 4.0)
    Q = 0.0 if white else N_TRUE * math.sqrt(ratio / (4 * RATE))
    values = bc.NoiseModel(rate_hz=RATE, N=N_TRUE, Q=Q).simulate(samples, seed=seed)
    fit = bc.fit_noise(values, RATE, unit="deg/s", seed=seed, terms="white,quantization")
    n, q = fit.parameters["N"], fit.parameters["Q"]
    return {
        "z_mean": (n.mean - N_TRUE) / n.sd,
        "z_map": (n.map - N_TRUE) / n.map_sd,
        "covered": n.q05 <= N_TRUE <= n.q95,
        "n_ratio": n.mean / N_TRUE,
        "q_ratio": q.mean / Q if Q else math.nan,
    }


def main() -> None:
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
        q = np.array([row["q_ratio"] for row in rows])
        n = np.array([row["n_ratio"] for row in rows])
        correlation = math.nan if args.white else float(np.corrcoef(n, q)[0, 1])
        print(
            f"{samples:>8} {z.mean():>+9.2f} {z.std(ddof=1):>6.2f} "
            f"{np.mean([row['z_map'] for row in rows]):>+8.2f} {np.mean(q):>9.3f} "
            f"{correlation:>9.2f} {np.mean([row['covered'] for row in rows]):>10.2f} "
            f"{time.perf_counter() - start:>5.0f}",
            flush=True,
        )
    print(f"(the sd of a mean of {args.records} z's is {1 / math.sqrt(args.records):.2f})")


if __name__ == "__main__":
    main()
