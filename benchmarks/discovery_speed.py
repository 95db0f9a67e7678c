"""Runtime of discovery on a 90-minute static gyro recording at 50 Hz (270,000 samples) with
a concealed thermal bias, on this machine: discovery itself, then the final posterior.

    python benchmarks/discovery_speed.py [--processes]

In one process: the first run includes JAX's tracing and compilation; the second, on a new
recording of the same length, shows the steady cost. With ``--processes``, also as a user
runs it: ``bayescal discover`` on the recording written as CSV, whole processes, first on a
machine (empty caches: a fresh ``XDG_CACHE_HOME``) and then again (the caches that run left).

Targets: under 60 s on 2 cores (the discovery issue); within 30 s (the long-recordings
issue, a whole process).
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _common import fresh_cache_environment

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
        log=lambda _: stamps.append(time.perf_counter()),
    )
    return result, stamps[-1]


def whole_processes() -> None:
    """``bayescal discover`` on the recording as CSV: a machine's first run, then a later one."""
    values, temperature = recording(3)
    with tempfile.TemporaryDirectory(prefix="bayescal-discover-speed-") as folder:
        path = Path(folder) / "gyro.csv"
        t = np.arange(values.size) / RATE
        np.savetxt(
            path,
            np.column_stack([t, values, temperature]),
            delimiter=",",
            header="time,gyro_x[deg/s],temperature[degC]",
            comments="",
        )
        environment = fresh_cache_environment(Path(folder) / "cache")
        entry = "import sys; from bayescal.cli import main; sys.exit(main())"
        command = [sys.executable, "-c", entry, "discover", str(path), "--channel"]
        command += ["gyro_x", "--temperature", "temperature", "--quiet", "--seed", "3"]
        command += ["--json", str(Path(folder) / "found.json")]
        for run in ("first on a machine", "a later run"):
            started = time.perf_counter()
            done = subprocess.run(
                command, check=False, env=environment, capture_output=True, text=True
            )
            seconds = time.perf_counter() - started
            document = json.loads((Path(folder) / "found.json").read_text())
            found = [effect["name"] for effect in document["effects"]]
            print(
                f"whole process, {run:<19} {seconds:5.1f} s (exit {done.returncode}); found {found}"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--processes", action="store_true", help="also time whole processes")
    args = parser.parse_args()
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
    if args.processes:
        whole_processes()


if __name__ == "__main__":
    main()
