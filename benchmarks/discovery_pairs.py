"""Discovery on pairs of effects that commonly occur together (issue 33 item 5): the hit
rate of each pair, with exact binomial bounds.

    python benchmarks/discovery_pairs.py [--records 50] [--minutes 10] [--seed 0]
                                         [--pairs NAME ...] [--per-process 4] [--workers 1]

Each record is a static gyro, white noise of 0.05 deg/s per sample at 50 Hz (``--minutes``
long), holding both effects of its pair at random sizes the record can be expected to show
(each alone at least a few sample sds over the record, or the line or grid plainly there):

- ``rate_random_walk+bias_instability``: a random walk whose share at the record's length is
  0.5-1.5x the white noise's, and flicker of 0.15-0.25 sample sd (the two slow terms of
  every MEMS gyro);
- ``gauss_markov+rate_random_walk``: a Gauss-Markov bias of 0.3-0.6 sample sd with tau
  2-5 % of the record (it returns to its mean 20-50 times: a Gauss-Markov term is told from a
  random walk by that return, worth about T / (4 tau) nats), and a random walk as above (a
  navigation filter's usual bias model);
- ``sinusoid+output_filter``: a line of 0.3-0.6 sample sd between 1 and 10 Hz, and a one-tap
  output filter with F 0.3-0.6 (vibration read through the part's own low-pass);
- ``quantization+white``: the samples rounded to a grid of 0.5-1 sample sd (a low-resolution
  converter: the grid is named ``quantization``);
- ``bias_step+rate_random_walk``: a step of 0.5-1 sample sd at 25-75 % of the record
  (a mode change), and a random walk as above.

A record is a hit when discovery names exactly the pair (a random walk it adds beside it
counts against it, as every extra name does). Discovery runs without its final posterior
(the names are decided before it). Records run in worker processes of ``--per-process``
records each, one at a time by default (``nice`` it on a shared machine), so that memory stays
that of one discovery (``--workers``: that many at once, on a machine with the cores and memory
for them); the run prints each record and then, per pair, hits / records with 90 %
Clopper-Pearson bounds and what the misses were named.
"""

import argparse
import math
import multiprocessing
import sys
import time
from collections import Counter

import numpy as np
from scipy import signal, stats

WHITE_SD = 0.05  # deg/s per sample
RATE = 50.0  # Hz
PAIRS = {
    "rate_random_walk+bias_instability": {"rate_random_walk", "bias_instability"},
    "gauss_markov+rate_random_walk": {"gauss_markov", "rate_random_walk"},
    "sinusoid+output_filter": {"sinusoid", "output_filter"},
    "quantization+white": {"quantization"},
    "bias_step+rate_random_walk": {"bias_step", "rate_random_walk"},
}
"""Each pair by name, and the names a correct discovery gives it (white is in every
baseline)."""


def _random_walk(rng, n: int) -> np.ndarray:
    """A random walk (deg/s) whose spread at the record's length is 0.5-1.5 sample sds."""
    step = rng.uniform(0.5, 1.5) * WHITE_SD / math.sqrt(n)
    return np.cumsum(step * rng.standard_normal(n))


def simulate(pair: str, rng, minutes: float) -> np.ndarray:
    """The record of ``pair`` (module docstring), deg/s at :data:`RATE`."""
    import bayescal as bc

    n = int(minutes * 60 * RATE)
    t = np.arange(n) / RATE
    white = WHITE_SD * rng.standard_normal(n + 1)
    values = 0.2 + white[1:]
    match pair:
        case "rate_random_walk+bias_instability":
            flicker = bc.NoiseModel(RATE, B=rng.uniform(0.15, 0.25) * WHITE_SD)
            values += _random_walk(rng, n) + flicker.simulate(n, seed=int(rng.integers(2**31)))
        case "gauss_markov+rate_random_walk":
            tau, sigma = rng.uniform(0.02, 0.05) * n / RATE, rng.uniform(0.3, 0.6) * WHITE_SD
            phi = math.exp(-1 / (RATE * tau))
            drive = rng.standard_normal(n) * sigma * math.sqrt(1 - phi * phi)
            values += signal.lfilter([1.0], [1.0, -phi], drive) + _random_walk(rng, n)
        case "sinusoid+output_filter":
            coefficient = rng.uniform(0.3, 0.6)
            values = 0.2 + (white[1:] + coefficient * white[:-1]) / (1 + coefficient)
            frequency, amplitude = rng.uniform(1, 10), rng.uniform(0.3, 0.6) * WHITE_SD
            values += amplitude * np.sin(2 * np.pi * frequency * t + rng.uniform(0, 2 * np.pi))
        case "quantization+white":
            lsb = rng.uniform(0.5, 1.0) * WHITE_SD
            values = np.round(values / lsb) * lsb
        case "bias_step+rate_random_walk":
            at = rng.uniform(0.25, 0.75) * n / RATE
            size = rng.uniform(0.5, 1.0) * WHITE_SD * rng.choice([-1, 1])
            values += size * (t >= at) + _random_walk(rng, n)
        case _:
            raise ValueError(f"pair={pair!r}: one of {', '.join(PAIRS)}")
    return values


def run(job: tuple[str, int, float]) -> dict:
    """Discovery on one record: the pair, its seed, the names found, whether they are the
    pair's exactly, and the seconds it took."""
    import bayescal as bc

    pair, seed, minutes = job
    values = simulate(pair, np.random.default_rng(seed), minutes)
    started = time.perf_counter()
    found = bc.discover(values, RATE, unit="deg/s", posterior=False, seed=seed)
    names = sorted({effect.name for effect in found.effects})
    return {
        "pair": pair,
        "seed": seed,
        "found": names,
        "hit": set(names) == PAIRS[pair],
        "seconds": time.perf_counter() - started,
    }


def bounds(successes: int, trials: int) -> tuple[float, float]:
    """90 % Clopper-Pearson interval of a rate seen as ``successes`` of ``trials``."""
    low = stats.beta.ppf(0.05, successes, trials - successes + 1) if successes else 0.0
    high = stats.beta.ppf(0.95, successes + 1, trials - successes) if successes < trials else 1.0
    return float(low), float(high)


def table(results: list[dict]) -> list[str]:
    """Per pair: hits / records, the rate and its 90 % bounds, and the misses' names."""
    lines = []
    for pair in PAIRS:
        some = [r for r in results if r["pair"] == pair]
        if not some:
            continue
        hits = sum(r["hit"] for r in some)
        low, high = bounds(hits, len(some))
        misses = Counter(",".join(r["found"]) or "-" for r in some if not r["hit"])
        named = "; ".join(f"{names} x{count}" for names, count in misses.most_common())
        lines.append(
            f"  {pair:<36} {hits:3d}/{len(some):<3d} = {hits / len(some):.2f} "
            f"(90 % bounds {low:.2f}-{high:.2f})  {named}"
        )
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=50, help="records per pair")
    parser.add_argument("--minutes", type=float, default=10.0, help="length of each record")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--pairs", nargs="*", default=list(PAIRS), choices=list(PAIRS))
    parser.add_argument("--per-process", type=int, default=4, help="records per worker")
    parser.add_argument("--workers", type=int, default=1, help="worker processes at once")
    args = parser.parse_args()
    jobs = [
        (pair, args.seed * 100_000 + 1000 * index + k, args.minutes)
        for k in range(args.records)
        for index, pair in enumerate(PAIRS)
        if pair in args.pairs
    ]
    started = time.perf_counter()
    results = []
    # Workers replaced every few records: memory stays one discovery's per worker.
    context = multiprocessing.get_context("spawn")
    with context.Pool(args.workers, maxtasksperchild=args.per_process) as pool:
        for result in pool.imap(run, jobs):
            results.append(result)
            print(
                f"  {result['pair']:<36} seed {result['seed']:<7d} "
                f"found {','.join(result['found']) or '-':<36} "
                f"{'hit ' if result['hit'] else 'MISS'} {result['seconds']:5.1f} s",
                flush=True,
            )
    print(
        f"\n{len(results)} records of {args.minutes:g} min at {RATE:g} Hz, "
        f"{time.perf_counter() - started:.0f} s"
    )
    print("\n".join(table(results)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
