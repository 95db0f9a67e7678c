"""A channel too long to hold in memory: its samples in a file on disk, read in blocks.

A recording of 10^8 samples is 800 MB per float64 channel, and every full-length temporary
(a difference, a mask, a phase) another 800 MB: the analysis of a long record reads its
samples block by block instead. :class:`SpooledSeries` keeps a channel's samples (NaN: a
missing one, as in memory) in a raw float64 file in a temporary folder, removed with the
object; :func:`blocks` hands any series — a NumPy array or a spooled one — to a computation
one block at a time, so each statistic is written once and runs on either. Blocks are read
with ordinary file reads into fresh buffers, not a memory map: the pages of a mapping that a
pass has touched stay in the process's resident memory, the buffers of a read do not.
"""

import contextlib
import os
import shutil
import tempfile
import weakref
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from .._output import signals_deferred, write_error

BLOCK = 1 << 20
"""Samples per block read (8 MB of float64): large enough that the per-block overhead
vanishes, small enough that a few of them cost nothing beside the process."""


def spool_folder() -> Path:
    """A fresh folder for spooled series under ``$BAYESCAL_SPOOL`` (else the system's
    temporary folder): put it on a disk with room for the record, 8 bytes a sample."""
    parent = os.environ.get("BAYESCAL_SPOOL") or None
    return Path(tempfile.mkdtemp(prefix="bayescal-spool-", dir=parent))


class SpooledSeries:
    """A float64 series on disk (NaN marks a missing sample), read in blocks.

    What :func:`~bayescal.stream_channel` gives as a long channel's ``values``; the noise
    analysis (:func:`~bayescal.fit_noise`, :func:`~bayescal.classical_noise`,
    :func:`~bayescal.allan_deviation`, :func:`~bayescal.hadamard_deviation`) reads it block
    by block. Converting it to an array (``np.asarray``) raises: a computation that needs
    every sample at once would defeat the bound on memory it exists for.

    Parameters
    ----------
    path : Path
        The raw float64 file (native byte order, no header).
    size : int
        Its number of samples.
    folder : Path, optional
        A folder made for it, removed with it; else only the file is removed. Removal happens
        when the object is collected, or at exit.

    Examples
    --------
    >>> import numpy as np
    >>> from bayescal.recording._series import SpoolWriter
    >>> writer = SpoolWriter()
    >>> writer.append(np.arange(10.0))
    >>> series = writer.finish()
    >>> series.size, series.read(2, 9, 3).tolist()
    (10, [2.0, 5.0, 8.0])
    """

    def __init__(self, path: Path, size: int, folder: Path | None = None):
        self.path = Path(path)
        self.size = int(size)
        self._statistics = {}  # name -> value (:func:`_once`): its samples never change
        self._cleanup = weakref.finalize(self, _remove, self.path, folder)

    @property
    def shape(self) -> tuple[int]:
        """``(size,)``: a series is one-dimensional."""
        return (self.size,)

    @property
    def ndim(self) -> int:
        """1: a series is one-dimensional."""
        return 1

    def __len__(self) -> int:
        return self.size

    def __array__(self, *args, **kwargs):
        raise TypeError(
            f"a spooled series of {self.size} samples is read in blocks (bayescal.recording."
            "blocks), not converted to one array"
        )

    def read(self, start: int, stop: int, step: int = 1) -> np.ndarray:
        """Samples ``start:stop:step`` (clipped to the series) as a new array.

        Parameters
        ----------
        start, stop, step : int
            As in a slice, non-negative.

        Returns
        -------
        numpy.ndarray
            The samples, read from disk into a fresh buffer.
        """
        start, stop = max(0, int(start)), min(self.size, int(stop))
        if stop <= start:
            return np.empty(0)
        if step == 1:
            return np.fromfile(self.path, dtype=np.float64, count=stop - start, offset=8 * start)
        count = (stop - start + step - 1) // step
        if step < 512:  # dense enough that reading the span and striding it is cheaper
            out = np.empty(count)
            span = max(1, BLOCK // step) * step  # whole steps, about a block read at a time
            for first in range(start, stop, span):
                block = self.read(first, min(stop, first + span))[::step]
                done = (first - start) // step
                out[done : done + block.size] = block
            return out
        # Sparse: one sample per read (each a page apart anyway).
        out = np.empty(count)
        with open(self.path, "rb") as handle:
            for index, position in enumerate(range(start, stop, step)):
                handle.seek(8 * position)
                out[index] = np.frombuffer(handle.read(8), dtype=np.float64)[0]
        return out


def _remove(path: Path, folder: Path | None = None) -> None:
    """Remove a spooled file, and the folder made for it."""
    if folder is not None:
        shutil.rmtree(folder, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


@contextlib.contextmanager
def _spooling(path):
    """A full disk (or any refused write) while spooling, said with where to spool instead."""
    try:
        yield
    except OSError as error:
        raise write_error(
            path,
            error,
            fix="set BAYESCAL_SPOOL to a folder on a disk with room for the record "
            "(8 bytes a sample)",
        ) from None


class SpoolWriter:
    """Appends float64 blocks to a new spooled series; :meth:`finish` returns it.

    The folder (:func:`spool_folder` by default) is removed with the series."""

    def __init__(self, folder: Path | None = None, name: str = "series"):
        self._own = folder is None
        self.folder = None
        spool = folder or os.environ.get("BAYESCAL_SPOOL") or tempfile.gettempdir()
        try:
            # A signal waits until the folder is made and known, so that it is removed below.
            with signals_deferred(), _spooling(spool):
                self.folder = spool_folder() if folder is None else Path(folder)
            self.path = self.folder / f"{name}.f8"
            with _spooling(self.path):
                self._handle = open(self.path, "wb")  # noqa: SIM115 (open across appends)
        except BaseException:  # a full disk, or a signal: no writer, and no folder left
            if self.folder is not None:
                _remove(self.folder / f"{name}.f8", self.folder if self._own else None)
            raise
        self.size = 0

    def append(self, values) -> None:
        block = np.ascontiguousarray(values, dtype=np.float64)
        with _spooling(self.path):
            self._handle.write(block.data)  # not tofile: its error carries no errno
        self.size += block.size

    def fill(self, count: int, value: float = np.nan) -> None:
        """Append ``count`` copies of ``value`` (a gap's missing samples), in blocks."""
        while count > 0:
            size = min(count, BLOCK)
            self.append(np.full(size, value))
            count -= size

    def finish(self) -> SpooledSeries:
        with _spooling(self.path):
            self._handle.close()
        return SpooledSeries(self.path, self.size, self.folder if self._own else None)

    def abandon(self) -> None:
        """Close and remove what was written (the read failed)."""
        self._handle.close()
        _remove(self.path, self.folder if self._own else None)


def is_spooled(values) -> bool:
    return isinstance(values, SpooledSeries)


def series_size(values) -> int:
    return values.size if is_spooled(values) else int(np.size(values))


def blocks(
    values, length: int | None = None, start: int = 0, stop: int | None = None
) -> Iterator[tuple[int, np.ndarray]]:
    """(first index, block) over ``values[start:stop]`` — views of an array, fresh reads of
    a spooled series — each block at most ``length`` samples (:data:`BLOCK` by default)."""
    length = BLOCK if length is None else length
    stop = series_size(values) if stop is None else min(stop, series_size(values))
    for first in range(start, stop, length):
        last = min(stop, first + length)
        if is_spooled(values):
            yield first, values.read(first, last)
        else:
            yield first, np.asarray(values[first:last], dtype=float)


def read(values, start: int, stop: int, step: int = 1) -> np.ndarray:
    """``values[start:stop:step]`` of an array or a spooled series."""
    if is_spooled(values):
        return values.read(start, stop, step)
    return np.asarray(values[start:stop:step], dtype=float)


def _once(values, name: str, compute):
    """``compute()``, computed once for a spooled series (a pass over the record each time
    otherwise: several stages ask) and every time for an array."""
    if not is_spooled(values):
        return compute()
    if name not in values._statistics:
        values._statistics[name] = compute()
    return values._statistics[name]


def gap_free_runs(values) -> np.ndarray:
    """(runs, 2): [start, stop) of each run of samples without NaN, in order (read-only)."""
    return _once(values, "gap_free_runs", lambda: _gap_free_runs(values))


def _gap_free_runs(values) -> np.ndarray:
    if not is_spooled(values):
        array = np.asarray(values, dtype=float)
        # A record without a gap, the usual one, is one run: told by its sum, which is NaN
        # where a sample is (or where infinities of both signs meet: then the pass below), in
        # one read of the record without a mask or its edges (the stages of a noise fit ask
        # four times or more).
        with np.errstate(invalid="ignore", over="ignore"):
            total = np.sum(array)
        if array.size and not np.isnan(total):
            runs = np.array([[0, array.size]], dtype=np.int64)
            runs.flags.writeable = False
            return runs
    runs = []
    open_at = None
    for first, block in blocks(values):
        present = ~np.isnan(block)
        edges = np.flatnonzero(
            np.diff(present.astype(np.int8), prepend=np.int8(open_at is not None))
        )
        for edge in edges:
            if present[edge]:
                open_at = first + int(edge)
            else:
                runs.append((open_at, first + int(edge)))
                open_at = None
    if open_at is not None:
        runs.append((open_at, series_size(values)))
    runs = np.array(runs, dtype=np.int64).reshape(-1, 2)
    runs.flags.writeable = False
    return runs


def finite_moments(values) -> tuple[int, float, float]:
    """(count, mean, sum of squared deviations) of the finite samples, combined block by
    block (Chan, Golub & LeVeque 1983) so no block's rounding reaches the others."""
    return _once(values, "finite_moments", lambda: _finite_moments(values))


def _finite_moments(values) -> tuple[int, float, float]:
    count, mean, squares = 0, 0.0, 0.0
    for _, block in blocks(values):
        finite = block[np.isfinite(block)]
        if finite.size == 0:
            continue
        block_mean = float(np.mean(finite))
        block_squares = float(np.sum((finite - block_mean) ** 2))
        total = count + finite.size
        delta = block_mean - mean
        mean += delta * finite.size / total
        squares += block_squares + delta**2 * count * finite.size / total
        count = total
    return count, mean, squares
