"""The in-field update with a taxi along a known track over many simulated park + taxi
scenarios (issue 36): whether the heading error's and the updated coefficients' intervals
cover, how far the taxi narrows the east bias level, the ablations, and what the update buys
in free inertial navigation.

    nice -n 10 python benchmarks/infield_taxi.py [--scenarios 100] [--rate 100] [--seed 0]
        [--aging 4] [--aging-shape drift|level] [--tactical] [--given-aging] [--park-s 1200]
        [--warmup 20:38.6] [--wander 0.5:20] [--gnss SD] [--workers 1] [--no-ablations]
        [--every 10] [--dump FILE]

Each scenario: benchmarks/infield_alignment.py's park (navigation grade, 20 minutes, latitude
45 deg, heading 30 deg, warming 20 -> 38.6 degC), aged by ``--aging`` times the calibration's
sd of c0 (``--aging-shape``: ``drift``, the default, every coefficient by the update's own drift
model, c_j by N(0, (s / h^j)^2); ``level``, the bias level c0 alone by N(0, s^2); the update is
not told which and learns s as a user's does; the default keeps every earlier command's figures
as they were), then a taxi of 10 minutes at 10 m/s (bc.Taxi): from rest along 30 deg for 330 s, a 90
deg turn at 3 deg/s, 240 s along 120 deg; the vehicle wanders about the centre line
(second-order Gauss-Markov, ``--wander SD:TAU``, default sd 0.5 m, time constant 20 s; the
same wander is given to the update, ``wander=(sd, tau)``). Four updates per scenario:

- taxi: ``taxi=(1200, end), track_heading=(30, 120)``;
- not aged: the same, on the scenario drawn with no aging since the calibration;
- no taxi (ablation): the park alone; the east level should stay at its prior;
- heading forced to zero (ablation): the park alone with the coarse heading taken as exact
  (its prior sd 1e-9 rad): the east level then looks measured, and its intervals should
  stop covering.

Printed per run: the 90 % coverage of the heading error (at the window's end), of the east and
north levels and of every gyro's coefficients (the joint posterior's draws,
``coefficient_draws``: the vertical gyro's stored calibration is kept, its draws are the old one
and the aging); the east level's posterior sd against the ideal 0.0040 deg/h of
../shared/NAVIGATION.md and against its prior sd; the heading error's correlation with the east
level; the time of one update. For the taxi runs also (steps m-q): each gyro's bias error, RMS
over the calibrated range +-5 degC (15-45 degC), of the old calibration, the Bayesian update
and the patent's classical pipeline (heading-corrected points, weighted interpolation of old
and new); the horizontal position error after 1 h of free inertial navigation (parked, and at
250 m/s turning 90 deg every 15 min; ``InFieldUpdate.position_error``) with the old and the
updated calibrations, the gyros at the park's mean temperature and at the taxi's end, and how
often the posterior's predicted 90 % region (chi^2, 2 dof) holds the realised error.
``--given-aging``: every update is given its record's simulated aging scale (``drift=``;
zero where not aged) instead of learning it: what the learned aging costs or not.
``--park-s`` and ``--warmup`` change the park's length and its temperatures (start:end, degC):
what the data must span for the updated calibration to hold over the calibrated range
(benchmarks/infield_ideal.py gives the least bias error any update can reach on these
scenarios: the exact posterior at the true aging scale).
``--tactical``: gyros of ARW 0.05 deg/sqrt(h) and bias instability 0.05 deg/h, calibrated
with 10 times the navigation grade's sds. ``--gnss SD``: the taxi also logs GNSS fixes of SD m
(white, once a second; drawn after the rest, so the IMU's record is the same), and a fifth
update, "positions, no track", takes the heading from them alone (``positions=`` the
latitude and longitude columns, ``position_sd=SD``, no track heading).

The wander and the ideal. ../shared/NAVIGATION.md's ideal east sd (0.0040 deg/h) takes a
known-track taxi with a 0.01 m/s cross-track velocity reference. The wander's cross-track
velocity is that reference's error: for the second-order Gauss-Markov offset w of
bayescal/navigation/_taxi.py (zeta = 1/sqrt(2), omega = 1/tau, white input of density
q = 4 zeta omega^3 sd^2), the velocity's spectrum is omega'^2 q / |omega^2 - omega'^2 +
2i zeta omega omega'|^2, whose integral gives var(dw/dt) = q / (4 zeta omega) = omega^2 sd^2
(Gelb 1974, table 3.8-1): the velocity sd is sd / tau. The default 0.5 m over 20 s is
0.025 m/s, 2.5 times the ideal's reference; 0.05 m over 20 s (benchmarks/infield_wander.py)
is 0.0025 m/s. ``--wander 0.2:20`` (0.2 / 20 = 0.01 m/s) matches the ideal's velocity sd.
It is correlated over tau, where the ideal's reference may be white, so the match is of the
velocity's sd, not of the information per second.

``--workers K`` runs the scenarios in K processes (spawned, each held to one thread:
WORKER_ENV is set before they import numpy or JAX); each scenario is seeded by its own seed,
so the figures are those of the serial run. ``--no-ablations`` keeps the two updates the main
figures need (taxi, not aged) and drops the no-taxi and heading-forced-to-zero ones.
``--dump FILE`` writes one JSON line per scenario (``scenario_record``): what the misses have
in common is read from it (which seeds, the heading's z beside the east level's, the learned
aging scale), not from the coverage alone.
"""

import argparse
import contextlib
import functools
import json
import math
import os
import time

import numpy as np

from bayescal.navigation._simulate import AGING_SHAPES
from bayescal.navigation._taxi import WANDER_SD, WANDER_TIME_S

IDEAL_EAST = 0.0040  # deg/h, ../shared/NAVIGATION.md
GYROS = ("gyro_x", "gyro_y", "gyro_z")
LEGS = ((30.0, 330.0), (120.0, 240.0))
RANGE = np.linspace(15.0, 45.0, 61)  # degC: the calibrated 20-40 degC +- 5
CHI2_2_90 = 4.605  # the 90 % quantile of chi^2 with 2 dof
FLIGHTS = {"parked": 0.0, "250 m/s": 250.0}  # m/s
TACTICAL_GYRO = {"N": 0.05 / 60.0, "B": 0.05 / 3600.0}  # deg/s/sqrt(Hz), deg/s
TACTICAL_SD_FACTOR = 10.0  # the tactical chamber calibration's sds over the navigation grade's
WANDER = (WANDER_SD, WANDER_TIME_S)  # m, s: the simulator's and the update's default
ABLATIONS = ("no taxi", "heading forced to zero")
# One thread per worker: the pool's processes share the cores, and BLAS or XLA threads of
# their own would oversubscribe them. Set before a worker imports numpy or JAX.
WORKER_ENV = {
    **dict.fromkeys(
        ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"), "1"
    ),
    "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1",
}


def tactical(old) -> dict:
    """The example calibrations as a tactical-grade IMU's: its noise (TACTICAL_GYRO) and sds
    TACTICAL_SD_FACTOR times the navigation grade's."""
    from dataclasses import replace

    units = {"N": "deg/s/sqrt(Hz)", "B": "deg/s"}
    noise = {
        key: {"mean": value, "q05": value, "q95": value, "unit": units[key]}
        for key, value in TACTICAL_GYRO.items()
    }
    return {
        name: replace(
            calibration,
            noise={"terms": ["white", "bias_instability"], **noise},
            covariance=calibration.covariance * TACTICAL_SD_FACTOR**2,
        )
        for name, calibration in old.items()
    }


def park_truth(park, rate: float) -> dict:
    """The true east and north levels (mean over the park, deg/h)."""
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
    legs = result.checks["taxi_innovations"]
    row["leg_nis"] = max((leg["sum_nis"] / leg["dof"] for leg in legs), default=math.nan)
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
    covered, scores = [], []
    for name in GYROS:
        true = np.asarray(park.truth["thermal"][name]["coefficients"])
        draws = result.coefficient_draws[name]
        low, high = np.quantile(draws, [0.05, 0.95], axis=0)
        covered.extend(((low <= true) & (true <= high)).tolist())
        scores.extend(((draws.mean(axis=0) - true) / draws.std(axis=0)).tolist())
    row["coefficients"] = covered
    # For --dump: each coefficient's error over its posterior sd (x, y, z; c0, c1, c2 each)
    # and the learned aging scale over the simulated one.
    row["coefficient_z"] = scores
    aging = math.radians(park.truth["thermal"][GYROS[0]]["aging_scale"])  # deg/s -> rad/s
    learned = float(np.median(result.posterior.drift))  # rad/s
    row["drift_over_truth"] = learned / aging if aging > 0 else math.nan
    return row


def payoff(park, result, old) -> dict:
    """Steps m-q: each gyro's bias error over RANGE (old, Bayesian, classical; RMS, deg/h) and
    the 1 h horizontal position error (old, updated, m) with the posterior's prediction."""
    row = {}
    park_n = int(np.searchsorted(park.recording.columns["time"], park.truth["park_s"]))
    record = park.recording.columns["temperature"]
    span = np.linspace(record[:park_n].min(), record[:park_n].max(), 61)
    for name in GYROS:
        true = park.gyro_bias(name, RANGE)
        errors = {
            "old": old[name].bias(RANGE)[0],
            "bayes": result.calibration[name].bias(RANGE)[0],
        }
        classical = result.classical["axes"][name]
        if "coefficients" in classical:
            powers = (RANGE[:, None] - old[name].reference) ** np.arange(old[name].degree + 1)
            errors["classical"] = powers @ classical["coefficients"]
        row[name] = {k: 3600 * float(np.sqrt(np.mean((v - true) ** 2))) for k, v in errors.items()}
        # What the posterior itself predicts for that RMS, and the errors over the park's own
        # temperatures (no extrapolation).
        row[name]["bayes predicted"] = 3600 * float(
            np.sqrt(np.mean(result.calibration[name].bias(RANGE)[1] ** 2))
        )
        inside = park.gyro_bias(name, span)
        for key, calibration in (("old", old[name]), ("bayes", result.calibration[name])):
            row[name][f"{key} in span"] = 3600 * float(
                np.sqrt(np.mean((calibration.bias(span)[0] - inside) ** 2))
            )
    for label, temperature in (("park mean", record[:park_n].mean()), ("taxi end", record[-1])):
        true = np.array([float(park.gyro_bias(name, temperature)) for name in GYROS])
        used = {
            "old": np.array([old[name].bias(temperature)[0] for name in GYROS]),
            "updated": np.array([result.calibration[n].bias(temperature)[0] for n in GYROS]),
        }
        for flight, speed in FLIGHTS.items():
            predicted = result.position_error(temperature, speed=speed)
            realised = {key: predicted["map"] @ (value - true) for key, value in used.items()}
            offset = realised["updated"] - predicted["mean"]
            distance = float(offset @ np.linalg.solve(predicted["covariance"], offset))
            row[f"{flight} at the {label} temperature"] = {
                "old": float(np.hypot(*realised["old"])),
                "updated": float(np.hypot(*realised["updated"])),
                "sd": predicted["sd"],
                "mahalanobis2": distance,
                "covered": distance <= CHI2_2_90,
            }
    return row


def one_scenario(
    seed: int,
    old,
    rate: float,
    aging: float,
    gyro_noise=None,
    park: dict | None = None,
    wander: tuple[float, float] = WANDER,
    ablations: bool = True,
    gnss: float | None = None,
    aging_shape: str = "drift",
    given_aging: bool = False,
) -> dict:
    import bayescal as bc
    from bayescal.navigation import _alignment

    taxi = bc.Taxi(
        legs=LEGS, speed=10.0, wander_sd=wander[0], wander_time_s=wander[1], gnss_sd=gnss
    )
    parks = {
        aged: bc.simulate_park(
            old,
            aging=aged,
            aging_shape=aging_shape,
            rate_hz=rate,
            taxi=taxi,
            gyro_noise=gyro_noise,
            seed=seed,
            **(park or {}),
        )
        for aged in (aging, 0.0)
    }
    park_s = parks[aging].truth["park_s"]
    end = parks[aging].recording.columns["time"][-1] + 1 / rate
    taxied = {"taxi": (park_s, end), "track_heading": [h for h, _ in LEGS], "wander": wander}
    runs = {
        "taxi": (aging, taxied, -1),
        "not aged": (0.0, taxied, -1),
        "no taxi": (aging, {}, round(park_s * rate)),
        "heading forced to zero": (aging, {}, round(park_s * rate)),
    }
    if gnss is not None:
        fixes = {"positions": "gnss_latitude,gnss_longitude", "position_sd": gnss}
        runs["positions, no track"] = (aging, {"taxi": (park_s, end), **fixes}, -1)
    if not ablations:
        runs = {name: run for name, run in runs.items() if name not in ABLATIONS}
    if given_aging:
        # Each record's aging scale as the simulator drew it (one scale for the three gyros;
        # zero where not aged), given instead of learned.
        runs = {
            name: (
                aged,
                {**extra, "drift": parks[aged].truth["thermal"][GYROS[0]]["aging_scale"]},
                last,
            )
            for name, (aged, extra, last) in runs.items()
        }
    rows = {}
    for name, (aged, extra, last) in runs.items():
        saved = _alignment.HEADING_PRIOR
        if name == "heading forced to zero":
            _alignment.HEADING_PRIOR = 1e-9
        try:
            started = time.perf_counter()
            result = bc.infield_update(
                parks[aged].recording, old, latitude=45.0, align=(0, park_s), seed=seed, **extra
            )
            seconds = time.perf_counter() - started
        finally:
            _alignment.HEADING_PRIOR = saved
        final = parks[aged].truth["trajectory"]["heading"][last]
        rows[name] = summarize(parks[aged], result, seconds, rate, final)
        if extra:
            rows[name]["payoff"] = payoff(parks[aged], result, old)
    return rows


def scenario_record(seed: int, rows: dict) -> dict:
    """One scenario's line of ``--dump``: per update, the heading error's and the north and
    east levels' error, posterior sd and z (error / sd; deg, deg/h), the learned aging scale
    over the simulated one, and every coefficient's z (x, y, z; c0, c1, c2 each)."""
    record = {"seed": seed}
    for name, row in rows.items():
        entry = {
            key: {"error": row[key][0], "sd": row[key][1], "z": row[key][0] / row[key][1]}
            for key in ("heading", "east", "north")
        }
        entry["drift_over_truth"] = row["drift_over_truth"]
        entry["coefficient_z"] = row["coefficient_z"]
        record[name] = entry
    return record


def report(name: str, rows: list[dict]) -> None:
    def column(key, index):
        return np.array([row[key][index] for row in rows], dtype=float)

    print(f"== {name}: {len(rows)} scenarios; all checks passed: {all(r['passed'] for r in rows)}")
    for key, unit in (("heading", "deg"), ("east", "deg/h"), ("north", "deg/h")):
        error, sd, prior, covered = (column(key, i) for i in range(4))
        z = error / sd
        line = (
            f"  {key:8} posterior sd mean {np.mean(sd):.3g} {unit} (median "
            f"{np.median(sd):.3g}, 10-90 % {np.quantile(sd, 0.1):.3g}-"
            f"{np.quantile(sd, 0.9):.3g}), RMS error "
            f"{np.sqrt(np.mean(error**2)):.3g} {unit}; 90 % intervals cover "
            f"{100 * np.mean(covered):.1f} %; error/sd mean {z.mean():+.2f} sd {z.std():.2f}"
        )
        if key != "heading":
            line += f"; sd / prior sd {np.mean(sd / prior):.3f}"
        if key == "east":
            line += (
                f"; sd / ideal {IDEAL_EAST:g}: mean {np.mean(sd) / IDEAL_EAST:.2f}x, median "
                f"{np.median(sd) / IDEAL_EAST:.2f}x"
            )
        print(line)
    coefficients = np.array([row["coefficients"] for row in rows], dtype=float)
    per_gyro = coefficients.reshape(len(rows), len(GYROS), -1)
    print(
        f"  coefficients: 90 % intervals cover {100 * coefficients.mean():.1f} % "
        f"({coefficients.size} intervals; per gyro "
        f"{', '.join(f'{g[-1]} {100 * per_gyro[:, i].mean():.0f}' for i, g in enumerate(GYROS))}"
        f" %; per coefficient {', '.join(f'{100 * c:.0f}' for c in coefficients.mean(axis=0))} %)"
    )
    passed = np.array([row["passed"] for row in rows])
    leg_nis = np.array([row["leg_nis"] for row in rows])
    if np.isfinite(leg_nis).any():
        covered = column("heading", 3)
        print(
            f"  taxi legs' NIS / dof: median {np.nanmedian(leg_nis):.2f}, max "
            f"{np.nanmax(leg_nis):.2f}; checks failed in {np.sum(~passed)} runs; heading "
            f"covered in {100 * covered[passed].mean() if passed.any() else math.nan:.0f} % "
            f"of the passed, {100 * covered[~passed].mean() if (~passed).any() else math.nan:.0f}"
            " % of the failed"
        )
    correlation = np.array([row["correlation"] for row in rows])
    seconds = np.array([row["seconds"] for row in rows])
    print(
        f"  heading-east level correlation: mean {correlation.mean():+.2f}; one update "
        f"median {np.median(seconds):.1f} s, max {seconds.max():.1f} s"
    )
    if "payoff" in rows[0]:
        report_payoff([row["payoff"] for row in rows])


def report_payoff(rows: list[dict]) -> None:
    for name in GYROS:
        errors = {k: np.array([row[name][k] for row in rows]) for k in rows[0][name]}
        rms = {k: float(np.sqrt(np.mean(v**2))) for k, v in errors.items()}
        line = (
            f"  {name} bias RMS error over 15-45 degC: old {rms['old']:.3g}, updated "
            f"{rms['bayes']:.3g} deg/h (updated / old {rms['bayes'] / rms['old']:.2f}; per "
            f"scenario median {np.median(errors['bayes'] / errors['old']):.2f})"
        )
        line += (
            f"; the posterior's own RMS sd {rms['bayes predicted']:.3g} deg/h; over the park's "
            f"temperatures only: updated / old {rms['bayes in span'] / rms['old in span']:.2f}"
        )
        if "classical" in rms:
            line += (
                f"; classical {rms['classical']:.3g} deg/h "
                f"({rms['classical'] / rms['old']:.2f} of old)"
            )
        print(line)
    for flight in (key for key in rows[0] if key not in GYROS):
        old, new, sd = (
            np.array([row[flight][k] for row in rows]) for k in ("old", "updated", "sd")
        )
        covered = np.mean([row[flight]["covered"] for row in rows])
        print(
            f"  1 h free inertial, {flight}: horizontal error median old {np.median(old):.0f} m, "
            f"updated {np.median(new):.0f} m ({100 * (1 - np.median(new) / np.median(old)):.0f} "
            f"% below); predicted sd median {np.median(sd):.0f} m; its 90 % region holds the "
            f"realised error in {100 * covered:.0f} %"
        )


@functools.cache
def calibrations(tactical_grade: bool) -> tuple:
    """The old calibrations and the gyros' noise (None: the simulator's navigation grade)."""
    from bayescal.capabilities._examples import example_gyro_calibrations

    old = example_gyro_calibrations()
    return (tactical(old), TACTICAL_GYRO) if tactical_grade else (old, None)


def scenario(seed: int, options: dict) -> dict:
    """One scenario's rows from picklable ``options`` (the pool's unit of work)."""
    old, noise = calibrations(options["tactical"])
    return one_scenario(
        seed,
        old,
        options["rate"],
        options["aging"],
        noise,
        options["park"],
        options["wander"],
        options["ablations"],
        options["gnss"],
        options["aging_shape"],
        options["given_aging"],
    )


def scenarios(seeds, options: dict, workers: int = 1):
    """Each seed's rows, in the seeds' order: in this process, or in ``workers`` spawned ones
    held to one thread each (WORKER_ENV)."""
    if workers == 1:
        yield from (scenario(seed, options) for seed in seeds)
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    # Spawned children copy this environment at their start, before their first import.
    saved = {name: os.environ.get(name) for name in WORKER_ENV}
    os.environ.update(WORKER_ENV)
    try:
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(workers, mp_context=context) as pool:
            yield from pool.map(scenario, seeds, [options] * len(seeds))
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def pair(text: str, flag: str) -> tuple[float, float]:
    try:
        first, second = (float(x) for x in text.split(":"))
    except ValueError:
        raise SystemExit(f"{flag} {text!r}: give two numbers as A:B") from None
    return first, second


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenarios", type=int, default=100)
    parser.add_argument("--rate", type=float, default=100.0, help="the IMU's rate, Hz")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--every", type=int, default=10, help="report every this many")
    parser.add_argument("--aging", type=float, default=4.0, help="in the old sd of c0")
    parser.add_argument(
        "--aging-shape",
        choices=AGING_SHAPES,
        default="drift",
        help="what has aged: every coefficient by the update's drift model (drift), or the bias "
        "level c0 alone (level); the update is not told",
    )
    parser.add_argument("--tactical", action="store_true", help="ARW 0.05 deg/sqrt(h) gyros")
    parser.add_argument(
        "--given-aging",
        action="store_true",
        help="give every update the simulated aging scale (drift=) instead of learning it",
    )
    parser.add_argument("--park-s", type=float, default=1200.0, help="the park's length, s")
    parser.add_argument("--warmup", default="20:38.6", help="START:END degC over the park")
    parser.add_argument("--gnss", type=float, help="GNSS fixes of this sd (m) in the taxi")
    parser.add_argument(
        "--wander",
        default=f"{WANDER[0]:g}:{WANDER[1]:g}",
        help="SD:TAU, m and s: the vehicle's wander about the centre line, simulated and given "
        "to the update (velocity sd SD / TAU; 0.2:20 matches NAVIGATION.md's 0.01 m/s)",
    )
    parser.add_argument("--workers", type=int, default=1, help="processes, one thread each")
    parser.add_argument(
        "--dump",
        metavar="FILE",
        help="write one JSON line per scenario: each update's heading, east and north level "
        "errors, sds and z, the learned aging scale over the truth, the coefficients' z",
    )
    parser.add_argument(
        "--no-ablations",
        dest="ablations",
        action="store_false",
        help="only the taxi and not-aged updates (two per scenario, not four)",
    )
    args = parser.parse_args()
    if args.workers < 1:
        raise SystemExit(f"--workers {args.workers}: give 1 or more")
    wander = pair(args.wander, "--wander")
    options = {
        "rate": args.rate,
        "aging": args.aging,
        "aging_shape": args.aging_shape,
        "given_aging": args.given_aging,
        "tactical": args.tactical,
        "park": {"duration_s": args.park_s, "warmup": pair(args.warmup, "--warmup")},
        "wander": wander,
        "ablations": args.ablations,
        "gnss": args.gnss,
    }
    print(
        f"wander sd {wander[0]:g} m, time constant {wander[1]:g} s: cross-track velocity sd "
        f"{wander[0] / wander[1]:.4g} m/s; aging {args.aging:g} sd of c0, shape "
        f"{args.aging_shape}; {args.workers} worker(s)",
        flush=True,
    )
    started = time.perf_counter()
    results: dict[str, list] = {}
    seeds = [args.seed + index for index in range(args.scenarios)]
    with open(args.dump, "w") if args.dump else contextlib.nullcontext() as dump:
        for index, rows in enumerate(scenarios(seeds, options, args.workers)):
            for name, row in rows.items():
                results.setdefault(name, []).append(row)
            if args.dump:
                dump.write(json.dumps(scenario_record(seeds[index], rows)) + "\n")
                dump.flush()
            if (index + 1) % args.every == 0 or index + 1 == args.scenarios:
                elapsed = time.perf_counter() - started
                print(
                    f"... {index + 1} scenarios, {elapsed:.0f} s wall "
                    f"({elapsed / (index + 1):.0f} s per scenario)",
                    flush=True,
                )
                for name, collected in results.items():
                    report(name, collected)


if __name__ == "__main__":
    main()
