"""Runtime of discovery on a 90-minute static gyro recording at 50 Hz (270,000 samples) with
a concealed thermal bias, on this machine: discovery itself, then the final posterior.

    python benchmarks/discovery_speed.py

Target (the discovery issue): under 60 s on 2 cores. The first run includes JAX compilation;
the second, on a new recording of the same length, shows the steady cost.
"""

import time

import numpy as np

import bayescal as bc

RATE = 50.0
MINUTES = 90


def recording(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The gyro channel (deg/s) and its temperature (degC)."""
    rng = np.random.default_rng(seed)
    n = int(MINUTES * 60 * RATE)
    t = np.arange(n) / RATE
    temperature = 22 + 10 * -np.expm1(-t / 900) + np.sin(2 * np.pi * t / 1200)
    values = 0.05 * rng.standard_normal(n) + 0.002 * (temperature - temperature.mean())
    return values, temperature


def timed_discovery(values, temperature, seed):
    """Discovery with its final posterior, and the time at which the search ended (its last
    progress report; the posterior is sampled after it)."""
    stamps = []
    result = bc.discover(
        values,
        RATE,
        temperature=temperature,
        unit="deg/s",
        channel="gyro_x",
        seed=seed,
        progress=lambda _: stamps.append(time.perf_counter()),
    )
    return result, stamps[-1]


def main() -> None:
    for run, seed in (("first (compiles)", 1), ("second", 2)):
        values, temperature = recording(seed)
        started = time.perf_counter()
        result, found = timed_discovery(values, temperature, seed)
        done = time.perf_counter()
        print(
            f"{run:<17} {values.size} samples: discovery {found - started:5.1f} s, "
            f"posterior {done - found:5.1f} s, total {done - started:5.1f} s; found "
            f"{[effect.name for effect in result.effects]}; posterior checks "
            f"{'passed' if result.passed else 'FAILED'}"
        )


if __name__ == "__main__":
    main()
