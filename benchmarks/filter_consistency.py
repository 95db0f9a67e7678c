"""Does a navigation filter told bayescal's exported noise have the covariance of its errors?
The consistency check of issue 37 item 2, beside the common practice (the bare Allan-line
values).

    python benchmarks/filter_consistency.py [--runs 50] [--minutes 10] [--static-minutes 60]
                                            [--horizons 600,60] [--seed 1]

For each grade (MEMS, tactical, and the MEMS unit on a vibrating vehicle; the truths below,
SI), a static record of each sensor (``--static-minutes`` at 100 Hz: white noise through a
one-tap output filter F = 0.3, bias instability, rate random walk) is fitted with those terms
(``bc.fit_noise``) and exported for Kalibr (``bc.filter_noise``, continuous-time N and K) at
each ``--horizon`` and with each channel's horizon from the drive's aiding (``aiding=``); for
the vibrating vehicle also with a 10-minute record with the motors running (``vibration=``),
whose extra white noise the drive carries (the vibration enters before the output filter,
the white noise doubled in the gyro and tripled in the accelerometer); the Allan-line
values are the classical readings of the same records (N on the -1/2 line at tau = 1 s, K on
the +1/2 line at tau = 3 s, as read). Then ``--runs`` seeded drives of ``--minutes`` (a
vehicle at 10 m/s swinging its heading +-90 deg every minute, position fixes of 1 m sd every
second; :mod:`bayescal.navigation._consistency`) with the truth's IMU, each filtered with every
set of values. Printed per grade and set: the values, the median over runs of the run's mean
NEES (7 navigation states), its 95 % band for a consistent filter (2.5-97.5 % of the mean NEES
over 400 runs whose truth is the filter's own model), the fraction of runs inside it (and
above it: overconfident), and the fraction of runs whose mean NIS lies in its chi^2(2 J) / J
95 % band. Target (issue 37): exported values inside in >= 80 % of runs, the Allan line not.
"""

import argparse
import math
import time

import numpy as np
from scipy.stats import chi2

import bayescal as bc
from bayescal.navigation._consistency import (
    Grade,
    Scenario,
    filter_model,
    nees_band,
    scores,
    setup,
    simulate_runs,
)

DEG = math.pi / 180
G = 9.80665
RATE = 100.0
F = 0.3
GRADES = {
    "MEMS": Grade(
        gyro={"N": 0.3 / 60 * DEG, "B": 10 / 3600 * DEG, "K": 2 / 3600 / 60 * DEG, "F": F},
        accel={"N": 100e-6 * G, "B": 50e-6 * G, "K": 2e-5, "F": F},
        gyro_bias_sd=100 / 3600 * DEG,
        accel_bias_sd=5e-3,
    ),
    "tactical": Grade(
        gyro={"N": 0.05 / 60 * DEG, "B": 1 / 3600 * DEG, "K": 0.1 / 3600 / 60 * DEG, "F": F},
        accel={"N": 30e-6 * G, "B": 10e-6 * G, "K": 3e-6, "F": F},
        gyro_bias_sd=5 / 3600 * DEG,
        accel_bias_sd=1e-3,
    ),
}
# The MEMS unit on a vibrating vehicle: its white noise doubled (gyro) and tripled
# (accelerometer) while it moves, measured by a static record with the motors running.
GRADES["MEMS, vibrating"] = Grade(
    GRADES["MEMS"].gyro,
    GRADES["MEMS"].accel,
    GRADES["MEMS"].gyro_bias_sd,
    GRADES["MEMS"].accel_bias_sd,
    vibration=(math.sqrt(3) * GRADES["MEMS"].gyro["N"], math.sqrt(8) * GRADES["MEMS"].accel["N"]),
)
TERMS = ("white", "output_filter", "bias_instability", "rate_random_walk")


def values_of(grade: Grade, minutes: float, horizons, aiding: bc.Aiding, seed: int) -> dict:
    """label -> (white (gyro, accel), walk (gyro, accel)), SI: exported at each horizon and
    with the horizon from the aiding (and, for a vibrating grade, with and without the motors'
    record), and the Allan line's readings."""
    n = round(minutes * 60 * RATE)
    fits, allan, shaking = [], {"N": [], "K": []}, {}
    for index, (name, unit) in enumerate((("gyro_x", "rad/s"), ("acc_x", "m/s^2"))):
        truth = grade.gyro if index == 0 else grade.accel
        record = bc.NoiseModel(rate_hz=RATE, **truth).simulate(n, seed=seed + index)
        fit = bc.fit_noise(record, RATE, terms=TERMS, unit=unit, channel=name, seed=seed)
        if not fit.passed:
            print(f"    {name}: the fit failed its checks: {'; '.join(fit.failures)}")
        fits.append(fit)
        for p in ("N", "K"):
            allan[p].append(fit.classical.slope_readings[p].value)
        if any(grade.vibration):
            motors = bc.NoiseModel(rate_hz=RATE, **grade.moving(3 * index))
            shaking[name] = motors.simulate(round(10 * 60 * RATE), seed=seed + 10 + index)

    def densities(noise) -> tuple:
        return tuple(
            tuple(noise.channels[c].density[p] for c in ("gyro_x", "acc_x")) for p in ("N", "K")
        )

    found = {}
    for horizon in horizons:
        noise = bc.filter_noise(fits, estimator="kalibr", horizon=horizon)
        found[f"exported, H = {horizon:g} s"] = densities(noise)
    noise = bc.filter_noise(fits, estimator="kalibr", aiding=aiding)
    spans = "/".join(f"{noise.channels[c].horizon_s:.0f}" for c in ("gyro_x", "acc_x"))
    found[f"exported, aided H {spans} s"] = densities(noise)
    if shaking:
        noise = bc.filter_noise(fits, estimator="kalibr", aiding=aiding, vibration=shaking)
        found["exported + vibration"] = densities(noise)
    found["Allan line"] = (tuple(allan["N"]), tuple(allan["K"]))
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=50)
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--static-minutes", type=float, default=60.0)
    parser.add_argument("--horizons", default="600,60")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    horizons = [float(h) for h in args.horizons.split(",")]
    started = time.perf_counter()
    scenario = Scenario(duration_s=args.minutes * 60)
    prepared = setup(scenario)
    fixes_count = scenario.fixes + 1
    nis_band = chi2.ppf([0.025, 0.975], 2 * fixes_count) / fixes_count
    print(
        f"filter consistency: {args.runs} drives of {args.minutes:g} min, fixes every "
        f"{scenario.fix_interval_s:g} s (sd {scenario.fix_sd_m:g} m), static records of "
        f"{args.static_minutes:g} min at {RATE:g} Hz; mean NEES of 7 states per run; NIS "
        f"band [{nis_band[0]:.3f}, {nis_band[1]:.3f}]"
    )
    for grade_name, grade in GRADES.items():
        aiding = bc.Aiding("position", scenario.fix_sd_m, scenario.fix_interval_s)
        sets = values_of(grade, args.static_minutes, horizons, aiding, args.seed)
        truth, fixes = simulate_runs(prepared, grade, args.runs, args.seed)
        print(f"  {grade_name}")
        print(
            f"    {'values':<27}{'N_g':>10}{'K_g':>10}{'N_a':>10}{'K_a':>10}"
            f"{'NEES':>7}{'band':>14}{'inside':>8}{'above':>7}{'NIS in':>8}"
        )
        for label, (white, walk) in sets.items():
            model, scale = filter_model(prepared, grade, white, walk)
            nees, nis = scores(model, scale, truth, fixes)
            low, high = nees_band(model, 400, args.seed + 7)
            inside = np.mean((nees >= low) & (nees <= high))
            above = np.mean(nees > high)
            nis_in = np.mean((nis >= nis_band[0]) & (nis <= nis_band[1]))
            print(
                f"    {label:<27}{white[0]:>10.2e}{walk[0]:>10.2e}{white[1]:>10.2e}"
                f"{walk[1]:>10.2e}{np.median(nees):>7.2f}  [{low:5.2f}, {high:5.2f}]"
                f"{100 * inside:>7.0f}%{100 * above:>6.0f}%{100 * nis_in:>7.0f}%"
            )
    print(f"  ({time.perf_counter() - started:.0f} s)")


if __name__ == "__main__":
    main()
