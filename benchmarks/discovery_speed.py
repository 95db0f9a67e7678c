"""Runtime of discovery on a 90-minute static gyro recording at 50 Hz (270,000 samples) with
a concealed thermal bias, on this machine: discovery itself, then the final posterior.

    python benchmarks/discovery_speed.py

Target (the discovery issue): under 60 s on 2 cores. The first run includes JAX compilation;
the second, on a new recording of the same length, shows the steady cost.
"""

import time

import numpy as np

from bayescal._discover import DiscoveryData, discover, sample_final

RATE = 50.0
MINUTES = 90


def recording(seed: int) -> DiscoveryData:
    rng = np.random.default_rng(seed)
    n = int(MINUTES * 60 * RATE)
    t = np.arange(n) / RATE
    temperature = 22 + 10 * -np.expm1(-t / 900) + np.sin(2 * np.pi * t / 1200)
    values = 0.05 * rng.standard_normal(n) + 0.002 * (temperature - temperature.mean())
    return DiscoveryData(
        values=values, rate_hz=RATE, channel="gyro_x", unit="deg/s", temperature=temperature
    )


def main() -> None:
    for run, seed in (("first (compiles)", 1), ("second", 2)):
        data = recording(seed)
        started = time.perf_counter()
        result = discover(data)
        found = time.perf_counter()
        posterior = sample_final(result.final, data, seed=seed)
        done = time.perf_counter()
        print(
            f"{run:<17} {data.values.size} samples: discovery {found - started:5.1f} s, "
            f"posterior {done - found:5.1f} s, total {done - started:5.1f} s; found "
            f"{[f.name for f in result.findings]}; posterior checks "
            f"{'passed' if posterior.diagnostics.passed else 'FAILED'}"
        )


if __name__ == "__main__":
    main()
