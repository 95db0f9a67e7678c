"""N where the sensor's noise is not white at high frequency: the default ``noise``
(``terms="auto"``) against the Allan curve's reading and the classical three-term model.

    python benchmarks/noise_high_frequency.py [--recordings 100] [--samples 65536] [--discover 5]

Four kinds of record at 200 Hz, N = 0.01 deg/s/sqrt(Hz) and a rate random walk of
K = 1e-4 deg/s*sqrt(Hz), each shaped at high frequency as real parts are, none of them by
bayescal's own filter shapes:

- ``butterworth``: white noise at an internal 1 kHz through a second-order digital
  Butterworth low-pass (scipy.signal.butter, cutoff drawn in 20-80 Hz), read every fifth
  sample and rounded to 1/20 of the noise sd (a 16-bit part);
- ``butterworth_at_rate``: the same filter designed and run at the output rate (its zero at
  Nyquist filled only by the rounding), cutoff in 20-60 Hz;
- ``white_angle``: white angle noise (IEEE 952's Q) whose spectrum reaches 0.5-4x the white
  noise's at Nyquist;
- ``quantization``: the output rounded to an LSB of 0.3-1.5 noise sd.

For each record: N from ``bc.fit_noise`` (the default, auto: mean and 90 % interval, the
terms chosen, whether the model fits), the MAP of the classical model (white, bias instability,
rate random walk; the default before auto) and the IEEE 952 reading of the Allan curve. Target
(issue 16): the default gives N within 5 % of the truth, and its 90 % intervals cover the
truth at the nominal rate; on ``--discover`` records per kind, discovery names output_filter
(the filtered kinds) or quantization (the others).
"""

import argparse
import math
import time
from collections import Counter

import numpy as np
from scipy import signal, stats

import bayescal as bc
from bayescal.inference._noise_posterior import noise_mode
from bayescal.inference._priors import default_prior
from bayescal.models._noise_problem import NoiseProblem, noise_summaries
from bayescal.models._terms import CLASSICAL_TERMS

RATE = 200.0
N_TRUE = 0.01
K_TRUE = 1e-4
SD = N_TRUE * math.sqrt(RATE)
KINDS = ("butterworth", "butterworth_at_rate", "white_angle", "quantization")
EXPECTED_EFFECT = {
    "butterworth": "output_filter",
    "butterworth_at_rate": "output_filter",
    "white_angle": "quantization",
    "quantization": "quantization",
}


def walk(rng: np.random.Generator, n: int) -> np.ndarray:
    """A rate random walk of density K, sampled at the output rate."""
    return K_TRUE * np.cumsum(rng.standard_normal(n)) / math.sqrt(RATE)


def decimated_density(b, a, rate: float, factor: int) -> float:
    """The record's N: the low-frequency density of white noise of density N_TRUE at ``rate``
    through the filter (b, a), read every ``factor``-th sample. Read without an anti-alias
    filter beyond (b, a), the output folds the filter's gain at multiples of the output rate
    onto zero frequency: N^2 sum_k |H(k fs / factor)|^2, k = 0 .. factor - 1 (1.5 % over N_TRUE
    for a 2nd-order Butterworth at 80 Hz read at 200 Hz of 1 kHz). That is the level the
    Allan curve reads at long tau, and IEEE 952's N of the record."""
    aliases = np.arange(factor) * rate / factor
    _, response = signal.freqz(b, a, worN=aliases, fs=rate)
    return N_TRUE * math.sqrt(float(np.sum(np.abs(response) ** 2)))


def simulate(kind: str, n: int, seed: int) -> tuple[np.ndarray, dict]:
    """One record of ``kind`` and what shaped it; ``N`` the record's IEEE 952 N."""
    rng = np.random.default_rng(seed)
    if kind in ("butterworth", "butterworth_at_rate"):
        internal = 5 if kind == "butterworth" else 1
        cutoff = rng.uniform(20.0, 80.0 if internal > 1 else 60.0)
        rate = RATE * internal
        b, a = signal.butter(2, cutoff, fs=rate)
        settle = 4096
        white = rng.normal(0.0, N_TRUE * math.sqrt(rate), (n + settle) * internal)
        values = signal.lfilter(b, a, white)[settle * internal :: internal][:n]
        lsb = SD / 20
        values = lsb * np.round((values + walk(rng, n)) / lsb)
        return values, {"cutoff_hz": cutoff, "N": decimated_density(b, a, rate, internal)}
    if kind == "white_angle":
        ratio = rng.uniform(0.5, 4.0)
        Q = N_TRUE * math.sqrt(ratio / (4 * RATE))
        model = bc.NoiseModel(rate_hz=RATE, N=N_TRUE, K=K_TRUE, Q=Q)
        return model.simulate(n, seed=seed), {"Q_over_white_at_nyquist": ratio, "N": N_TRUE}
    lsb_over_sd = rng.uniform(0.3, 1.5)
    model = bc.NoiseModel(rate_hz=RATE, N=N_TRUE, K=K_TRUE, lsb=lsb_over_sd * SD)
    return model.simulate(n, seed=seed), {"lsb_over_sd": lsb_over_sd, "N": N_TRUE}


def classical_model_n(values: np.ndarray, allan) -> float:
    """MAP of N in the classical model (white, bias instability, rate random walk)."""
    problem = NoiseProblem(
        *noise_summaries(values, RATE, CLASSICAL_TERMS),
        default_prior(CLASSICAL_TERMS, allan),
    )
    mode = noise_mode(problem)
    return float(problem.natural(mode.theta)["N"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recordings", type=int, default=100, help="in all, over the kinds")
    parser.add_argument("--samples", type=int, default=2**16)
    parser.add_argument("--discover", type=int, default=5, help="records per kind")
    parser.add_argument("--kinds", default=",".join(KINDS), help=f"comma-separated, of {KINDS}")
    args = parser.parse_args()
    kinds = [kind for kind in KINDS if kind in args.kinds.split(",")]

    per_kind = math.ceil(args.recordings / len(kinds))
    start = time.perf_counter()
    rows = []
    for kind_index, kind in enumerate(KINDS):
        if kind not in kinds:
            continue
        for index in range(per_kind):
            seed = 1000 * kind_index + index
            values, shaped = simulate(kind, args.samples, seed)
            truth = shaped["N"]
            fit = bc.fit_noise(values, RATE, unit="deg/s", seed=seed)
            summary = fit.parameters["N"]
            reading = fit.classical.slope_readings["N"]
            rows.append(
                {
                    "kind": kind,
                    "auto": summary.mean / truth - 1,
                    "covered": summary.q05 <= truth <= summary.q95,
                    "terms": "+".join(t for t in fit.terms if t != "white") or "white",
                    "fits": fit.fits,
                    "healthy": fit.passed,
                    "classical_model": classical_model_n(values, fit.classical.allan) / truth - 1,
                    "allan": reading.value / truth - 1,
                    "allan_kind": reading.kind,
                }
            )
    elapsed = time.perf_counter() - start
    print(
        f"noise at high frequency: {len(rows)} records of {args.samples} samples at {RATE:g} Hz "
        f"(N = {N_TRUE} deg/s/sqrt(Hz), K = {K_TRUE} deg/s*sqrt(Hz)); {elapsed:.0f} s"
    )
    print(
        f"  {'kind':<21}{'n':>4}{'|err| median':>14}{'within 5%':>11}{'90% cover':>11}"
        f"{'fits':>6}{'healthy':>9}   {'classical model':>16}{'Allan reading':>15}"
    )
    for kind in kinds:
        mine = [row for row in rows if row["kind"] == kind]
        count = len(mine)
        errors = np.abs([row["auto"] for row in mine])
        print(
            f"  {kind:<21}{count:>4}{100 * np.median(errors):>13.1f}%"
            f"{np.mean(errors < 0.05):>11.2f}{np.mean([r['covered'] for r in mine]):>11.2f}"
            f"{np.mean([r['fits'] for r in mine]):>6.2f}"
            f"{np.mean([r['healthy'] for r in mine]):>9.2f}"
            f"   {100 * np.median(np.abs([r['classical_model'] for r in mine])):>15.1f}%"
            f"{100 * np.median(np.abs([r['allan'] for r in mine])):>14.1f}%"
        )
        print(f"  {'':<21}terms chosen: {dict(Counter(row['terms'] for row in mine))}")
    covered = sum(row["covered"] for row in rows)
    low, high = stats.binom.ppf([0.025, 0.975], len(rows), 0.9) / len(rows)
    within = np.mean([abs(row["auto"]) < 0.05 for row in rows])
    print(
        f"  all: N within 5 % in {within:.2f} of records; 90 % intervals cover "
        f"{covered / len(rows):.3f} (a calibrated interval: {low:.3f}-{high:.3f} with 95 % "
        "probability)"
    )
    if args.discover:
        print(f"  discovery on {args.discover} records per kind (seeds as above):")
        for kind_index, kind in enumerate(KINDS):
            if kind not in kinds:
                continue
            named = Counter()
            for index in range(args.discover):
                values, _ = simulate(kind, args.samples, 1000 * kind_index + index)
                found = bc.discover(values, RATE, unit="deg/s", posterior=False)
                named.update(effect.name for effect in found.effects)
            expected = EXPECTED_EFFECT[kind]
            print(
                f"  {kind:<21}{expected} named in {named[expected]}/{args.discover}; "
                f"all named: {dict(named)}"
            )


if __name__ == "__main__":
    main()
