"""What limits the east bias level after a known-track taxi (issue 36): the vehicle's wander
about the centre line, or the accelerometer biases. A few seeded park + taxi scenarios (those
of benchmarks/infield_taxi.py, aged 4x), each updated three ways:

- as simulated (wander sd 0.5 m, time constant 20 s; accelerometer biases of sd 50 ug, the
  filter's prior 1 mg);
- the accelerometer biases zero and known to be (the filter's prior 1e-8 m/s^2);
- a wander of 0.05 m, simulated and given to the update (``wander=(0.05, 20)``).

    nice -n 10 python benchmarks/infield_wander.py [--seeds 2] [--rate 10]

Printed per scenario and variant: the east level's posterior sd and prior sd (deg/h), the
heading error's sd (deg) and the learned aging scale (deg/h). ../shared/NAVIGATION.md's ideal
for the east level is 0.0040 deg/h with a 0.01 m/s cross-track reference.
"""

import argparse

from infield_taxi import LEGS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--rate", type=float, default=10.0, help="the IMU's rate, Hz")
    args = parser.parse_args()
    import bayescal as bc
    from bayescal.capabilities._examples import example_gyro_calibrations
    from bayescal.navigation import _alignment

    old = example_gyro_calibrations()
    variants = {
        "as simulated": ({}, 0.5, None),
        "accelerometer biases known zero": ({"accel_bias_sd": 0.0}, 0.5, 1e-8),
        "wander 0.05 m": ({}, 0.05, None),
    }
    for seed in range(args.seeds):
        for name, (simulated, wander, accel_prior) in variants.items():
            taxi = bc.Taxi(legs=LEGS, speed=10.0, wander_sd=wander)
            park = bc.simulate_park(
                old, aging=4.0, rate_hz=args.rate, taxi=taxi, seed=seed, **simulated
            )
            end = park.recording.columns["time"][-1] + 1 / args.rate
            saved = _alignment.ACCEL_BIAS_PRIOR
            if accel_prior is not None:
                _alignment.ACCEL_BIAS_PRIOR = accel_prior
            try:
                result = bc.infield_update(
                    park.recording,
                    old,
                    latitude=45.0,
                    align=(0, park.truth["park_s"]),
                    taxi=(park.truth["park_s"], end),
                    track_heading=[h for h, _ in LEGS],
                    wander=(wander, 20.0),
                    seed=seed,
                )
            finally:
                _alignment.ACCEL_BIAS_PRIOR = saved
            east = result.projections["east"]["level"]
            print(
                f"seed {seed}, {name}: east level sd {east['sd']:.4f} deg/h (prior "
                f"{east['prior_sd']:.4f}), heading sd {result.heading_error['sd']:.4f} deg, "
                f"aging {result.drift['scale'] * 3600:.4f} deg/h",
                flush=True,
            )


if __name__ == "__main__":
    main()
