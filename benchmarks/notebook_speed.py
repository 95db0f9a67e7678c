"""The fit in a notebook: ``bc.fit_noise`` called again and again in one Python process, its
imports excluded, beside allantools' ``oadev`` plus a curve fit on the same array in the same
process (issue 38).

    python benchmarks/notebook_speed.py [--sizes 1048576,8388608] [--calls 3] [--json PATH]

For each size, a static gyro record at 100 Hz (white noise N and a rate random walk K) is
fitted with the defaults (``bc.fit_noise(y, rate_hz=100.0, seed=1)``: terms chosen by
evidence, the full posterior) in fresh processes sharing one cache folder, empty at the start
(``XDG_CACHE_HOME``: bayescal's traces and JAX's compilations, :mod:`bayescal._caches`):

- cold: the first process on a machine (the first size), which traces and compiles;
- warmed by the sizes before: the first process of a later size, whose bins, padded, are those
  of the sizes before (2^20 and 2^23 samples: 640): what it still compiles is what depends on
  the record beyond its bins (the block means of the bias, the checks);
- warm: a new process after it, as a user's next notebook session is.

Each process times, after its imports, the peer (``_common.allan_wls_fit``: allantools'
overlapping Allan deviation at octave taus and the weighted least-squares fit of N, B, K),
then ``--calls`` calls of ``fit_noise``: the first call of a process, then later calls on the
same record. The peer is timed again after the last call: the machine is shared, so read the
ratios to the peer of the same process, and the CPU time (all threads) each call took beside
its wall time, with the last call's stages (those of ``bayescal noise --profile``): on a
machine shared with other jobs, the CPU time moves less with the load than the wall time.
The fastest of each stage over the later calls, summed, is printed beside the peer: a call
of this code on this machine takes no less (the calls differ by what the kernel adds: page
faults and huge-page compaction, docs/guide/long-recordings.md); and four parts of a fit at
their fastest, two of them timed alone after the calls (the record's tapered transform, its
Allan deviation), with the term selection and the posterior.
Targets (issue 38): first call in a fresh process with a warm cache <= 5 s at 2^20; later
calls <= 1 s at 2^20 and <= the peer at 2^23.

It prints JAX's default backend and devices (a GPU is used where JAX finds one) and the load
average; ``--json PATH`` writes every process's timings there too (after each process, so
that a run cut short keeps its part), with the machine's description: a record of where
each figure was measured.
"""

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

RATE = 100.0
TRUTH = {"N": 0.005, "K": 5e-6}


def child(samples: int, calls: int) -> dict:
    """The timings of one process (its imports excluded)."""
    from _common import allan_wls_fit

    import bayescal as bc
    from bayescal._stages import timing

    bc.fit_noise  # noqa: B018  (bayescal's names load on first use: an import, excluded)
    values = bc.NoiseModel(rate_hz=RATE, bias=0.3, **TRUTH).simulate(samples, seed=1)
    start = time.perf_counter()
    allan_wls_fit(values, RATE)
    peer = [time.perf_counter() - start]
    times, cpu, system, faults, stages, fit = [], [], [], [], [], None
    for _ in range(calls):
        with timing() as stage_times:
            start, start_cpu, start_usage = time.perf_counter(), time.process_time(), _usage()
            fit = bc.fit_noise(values, rate_hz=RATE, seed=1)
            times.append(time.perf_counter() - start)
            cpu.append(time.process_time() - start_cpu)
            usage = _usage()
            system.append(usage[0] - start_usage[0])
            faults.append(usage[1] - start_usage[1])
        stages.append({name.split(" (")[0]: s for name, depth, s in stage_times if depth == 0})
    start = time.perf_counter()
    allan_wls_fit(values, RATE)
    peer.append(time.perf_counter() - start)
    return {
        "alone_s": _parts_alone(values, calls),
        "peer_s": peer,
        "fit_s": times,
        "fit_cpu_s": cpu,
        "fit_system_s": system,
        "fit_page_faults": faults,
        "stages_s": stages,
        "steps": fit.diagnostics.n_steps,
        "terms": list(fit.terms),
        "passed": bool(fit.passed),
        "N": fit.parameters["N"].mean,
        **_devices(),
    }


def _parts_alone(values, repeats: int) -> dict:
    """The fastest of ``repeats`` runs of two parts of a fit, each alone: the tapered transform
    of the record (what the line scan reads) and its Allan deviation at octave taus (what the
    classical block and the fit checks read)."""
    import bayescal as bc
    from bayescal.classical._periodogram import longest_run_transform

    parts = {
        "record transform": lambda: longest_run_transform(values),
        "Allan deviation": lambda: bc.allan_deviation(values, RATE),
    }
    fastest = {}
    for name, part in parts.items():
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            part()
            times.append(time.perf_counter() - start)
        fastest[name] = min(times)
    return fastest


def _fastest_stages(calls: list[dict]) -> dict:
    """Each stage's shortest time over ``calls`` (their stage times): what a call would take
    were every stage at its fastest at once, a floor of this code on this machine."""
    shared = [name for name in calls[0] if all(name in call for call in calls)]
    return {name: min(call[name] for call in calls) for name in shared}


def _usage() -> tuple[float, int]:
    """The process's system CPU time (s) and minor page faults so far: the kernel's share of a
    call, which handing out and zeroing fresh large arrays makes (NaN where the platform does
    not count them)."""
    try:
        import resource
    except ImportError:  # not on Windows
        return math.nan, 0
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_stime, usage.ru_minflt


def _devices() -> dict:
    """JAX's default backend and its devices (imported after bayescal, as a user would)."""
    import jax

    return {"backend": jax.default_backend(), "devices": [str(d) for d in jax.devices()]}


def run(samples: int, calls: int, cache: Path) -> dict:
    """:func:`child` in a fresh process whose caches live in ``cache``."""
    from _common import fresh_cache_environment

    environment = fresh_cache_environment(cache)
    command = [sys.executable, __file__, "--child", str(samples), "--calls", str(calls)]
    output = subprocess.run(
        command, env=environment, check=True, capture_output=True, text=True
    ).stdout
    return json.loads(output.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default=f"{2**20},{2**23}")
    parser.add_argument("--calls", type=int, default=3)
    parser.add_argument("--json", type=Path, help="write the timings there too")
    parser.add_argument("--child", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(child(args.child, args.calls)))
        return
    print(f"bc.fit_noise in one process, imports excluded; {os.cpu_count()} CPU core(s)")
    runs = []
    with tempfile.TemporaryDirectory() as folder:
        for index, samples in enumerate(int(size) for size in args.sizes.split(",")):
            first_label = "cold cache" if index == 0 else "cache warmed by the sizes before"
            for label in (first_label, "warm cache"):
                result = run(samples, args.calls, Path(folder))
                if not runs:
                    print(f"JAX backend {result['backend']}: {', '.join(result['devices'])}")
                runs.append({"samples": samples, "cache": label, "load": os.getloadavg(), **result})
                first, *later = result["fit_s"]
                peer = min(result["peer_s"])
                print(
                    f"  2^{samples.bit_length() - 1} samples, {label}: first call "
                    f"{first:.1f} s ({first / peer:.1f}x peer), later calls "
                    f"{', '.join(f'{t:.2f}' for t in later)} s "
                    f"({', '.join(f'{t / peer:.1f}' for t in later)}x peer); peer "
                    f"(allantools oadev + WLS) {', '.join(f'{t:.2f}' for t in result['peer_s'])}"
                    f" s; terms {'+'.join(result['terms'])}, checks "
                    f"{'passed' if result['passed'] else 'FAILED'}, N {result['N']:.5f}; "
                    f"load {os.getloadavg()[0]:.1f}",
                    flush=True,
                )
                system = ", ".join(f"{t:.2f}" for t in result["fit_system_s"])
                faults = ", ".join(str(n) for n in result["fit_page_faults"])
                print(
                    f"    CPU (all threads) {', '.join(f'{t:.2f}' for t in result['fit_cpu_s'])}"
                    f" s, of it the kernel's {system} s ({faults} page faults); emcee "
                    f"{result['steps']} steps; the last call's stages: "
                    + ", ".join(f"{k} {v:.2f}" for k, v in result["stages_s"][-1].items()),
                    flush=True,
                )
                if later:
                    fastest = _fastest_stages(result["stages_s"][1:])
                    total = sum(fastest.values())
                    print(
                        "    the fastest of each stage over the later calls: "
                        + ", ".join(f"{k} {v:.2f}" for k, v in fastest.items())
                        + f"; together {total:.2f} s ({total / peer:.1f}x the peer's fastest)",
                        flush=True,
                    )
                    alone = result["alone_s"]
                    parts = sum(alone.values()) + fastest["term selection"] + fastest["posterior"]
                    print(
                        "    alone, at their fastest: "
                        + ", ".join(f"{k} {v:.3f}" for k, v in alone.items())
                        + f" s; with the term selection and the posterior {parts:.2f} s "
                        f"({parts / peer:.1f}x the peer's fastest)",
                        flush=True,
                    )
                if args.json is not None:
                    machine = {"cpu_count": os.cpu_count(), "platform": platform.platform()}
                    args.json.write_text(json.dumps({"machine": machine, "runs": runs}, indent=1))


if __name__ == "__main__":
    main()
