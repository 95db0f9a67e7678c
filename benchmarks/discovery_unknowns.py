"""Discovery's "done when" suite (issue 33): physics the catalogue lacks reported as
unexplained, at its time or band, with no false name; catalogue effects alone and in the
combinations that went wrong (a weak line, a short-tau Gauss-Markov, Gauss-Markov beside a
random walk) named exactly; no false alarm on clean records.

    python benchmarks/discovery_unknowns.py [--seed 0] [--scale 1] [--kinds ...] [--workers 1]

Each record is a static gyro, white noise of 0.05 deg/s per sample, 50 or 100 Hz, 10 to 20
minutes (``--scale`` multiplies the counts of records; ``--kinds`` runs only those kinds).
Each record runs in a fresh process (``--workers`` at once), so memory is that of one record
per worker. The kinds:

- out of the catalogue (each must leave every name out and be reported unexplained where it
  is): a scale factor that changes by 3-6 % at a random time under a slow input ramp that
  passes zero there (a drift that starts there; the ramp itself, ``rate_ramp``, may be
  named), the sawtooth of a
  temperature controller (period 60-200 s, 0.3-0.6 sample sd: a line at a harmonic of its
  period), a step of the noise level (sd x 1.4-1.7 from a random time on), time-stamp jitter
  (a vibration line, 2 Hz to a tenth of the rate, sampled by a clock whose error wanders: the
  line broadens, at its frequency);
- in the catalogue, exact when the names are the truth's: a step, a burst, a random walk,
  bias instability, a Gauss-Markov term, a rate ramp, a two-level telegraph (switching every
  few minutes: ``random_telegraph``); a weak sinusoid (0.3-0.5 sample sd)
  that must not bring an output filter, a Gauss-Markov term with tau 0.2-1 s that must not
  bring a filter and bias instability, a Gauss-Markov term with a random walk that must
  keep both;
- clean: white noise and a random walk (its share at the record's length 0.1-1x the white
  noise's), none named;
- beyond the record's resolution (``long_gauss_markov``, appended after the clean records so
  that the others keep their seeds): a Gauss-Markov term of tau 60 s, 10-20 correlation times
  in the record, which over it is a random walk. Right when discovery names one of the two and
  reports it ``indistinguishable_from`` the other; counted apart, not in the exact rate.

The Gauss-Markov kinds are drawn where the record can tell them apart (the expected log
likelihood ratios below are of discovery's likelihood — the exact Gaussian of 128 block
means, the Whittle bins above their Nyquist — for the truth against the best fit of the model
without the term, computed from the truth alone). Against a random walk a Gauss-Markov term
of tau_c has only its level's return to the mean, about T / (6 tau_c) nats over T seconds:
1.4-3.3 nats at tau_c = 60 s in 10-20 minutes, about the log 14 its time-constant search
pays, so that the random walk, with nothing to pay, won as often as not (by 0.2 and 1.2 on
seeds 20 and 21, as first drawn; ``long_gauss_markov`` keeps that case). ``gauss_markov``
draws tau_c = T / 160 to T / 80 (4-15 s): 16-32 nats, a log Bayes factor of 13-29 after that
cost, decisive. Beside a random walk each term must be decisive against the other alone, the
random walk after its Schwarz cost (about 5.5 nats here), the Gauss-Markov term after that
and the search's: the walk must rise above the Gauss-Markov plateau well above 1 / T, and
stay below its 1 / f^2 tail beyond its corner. ``gauss_markov+rate_random_walk`` draws
tau_c = T / 350 to T / 250 and the walk's K where its spectrum crosses that plateau at
6-10 / T (K = 2 pi sigma sqrt(2 tau_c) x 6-10 / T): about 20-30 nats against the
Gauss-Markov term alone, 30-50 against the walk alone. As first drawn (tau_c = 60 s, K of
0.5-1.5 white sd per sqrt(record)) neither term was resolvable beside the other.

Prints each record and the three rates against the issue's targets (>= 9 of 10 unknowns,
>= 90 % exact, no false alarm on >= 20 clean records) with exact binomial bounds. A name
discovery reports ``indistinguishable_from`` a term of the truth (its runner-up within log 10
of it: on this record either explains the mismatch, and it says so) is not counted a false
name; the in-catalogue records are also counted "exact but for a stated ambiguity" (each such
name read as the truth's term, one to one: one term found for two is still a miss), beside
the exact rate, which counts it a miss.
"""

import argparse
import math
import multiprocessing
import sys
import time

import numpy as np
from scipy import signal, stats

WHITE_SD = 0.05  # deg/s per sample

UNKNOWN = ("scale_factor_change", "sawtooth", "noise_level_step", "clock_jitter")
SINGLE = (
    "bias_step",
    "noise_burst",
    "rate_random_walk",
    "bias_instability",
    "gauss_markov",
    "rate_ramp",
    "weak_sinusoid",
    "short_gauss_markov",
    "gauss_markov+rate_random_walk",
    "telegraph",
)
NAMES = {  # the catalogue names a correct discovery gives each in-catalogue kind
    "telegraph": {"random_telegraph"},
    "weak_sinusoid": {"sinusoid"},
    "short_gauss_markov": {"gauss_markov"},
    "gauss_markov+rate_random_walk": {"gauss_markov", "rate_random_walk"},
    "long_gauss_markov": {"gauss_markov"},
}
AMBIGUOUS = {"long_gauss_markov": {"gauss_markov", "rate_random_walk"}}
"""Kinds beyond the record's resolution -> the terms among which discovery must name one and
report it indistinguishable from another."""


def plan(scale: int) -> list[str]:
    """The kinds of the records: 10 unknowns (3 noise-level steps, 3 sawtooths, 2 scale
    factor changes, 2 jitters), 2 telegraphs, 2 of each in-catalogue kind, 20 clean, 2
    Gauss-Markov terms beyond the record's resolution."""
    kinds = ["noise_level_step"] * 3 + ["sawtooth"] * 3
    kinds += ["scale_factor_change"] * 2 + ["clock_jitter"] * 2 + ["telegraph"] * 2
    kinds += [kind for kind in SINGLE[:-1] for _ in range(2)] + ["clean"] * 20
    return (kinds + ["long_gauss_markov"] * 2) * scale


def _gauss_markov(rng, n, rate, sigma, tau):
    phi = math.exp(-1 / (rate * tau))
    drive = rng.standard_normal(n) * sigma * math.sqrt(1 - phi * phi)
    return signal.lfilter([1.0], [1.0, -phi], drive)


def simulate(kind: str, rng):
    """(values, rate, truth): the record and what a correct discovery says of it — the names
    it may give (``allowed``), those it must give (``names``), and for an unknown where it
    must locate the mismatch (``where``)."""
    import bayescal as bc

    rate = float(rng.choice([50.0, 100.0]))
    n = int(rng.uniform(10, 20) * 60 * rate)
    t = np.arange(n) / rate
    duration = n / rate
    values = 0.2 + WHITE_SD * rng.standard_normal(n)
    names = NAMES.get(kind, {kind} if kind in SINGLE else set())
    allowed, where = set(names) | AMBIGUOUS.get(kind, set()), None
    at = rng.uniform(0.25, 0.75) * duration
    match kind:
        case "clean":
            walk = WHITE_SD * rng.uniform(0.1, 1.0) / math.sqrt(n)
            values += np.cumsum(walk * rng.standard_normal(n))
            allowed.add("rate_random_walk")  # a random walk is there: naming it is right
        case "scale_factor_change":
            # A slow input ramp through zero at `at` (10-20 sample sd over the record),
            # seen with a scale factor that changes by 3-6 % there: the slope kinks.
            ramp = rng.uniform(10, 20) * WHITE_SD / duration * rng.choice([-1, 1])
            change = rng.uniform(0.03, 0.06) * rng.choice([-1, 1])
            values += ramp * (t - at) * (1 + change * (t >= at))
            allowed.add("rate_ramp")
            where = ("time", at)
        case "sawtooth":
            period = rng.uniform(60, 200)
            values += rng.uniform(0.3, 0.6) * WHITE_SD * 2 * ((t / period) % 1 - 0.5)
            where = ("line", 1 / period)
        case "noise_level_step":
            values[t >= at] = 0.2 + (values[t >= at] - 0.2) * rng.uniform(1.4, 1.7)
            where = ("time", at)
        case "clock_jitter":
            # Below the band where output filters act (a line there is theirs to shape).
            frequency = rng.uniform(2, 0.1 * rate)
            error = np.cumsum(rng.standard_normal(n)) * 0.3 / frequency / math.sqrt(n)
            values += 0.5 * WHITE_SD * np.sin(2 * np.pi * frequency * (t + error))
            where = ("line", frequency)
        case "telegraph":
            level, state, switch = 0.3 * WHITE_SD, 0, []
            jumps = np.zeros(n)
            dwell = rng.exponential(rng.uniform(120, 300))
            while dwell < duration:
                switch.append(dwell)
                dwell += rng.exponential(rng.uniform(120, 300))
            for time_s in switch:
                state = 1 - state
                jumps[t >= time_s] += level if state else -level
            values += jumps
        case "bias_step":
            values += rng.uniform(0.15, 0.4) * WHITE_SD * rng.choice([-1, 1]) * (t >= at)
        case "noise_burst":
            width = rng.uniform(20, 60)
            inside = (t >= at) & (t < at + width)
            values[inside] += WHITE_SD * rng.uniform(1.5, 3) * rng.standard_normal(inside.sum())
        case "rate_random_walk":
            k = rng.uniform(0.5, 1.5) * WHITE_SD / math.sqrt(duration)
            values += k * np.cumsum(rng.standard_normal(n)) / math.sqrt(rate)
        case "bias_instability":
            model = bc.NoiseModel(rate, B=rng.uniform(0.1, 0.2) * WHITE_SD)
            values += model.simulate(n, seed=int(rng.integers(2**31)))
        case "gauss_markov":
            tau = duration / rng.uniform(80, 160)
            values += _gauss_markov(rng, n, rate, rng.uniform(0.3, 0.6) * WHITE_SD, tau)
        case "long_gauss_markov":
            values += _gauss_markov(rng, n, rate, rng.uniform(0.3, 0.6) * WHITE_SD, 60)
        case "rate_ramp":
            values += rng.uniform(0.3, 0.8) * WHITE_SD / duration * rng.choice([-1, 1]) * t
        case "weak_sinusoid":
            frequency = rng.uniform(0.5, 0.4 * rate)
            values += rng.uniform(0.3, 0.5) * WHITE_SD * np.sin(2 * np.pi * frequency * t)
        case "short_gauss_markov":
            tau = rng.uniform(0.2, 1.0)
            values += _gauss_markov(rng, n, rate, rng.uniform(0.5, 1.0) * WHITE_SD, tau)
        case "gauss_markov+rate_random_walk":
            tau, sigma = duration / rng.uniform(250, 350), rng.uniform(0.3, 0.6) * WHITE_SD
            values += _gauss_markov(rng, n, rate, sigma, tau)
            k = 2 * math.pi * sigma * math.sqrt(2 * tau) * rng.uniform(6, 10) / duration
            values += k * np.cumsum(rng.standard_normal(n)) / math.sqrt(rate)
    return values, rate, {"names": names, "allowed": allowed, "where": where}


def located(unexplained: dict | None, where, duration_s: float) -> bool:
    """Whether the unexplained mismatches put the unknown at its time (within 3 % of the
    record) or its line (within 5 Fourier resolutions of a harmonic, or 5 % for a line that
    wanders)."""
    if not unexplained:
        return False
    kind, value = where
    for mismatch in unexplained["mismatches"]:
        if kind == "time" and mismatch["check"] in ("level_scan", "variance_scan"):
            times = mismatch["time_s"] if isinstance(mismatch["time_s"], list) else []
            times = times or [mismatch["time_s"]]
            if any(abs(a - value) <= 0.03 * duration_s for a in times):
                return True
        if kind == "line" and mismatch["check"] in ("spectral_line", "spectrum_bands"):
            found = mismatch["frequency_hz"]
            if isinstance(found, list):  # a band: the line or a harmonic inside it
                if any(found[0] <= k * value <= found[1] for k in range(1, 11)):
                    return True
                continue
            harmonic = max(round(found / value), 1)
            tolerance = max(5 / duration_s, 0.05 * value)
            if abs(found - harmonic * value) <= tolerance:
                return True
    return False


def run(kind: str, seed: int) -> dict:
    """One record of ``kind`` simulated with ``seed``, discovered, and judged."""
    import bayescal as bc

    rng = np.random.default_rng(seed)
    values, rate, truth = simulate(kind, rng)
    started = time.perf_counter()
    found = bc.discover(values, rate, unit="deg/s", posterior=False, seed=seed)
    names = {effect.name for effect in found.effects}
    # A name discovery itself reports indistinguishable from a term of the truth (the runner-
    # up within log 10, said in its explanation) is an ambiguity it states, not a false name.
    partner = {
        effect.name: effect.evidence["indistinguishable_from"]
        for effect in found.effects
        if effect.evidence.get("indistinguishable_from") in truth["names"] - names
    }
    duration = values.size / rate
    result = {
        "kind": kind,
        "seed": seed,
        "minutes": duration / 60,
        "rate": rate,
        "found": sorted(names),
        "seconds": time.perf_counter() - started,
        "false_name": sorted(names - truth["allowed"] - set(partner)),
        "ambiguous": sorted(f"{name}|{other}" for name, other in partner.items()),
    }
    if kind in AMBIGUOUS:
        stated = {e.name: e.evidence.get("indistinguishable_from") for e in found.effects}
        result["ok"] = len(names) == 1 and all(
            name in AMBIGUOUS[kind] and other in AMBIGUOUS[kind] - {name}
            for name, other in stated.items()
        )
        result["ambiguous"] = sorted(f"{name}|{other}" for name, other in stated.items() if other)
    elif truth["where"] is not None:
        result["located"] = located(found.unexplained, truth["where"], duration)
        result["ok"] = result["located"] and not result["false_name"]
        result["where"] = (found.unexplained or {}).get("where", "-")
    else:
        result["ok"] = truth["names"] <= names <= truth["allowed"]
        # Exact once each stated ambiguity is read as the truth's term: the names, one to one.
        read = {partner.get(name, name) for name in names}
        result["ok_or_ambiguous"] = truth["names"] <= read <= truth["allowed"]
    return result


def _run(job: tuple[str, int]) -> dict:
    return run(*job)


def _bounds(successes: int, trials: int) -> str:
    low = stats.beta.ppf(0.05, successes, trials - successes + 1) if successes else 0.0
    high = stats.beta.ppf(0.95, successes + 1, trials - successes) if successes < trials else 1.0
    return f"{successes}/{trials} = {successes / trials:.2f} (90 % bounds {low:.2f}-{high:.2f})"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--scale", type=int, default=1)
    parser.add_argument(
        "--kinds", nargs="*", default=None, help="run only the records of these kinds"
    )
    parser.add_argument("--workers", type=int, default=1, help="records run at once")
    args = parser.parse_args()
    kinds = plan(args.scale)
    jobs = [
        (kind, args.seed * 10_000 + index)
        for index, kind in enumerate(kinds)
        if args.kinds is None or kind in args.kinds
    ]
    # One record of each kind, then the second of each ...: a run cut short has every kind.
    # (A record's seed is its place in the plan, so the order changes no result.)
    jobs.sort(key=lambda job: kinds[: job[1] - args.seed * 10_000].count(job[0]))
    started = time.perf_counter()
    results = []
    # One record per fresh process: JAX's compilation caches and the fits' arrays of one
    # record are freed with its process, so memory stays that of one record.
    context = multiprocessing.get_context("spawn")
    with context.Pool(args.workers, maxtasksperchild=1) as pool:
        outcomes = pool.imap(_run, jobs)
        for (kind, seed), result in zip(jobs, outcomes, strict=True):
            index = seed - args.seed * 10_000
            results.append(result)
            print(
                f"  {index:3d} {kind:<30} {result['minutes']:4.1f} min {result['rate']:4.0f} Hz "
                f"found {','.join(result['found']) or '-':<32} {'ok ' if result['ok'] else 'NO '}"
                f"{result['seconds']:5.1f} s  {result.get('where', '')}"
                + (f" ambiguous {','.join(result['ambiguous'])}" if result["ambiguous"] else ""),
                flush=True,
            )
    print(f"\n{len(results)} records, {time.perf_counter() - started:.0f} s")
    groups = {
        "unknowns (unexplained, located, no false name)": UNKNOWN,
        "in the catalogue (exact)": SINGLE,
        "clean (no false alarm)": ("clean",),
        "beyond the record's resolution (one of the two named, stated indistinguishable from "
        "the other)": tuple(AMBIGUOUS),
    }
    for title, members in groups.items():
        chosen = [r for r in results if r["kind"] in members]
        if not chosen:
            continue
        print(f"  {title}: {_bounds(sum(r['ok'] for r in chosen), len(chosen))}")
        if members == SINGLE:
            stated = sum(r["ok_or_ambiguous"] for r in chosen)
            print(
                "  ... exact or exact but for an ambiguity discovery states (a name reported "
                f"indistinguishable_from the truth's term): {_bounds(stated, len(chosen))}"
            )
        for kind in members:
            some = [r for r in chosen if r["kind"] == kind]
            misses = [f"{r['found'] or '-'} at {r.get('where', '')}" for r in some if not r["ok"]]
            print(f"    {kind:<30} {sum(r['ok'] for r in some)}/{len(some)}  {'; '.join(misses)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
