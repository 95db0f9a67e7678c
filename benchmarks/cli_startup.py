"""How fast the command line answers when it has nothing to compute: ``bayescal --help``,
``bayescal sensors`` and a bad-input error, against ``python -c "import numpy"`` (the target:
at most 5x that), whole processes, the best of several runs.

    python benchmarks/cli_startup.py [--runs 7]
"""

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET = 5.0


def best_of(command: list[str], runs: int) -> float:
    times = []
    for _ in range(runs):
        started = time.perf_counter()
        subprocess.run(command, capture_output=True, check=False)
        times.append(time.perf_counter() - started)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    cli = [sys.executable, "-c", "import sys; from bayescal.cli import main; sys.exit(main())"]
    with tempfile.TemporaryDirectory() as folder:
        recording = Path(folder) / "pad.csv"
        recording.write_text("time,gyro_x\n" + "\n".join(f"{k / 100},{k % 7}" for k in range(64)))
        cases = {
            "python -c 'import numpy'": [sys.executable, "-c", "import numpy"],
            "bayescal --help": [*cli, "--help"],
            "bayescal sensors": [*cli, "sensors"],
            "bad input: no such file": [
                *cli,
                "noise",
                str(Path(folder) / "no.csv"),
                "--channel",
                "x",
            ],
            "bad input: no such column": [*cli, "noise", str(recording), "--channel", "gyro_q"],
        }
        timings = {name: best_of(command, args.runs) for name, command in cases.items()}
    reference = timings.pop("python -c 'import numpy'")
    print(f"python -c 'import numpy': {reference:.3f} s (best of {args.runs})")
    for name, seconds in timings.items():
        ratio = seconds / reference
        verdict = "met" if ratio <= TARGET else "MISSED"
        print(f"{name:<28} {seconds:.3f} s = {ratio:.1f}x numpy (target <= {TARGET:g}x): {verdict}")
    print(f"median ratio {statistics.median(t / reference for t in timings.values()):.1f}x")


if __name__ == "__main__":
    main()
