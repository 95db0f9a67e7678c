"""The in-field update at rest over many simulated parks: what the alignment recovers, whether
its intervals cover, and how long one update takes (issue 35's done-when).

    nice -n 10 python benchmarks/infield_alignment.py [--parks 100] [--seed 0]

Each park (bc.simulate_park): a navigation-grade IMU (angle random walk 0.002 deg/sqrt(h),
bias instability 0.0005 deg/h; accelerometers 20 ug/sqrt(Hz), 1 ug; biases 50 ug) standing
20 minutes at 100 Hz at latitude 45 deg, heading 30 deg, roll 0.5 deg, pitch -0.8 deg,
warming from 20 to 38.6 degC; its gyros' thermal polynomials are the example chamber
calibration (bayescal.capabilities._examples: degree 2 about 30 degC, sd of c0 0.0025 deg/h)
plus its own error and an aging of 3-5 times its sd of c0 (uniform, per park), drawn as the
drift model of the update says. bc.infield_update runs on each, as
``bayescal thermal infield`` does.

Printed, against ../shared/NAVIGATION.md's ideal figures:
- the north-projected bias (mean over the park): posterior sd and RMS error against the ARW
  limit 0.0034 deg/h (= ARW / sqrt(T)), its 90 % coverage (target 86-94 %);
- the east level: posterior sd / prior sd (target >= 0.9) and coverage;
- the north and east projections of the thermal slope at the mean temperature: posterior sd
  and RMS error against 0.00076 deg/h/degC, the data's own sd (1/sd^2 = 1/post^2 - 1/prior^2),
  coverage;
- the heading error: sd and coverage;
- the time of one update: in-process once compiled, and ``bayescal thermal infield`` on a CSV
  in a fresh process with an empty compilation cache (what a first run on a new machine pays).

Each park is updated twice: with the aging learned from the alignment (the default) and with
the aging scale given (``--given``, in the calibration's sd of c0), since the alignment informs
the aging in a few directions only and the east level and the heading lean on it.
"""

import argparse
import math
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _common import fresh_cache_environment

ARW_LIMIT = 0.002 / math.sqrt(1200 / 3600)  # deg/h
SLOPE_IDEAL = 0.00076  # deg/h/degC, NAVIGATION.md
GYROS = ("gyro_x", "gyro_y", "gyro_z")


def truth_of(park) -> dict:
    attitude = park.truth["attitude"]
    temperature = park.recording.columns["temperature"]
    found = {}
    for row, direction in enumerate(("north", "east")):
        level = slope = at_reference = 0.0
        for axis, name in enumerate(GYROS):
            polynomial = park.truth["thermal"][name]
            level += attitude[row, axis] * park.gyro_bias(name, temperature).mean()
            at_reference += attitude[row, axis] * polynomial["coefficients"][0]
            power = np.arange(len(polynomial["coefficients"]))
            weights = power * (temperature.mean() - polynomial["reference"]) ** np.maximum(
                power - 1, 0
            )
            slope += attitude[row, axis] * weights @ polynomial["coefficients"]
        found[direction] = {
            "level": level * 3600,
            "level_at_reference": at_reference * 3600,
            "slope": slope * 3600,
        }
    return found


def summarize(park, result, seconds: float, aging: float) -> dict:
    truth = truth_of(park)
    row = {"seconds": seconds, "passed": result.passed, "aging": aging}
    true_scale = park.truth["thermal"]["gyro_x"]["aging_scale"]
    drift = result.posterior.drift / (math.pi / 180)
    row["drift"] = (float(np.median(drift)) / true_scale, float(np.mean(drift < true_scale)))
    for direction in ("north", "east"):
        for kind in ("level", "level_at_reference", "slope"):
            entry = result.projections[direction][kind]
            row[f"{direction}_{kind}"] = (
                entry["mean"] - truth[direction][kind],
                entry["sd"],
                entry["prior_sd"],
                entry["q05"] <= truth[direction][kind] <= entry["q95"],
            )
    computed = result.alignment["final_attitude_deg"]["heading"]
    true_heading = (computed - park.truth["heading"] + 180) % 360 - 180
    heading = result.heading_error
    row["heading"] = (
        heading["mean"] - true_heading,
        heading["sd"],
        math.nan,
        heading["q05"] <= true_heading <= heading["q95"],
    )
    return row


def one_park(seed: int, old, given: float) -> tuple[dict, dict]:
    """The park's update with the aging learned (the default) and given as ``given`` times
    the calibration's sd of c0."""
    import bayescal as bc

    rng = np.random.default_rng(10_000 + seed)
    aging = rng.uniform(3.0, 5.0)
    park = bc.simulate_park(old, aging=aging, seed=seed)
    rows = []
    for drift in ("auto", given * math.sqrt(old["gyro_x"].covariance[0, 0])):
        started = time.perf_counter()
        result = bc.infield_update(
            park.recording, old, latitude=45.0, align=(0, 1200), seed=seed, drift=drift
        )
        rows.append(summarize(park, result, time.perf_counter() - started, aging))
    return rows[0], rows[1]


def cold_command_line(old) -> tuple[float, float]:
    """Wall and CPU seconds of ``bayescal thermal infield`` on a 20-minute, 100 Hz CSV in a
    fresh process whose JAX compilation cache starts empty (CPU time: what a busy machine does
    not inflate)."""
    import bayescal as bc
    from bayescal._output import write_csv

    park = bc.simulate_park(old, seed=999)
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        recording = park.recording
        write_csv(
            folder / "park.csv",
            {f"{k}[{recording.header_units[k]}]": v for k, v in recording.columns.items()},
        )
        bc.save_thermal_calibrations(old, folder / "old.json")
        environment = fresh_cache_environment(folder / "cache")
        command = [
            *(sys.executable, "-m", "bayescal.cli._main"),
            *("thermal", "infield", str(folder / "park.csv")),
            *("--calibration", str(folder / "old.json"), "--latitude", "45"),
            *("--align", "0:1200", "--unit", "deg/s", "--json", str(folder / "out.json")),
            *("--save", str(folder / "new.json"), "--quiet"),
        ]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        started = time.perf_counter()
        done = subprocess.run(command, check=False, env=environment, capture_output=True, text=True)
        seconds = time.perf_counter() - started
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if done.returncode != 0:
            raise RuntimeError(done.stderr)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return seconds, cpu


def report(rows: list[dict], drift_learned: bool = True) -> None:
    def column(name, index):
        return np.array([row[name][index] for row in rows], dtype=float)

    print(f"{len(rows)} parks; all checks passed: {all(row['passed'] for row in rows)}")
    for name, ideal, unit in (
        ("north_level", ARW_LIMIT, "deg/h"),
        ("east_level", None, "deg/h"),
        ("east_level_at_reference", None, "deg/h"),
        ("north_slope", SLOPE_IDEAL, "deg/h/degC"),
        ("east_slope", SLOPE_IDEAL, "deg/h/degC"),
        ("heading", None, "deg"),
    ):
        error, sd, prior, covered = (column(name, i) for i in range(4))
        z = error / sd
        line = (
            f"{name:24} posterior sd {np.mean(sd):.3g} (median {np.median(sd):.3g}), RMS error "
            f"{np.sqrt(np.mean(error**2)):.3g} {unit}; 90 % intervals cover "
            f"{100 * np.mean(covered):.1f} %; error / sd: mean {z.mean():+.2f}, sd {z.std():.2f}"
        )
        if name != "heading":
            line += f"; sd / prior sd {np.mean(sd / prior):.3f} (min {np.min(sd / prior):.3f})"
            own = 1 / np.sqrt(np.maximum(1 / sd**2 - 1 / prior**2, 1e-300))
            if ideal is not None:
                line += (
                    f"; the data's own sd {np.median(own):.3g} (ideal {ideal:.3g}: "
                    f"{np.median(own) / ideal:.2f}x), posterior sd {np.mean(sd) / ideal:.2f}x"
                )
        print(line)
    if drift_learned:
        ratio = np.array([row["drift"][0] for row in rows])
        rank = np.array([row["drift"][1] for row in rows])
        print(
            f"aging scale learned: posterior median / truth {np.median(ratio):.2f} (quartiles "
            f"{np.quantile(ratio, 0.25):.2f}-{np.quantile(ratio, 0.75):.2f}); the truth's "
            f"posterior quantile: mean {rank.mean():.2f}, sd {rank.std():.2f} (uniform: 0.50, "
            "0.29)"
        )
    seconds = np.array([row["seconds"] for row in rows])
    print(
        f"one update in-process (compiled): median {np.median(seconds):.2f} s, "
        f"max {seconds.max():.2f} s"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--parks", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-timing", action="store_true", help="skip the cold CLI run")
    parser.add_argument(
        "--given",
        type=float,
        default=4.0,
        help="the aging scale of the second run, in the calibration's sd of c0 (default 4: "
        "the middle of the simulated 3-5)",
    )
    args = parser.parse_args()
    from bayescal.capabilities._examples import example_gyro_calibrations

    old = example_gyro_calibrations()
    if not args.no_timing:
        wall, cpu = cold_command_line(old)
        print(
            "bayescal thermal infield, 20 min at 100 Hz, fresh process and cache: "
            f"{wall:.1f} s wall, {cpu:.1f} s CPU (both cores together)"
        )
    learned, given = [], []
    for index in range(args.parks):
        first, second = one_park(args.seed + index, old, args.given)
        learned.append(first)
        given.append(second)
        if (index + 1) % 10 == 0:
            print(f"... {index + 1} parks", flush=True)
    if not learned:
        return
    print("== the aging learned from the alignment (drift='auto', the default)")
    report(learned)
    print(f"== the aging given: {args.given:g} times the calibration's sd of c0 (drift=S)")
    report(given, drift_learned=False)


if __name__ == "__main__":
    main()
