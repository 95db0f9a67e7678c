"""Traced functions kept on disk between runs.

JAX's persistent compilation cache keeps XLA's compilation, not the tracing before it, and
tracing the term search's optimisers (BFGS from two starts with the Hessian at the optimum,
one per output-filter family) cost a ``noise`` run about five seconds of Python: more than
the whole classical analysis of 10^7 samples. :func:`persistent_jit` keeps the traced
function itself, exported as StableHLO (``jax.export``: a versioned, portable format, not
pickled code), keyed by everything that shapes it: the function, the static part of its
arguments, the shapes and dtypes of their arrays, bayescal's own source, the versions of JAX
and the libraries traced through, and the device. A later run with the same structure loads
it in milliseconds and XLA's compilation comes from JAX's cache; a changed line of bayescal
or another JAX misses and traces afresh. The exported function computes what the traced one
does: the same StableHLO, compiled by the same XLA.

The cache is the folder ``BAYESCAL_TRACE_CACHE`` names: ``~/.cache/bayescal/traces`` unless
the environment says otherwise, for the library and the command line alike
(:mod:`bayescal._caches`); empty, nothing is kept. A function traced afresh says so where a
progress bar was asked for (:func:`announcing`): the first run on a machine pays for it once.
Arguments whose static part has no stable description
(an object printed with its address) are traced as ``eqx.filter_jit`` would, and not stored.
"""

import contextlib
import contextvars
import functools
import hashlib
import os
import sys
from collections.abc import Callable
from importlib.metadata import version
from pathlib import Path

import equinox as eqx
import jax

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._caches import TRACE_CACHE, source_digest

_ANNOUNCE = contextvars.ContextVar("bayescal_announce_tracing", default=None)
"""Inside :func:`announcing`: a one-item list, whether tracing was announced yet."""


@contextlib.contextmanager
def announcing(enabled: bool):
    """Within the block, the first function traced afresh writes one line beside the
    progress bar (tqdm's, on stderr) saying so; ``enabled`` False: nothing is written."""
    token = _ANNOUNCE.set([False] if enabled else None)
    try:
        yield
    finally:
        _ANNOUNCE.reset(token)


def _announce(folder: str) -> None:
    state = _ANNOUNCE.get()
    if state is None or state[0]:
        return
    state[0] = True
    from tqdm import tqdm

    tqdm.write(
        f"compiling the model's functions for this record's shapes (first use on this "
        f"machine; kept in {folder}, later runs skip it)",
        file=sys.stderr,
    )


_PACKAGES = ("jax", "jaxlib", "equinox", "optimistix", "lineax")


def persistent_jit(fun: Callable) -> Callable:
    """``eqx.filter_jit(fun)`` whose traced function persists between runs (module
    docstring). ``fun`` takes positional arguments and returns a pytree of arrays.

    The function returned has a ``specialised(*args)`` attribute: (a function of the arrays
    of ``args``, flattened, and those arrays), for a caller that calls it thousands of times
    with only the last of them changing (the sampler's walkers): no key is computed per
    call."""
    jitted = eqx.filter_jit(fun)
    compiled = {}

    def specialised(*args):
        dynamic, static = eqx.partition(args, eqx.is_array)
        leaves, treedef = jax.tree_util.tree_flatten(dynamic)
        folder = os.environ.get(TRACE_CACHE)
        key = _key(fun, treedef, static, leaves) if folder else None
        if key is None:

            def traced(*arrays):
                return jitted(*eqx.combine(jax.tree_util.tree_unflatten(treedef, arrays), static))

            return traced, leaves
        if key not in compiled:
            path = Path(folder) / f"{fun.__name__}-{key}.stablehlo"
            exported = _load(path)
            if exported is None:
                _announce(folder)
                exported = _export_and_store(fun, treedef, static, leaves, path)
            compiled[key] = jax.jit(exported.call)
        return compiled[key], leaves

    @functools.wraps(fun)
    def call(*args):
        function, leaves = specialised(*args)
        return function(*leaves)

    call.specialised = specialised
    return call


def _token(leaf) -> str | None:
    """A stable description of a static leaf, or None when it has none. A function is named
    by its module and qualified name only when that name is unique to it: a nested function
    or a lambda may capture different values under one name."""
    if callable(leaf) and hasattr(leaf, "__qualname__"):
        if "<locals>" in leaf.__qualname__ or "<lambda>" in leaf.__qualname__:
            return None
        return f"{leaf.__module__}.{leaf.__qualname__}"
    if leaf is None or isinstance(leaf, (bool, int, float, str)):
        return repr(leaf)
    return None


def _key(fun, treedef, static, leaves) -> str | None:
    """The digest of everything the traced function depends on, or None when a static part
    has no stable description."""
    static_leaves, static_treedef = jax.tree_util.tree_flatten(static)
    tokens = [_token(leaf) for leaf in static_leaves]
    structure = _structure(treedef, static_treedef)
    if None in tokens or " at 0x" in structure:
        return None
    description = "\n".join(
        [
            _token(fun) or "",
            structure,
            *tokens,
            *(f"{leaf.shape}:{leaf.dtype}:{getattr(leaf, 'weak_type', False)}" for leaf in leaves),
            _environment(),
        ]
    )
    return hashlib.sha256(description.encode()).hexdigest()[:32]


_STRUCTURES: dict = {}


def _structure(treedef, static_treedef) -> str:
    """The printed structure of the arguments, kept for structures met before: printing a
    model's static parts (equinox prints every field) took 70 ms a call, 2.8 s of a fit's
    40 calls. Structures that cannot be hashed are printed each time."""
    pair = (treedef, static_treedef)
    try:
        if pair not in _STRUCTURES:
            _STRUCTURES[pair] = f"{treedef}|{static_treedef}"
        return _STRUCTURES[pair]
    except TypeError:
        return f"{treedef}|{static_treedef}"


@functools.cache
def _environment() -> str:
    """bayescal's source, the versions of the libraries traced through, and the device."""
    device = jax.devices()[0]
    return "|".join(
        [
            source_digest(),
            *(f"{name}={version(name)}" for name in _PACKAGES),
            device.platform,
            device.device_kind,
            str(jax.config.jax_enable_x64),
        ]
    )


def _load(path: Path):
    """The exported function stored at ``path``, or None (absent or unreadable: traced
    again and stored anew)."""
    try:
        return jax.export.deserialize(bytearray(path.read_bytes()))
    except Exception:  # any unreadable entry is only a cache miss
        return None


def _export_and_store(fun, treedef, static, leaves, path: Path):
    """Trace ``fun`` for these arguments, export it and store it (a folder that cannot be
    written only costs the next run its tracing)."""

    def flat(*arrays):
        return fun(*eqx.combine(jax.tree_util.tree_unflatten(treedef, arrays), static))

    exported = jax.export.export(jax.jit(flat))(*leaves)
    partial = path.with_suffix(f".{os.getpid()}.partial")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        partial.write_bytes(exported.serialize())
        partial.replace(path)  # atomic: a concurrent run reads the whole file or none
    except OSError:
        partial.unlink(missing_ok=True)
    except BaseException:  # interrupted: no partial entry is left in the cache
        partial.unlink(missing_ok=True)
        raise
    return exported
