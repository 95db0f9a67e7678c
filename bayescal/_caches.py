"""Where bayescal keeps what it compiles, between processes: one home for the setting, used by
the library and the command line alike.

Two caches, both under ``~/.cache/bayescal`` (``XDG_CACHE_HOME`` moves it): JAX's persistent
compilation cache (``jax/``: XLA's compiled code, every compilation kept however quick) and
bayescal's traced functions (``traces/``, :mod:`bayescal.inference._traced`: the tracing before
XLA, which JAX's cache does not keep). With both warm a new process neither traces nor
compiles the noise fit's functions; a changed line of bayescal, another JAX or another device
misses and traces afresh, and deleting either folder is always safe.

:func:`enable_caches` runs when bayescal first loads JAX (:mod:`bayescal._x64`), so a library
call (``bc.fit_noise`` in a notebook) and a command share one cache. It only fills in what the
environment leaves unset: ``JAX_COMPILATION_CACHE_DIR`` and ``BAYESCAL_TRACE_CACHE`` set to
another folder move a cache, set to an empty string turn it off. Setting JAX's cache is a
process-wide choice, like the 64-bit mode: a caller's own JAX functions are then kept there
too, unless the caller set a cache of its own first.
"""

import functools
import hashlib
import os
import sys
from pathlib import Path

TRACE_CACHE = "BAYESCAL_TRACE_CACHE"
"""The environment variable naming the folder of traced functions (empty: none kept)."""


def cache_root() -> Path:
    """``$XDG_CACHE_HOME/bayescal``, or ``~/.cache/bayescal``."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "bayescal"


def enable_caches() -> None:
    """Turn on JAX's compilation cache and bayescal's trace cache where the environment does
    not say otherwise (module docstring). Set through the environment when JAX is not yet
    imported (a command that never needs JAX does not pay for importing it), and through
    JAX's configuration when it is. A folder that cannot be made leaves both off."""
    root = cache_root()
    try:
        (root / "jax").mkdir(parents=True, exist_ok=True)
    except OSError:
        return
    ours = "JAX_COMPILATION_CACHE_DIR" not in os.environ
    os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", str(root / "jax"))
    os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0")
    os.environ.setdefault(TRACE_CACHE, str(root / "traces"))
    jax = sys.modules.get("jax")
    if ours and jax is not None and not jax.config.jax_compilation_cache_dir:
        jax.config.update("jax_compilation_cache_dir", str(root / "jax"))
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)


@functools.cache
def source_digest() -> str:
    """The digest of bayescal's source: what is kept between runs is kept for one version of
    the code that made it (a changed line misses and computes afresh)."""
    digest = hashlib.sha256()
    package = Path(__file__).resolve().parent
    for path in sorted(package.rglob("*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()


def kept_array(name: str, description: str, compute):
    """``compute()``, a numpy array, kept between runs in the trace cache's folder
    (:data:`TRACE_CACHE`; empty or unset: computed each time), keyed by ``description`` —
    everything the array depends on — and bayescal's source. For arrays that depend on a
    record's shape, not its values, and cost more to compute than to read (the expected
    periodogram of each spectral component: a second of a first fit at 2^20 samples). An
    unreadable entry is computed again; a folder that cannot be written only costs the next
    run the computation."""
    import numpy as np

    folder = os.environ.get(TRACE_CACHE)
    if not folder:
        return compute()
    key = hashlib.sha256(f"{description}\n{source_digest()}".encode()).hexdigest()[:32]
    path = Path(folder) / f"{name}-{key}.npy"
    try:
        return np.load(path, allow_pickle=False)
    except Exception:  # absent or unreadable: only a cache miss
        pass
    value = compute()
    partial = path.with_suffix(f".{os.getpid()}.partial")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(partial, "wb") as file:
            np.save(file, value, allow_pickle=False)
        partial.replace(path)  # atomic: a concurrent run reads the whole file or none
    except OSError:
        partial.unlink(missing_ok=True)
    return value


MAP_LIMIT = Path("/proc/sys/vm/max_map_count")
"""Linux's limit on a process's memory maps (65530 by default)."""


def _memory_maps() -> int | None:
    """How many memory maps this process holds (Linux), or None where that cannot be read."""
    try:
        with open("/proc/self/maps", "rb") as maps:
            return maps.read().count(b"\n")
    except OSError:
        return None


def release_compiled_code(fraction: float = 0.5) -> bool:
    """Drop JAX's in-memory compiled functions when this process's memory maps pass
    ``fraction`` of Linux's limit (:data:`MAP_LIMIT`); return whether they were dropped.

    XLA's CPU code of one compiled function takes a handful of memory maps, a noise fit's
    functions for one record shape about 3,200 (measured), and none are returned while JAX
    keeps the function: a long session that fits records of twenty lengths, or a test run of
    hundreds of models, reaches the limit, and the next compilation then dies of a
    segmentation fault inside XLA instead of an error. Dropped (``jax.clear_caches``), a
    function is compiled again when next called, from the on-disk caches (module docstring):
    the next fit costs what a first fit in a new process does (measured at 30,000 samples,
    load ~10: 8.4 s against 1.1 s warm). A caller's own jitted functions are dropped too, and
    recompiled the same way. Nowhere to read the maps (not Linux): nothing is done.
    """
    jax = sys.modules.get("jax")
    if jax is None:
        return False
    try:
        limit = int(MAP_LIMIT.read_text())
    except (OSError, ValueError):
        return False
    maps = _memory_maps()
    if maps is None or maps < fraction * limit:
        return False
    jax.clear_caches()
    return True
