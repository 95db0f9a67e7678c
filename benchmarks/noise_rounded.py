"""Rounded channels: does the default ``noise`` converge on a channel with 5 to 30 distinct
levels, as a module's accelerometers on a 0.001 g grid give them?

    python benchmarks/noise_rounded.py [--samples 65536] [--seeds 2]

Each record: 100 Hz, rounded to an LSB of 0.001 g, white noise whose sample sd puts the
record on the number of levels asked (5, 8, 12, 20 or 30: sd = levels x LSB / 7), a flicker
(B = 0.3 N) or a rate random walk, the output filter in one of three shapes (one-tap F = 0.3;
a fourth-order Butterworth at 20 Hz read at 100 Hz; a biquad), with or without three lines of
0.3 to 2 sample sd (the issue's failures were on channels with lines). Fitted with
``terms="auto"``, seed 0. Prints the levels, the terms chosen, N over its truth and whether
its 90 % interval holds it, the sampler's verdict (restarts, refused terms) and the fit's.
"""

import argparse
import math
import sys
import time

import numpy as np

RATE = 100.0
LSB = 0.001
FILTERS = {
    "one_tap": {"F": 0.3},
    "butterworth": {"filter_cutoff": 20.0, "filter_order": 4.0, "filter_warping": 0.5},
    "biquad": {
        "filter_pole_k1": 0.6,
        "filter_pole_k2": 0.3,
        "filter_zero_k1": 0.9,
        "filter_zero_k2": 0.5,
    },
}


def record(levels: int, shape: str, lines: bool, seed: int, samples: int):
    """The record and its N (module docstring)."""
    import bayescal as bc

    rng = np.random.default_rng(1000 * levels + 10 * seed + lines)
    sd = levels * LSB / 7.0
    n = sd / math.sqrt(RATE)
    slow = {"B": 0.3 * n} if seed % 2 == 0 else {"K": 0.02 * n}
    extra = {}
    if lines:
        extra = {
            "line_frequency": tuple(rng.uniform(1.0, 45.0, 3)),
            "line_amplitude": tuple(sd * rng.uniform(0.3, 2.0, 3)),
        }
    model = bc.NoiseModel(RATE, 0.0123, lsb=LSB, N=n, **slow, **FILTERS[shape], **extra)
    # Each record its own noise: a seed shared across levels and shapes would repeat one
    # realisation (scaled) in every record, and their N errors with it.
    return model.simulate(samples, seed=int(rng.integers(2**31))), n


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=2**16)
    parser.add_argument("--seeds", type=int, default=2)
    args = parser.parse_args()

    import bayescal as bc

    failures = misfits = held = total = 0
    for levels in (5, 8, 12, 20, 30):
        for shape in FILTERS:
            for lines in (False, True):
                for seed in range(args.seeds):
                    values, n = record(levels, shape, lines, seed, args.samples)
                    started = time.perf_counter()
                    fit = bc.fit_noise(values, RATE, unit="g", seed=0)
                    elapsed = time.perf_counter() - started
                    d = fit.diagnostics
                    refused = [r["term"] for r in fit.selection.table if "refused" in r["reason"]]
                    summary = fit.summary["N"]
                    inside = summary["q05"] <= n <= summary["q95"]
                    total += 1
                    held += inside
                    failures += not d.passed
                    misfits += not fit.fits
                    terms = ", ".join(t for t in fit.terms if t != "white")
                    sampler = "passed" if d.passed else "FAILED: " + "; ".join(d.failures)
                    print(
                        f"{levels:2d} levels ({np.unique(values).size} seen), {shape:<11} "
                        f"{'lines' if lines else 'clean'} seed {seed}: {terms}; N/truth "
                        f"{summary['mean'] / n:.3f} ({'in' if inside else 'OUT of'} 90 %); "
                        f"sampler {sampler} ({d.n_steps} steps, acceptance "
                        f"{d.acceptance_fraction:.2f}, restarts {d.restarts}"
                        f"{', refused ' + ', '.join(refused) if refused else ''}); "
                        f"{'fits' if fit.fits else 'MISFIT: ' + '; '.join(fit.misfits)} "
                        f"({elapsed:.0f} s)"
                    )
                    sys.stdout.flush()
    print(
        f"\n{total} records: sampler failures {failures}, misfits {misfits}, N's 90 % "
        f"interval held the truth in {held}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
