"""Coverage of the 90 % intervals of every multi-position calibration parameter, Bayesian
(5-95 % posterior quantiles) and classical (Student-t at 0.90), over simulated sessions.

    python benchmarks/multi_position_recovery.py [--simulations 100] [--poses 14]

The sensor: an Xsens-like raw-count accelerometer (scales 1/415, 1/413, 1/418 m/s^2 per count,
misalignment angles of 0.004 to 0.011 rad, offsets near 33 000 counts, white noise of 3.3 counts
per sample, 200 samples per pose). Free sessions hold it in ``--poses`` orientations drawn
uniformly on the sphere (a set the model rejects as too poorly spread is drawn again); six-face
sessions put it on each face of a cube in which it sits rotated by (0.02, -0.01, 0.015) rad.
A calibrated 90 % interval covers the truth in 90 % of sessions, within the binomial band
printed beside it. Also printed: "width B/C", the Bayesian interval's width over the
classical one's (mean over sessions), and z = (posterior mean - truth) / posterior sd, whose
mean and sd over sessions are 0 and 1 for a calibrated posterior. Seeds: session s draws its
poses with seed 1000 + s and its posterior with seed s. About 4 s (free) and 6 s (six-face)
of CPU per session.

A run with ``--simulations 40`` (band [0.80, 0.97]; 7 min of CPU), over all parameters:
free, 14 poses: Bayesian 0.87, classical 0.86, widths B/C 1.01, z mean -0.03, sd 1.11;
six faces: Bayesian 0.88, classical 0.89, widths B/C 0.98, z mean -0.06, sd 1.05; every
parameter between 0.78 and 0.95; no posterior failed its health checks.
"""

import argparse
import time

import numpy as np
from scipy import stats

import bayescal as bc
from bayescal.classical._multi_position import FREE_PARAMETERS, SIX_FACE_PARAMETERS
from bayescal.models._multi_position import simulate_poses

G = bc.LocalGravity.measured(9.80123, 1e-5)
SCALES, ANGLES, OFFSETS = [1 / 415, 1 / 413, 1 / 418], [0.004, -0.007, 0.011], [33100, 33270, 32370]
TRUTH = {
    "free": np.array([*SCALES, *ANGLES, *OFFSETS], dtype=float),
    "six-face": np.array([*SCALES, *ANGLES, 0.02, -0.01, 0.015, *OFFSETS], dtype=float),
}
NAMES = {"free": FREE_PARAMETERS, "six-face": SIX_FACE_PARAMETERS}
NOISE_SD = 3.3  # counts per sample
FACES = np.vstack([np.eye(3), -np.eye(3)])


def session(orientations: str, seed: int, n_poses: int, posterior_seed: int):
    """The calibration of simulated poses (classical and Bayesian, the posterior drawn with
    ``posterior_seed``); free pose sets the model rejects are redrawn."""
    rng = np.random.default_rng(seed)
    while True:
        if orientations == "six-face":
            directions = FACES
        else:
            directions = rng.standard_normal((n_poses, 3))
            directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        poses = simulate_poses(
            rng,
            TRUTH[orientations],
            directions,
            G.value,
            six_face=orientations == "six-face",
            noise_sd=NOISE_SD,
        )
        try:
            return bc.calibrate_multi_position(
                poses,
                gravity=G,
                unit="LSB",
                orientations=orientations,
                confidence=0.90,
                seed=posterior_seed,
            )
        except bc.InputError:
            continue


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--simulations", type=int, default=100)
    parser.add_argument("--poses", type=int, default=14, help="poses of a free session")
    args = parser.parse_args()
    count = args.simulations
    band = stats.binom.ppf([0.025, 0.975], count, 0.9) / count
    print(
        f"multi-position recovery: {count} simulated sessions per model; a calibrated 90 % "
        f"interval covers [{band[0]:.2f}, {band[1]:.2f}] of sessions with 95 % probability"
    )
    for orientations in ("free", "six-face"):
        names, truth = NAMES[orientations], TRUTH[orientations]
        bayes_inside = np.zeros(len(names))
        classical_inside = np.zeros(len(names))
        width_ratio = np.zeros(len(names))
        z_scores, unhealthy = [], 0
        start, cpu = time.perf_counter(), time.process_time()
        for seed in range(count):
            calibration = session(orientations, 1000 + seed, args.poses, seed)
            classical, fit = calibration.classical, calibration.bayesian
            unhealthy += not calibration.passed
            for i, name in enumerate(names):
                low, high = np.quantile(fit.draws[name], [0.05, 0.95])
                bayes_inside[i] += low <= truth[i] <= high
                value, half_width = classical.parameters[name]
                classical_inside[i] += abs(value - truth[i]) <= half_width
                width_ratio[i] += (high - low) / (2 * half_width) / count
            z_scores.append(
                [
                    (fit.draws[n].mean() - t) / fit.draws[n].std()
                    for n, t in zip(names, truth, strict=True)
                ]
            )
        elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu
        z = np.array(z_scores)
        poses_text = "6 faces" if orientations == "six-face" else f"{args.poses} random poses"
        print(
            f"\n{orientations} ({poses_text}; {elapsed:.0f} s wall, {cpu:.0f} s CPU; "
            f"{unhealthy} posterior(s) failed their health checks)"
        )
        print(
            f"  {'parameter':<17}{'Bayesian 90%':>13}{'classical 90%':>15}{'width B/C':>11}"
            f"{'mean z':>9}{'sd z':>7}"
        )
        for i, name in enumerate(names):
            print(
                f"  {name:<17}{bayes_inside[i] / count:>13.2f}{classical_inside[i] / count:>15.2f}"
                f"{width_ratio[i]:>11.2f}{z[:, i].mean():>9.2f}{z[:, i].std():>7.2f}"
            )
        print(
            f"  {'all parameters':<17}{bayes_inside.sum() / bayes_inside.size / count:>13.2f}"
            f"{classical_inside.sum() / classical_inside.size / count:>15.2f}"
            f"{width_ratio.mean():>11.2f}{z.mean():>9.2f}{z.std():>7.2f}"
        )


if __name__ == "__main__":
    main()
