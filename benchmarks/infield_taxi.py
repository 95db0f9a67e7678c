"""The in-field update with a taxi along a known track over many simulated park + taxi
scenarios (issue 36): whether the heading error's and the updated coefficients' intervals
cover, how far the taxi narrows the east bias level, and the ablations.

    nice -n 10 python benchmarks/infield_taxi.py [--scenarios 100] [--rate 100] [--seed 0]

Each scenario: benchmarks/infield_alignment.py's park (navigation grade, 20 minutes, latitude
45 deg, heading 30 deg, warming 20 -> 38.6 degC, aging 3-5 times the calibration's sd of c0),
then a taxi of 10 minutes at 10 m/s (bc.Taxi): from rest along 30 deg for 330 s, a 90 deg turn
at 3 deg/s, 240 s along 120 deg; the vehicle wanders about the centre line (second-order
Gauss-Markov, sd 0.5 m, time constant 20 s). Three updates per scenario:

- taxi: ``taxi=(1200, end), track_heading=(30, 120)``;
- no taxi (ablation): the park alone; the east level should stay at its prior;
- heading forced to zero (ablation): the park alone with the coarse heading taken as exact
  (its prior sd 1e-9 rad): the east level then looks measured, and its intervals should
  stop covering.

Printed: per run the 90 % coverage of the heading error (at the window's end), of the east and
north levels and of each horizontal gyro's updated coefficients; the east level's posterior sd
against the ideal 0.0040 deg/h of ../shared/NAVIGATION.md and against its prior sd; the
correlation of the heading error with the east level; the time of one update.
"""

import argparse
import math
import time

import numpy as np

IDEAL_EAST = 0.0040  # deg/h, ../shared/NAVIGATION.md
GYROS = ("gyro_x", "gyro_y", "gyro_z")
LEGS = ((30.0, 330.0), (120.0, 240.0))


def park_truth(park, rate: float) -> dict:
    """The true east and north levels (mean over the park, deg/h) and the final heading."""
    attitude = park.truth["attitude"]
    samples = round(park.truth["park_s"] * rate)
    temperature = park.recording.columns["temperature"][:samples]
    levels = {}
    for row, direction in enumerate(("north", "east")):
        levels[direction] = 3600 * sum(
            attitude[row, axis] * park.gyro_bias(name, temperature).mean()
            for axis, name in enumerate(GYROS)
        )
    return levels


def summarize(park, result, seconds: float, rate: float, final_heading: float) -> dict:
    truth = park_truth(park, rate)
    row = {"seconds": seconds, "passed": result.passed}
    for direction in ("north", "east"):
        entry = result.projections[direction]["level"]
        row[direction] = (
            entry["mean"] - truth[direction],
            entry["sd"],
            entry["prior_sd"],
            entry["q05"] <= truth[direction] <= entry["q95"],
        )
    computed = result.alignment["final_attitude_deg"]["heading"]
    true_error = (computed - final_heading + 180) % 360 - 180
    heading = result.heading_error
    row["heading"] = (
        heading["mean"] - true_error,
        heading["sd"],
        math.nan,
        heading["q05"] <= true_error <= heading["q95"],
    )
    row["correlation"] = heading["correlation_with_east_level"]
    covered = []
    for name in GYROS[:2]:
        calibration = result.calibration[name]
        true = np.asarray(park.truth["thermal"][name]["coefficients"])
        low = np.asarray(calibration.bayesian["coefficient_q05"])
        high = np.asarray(calibration.bayesian["coefficient_q95"])
        covered.extend(((low <= true) & (true <= high)).tolist())
    row["coefficients"] = covered
    return row


def one_scenario(seed: int, old, rate: float) -> dict:
    import bayescal as bc
    from bayescal.navigation import _alignment

    rng = np.random.default_rng(20_000 + seed)
    aging = rng.uniform(3.0, 5.0)
    taxi = bc.Taxi(legs=LEGS, speed=10.0)
    park = bc.simulate_park(old, aging=aging, rate_hz=rate, taxi=taxi, seed=seed)
    park_s = park.truth["park_s"]
    end = park.recording.columns["time"][-1] + 1 / rate
    rows = {}
    runs = {
        "taxi": ({"taxi": (park_s, end), "track_heading": [h for h, _ in LEGS]}, -1),
        "no taxi": ({}, round(park_s * rate)),
        "heading forced to zero": ({}, round(park_s * rate)),
    }
    for name, (extra, last) in runs.items():
        recording = park.recording
        saved = _alignment.HEADING_PRIOR
        if name == "heading forced to zero":
            _alignment.HEADING_PRIOR = 1e-9
        try:
            started = time.perf_counter()
            result = bc.infield_update(
                recording, old, latitude=45.0, align=(0, park_s), seed=seed, **extra
            )
            seconds = time.perf_counter() - started
        finally:
            _alignment.HEADING_PRIOR = saved
        final = park.truth["trajectory"]["heading"][last]
        rows[name] = summarize(park, result, seconds, rate, final)
    return rows


def report(name: str, rows: list[dict]) -> None:
    def column(key, index):
        return np.array([row[key][index] for row in rows], dtype=float)

    print(f"== {name}: {len(rows)} scenarios; all checks passed: {all(r['passed'] for r in rows)}")
    for key, unit in (("heading", "deg"), ("east", "deg/h"), ("north", "deg/h")):
        error, sd, prior, covered = (column(key, i) for i in range(4))
        z = error / sd
        line = (
            f"  {key:8} posterior sd mean {np.mean(sd):.3g} {unit}, RMS error "
            f"{np.sqrt(np.mean(error**2)):.3g} {unit}; 90 % intervals cover "
            f"{100 * np.mean(covered):.1f} %; error/sd mean {z.mean():+.2f} sd {z.std():.2f}"
        )
        if key != "heading":
            line += f"; sd / prior sd {np.mean(sd / prior):.3f}"
        if key == "east":
            line += f"; sd / ideal {IDEAL_EAST:g}: {np.mean(sd) / IDEAL_EAST:.2f}x"
        print(line)
    coefficients = np.array([row["coefficients"] for row in rows], dtype=float)
    print(
        f"  x and y gyro coefficients: 90 % intervals cover {100 * coefficients.mean():.1f} % "
        f"({coefficients.size} intervals; per coefficient "
        f"{', '.join(f'{100 * c:.0f}' for c in coefficients.mean(axis=0))} %)"
    )
    correlation = np.array([row["correlation"] for row in rows])
    seconds = np.array([row["seconds"] for row in rows])
    print(
        f"  heading-east level correlation: mean {correlation.mean():+.2f}; one update "
        f"median {np.median(seconds):.1f} s, max {seconds.max():.1f} s"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenarios", type=int, default=100)
    parser.add_argument("--rate", type=float, default=100.0, help="the IMU's rate, Hz")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--every", type=int, default=10, help="report every this many")
    args = parser.parse_args()
    from bayescal.capabilities._examples import example_gyro_calibrations

    old = example_gyro_calibrations()
    results: dict[str, list] = {}
    for index in range(args.scenarios):
        for name, row in one_scenario(args.seed + index, old, args.rate).items():
            results.setdefault(name, []).append(row)
        if (index + 1) % args.every == 0 or index + 1 == args.scenarios:
            print(f"... {index + 1} scenarios", flush=True)
            for name, rows in results.items():
                report(name, rows)


if __name__ == "__main__":
    main()
