"""Is the fine alignment's model of the gyros' bias instability (flicker) what makes the
tactical-grade in-field update overconfident (issue 36)? The filter holds each gyro's flicker
as an offset plus a random walk (bayescal/navigation/_alignment.py, gyro_priors in
bayescal/capabilities/_infield_inputs.py); this measures that approximation two ways.

1. Theory (no simulation): one gyro's bias seen through the park, y(t) = c0 + c1 dT(t) +
   c2 dT(t)^2 + w(t) + white, 1 s means over the 20-minute warm-up of the scenarios
   (20 -> 38.6 degC, time constant 600 s), the coefficients' prior that of the tactical
   calibration aged by 4 of its sd (s = 0.1 deg/h, h = 10 degC). The Bayes estimator built on
   the filter's model of w is applied to data whose w is the exact flicker (its block
   covariances, bayescal/models/_components.py): the level's (the polynomial's mean over the
   park) sd the model claims against the sd it has. Beside it, the estimator that ignores the
   flicker (white noise only).
2. Simulation, paired: each seed's tactical park (benchmarks/infield_taxi.py --tactical: ARW
   0.05 deg/sqrt(h), B 0.05 deg/h, the calibration's sds 10x) is simulated twice with the same
   draws but for the bias instability: once as flicker (the simulator's), once as exactly the
   filter's model (a rate random walk of the filter's density and a constant offset of the
   filter's variance, drawn per gyro). Both are updated by the same filter, told B, the aging
   given at its truth (so the learned aging plays no part). If the approximation were the
   cause, the flicker's z-scores (error / posterior sd) would be wider than the model's.

    nice -n 10 python benchmarks/infield_flicker.py [--scenarios 40] [--seed 1000] [--taxi]
        [--rate 10]

``--taxi`` adds benchmarks/infield_taxi.py's 10-minute known-track taxi (about 30 s an
update at 10 Hz, against 1-2 s at rest). Printed: the theory's sds, then per variant the 90 %
coverage, mean and RMS of the z-scores of the north level, the east level and the heading
error, and the paired mean difference of z^2 (flicker less model) with its standard error.
"""

import argparse
import math

import numpy as np
from infield_taxi import LEGS, TACTICAL_GYRO, calibrations, summarize

KEYS = ("north", "east", "heading")
PARK_S = 1200.0
WARMUP = (20.0, 38.6)
WARMUP_TIME_S = 600.0
AGED_SCALE = 0.1  # deg/h: 4 x the tactical calibration's sd of c0 (0.025 deg/h)
DRIFT_STEP = 10.0  # degC: the drift's h of the example calibrations (20-40 degC)


def level_sds(rate: float = 10.0) -> dict[str, tuple[float, float]]:
    """The level's claimed and actual sd (deg/h) under data with the exact flicker, for the
    filter's model of the flicker and for white noise only (module docstring, 1)."""
    from bayescal.capabilities._infield_inputs import gyro_priors
    from bayescal.models._components import Components
    from bayescal.models.effects._parameter import Context

    old, _ = calibrations(True)
    n, size = round(PARK_S * rate), round(rate)
    blocks = n // size
    starts = np.arange(blocks) * size
    b, white = 3600 * TACTICAL_GYRO["B"], 3600 * TACTICAL_GYRO["N"]  # deg/h, deg/h/sqrt(Hz)
    components = Components.of(("bias_instability",), Context(rate, PARK_S))
    weights = np.asarray(components.weights({"B": b}))
    flicker = np.tensordot(weights, components.block_covariances(starts, starts + size, rate), 1)
    prior = gyro_priors(old, np.full((n, 3), 30.0), rate, 3600.0)[0]
    t = (starts + size / 2) / rate
    model = prior.offset_variance + prior.instability * np.minimum.outer(t, t)
    noise = np.eye(blocks) * white**2 / (size / rate)
    rise = (WARMUP[1] - WARMUP[0]) / (1 - math.exp(-PARK_S / WARMUP_TIME_S))
    heat = WARMUP[0] + rise * (1 - np.exp(-t / WARMUP_TIME_S)) - 30.0
    design = np.stack([np.ones(blocks), heat, heat**2], axis=1)
    sds = np.sqrt(np.diag(old["gyro_x"].covariance)) * 3600
    shape = AGED_SCALE / DRIFT_STEP ** np.arange(3)
    coefficients = np.diag(sds**2 + shape**2)
    level = design.mean(axis=0)
    found = {}
    for name, assumed in (("offset + walk (the filter)", model), ("white only", 0 * model)):
        covariance = assumed + noise
        inverse = np.linalg.inv(covariance)
        posterior = np.linalg.inv(np.linalg.inv(coefficients) + design.T @ inverse @ design)
        gain = posterior @ design.T @ inverse
        bias = np.eye(3) - gain @ design
        actual = bias @ coefficients @ bias.T + gain @ (flicker + noise) @ gain.T
        found[name] = (math.sqrt(level @ posterior @ level), math.sqrt(level @ actual @ level))
    return found


def simulate(seed: int, rate: float, taxi: bool, model: bool):
    """One tactical park (and taxi), its bias instability as flicker or as the filter's
    model (module docstring, 2)."""
    import bayescal as bc
    from bayescal.capabilities._infield_inputs import gyro_priors

    old, noise = calibrations(True)
    moving = bc.Taxi(legs=LEGS, speed=10.0) if taxi else None
    if not model:
        return bc.simulate_park(
            old, aging=4.0, rate_hz=rate, gyro_noise=noise, seed=seed, taxi=moving
        )
    white = {"N": noise["N"]}
    park = bc.simulate_park(old, aging=4.0, rate_hz=rate, gyro_noise=white, seed=seed, taxi=moving)
    samples = park.recording.columns["time"].size
    prior = gyro_priors(old, np.full((samples, 3), 30.0), rate, 1.0)[0]
    walk = {**white, "K": math.sqrt(prior.instability)}
    park = bc.simulate_park(old, aging=4.0, rate_hz=rate, gyro_noise=walk, seed=seed, taxi=moving)
    offsets = math.sqrt(prior.offset_variance) * np.random.default_rng([seed, 7]).normal(size=3)
    for axis, name in enumerate(("gyro_x", "gyro_y", "gyro_z")):
        park.recording.columns[name] = park.recording.columns[name] + offsets[axis]
    return park


def z_scores(seed: int, rate: float, taxi: bool, model: bool) -> dict:
    import bayescal as bc

    old, _ = calibrations(True)
    park = simulate(seed, rate, taxi, model)
    park_s = park.truth["park_s"]
    extra = {}
    final = park.truth["heading"]
    if taxi:
        end = park.recording.columns["time"][-1] + 1 / rate
        extra = {"taxi": (park_s, end), "track_heading": [h for h, _ in LEGS]}
        final = park.truth["trajectory"]["heading"][-1]
    result = bc.infield_update(
        park.recording,
        old,
        latitude=45.0,
        align=(0, park_s),
        seed=seed,
        drift=park.truth["thermal"]["gyro_x"]["aging_scale"],
        **extra,
    )
    row = summarize(park, result, 0.0, rate, final)
    return {key: row[key][0] / row[key][1] for key in KEYS} | {
        f"{key} covered": row[key][3] for key in KEYS
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenarios", type=int, default=40)
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument("--rate", type=float, default=10.0, help="the IMU's rate, Hz")
    parser.add_argument("--taxi", action="store_true", help="the known-track taxi after the park")
    args = parser.parse_args()
    print(
        f"theory: one gyro, 20-minute park at {args.rate:g} Hz, prior aged by {AGED_SCALE} "
        "deg/h; the level's sd, deg/h"
    )
    for name, (claimed, real) in level_sds(args.rate).items():
        print(f"  {name:28} claimed {claimed:.4f}, actual {real:.4f} (ratio {real / claimed:.3f})")
    seeds = range(args.seed, args.seed + args.scenarios)
    rows = {
        name: [z_scores(seed, args.rate, args.taxi, model) for seed in seeds]
        for name, model in (("flicker (simulated)", False), ("the filter's offset + walk", True))
    }
    print(
        f"{args.scenarios} tactical scenarios from seed {args.seed}, "
        f"{'park + taxi' if args.taxi else 'park only'}, aging given"
    )
    for name, collected in rows.items():
        parts = []
        for key in KEYS:
            z = np.array([row[key] for row in collected])
            covered = np.mean([row[f"{key} covered"] for row in collected])
            parts.append(
                f"{key} covers {100 * covered:.0f} %, z mean {z.mean():+.2f} RMS "
                f"{np.sqrt(np.mean(z**2)):.2f}"
            )
        print(f"  {name:28} " + "; ".join(parts))
    for key in KEYS:
        difference = np.array(
            [a[key] ** 2 - b[key] ** 2 for a, b in zip(*rows.values(), strict=True)]
        )
        print(
            f"  {key}: mean z^2 flicker less model {difference.mean():+.2f} "
            f"(standard error {difference.std(ddof=1) / math.sqrt(difference.size):.2f})"
        )


if __name__ == "__main__":
    main()
