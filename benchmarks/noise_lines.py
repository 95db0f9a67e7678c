"""Spectral lines over white noise, a rate random walk and an output filter: does ``noise``
find every line above the detection limit, invent none on clean records, and keep N (the
floor between the lines) within 5 % of the truth with nominal coverage?

    python benchmarks/noise_lines.py [--records 100] [--clean 200] [--samples 16384]

Each record (seeded by its index): 100 Hz, N = 0.01 U/sqrt(Hz) (a sample sd s of 0.1 U), a
rate random walk K = 2e-4 U sqrt(Hz), the one-tap output filter F uniform in [0.2, 0.5], and
1 to 20 lines of amplitude 0.2 to 5 s (log-uniform), at frequencies uniform from 0.5 Hz to
0.45 fs; a quarter of them placed 1.5 to 3 Fourier frequencies from another line. Each is
fitted with ``terms="auto"`` (seed 0). A line is above the detection limit where the test
finds it with probability >= 0.999 at its frequency: the non-central chi-square of its
expected peak ordinate (the taper's scalloping at its offset from the Fourier frequencies,
the true spectrum under it) against the F threshold of the test. (At 16,384 samples the limit
is 0.04 to 0.11 sample sd, so every line drawn is above it; shorter records put some below.)
Found lines are matched to true ones within two Fourier frequencies, one to one, the
closest first: a pair taken for one line counts one found. The clean records (``--clean``,
the same noise without lines) are only searched for lines (``find_lines``, what ``noise``
runs first). Prints N's error and coverage, lines found above and below the limit and of
those within 3 Fourier frequencies of another, lines invented, and the coverage of the
lines' frequency and amplitude intervals.
"""

import argparse
import math
import sys
import time

import numpy as np
from scipy import stats

RATE = 100.0
N = 0.01
K = 2e-4


def truth(index: int, samples: int, with_lines: bool) -> dict:
    """The noise and lines of record ``index`` (module docstring)."""
    rng = np.random.default_rng(10_000 + index)
    values = {"N": N, "K": K, "F": float(rng.uniform(0.2, 0.5))}
    if not with_lines:
        return values
    sd = N * math.sqrt(RATE)
    resolution = RATE / samples
    count = int(rng.integers(1, 21))
    frequencies = []
    while len(frequencies) < count:
        if frequencies and rng.random() < 0.25:
            step = rng.uniform(1.5, 3.0) * resolution * rng.choice([-1, 1])
            candidate = frequencies[int(rng.integers(len(frequencies)))] + step
        else:
            candidate = rng.uniform(0.5, 0.45 * RATE)
        others = np.abs(np.array(frequencies) - candidate) if frequencies else np.array([np.inf])
        if 0.5 < candidate < 0.45 * RATE and others.min() > 1.4 * resolution:
            frequencies.append(float(candidate))
    amplitudes = sd * np.exp(rng.uniform(math.log(0.2), math.log(5.0), count))
    return values | {"line_frequency": tuple(frequencies), "line_amplitude": tuple(amplitudes)}


def detection_probability(values: dict, samples: int) -> np.ndarray:
    """Each true line's probability of passing the test at its best ordinate (module
    docstring), alone over the noise."""
    import bayescal as bc
    from bayescal.classical._lines import FLOOR_FRACTION, FLOOR_ORDINATES, LINE_LEVEL, SCALES
    from bayescal.classical._periodogram import fast_length_at_most, tukey_window

    size = fast_length_at_most(samples - 1)
    taper = tukey_window(size, 0.1)
    noise = bc.NoiseModel(RATE, N=values["N"], K=values["K"], F=values["F"])
    tests = ((size - 1) // 2 - 10 + 1) * len(SCALES)
    alpha = -math.expm1(math.log1p(-LINE_LEVEL) / tests)
    t = np.arange(size)
    probabilities = []
    lines = zip(values["line_frequency"], values["line_amplitude"], strict=True)
    for frequency, amplitude in lines:
        nu = frequency / RATE
        spectrum = float(noise.psd(frequency)) * RATE * 4 * math.sin(math.pi * nu) ** 2
        best = 0.0
        for ordinate in (math.floor(nu * size), math.ceil(nu * size)):
            offset = nu - ordinate / size
            window = abs(np.dot(taper, np.exp(-2j * np.pi * offset * t))) ** 2 / np.sum(taper**2)
            increment_amplitude = 2 * amplitude * math.sin(math.pi * nu)
            ratio = increment_amplitude**2 / 4 * window / spectrum
            count = 2 * int(np.clip(round(FLOOR_FRACTION * ordinate), *FLOOR_ORDINATES)) - 2
            threshold = stats.f.isf(alpha, 2, 2 * count)
            best = max(best, stats.ncx2.sf(2 * threshold, 2, 2 * ratio))
        probabilities.append(best)
    return np.array(probabilities)


def matched(true_frequencies, found_frequencies, resolution: float) -> np.ndarray:
    """For each true line, the index of the found line within two resolutions, or -1: one to
    one, the closest pairs first (two true lines taken for one found line count once)."""
    found = np.asarray(found_frequencies, dtype=float)
    true = np.asarray(true_frequencies, dtype=float)
    index = np.full(true.size, -1)
    if found.size == 0:
        return index
    distance = np.abs(true[:, None] - found[None, :])
    for flat in np.argsort(distance, axis=None):
        i, j = np.unravel_index(flat, distance.shape)
        if distance[i, j] > 2 * resolution:
            break
        if index[i] < 0 and j not in index:
            index[i] = j
    return index


def close(true_frequencies, resolution: float) -> np.ndarray:
    """Whether each true line lies within three resolutions of another."""
    true = np.asarray(true_frequencies, dtype=float)
    distance = np.abs(true[:, None] - true[None, :])
    np.fill_diagonal(distance, np.inf)
    return distance.min(axis=1) <= 3 * resolution


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=100)
    parser.add_argument("--clean", type=int, default=200)
    parser.add_argument("--samples", type=int, default=2**14)
    parser.add_argument("--start", type=int, default=0, help="first record (resume a run)")
    args = parser.parse_args()

    import bayescal as bc
    from bayescal.classical._lines import find_lines

    invented_clean = 0
    started = time.perf_counter()
    for index in range(args.clean):
        values = truth(100_000 + index, args.samples, with_lines=False)
        record = bc.NoiseModel(RATE, **values).simulate(args.samples, seed=100_000 + index)
        invented_clean += len(find_lines(record, RATE).lines)
    print(
        f"clean records: {args.clean}, lines invented: {invented_clean} "
        f"({time.perf_counter() - started:.0f} s)"
    )
    resolution = RATE / args.samples
    rows = []
    for index in range(args.start, args.start + args.records):
        values = truth(index, args.samples, with_lines=True)
        record = bc.NoiseModel(RATE, **values).simulate(args.samples, seed=index)
        started = time.perf_counter()
        fit = bc.fit_noise(record, RATE, unit="deg/s", seed=0)
        elapsed = time.perf_counter() - started
        lines = fit.lines.lines if fit.lines else ()
        found = [line.frequency_hz["mean"] for line in lines]
        match = matched(values["line_frequency"], found, resolution)
        limit = detection_probability(values, args.samples)
        near = close(values["line_frequency"], resolution)
        above = limit >= 0.999
        used = set(match[match >= 0].tolist())
        invented = len(found) - len(used)
        frequency_held = amplitude_held = checked = 0
        for true_index, found_index in enumerate(match):
            if found_index < 0 or lines[found_index].broadened:
                continue
            line = lines[found_index]
            checked += 1
            f_true = values["line_frequency"][true_index]
            a_true = values["line_amplitude"][true_index]
            frequency_held += line.frequency_hz["q05"] <= f_true <= line.frequency_hz["q95"]
            amplitude_held += line.amplitude["q05"] <= a_true <= line.amplitude["q95"]
        summary = fit.summary["N"]
        row = {
            "index": index,
            "lines": len(values["line_frequency"]),
            "above": int(above.sum()),
            "found_above": int(np.sum(above & (match >= 0))),
            "below": int((~above).sum()),
            "close": int(near.sum()),
            "found_close": int(np.sum(near & (match >= 0))),
            "found_below": int(np.sum(~above & (match >= 0))),
            "invented": invented,
            "broadened": sum(line.broadened for line in lines),
            "n_ratio": summary["mean"] / N,
            "n_held": summary["q05"] <= N <= summary["q95"],
            "frequency_held": frequency_held,
            "amplitude_held": amplitude_held,
            "checked": checked,
            "passed": fit.diagnostics.passed,
            "fits": fit.fits,
            "terms": ",".join(t for t in fit.terms if t not in ("white", "spectral_lines")),
        }
        rows.append(row)
        print(
            f"record {index:3d}: {row['lines']:2d} lines ({row['above']} above the limit, "
            f"{row['found_above']} found; {row['found_below']}/{row['below']} below; "
            f"{row['found_close']}/{row['close']} within 3 bins of another), "
            f"{invented} invented, {row['broadened']} broadened; N/truth {row['n_ratio']:.4f} "
            f"{'in' if row['n_held'] else 'OUT of'} its 90 % interval; f {frequency_held}/"
            f"{checked}, A {amplitude_held}/{checked} held; sampler "
            f"{'passed' if row['passed'] else 'FAILED'}, {'fits' if row['fits'] else 'MISFIT'}; "
            f"{row['terms']} ({elapsed:.0f} s)"
        )
        sys.stdout.flush()
    if not rows:
        return 0
    ratios = np.array([row["n_ratio"] for row in rows])
    held = np.array([row["n_held"] for row in rows])
    total = {key: sum(row[key] for row in rows) for key in rows[0] if key not in ("terms",)}
    low, high = stats.binom.interval(0.95, len(rows), 0.9)
    print(
        f"\n{len(rows)} records: N/truth median {np.median(ratios):.4f}, worst "
        f"{ratios[np.argmax(np.abs(ratios - 1))]:.4f}, within 5 %: "
        f"{np.mean(np.abs(ratios - 1) <= 0.05):.1%}; N's 90 % interval held the truth "
        f"{held.mean():.1%} (95 % of runs of a calibrated interval: {low / len(rows):.0%}-"
        f"{high / len(rows):.0%})"
    )
    print(
        f"lines above the detection limit found: {total['found_above']}/{total['above']} "
        f"({total['found_close']}/{total['close']} of those within 3 Fourier frequencies of "
        f"another); "
        f"below it: {total['found_below']}/{total['below']}; invented: {total['invented']} "
        f"(broadened: {total['broadened']}); frequency intervals held "
        f"{total['frequency_held']}/{total['checked']}, amplitude intervals "
        f"{total['amplitude_held']}/{total['checked']}; sampler failures "
        f"{len(rows) - total['passed']}, misfits {len(rows) - total['fits']}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
