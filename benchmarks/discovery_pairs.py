"""Discovery on pairs of effects that commonly occur together (issue 33 item 5): the hit
rate of each pair, with exact binomial bounds.

    python benchmarks/discovery_pairs.py [--records 50] [--minutes 10] [--seed 0]
                                         [--pairs NAME ...] [--per-process 4] [--workers 1]

Each record is a static gyro, white noise of 0.05 deg/s per sample at 50 Hz (``--minutes``
long), holding both effects of its pair at random sizes the record can be expected to show
(each alone at least a few sample sds over the record, or the line or grid plainly there):

- ``rate_random_walk+bias_instability``: flicker of 0.15-0.25 sample sd and a random walk
  whose expected log likelihood ratio beside flicker is 2-3 times what the search charges it
  (18.8-28.2 nats against 9.4; over the 50 records of seed 0 its spectrum crosses flicker's
  at 12.8-20.6 / T, its spread at the record's length 9.0-11.4 B, 1.6-2.4 sample sds): the
  two slow terms of every MEMS gyro, the walk's margin the step's beside a walk (below).
  Each term beside the other must be decisive: the walk shows only below that crossing. As
  first drawn (the walk's spread at the record's length 0.5-1.5 sample sds, drawn apart from
  flicker) it was beside flicker in 5 of the 50 records of seed 0, computed as
  ``--information`` computes it; crossing at 6-10 / T in 34, at 8-12 / T in 50 (10.4 nats
  the least, its charge 9.4), at 10-14 / T in 50 (13.4-21.4 nats). Drawn crossing at
  10-14 / T, 42 of the 50 were named exactly: the walk lost beside flicker on the six
  records whose realisation held it below its charge (the search's own log likelihood ratio
  of flicker and the walk against flicker alone, at their fits: 6.5-8.0 nats on seeds 9,
  12, 15, 24, 27 and 34, 10.1-91.4 on the other 44; expected 13.4-21.4), and a Gauss-Markov
  term accepted on a near tie took flicker's place on two (seeds 14 and 30, a search order
  since fixed). Redrawn at 2-3 times the charge, every record's realisation holds the walk
  above it (9.6-109.0 nats; median 29.2, 22.4 before);
- ``gauss_markov+rate_random_walk``: a Gauss-Markov bias of 0.3-0.6 sample sd with tau
  T / 350 to T / 250, and a random walk whose spectrum crosses the Gauss-Markov plateau at
  6-10 / T (a navigation filter's usual bias model; drawn as ``discovery_unknowns.py`` draws
  it). Each term beside the other must be decisive: the walk shows only below the
  Gauss-Markov corner, the Gauss-Markov term only where its plateau stands above the walk. As
  first drawn (tau 2-5 % of the record, the walk 0.5-1.5 sample sd at its length) neither
  was: over the 50 records of seed 0, computed as ``--information`` computes it, the walk
  beside the Gauss-Markov term held 0.0-0.7 nats (its charge 9.4), the Gauss-Markov term
  beside the walk 0.8-6.4 (its charge 12.1), and discovery named one term in all 50;
- ``sinusoid+output_filter``: a line of 0.3-0.6 sample sd between 1 and 10 Hz, and a one-tap
  output filter with F 0.3-0.6 (vibration read through the part's own low-pass);
- ``quantization+white``: the samples rounded to a grid of 0.5-1 sample sd (a low-resolution
  converter: the grid is named ``quantization``);
- ``bias_step+rate_random_walk``: a random walk whose spread at the record's length is
  0.5-1.5 sample sds (a MEMS gyro's wandering bias), and a step at 25-75 % of the record whose
  expected log likelihood ratio beside that walk is 2-3 times what the search charges it
  (39.4-59.2 nats against 19.7 on 10 minutes at 50 Hz; 0.73-1.37 sample sd over the 50
  records of seed 0): a mode change (a range or bandwidth setting switched, a supply rail
  changed) of about one sample sd, the size a 10-minute record just tells from the walk. As
  first drawn (the step 0.5-1 sample sd, drawn apart from the walk) it was above its charge
  in 38 of the 50 records of seed 0 (10.8-79.1 nats), and named in 30; redrawn, 50/50
  (39.6-59.0 nats), and named in 49. The walk beside the step holds 292-2449 nats against
  9.4 either way.

``--information`` prints, instead of running discovery, what each record's truth lets a
search find: for each term of a pair, the expected log likelihood ratio of the pair against
the model without it (Whittle, the truth's spectrum against the best fit of the other term and
white noise over the record's Fourier frequencies; a step's beside a walk in closed form,
s^2 / (2 q sqrt(q^2 + 4 sigma^2)) for a step s, a walk's per-sample step q and white sd
sigma), beside what the search charges the term (its Schwarz cost, 0.5 log of the record's
frequencies per continuous parameter, the log of the values a searched parameter chose among,
and the decisive log 100). A record where a term's expected ratio is below its charge is
named exactly about half the time or less, whatever the search does.

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


def _walk_step(rng, n: int) -> float:
    """The per-sample step (deg/s) of a random walk whose spread at the record's length is
    0.5-1.5 sample sds."""
    return rng.uniform(0.5, 1.5) * WHITE_SD / math.sqrt(n)


STEP_MULTIPLE = (2.0, 3.0)
"""The range of a step's expected log likelihood ratio beside the walk, in multiples of what
the search charges it (:func:`charges`)."""


def _step_information(step: float, walk: float) -> float:
    """A step's expected log likelihood ratio beside a walk of per-sample step ``walk`` and
    white noise: s^2 / (2 q sqrt(q^2 + 4 sigma^2)) (module docstring)."""
    return step**2 / (2 * walk * math.sqrt(walk * walk + 4 * WHITE_SD**2))


def _step_for(ratio: float, walk: float) -> float:
    """The step (deg/s) whose expected log likelihood ratio beside ``walk`` is ``ratio``: the
    inverse of :func:`_step_information`."""
    return math.sqrt(2 * ratio * walk * math.sqrt(walk * walk + 4 * WHITE_SD**2))


WALK_MULTIPLE = (2.0, 3.0)
"""The range of a walk's expected log likelihood ratio beside flicker, in multiples of what
the search charges it (:func:`charges`), as a step's beside a walk (:data:`STEP_MULTIPLE`)."""


def _walk_for(ratio: float, truth: dict, n: int) -> float:
    """The walk's per-sample step (deg/s) whose expected log likelihood ratio beside the
    flicker of ``truth`` is ``ratio`` (:func:`information`'s, solved for the step: it grows
    with the step, the walk's spectrum K^2 / (4 pi^2 f^2) crossing flicker's B^2 / (2 pi f)
    at f = K^2 / (2 pi B^2), searched between 2 / T and 200 / T)."""
    from scipy import optimize

    nu = np.arange(1, n // 2 + 1) / n

    def excess(log_crossing):
        walk = truth["flicker"] * math.sqrt(2 * math.pi * math.exp(log_crossing) / n)
        return _without("rate_random_walk", truth | {"walk": walk}, nu) - ratio

    log_crossing = optimize.brentq(excess, math.log(2.0), math.log(200.0), xtol=1e-3)
    return truth["flicker"] * math.sqrt(2 * math.pi * math.exp(log_crossing) / n)


def charges(n: int) -> dict:
    """term -> what the search charges it on a record of ``n`` samples: its Schwarz cost
    (0.5 log of the record's frequencies per continuous parameter), the log of the values a
    searched parameter chose among (a time constant's grid, a step's samples) and the decisive
    log 100."""
    from bayescal.models.effects._base import TIME_CONSTANT_PENALTY

    schwarz = 0.5 * math.log(n // 2)
    decisive = math.log(100.0)
    return {
        "rate_random_walk": schwarz + decisive,
        "bias_instability": schwarz + decisive,
        "gauss_markov": schwarz + TIME_CONSTANT_PENALTY + decisive,
        "bias_step": schwarz + math.log(n) + decisive,
    }


def draw(pair: str, rng, minutes: float) -> tuple[np.ndarray, dict]:
    """The record of ``pair`` (module docstring), deg/s at :data:`RATE`, and its truth: the
    pair's parameters per sample (``walk``: a random walk's step; ``flicker``: B; ``sigma``
    and ``tau_samples``: a Gauss-Markov term's; ``step``: a step's size; ``at_s``: its
    time, s)."""
    import bayescal as bc

    n = int(minutes * 60 * RATE)
    t = np.arange(n) / RATE
    white = WHITE_SD * rng.standard_normal(n + 1)
    values = 0.2 + white[1:]
    truth = {}
    match pair:
        case "rate_random_walk+bias_instability":
            truth["flicker"] = rng.uniform(0.15, 0.25) * WHITE_SD
            flicker = bc.NoiseModel(RATE, B=truth["flicker"])
            # The walk whose expected log LR beside flicker is that multiple of its charge.
            multiple = rng.uniform(*WALK_MULTIPLE)
            truth["walk"] = _walk_for(multiple * charges(n)["rate_random_walk"], truth, n)
            values += np.cumsum(truth["walk"] * rng.standard_normal(n))
            values += flicker.simulate(n, seed=int(rng.integers(2**31)))
        case "gauss_markov+rate_random_walk":
            tau, sigma = n / RATE / rng.uniform(250, 350), rng.uniform(0.3, 0.6) * WHITE_SD
            phi = math.exp(-1 / (RATE * tau))
            drive = rng.standard_normal(n) * sigma * math.sqrt(1 - phi * phi)
            values += signal.lfilter([1.0], [1.0, -phi], drive)
            # K where the walk's spectrum crosses the plateau 2 sigma^2 tau at 6-10 / T.
            k = 2 * math.pi * sigma * math.sqrt(2 * tau) * rng.uniform(6, 10) / (n / RATE)
            truth |= {"sigma": sigma, "tau_samples": tau * RATE, "walk": k / math.sqrt(RATE)}
            values += truth["walk"] * np.cumsum(rng.standard_normal(n))
        case "sinusoid+output_filter":
            coefficient = rng.uniform(0.3, 0.6)
            values = 0.2 + (white[1:] + coefficient * white[:-1]) / (1 + coefficient)
            frequency, amplitude = rng.uniform(1, 10), rng.uniform(0.3, 0.6) * WHITE_SD
            values += amplitude * np.sin(2 * np.pi * frequency * t + rng.uniform(0, 2 * np.pi))
        case "quantization+white":
            lsb = rng.uniform(0.5, 1.0) * WHITE_SD
            values = np.round(values / lsb) * lsb
        case "bias_step+rate_random_walk":
            at = truth["at_s"] = rng.uniform(0.25, 0.75) * n / RATE
            multiple, sign = rng.uniform(*STEP_MULTIPLE), rng.choice([-1, 1])
            truth["walk"] = _walk_step(rng, n)
            # The step whose expected log LR beside the walk is that multiple of its charge.
            truth["step"] = sign * _step_for(multiple * charges(n)["bias_step"], truth["walk"])
            values += truth["step"] * (t >= at) + np.cumsum(truth["walk"] * rng.standard_normal(n))
        case _:
            raise ValueError(f"pair={pair!r}: one of {', '.join(PAIRS)}")
    return values, truth


def simulate(pair: str, rng, minutes: float) -> np.ndarray:
    """The record of ``pair`` (module docstring), deg/s at :data:`RATE`."""
    return draw(pair, rng, minutes)[0]


SPECTRAL_PARAMETERS = {
    "rate_random_walk": ("walk",),
    "bias_instability": ("flicker",),
    "gauss_markov": ("sigma", "tau_samples"),
}
"""The truth's parameters of each term with a spectrum (:func:`_spectra`)."""


def _spectra(truth: dict, nu: np.ndarray) -> dict:
    """Each term's two-sided spectrum per cycle per sample at frequencies ``nu``, from
    ``truth`` (or from parameters of the same names)."""
    spectra = {}
    if "walk" in truth:
        spectra["rate_random_walk"] = truth["walk"] ** 2 / (4 * np.sin(np.pi * nu) ** 2)
    if "flicker" in truth:  # B^2 / (2 pi |f|) per Hz, two-sided
        spectra["bias_instability"] = truth["flicker"] ** 2 / (2 * np.pi * nu)
    if "sigma" in truth:
        phi = math.exp(-1 / truth["tau_samples"])
        response = np.abs(1 - phi * np.exp(-2j * np.pi * nu)) ** 2
        spectra["gauss_markov"] = truth["sigma"] ** 2 * (1 - phi * phi) / response
    return spectra


def _without(term: str, truth: dict, nu: np.ndarray) -> float:
    """The expected log likelihood ratio of ``truth`` against the best fit of the model
    without ``term`` (the other term and white noise), Whittle over frequencies ``nu``:
    the minimum over that model's parameters of sum(r - 1 - log r), r = truth / model."""
    from scipy import optimize

    full = WHITE_SD**2 + sum(_spectra(truth, nu).values())
    kept = [
        key
        for other, keys in SPECTRAL_PARAMETERS.items()
        if other != term and keys[0] in truth
        for key in keys
    ]

    def divergence(logs):
        model = dict(zip(kept, np.exp(logs[1:]), strict=True))
        ratio = full / (np.exp(2 * logs[0]) + sum(_spectra(model, nu).values()))
        return float(np.sum(ratio - 1 - np.log(ratio)))

    start = np.log([WHITE_SD, *(truth[key] for key in kept)])
    # The term left out moves the others: a Gauss-Markov term alone takes a longer tau.
    tries = [start + shift * np.eye(len(start))[-1] for shift in (0.0, 1.0, 2.0)]
    return min(
        optimize.minimize(divergence, x, method="Nelder-Mead", options={"maxiter": 4000}).fun
        for x in tries
    )


def information(pair: str, truth: dict, n: int) -> dict:
    """term -> (expected log likelihood ratio of the pair against the model without it, what
    the search charges it) for each term of ``pair`` whose truth is a spectrum or a step
    (module docstring); empty for the others."""
    nu = np.arange(1, n // 2 + 1) / n
    charge = charges(n)
    found = {term: (_without(term, truth, nu), charge[term]) for term in _spectra(truth, nu)}
    if "step" in truth:
        q = truth["walk"]
        found["bias_step"] = (_step_information(truth["step"], q), charge["bias_step"])
        # Beside a step the walk is told from white noise (the step's column takes the step).
        found["rate_random_walk"] = (
            _without("rate_random_walk", {"walk": q}, nu),
            charge["rate_random_walk"],
        )
    return found


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


def information_table(jobs: list[tuple[str, int, float]]) -> list[str]:
    """Per pair and term: the median expected log likelihood ratio over the records of
    ``jobs``, the search's charge, and the records where the ratio exceeds it."""
    ratios: dict[tuple[str, str], list] = {}
    for pair, seed, minutes in jobs:
        _, truth = draw(pair, np.random.default_rng(seed), minutes)
        n = int(minutes * 60 * RATE)
        for term, (ratio, charge) in information(pair, truth, n).items():
            ratios.setdefault((pair, term), []).append((ratio, charge))
    lines = []
    for (pair, term), found in ratios.items():
        ratio, charge = np.array(found).T
        lines.append(
            f"  {pair:<36} {term:<18} expected log LR median {np.median(ratio):6.1f} "
            f"(range {ratio.min():.1f}-{ratio.max():.1f}), charge {charge[0]:.1f}: above it "
            f"{np.count_nonzero(ratio > charge)}/{ratio.size}"
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
    parser.add_argument(
        "--information",
        action="store_true",
        help="print what each record's truth lets a search find, without running discovery",
    )
    args = parser.parse_args()
    jobs = [
        (pair, args.seed * 100_000 + 1000 * index + k, args.minutes)
        for k in range(args.records)
        for index, pair in enumerate(PAIRS)
        if pair in args.pairs
    ]
    if args.information:
        print("\n".join(information_table(jobs)))
        return 0
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
