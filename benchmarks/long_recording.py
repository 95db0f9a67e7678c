"""Long recordings: bayescal against allantools, whole processes, time and peak memory, at
2^20, 2^23 and 10^8 samples (issue 17).

    python benchmarks/long_recording.py [--sizes 1048576,8388608,100000000] [--folder DIR]
                                        [--repeat 3]

Each size is a Parquet file (time, gyro_x[deg/s]) of a simulated gyro at 100 Hz with white
noise N and a rate random walk K (generated block by block, the walk carried across blocks,
so a 10^8 file needs no 10^8 array), written once into ``--folder``. Three whole processes
run on each, one after the other, each timed and its peak resident memory read from the
kernel (``os.wait4``), each ``--repeat`` times in turn (the median time is printed with the
range: a shared 2-core machine varies by a third from run to run); the first round of
bayescal's runs, unmeasured, fills its caches (JAX's compilation, the traced optimisers):

- the peer: allantools' ``oadev`` at octave taus plus the weighted least-squares fit of
  N, B, K to it (``_common.allan_wls_fit``), reading the channel with pyarrow;
- ``bayescal noise --classical-only``: bias with its interval, Allan deviation with
  intervals, IEEE 952 readings;
- ``bayescal noise``: the same and the posterior (terms by evidence, emcee to convergence,
  fit checks).

bayescal streams files over 256 MB (10^8 samples: 1.6 GB) and reads the smaller ones in
memory; ``--stream`` streams every size (the growth with length of the streamed path alone).
Targets (issue 17): at 2^23, classical-only 3x faster than the peer and the posterior no
slower than it; at 10^8, the posterior's peak memory within 2x the float64 channel (1.6 GB).
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

RATE = 100.0
TRUTH = {"bias": 0.3, "N": 0.005, "K": 2e-5}
BLOCK = 1 << 20
PEER = """
import json, sys
import numpy as np, pyarrow.parquet as pq
sys.path.insert(0, {benchmarks!r})
from _common import allan_wls_fit
values = pq.read_table(sys.argv[1], columns=["gyro_x[deg/s]"]).column(0).to_numpy()
print(json.dumps({{k: float(v) for k, v in allan_wls_fit(values, {rate!r}).items()}}))
"""


def write_recording(path: Path, n: int, seed: int) -> None:
    """A Parquet file of n samples, written block by block."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    rng = np.random.default_rng(seed)
    schema = pa.schema([("time", pa.float64()), ("gyro_x[deg/s]", pa.float64())])
    walk = 0.0
    partial = path.with_suffix(".partial")
    with pq.ParquetWriter(partial, schema) as writer:
        for first in range(0, n, BLOCK):
            size = min(BLOCK, n - first)
            steps = rng.standard_normal(size) * TRUTH["K"] / math.sqrt(RATE)
            drift = walk + np.cumsum(steps)
            walk = float(drift[-1])
            white = rng.standard_normal(size) * TRUTH["N"] * math.sqrt(RATE)
            rows = {
                "time": (first + np.arange(size)) / RATE,
                "gyro_x[deg/s]": TRUTH["bias"] + drift + white,
            }
            writer.write_table(pa.table(rows, schema=schema))
    partial.rename(path)


def measured(command: list[str], workdir: Path) -> tuple[float, float, str]:
    """(seconds, peak resident MB, stdout) of one whole process."""
    start = time.perf_counter()
    with tempfile.TemporaryFile("w+") as out:
        process = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, cwd=workdir)
        _, status, usage = os.wait4(process.pid, 0)
        seconds = time.perf_counter() - start
        out.seek(0)
        text = out.read()
    code = os.waitstatus_to_exitcode(status)
    if code not in (0, 1):
        raise RuntimeError(f"{' '.join(command)} exited {code}:\n{text[-2000:]}")
    return seconds, usage.ru_maxrss / 1024, text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="1048576,8388608,100000000")
    parser.add_argument("--folder", default=os.path.join(tempfile.gettempdir(), "bayescal-long"))
    parser.add_argument("--stream", action="store_true", help="stream every size")
    parser.add_argument("--skip-bayes-above", type=float, default=math.inf)
    parser.add_argument("--repeat", type=int, default=3, help="runs of each process (median)")
    args = parser.parse_args()
    folder = Path(args.folder)
    folder.mkdir(parents=True, exist_ok=True)
    benchmarks = str(Path(__file__).resolve().parent)
    bayescal = [sys.executable, "-c", "import sys; from bayescal.cli import main; sys.exit(main())"]
    print(
        f"long recordings, gyro at {RATE:g} Hz, N = {TRUTH['N']} deg/s/sqrt(Hz), "
        f"K = {TRUTH['K']} deg/s*sqrt(Hz); {os.cpu_count()} CPU core(s); whole processes"
    )
    print(
        f"{'samples':>11} {'run':<34} {'time s':>8} {'(range)':>13} {'peak MB':>8}  "
        "N (deg/s/sqrt(Hz))"
    )
    rows = []
    for n in (int(float(size)) for size in args.sizes.split(",")):
        path = folder / f"gyro_{n}.parquet"
        if not path.exists():
            write_recording(path, n, seed=n % 1000)
        channel = ["--channel", "gyro_x", "--quiet", "--seed", "1"]
        channel += ["--stream"] if args.stream else []
        runs = {
            "allantools oadev + WLS fit": [
                sys.executable,
                "-c",
                PEER.format(benchmarks=benchmarks, rate=RATE),
                str(path),
            ],
            "bayescal noise --classical-only": [
                *bayescal,
                "noise",
                str(path),
                *channel,
                "--classical-only",
                "--json",
                "classical.json",
            ],
            "bayescal noise (posterior)": [
                *bayescal,
                "noise",
                str(path),
                *channel,
                "--json",
                "posterior.json",
            ],
        }
        if n > args.skip_bayes_above:
            runs.pop("bayescal noise (posterior)")
        for name, command in runs.items():
            if name.startswith("bayescal"):
                measured(command, folder)  # fills the caches a user's second run finds
        rounds = [
            {name: measured(command, folder) for name, command in runs.items()}
            for _ in range(args.repeat)
        ]
        for name in runs:
            times = sorted(round_[name][0] for round_ in rounds)
            seconds = float(np.median(times))
            peak = max(round_[name][1] for round_ in rounds)
            text = rounds[-1][name][2]
            if name.startswith("allantools"):
                estimate = f"{json.loads(text.strip().splitlines()[-1])['N']:.6g} (WLS fit)"
            else:
                output = "classical.json" if "classical" in name else "posterior.json"
                estimate = _n_of(json.loads((folder / output).read_text()))
            rows.append((n, name, seconds, peak))
            spread = f"({times[0]:.1f}-{times[-1]:.1f})"
            print(
                f"{n:>11} {name:<34} {seconds:>8.1f} {spread:>13} {peak:>8.0f}  {estimate}",
                flush=True,
            )
    _growth(rows)


def _n_of(document: dict) -> str:
    bayesian = document.get("bayesian") or {}
    if "N" in bayesian.get("parameters", {}):
        entry = bayesian["parameters"]["N"]
        return f"{entry['mean']:.6g} [{entry['q05']:.6g}, {entry['q95']:.6g}] (posterior)"
    reading = document["classical"]["slope_readings"]["N"]
    return f"{reading['value']:.6g} (Allan reading)"


def _growth(rows) -> None:
    """Time and memory of each run per sample count, relative to its smallest size."""
    if len({row[0] for row in rows}) < 2:
        return
    print("\ngrowth with length (relative to the smallest size)")
    for name in dict.fromkeys(row[1] for row in rows):
        mine = [row for row in rows if row[1] == name]
        n0, _, t0, m0 = mine[0]
        steps = ", ".join(
            f"{n / n0:.0f}x samples: {t / t0:.1f}x time, {m / m0:.2f}x memory"
            for n, _, t, m in mine[1:]
        )
        print(f"  {name}: {steps}")


if __name__ == "__main__":
    main()
