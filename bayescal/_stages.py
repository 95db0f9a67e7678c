"""The time each stage of a run takes, kept where a caller asks for it (the command line's
``--profile``): the stages are named where the work is done, the caller says what to do with
their times, and nothing is kept or written otherwise."""

import contextlib
import contextvars
import time
from collections.abc import Iterator

_TIMES = contextvars.ContextVar("bayescal_stage_times", default=None)
"""Inside :func:`timing`: the list the stages append (name, depth, seconds) to."""
_DEPTH = contextvars.ContextVar("bayescal_stage_depth", default=0)


@contextlib.contextmanager
def timing() -> Iterator[list[tuple[str, int, float]]]:
    """Within the block, each :func:`stage` appends (name, depth, seconds) to the list
    yielded, in the order the stages end (a stage inside another has the larger depth)."""
    times: list[tuple[str, int, float]] = []
    token = _TIMES.set(times)
    try:
        yield times
    finally:
        _TIMES.reset(token)


@contextlib.contextmanager
def stage(name: str) -> Iterator[None]:
    """Time the block as stage ``name`` when inside :func:`timing`; else only run it."""
    times = _TIMES.get()
    if times is None:
        yield
        return
    depth = _DEPTH.get()
    token = _DEPTH.set(depth + 1)
    start = time.perf_counter()
    try:
        yield
    finally:
        _DEPTH.reset(token)
        times.append((name, depth, time.perf_counter() - start))
