"""Overlapping Allan deviation of 10^7 samples at 60 log-spaced taus: bayescal against
allantools.oadev on the same data, in the same run.

Prints both times, their ratio, the largest relative difference of the deviations, and the
peak memory of bayescal's computation in copies of the input. Targets (issue 2): at least 5x
faster than allantools, equal to 1e-9 relative, at most 4 copies of the input at peak.

    python benchmarks/allan_speed.py [--samples N] [--taus 60] [--repeat 3]

bayescal is timed twice: the deviations alone (noise type given, as allantools computes no
interval), and with its confidence intervals (noise identification and Greenhall EDF at every
tau). Both are warm (numba's compiled kernels are cached on disk after the first run).
"""

import argparse
import multiprocessing
import os
import time

import numpy as np


def _make_input(samples: int) -> np.ndarray:
    rng = np.random.default_rng(20261122)
    white = 0.035 * rng.standard_normal(samples)
    walk = 4e-5 * np.sqrt(0.01) * np.cumsum(rng.standard_normal(samples))
    return 0.4 + white + walk


def _taus(samples: int, count: int, rate: float) -> np.ndarray:
    """``count`` distinct averaging factors, log-spaced from 1 to a quarter of the record."""
    top = samples // 4
    candidates = count
    while True:
        factors = np.unique(np.round(np.geomspace(1, top, candidates)).astype(int))
        if factors.size >= count:
            break
        candidates += 1
    return factors[np.round(np.linspace(0, factors.size - 1, count)).astype(int)] / rate


def _status_kib(field: str) -> int:
    with open("/proc/self/status") as handle:
        for line in handle:
            if line.startswith(field):
                return int(line.split()[1])
    raise RuntimeError(field)


def _peak_copies(samples: int, count: int, rate: float, queue) -> None:
    """In a fresh process: peak resident memory of one bayescal call, in input copies."""
    import bayescal as bc

    y = _make_input(samples)
    taus = _taus(samples, count, rate)
    bc.allan_deviation(y[:4096], rate, taus[taus < 4096 / 4 / rate])  # load the kernels
    with open("/proc/self/clear_refs", "w") as handle:
        handle.write("5")  # reset the peak resident set (Linux)
    baseline = _status_kib("VmRSS")
    bc.allan_deviation(y, rate, taus)
    peak = _status_kib("VmHWM")
    queue.put((peak - baseline) * 1024 / y.nbytes + 1.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=10_000_000)
    parser.add_argument("--taus", type=int, default=60)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    rate = 100.0

    import allantools

    import bayescal as bc

    y = _make_input(args.samples)
    taus = _taus(args.samples, args.taus, rate)
    bc.allan_deviation(y[:4096], rate, taus[taus < 4096 / 4 / rate])  # compile / load kernels

    def best_of(function):
        times = []
        for _ in range(args.repeat):
            start = time.perf_counter()
            result = function()
            times.append(time.perf_counter() - start)
        return min(times), result

    peer_time, (_, peer_dev, _, _) = best_of(
        lambda: allantools.oadev(y, rate=rate, data_type="freq", taus=taus)
    )
    bare_time, bare = best_of(lambda: bc.allan_deviation(y, rate, taus, noise_type=0))
    full_time, full = best_of(lambda: bc.allan_deviation(y, rate, taus))
    difference = float(np.max(np.abs(bare.deviation / peer_dev - 1)))
    assert np.array_equal(bare.deviation, full.deviation)

    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    worker = context.Process(target=_peak_copies, args=(args.samples, args.taus, rate, queue))
    worker.start()
    copies = queue.get()
    worker.join()

    print(
        f"overlapping ADEV, {args.samples:.3g} samples, {taus.size} taus, "
        f"{os.cpu_count()} CPU core(s), best of {args.repeat}"
    )
    print(f"  allantools.oadev                 {peer_time:8.3f} s")
    for label, seconds in (("deviations", bare_time), ("with confidence limits", full_time)):
        print(f"  bayescal {label:<23} {seconds:8.3f} s   {peer_time / seconds:6.1f}x faster")
    print(f"  largest relative difference      {difference:.2e}")
    print(f"  peak memory                      {copies:.2f} copies of the input")


if __name__ == "__main__":
    main()
