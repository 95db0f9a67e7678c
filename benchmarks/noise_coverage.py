"""Coverage of the 90 % credible intervals of N, B and K over simulated records, and, for
contrast, of the Student-t interval on the turn-on bias of the same records.

    python benchmarks/noise_coverage.py [--simulations 200] [--samples 65536]
    python benchmarks/noise_coverage.py --rate 100 --samples 4096 --truth N=0.004,K=0.005
    python benchmarks/noise_coverage.py --rate 100 --samples 65536 --simulations 100 \
        --truth N=0.005,gm_sigma=0.003,gm_tau=20

The second is the record of ``fleet_coverage.py`` (41 s at 100 Hz, white noise and a rate
random walk, the middle of its ranges); the third a first-order Gauss-Markov bias beside white
noise (11 minutes at 100 Hz, 33 correlation times). The model is the truth's terms (any
registered parameters, :data:`bayescal.models._terms.PARAMETERS`).

Target (issue 3): the 90 % intervals of N and K contain the truth 86-94 % of the time over at
least 200 records. Printed beside each coverage: the sd over the records of the z-score
(ln truth - posterior mean of ln) / posterior sd of ln, which is 1 where the posterior is as wide
as its own error (above 1: too narrow), and the median posterior sd of the log against the
error's sd. The record: 10 Hz, white noise, bias instability and a rate random walk
that dominates the lowest frequencies, the default model. (When a term dominates only a
handful of the lowest frequencies — this same sensor recorded for a quarter of the time —
its interval is informed by a few periodogram ordinates and the prior, and its coverage
drops to about 80 %.)
"""

import argparse
import time

import numpy as np
from scipy import stats

import bayescal as bc
from bayescal.models._terms import TERM_OF_PARAMETER, parameter_unit

UNIT = "deg/s"

RATE = 10.0
TRUTH = {"bias": 0.4, "N": 0.005, "B": 2e-3, "K": 3e-4}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--simulations", type=int, default=200)
    parser.add_argument("--samples", type=int, default=2**16)
    parser.add_argument("--rate", type=float, default=RATE, help="Hz")
    parser.add_argument(
        "--truth",
        default=",".join(f"{k}={v:g}" for k, v in TRUTH.items() if k != "bias"),
        help="noise scales, e.g. N=0.004,K=0.005 (the model fitted is their terms)",
    )
    args = parser.parse_args()
    truth = {"bias": TRUTH["bias"]}
    truth |= {k: float(v) for k, v in (item.split("=") for item in args.truth.split(","))}
    scales = tuple(name for name in truth if name != "bias")
    # The truth's terms (by default CLASSICAL_TERMS).
    terms = tuple(dict.fromkeys(TERM_OF_PARAMETER[name] for name in scales))

    model = bc.NoiseModel(rate_hz=args.rate, **truth)
    names = (*scales, "bias")
    inside = {name: 0 for name in names}
    z_scores = {name: [] for name in scales}
    student, unhealthy = 0, 0
    start = time.perf_counter()
    for seed in range(args.simulations):
        values = model.simulate(args.samples, seed=20_000 + seed)
        fit = bc.fit_noise(values, args.rate, terms=terms, seed=seed)
        unhealthy += not fit.passed
        for name in names:
            summary = fit.parameters[name]
            inside[name] += summary.q05 <= truth[name] <= summary.q95
        for name, found in z_scores.items():
            logs = np.log(np.ravel(fit.draws[name]))
            found.append(((np.log(truth[name]) - logs.mean()) / logs.std(), logs.std()))
        _, low, high = bc.student_t_interval(values, 0.90)
        student += low <= truth["bias"] <= high
    elapsed = time.perf_counter() - start

    count = args.simulations
    band = stats.binom.ppf([0.025, 0.975], count, 0.9) / count
    print(
        f"noise coverage: {count} simulations of {args.samples} samples at {args.rate:g} Hz "
        f"({', '.join(f'{k}={v:g} {parameter_unit(k, UNIT)}' for k, v in truth.items())}); "
        f"{elapsed:.0f} s; {unhealthy} posterior(s) failed their health checks"
    )
    print(
        f"  a calibrated 90 % interval covers [{band[0]:.3f}, {band[1]:.3f}] of records "
        "with 95 % probability"
    )
    for name in names:
        held = inside[name] / count
        line = f"  90 % credible interval of {name:<5} contains the truth {held:.3f}"
        if name in z_scores:
            z, sd = np.array(z_scores[name]).T
            line += (
                f"; z-score sd {z.std():.2f}, posterior sd of ln {name} {np.median(sd):.3f} "
                f"(median) against its error's sd {np.std(z * sd):.3f}"
            )
        print(line)
    print(f"  90 % Student-t interval of the bias contains the turn-on bias {student / count:.3f}")


if __name__ == "__main__":
    main()
