"""Time from an array of 2^23 samples (about 23 h at 100 Hz) to a converged posterior of the
default four-term model (bias, white noise, bias instability, rate random walk), beside the
time of allantools.oadev plus a weighted least-squares curve fit on the same data.

    python benchmarks/noise_speed.py [--samples 8388608]

Target (issue 3): at most 15 s on 2 CPU cores. bayescal's time includes the classical Allan
deviation with its intervals (it centres the priors), the spectral summary, the MAP with its
Laplace covariance, the emcee run to the autocorrelation criterion, the bias draws and the
pointwise log-likelihood. The first run compiles the JAX functions (bayescal's command line
keeps them in ~/.cache/bayescal/jax, so only the first run on a machine pays); the second is
what every later run costs.
"""

import argparse
import os
import time

from _common import allan_wls_fit

import bayescal as bc

RATE = 100.0
TRUTH = {"N": 0.005, "B": 5e-4, "K": 5e-6}


def posterior(values):
    start = time.perf_counter()
    fit = bc.fit_noise(values, RATE, seed=0)
    return time.perf_counter() - start, fit


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=2**23)
    args = parser.parse_args()
    values = bc.NoiseModel(rate_hz=RATE, bias=0.3, **TRUTH).simulate(args.samples, seed=1)

    first, _ = posterior(values)
    second, fit = posterior(values)
    start = time.perf_counter()
    wls = allan_wls_fit(values, RATE)
    peer = time.perf_counter() - start

    diagnostics = fit.diagnostics
    print(
        f"noise posterior of {args.samples} samples at {RATE:g} Hz "
        f"({args.samples / RATE / 3600:.1f} h), {os.cpu_count()} CPU core(s)"
    )
    print(
        f"  bayescal, array to converged posterior: {first:.1f} s first run (compiling), "
        f"{second:.1f} s after"
    )
    print(
        f"    {diagnostics.n_steps} steps x {diagnostics.n_walkers} walkers, autocorrelation "
        f"time <= {max(diagnostics.autocorr_time.values()):.0f}, health checks "
        f"{'passed' if diagnostics.passed else 'FAILED: ' + '; '.join(diagnostics.failures)}"
    )
    print(f"  allantools.oadev + WLS curve fit:        {peer:.1f} s")
    print("  estimates (truth | bayescal mean [90%] | allantools WLS):")
    for name in ("N", "B", "K"):
        summary = fit.parameters[name]
        print(
            f"    {name}: {TRUTH[name]:.4g} | {summary.mean:.4g} [{summary.q05:.3g}, "
            f"{summary.q95:.3g}] | {wls[name]:.4g}"
        )


if __name__ == "__main__":
    main()
