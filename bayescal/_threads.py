"""bayescal's own parallel steps, on threads: a long record's Fourier transform (SciPy's
``workers``) and the term search's independent solves (:func:`in_threads`). Each gives the
same numbers whatever the thread count; only the time changes."""

import contextvars
import os
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor


def usable_cores() -> int:
    """The threads a parallel step takes: ``OMP_NUM_THREADS`` where it is set to a positive
    count (a user limiting a process's threads sets it; Dask gives a fleet's worker processes
    1, for they already share the machine), else the cores this process may run on (its
    affinity: a ``taskset`` or a container's share, not the machine's count)."""
    setting = os.environ.get("OMP_NUM_THREADS", "").strip()
    if setting.isdigit() and int(setting) > 0:
        return int(setting)
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows: no affinity to read
        return os.cpu_count() or 1


def in_threads(function: Callable, items: Iterable) -> list:
    """``[function(item) for item in items]``, the calls spread over :func:`usable_cores`
    threads: for calls that spend their time outside Python's lock (a compiled JAX
    function). Each runs in a copy of the caller's context (its stage timer, its progress
    line); the first exception raised is raised here, and the calls not started by then are
    not made."""
    items = list(items)
    workers = min(usable_cores(), len(items))
    if workers <= 1:
        return [function(item) for item in items]
    pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="bayescal")
    try:
        futures = [pool.submit(contextvars.copy_context().run, function, item) for item in items]
        return [future.result() for future in futures]
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
