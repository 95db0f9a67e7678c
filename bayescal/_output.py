"""Writing results: JSON with units beside numbers, and every file of a run written all or
nothing.

One writer for every file bayescal writes (:func:`atomic_path`): the content goes to a
temporary file beside the target, which replaces the target only once it is complete — a
failed or interrupted write leaves no partial file — with the mode the umask allows (a
temporary file is private, a result is made to be shared).

Inside :class:`Outputs` (every command of the command line runs in one), the temporaries wait
until the whole run has succeeded and are then moved into place together; a run that fails or
is interrupted removes them, and the folders it created, so that it leaves nothing behind. A
signal (Ctrl-C, SIGTERM) waits while files move into place or are removed, and while a
temporary is made and recorded (:func:`signals_deferred`): none is cut in half. An
output that is one of the run's inputs, or another of its outputs, is refused before any work.

A write the machine refuses — a full disk, a quota, a read-only file system — is an
:class:`~bayescal._errors.InputError` that names the file and what to do (exit 2), its
temporary removed; where the content is known before it is written (JSON, a page, the
posterior's netCDF) the free space is checked first. The netCDF file is made in memory and
written by Python: HDF5 writing to a full disk fails inside its C library, and the process
then died in HDF5's teardown (a segmentation fault) after the error.
"""

import contextlib
import contextvars
import errno
import io
import json
import math
import os
import re
import shutil
import signal
import tempfile
from pathlib import Path

import numpy as np

from ._errors import InputError

_ACTIVE: contextvars.ContextVar["Outputs | None"] = contextvars.ContextVar(
    "bayescal_outputs", default=None
)
# Characters a file name made from a column name must not carry: a path separator would point
# into a folder that does not exist, the rest trouble shells and other systems.
_UNSAFE_IN_NAME = re.compile(r"[^\w.\-+=@]+")


def to_jsonable(value):
    """Plain Python for JSON: arrays to lists, non-finite numbers to null."""
    if isinstance(value, dict):
        return {str(key): to_jsonable(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_jsonable(item) for item in value]
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    return value


def file_stem(name: str) -> str:
    """``name`` (a column's, say) made safe as part of a file name: every run of characters
    other than letters, digits and ``. - + = @`` becomes one underscore (``gyro/x`` ->
    ``gyro_x``)."""
    return _UNSAFE_IN_NAME.sub("_", name).strip("._") or "channel"


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and a.samefile(b))
    except OSError:
        return False


def check_writable(path: str | os.PathLike, argument: str) -> Path:
    """Fail early, before any work, when an output file cannot be written: its folder is
    missing or read-only, or the path is a folder."""
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    if target.is_dir():
        raise InputError(f"{argument} {target}: is a folder", fix="give a file name")
    if not folder.is_dir():
        raise InputError(
            f"{argument} {target}: folder '{folder}' does not exist",
            fix="create it or choose another path",
        )
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(
            f"{argument} {target}: folder '{folder}' is not writable", fix="choose another path"
        )
    return target


def check_folder(path: str | os.PathLike, argument: str) -> Path:
    """Fail early when an output folder cannot be made or written into."""
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{argument} {folder}: exists and is not a folder", fix="choose a folder")
    parent = folder if folder.is_dir() else folder.parent
    if not parent.is_dir():
        raise InputError(
            f"{argument} {folder}: folder '{parent}' does not exist",
            fix="create it or choose another path",
        )
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(
            f"{argument} {folder}: folder '{parent}' is not writable", fix="choose another path"
        )
    return folder


_DEFERRED_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextlib.contextmanager
def signals_deferred():
    """Hold SIGINT and SIGTERM while the block runs, then deliver them to the handlers in
    place before (in the main thread; elsewhere the block just runs): a step that must not
    be cut in half — files moving into place, a temporary made and recorded for removal —
    finishes first, and a Ctrl-C then acts as it would have."""
    held: list[int] = []
    try:
        before = {
            signum: signal.signal(signum, lambda signum, frame: held.append(signum))
            for signum in _DEFERRED_SIGNALS
        }
    except ValueError:  # not the main thread: signals are the main thread's to handle
        yield
        return
    try:
        yield
    finally:
        for signum, handler in before.items():
            signal.signal(signum, handler)
        for signum in dict.fromkeys(held):
            signal.raise_signal(signum)


# What an error of a write means to the user, and what to do about it.
_WRITE_FAILURES = {
    errno.ENOSPC: ("its file system is full", "free space there or choose another path"),
    errno.EDQUOT: (
        "the disk quota is used up",
        "free space within the quota or choose another path",
    ),
    errno.EROFS: ("its file system is read-only", "choose another path"),
    errno.EACCES: ("permission denied", "choose another path"),
    errno.EPERM: ("permission denied", "choose another path"),
    errno.EFBIG: ("too large for its file system", "choose another path"),
}


def write_error(path, error: OSError, fix: str | None = None) -> InputError:
    """The :class:`InputError` for an ``OSError`` of a write to ``path``: which file, what
    the machine said (a full disk, a quota, a read-only file system ...) and what to do
    (``fix``, else the usual advice for that error)."""
    problem, usual = _WRITE_FAILURES.get(
        error.errno, (error.strerror or str(error), "check the path and its disk")
    )
    return InputError(f"not written: {problem}", source=str(path), fix=fix or usual)


@contextlib.contextmanager
def _writing(target: Path):
    """An ``OSError`` in the block becomes :func:`write_error` for ``target``."""
    try:
        yield
    except OSError as error:
        raise write_error(target, error) from None


def _size(count: float) -> str:
    unit = "B"
    for larger in ("kB", "MB", "GB", "TB"):
        if count < 1000:
            break
        count, unit = count / 1000, larger
    return f"{count:.3g} {unit}"


def _check_room(target: Path, size: int) -> None:
    """Refuse, before writing, ``size`` bytes that the file system of ``target`` has no
    room for (the space an unprivileged user may fill; unknown: not checked)."""
    try:
        free = shutil.disk_usage(target.parent if str(target.parent) else ".").free
    except OSError:
        return
    if size > free:
        raise InputError(
            f"not written: it needs {_size(size)} and its file system has {_size(free)} free",
            source=str(target),
            fix="free space there or choose another path",
        )


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _temporary_beside(target: Path) -> Path:
    descriptor, temporary = tempfile.mkstemp(
        dir=target.parent if str(target.parent) else ".",
        prefix=f".{target.name}.",
        suffix=target.suffix,
    )
    os.close(descriptor)
    return Path(temporary)


class Outputs:
    """The output files of one run, all or nothing.

    Used as a context manager: while it is active, :func:`atomic_path` stages every file in a
    temporary beside its target; when the block ends without an exception the temporaries
    replace their targets (with the mode the umask allows) and locks taken with :meth:`lock`
    are released, and when it ends with one (an error, Ctrl-C, SIGTERM turned into an
    exception) the temporaries and the folders the run created are removed.

    Parameters
    ----------
    inputs : iterable of path-like
        The files the run reads: no output may name one of them.
    """

    def __init__(self, inputs=()):
        self._inputs = [Path(path) for path in inputs if path]
        self._claimed: dict[Path, str] = {}
        self._staged: dict[Path, Path] = {}
        self._created: list[Path] = []
        self._locks: list = []
        self._token = None

    @staticmethod
    def active() -> "Outputs | None":
        """The :class:`Outputs` of the run in progress, if any."""
        return _ACTIVE.get()

    def add_inputs(self, *paths) -> None:
        """More files the run reads (``None`` entries are skipped)."""
        self._inputs.extend(Path(path) for path in paths if path)

    def _check_not_input(self, target: Path, argument: str) -> None:
        for source in self._inputs:
            if _same_file(target, source):
                raise InputError(
                    f"{argument} {target}: is an input of this run ({source})",
                    fix="write the output to another path; the input is left as it is",
                )

    def claim(self, path, argument: str) -> Path:
        """Declare an output file before any work: it must be writable, not an input and not
        another output of this run."""
        target = check_writable(path, argument)
        self._check_not_input(target, argument)
        for other, other_argument in self._claimed.items():
            if _same_file(target, other):
                raise InputError(
                    f"{argument} {target}: {other_argument} already writes to this file",
                    fix="give each output its own path",
                )
        self._claimed[target] = argument
        return target

    def folder(self, path, argument: str) -> Path:
        """Declare an output folder: checked, and created now (removed again if the run
        fails and it was created by it)."""
        folder = check_folder(path, argument)
        self._check_not_input(folder, argument)
        if not folder.exists():
            with signals_deferred(), _writing(folder):
                folder.mkdir()
                self._created.append(folder)
        return folder

    def stage(self, path) -> Path:
        """A temporary that will replace ``path`` when the run succeeds."""
        target = Path(path)
        for other in self._staged:
            if _same_file(target, other):
                raise InputError(
                    f"{target}: two outputs of this run would write this file",
                    fix="give each output its own path",
                )
        self._check_not_input(target, "output")
        with signals_deferred(), _writing(target):
            temporary = _temporary_beside(target)
            self._staged[target] = temporary
        return temporary

    def temporary_of(self, path) -> Path | None:
        """The temporary staged for ``path``, if any."""
        return self._staged.get(Path(path))

    def unstage(self, path) -> None:
        """Drop the temporary of ``path`` (its writer failed)."""
        temporary = self._staged.pop(Path(path), None)
        if temporary is not None:
            temporary.unlink(missing_ok=True)

    def lock(self, path) -> None:
        """Hold an exclusive lock on ``.NAME.lock`` beside ``path`` until the run ends: two
        runs that read, merge and rewrite one file take turns."""
        import fcntl

        target = Path(path)
        lock_path = target.with_name(f".{target.name}.lock")
        with _writing(lock_path):
            handle = open(lock_path, "a")  # noqa: SIM115 (held until the run ends)
        fcntl.flock(handle, fcntl.LOCK_EX)
        self._locks.append(handle)

    def commit(self) -> None:
        mode = 0o666 & ~_umask()
        for target, temporary in self._staged.items():
            with _writing(target):
                os.chmod(temporary, mode)
                os.replace(temporary, target)
        self._staged.clear()
        self._created.clear()
        self._release()

    def discard(self) -> None:
        for temporary in self._staged.values():
            temporary.unlink(missing_ok=True)
        self._staged.clear()
        for folder in reversed(self._created):
            with contextlib.suppress(OSError):
                folder.rmdir()  # only if empty: never a user's file
        self._created.clear()
        self._release()

    def _release(self) -> None:
        for handle in self._locks:
            handle.close()  # closing releases the flock
        self._locks.clear()

    def __enter__(self) -> "Outputs":
        self._token = _ACTIVE.set(self)
        return self

    def __exit__(self, kind, error, traceback) -> None:
        _ACTIVE.reset(self._token)
        # All the files move, or all are removed, before a signal acts.
        with signals_deferred():
            if kind is None:
                try:
                    self.commit()
                except BaseException:
                    self.discard()
                    raise
            else:
                self.discard()


def staged(path: str | os.PathLike) -> Path:
    """Where a file this run wrote can be read before the run ends: its temporary inside
    :class:`Outputs` (the file itself appears only when the run succeeds), else ``path``."""
    outputs = Outputs.active()
    temporary = outputs.temporary_of(path) if outputs is not None else None
    return temporary or Path(path)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike):
    """A temporary path beside ``path`` to write to. Outside :class:`Outputs` it replaces
    ``path`` when the block ends without an error; inside, it waits for the run to succeed.
    Either way it is removed when the block (or the run) fails, and an ``OSError`` of the
    block (a full disk ...) becomes an :class:`InputError` naming ``path``
    (:func:`write_error`)."""
    target = Path(path)
    outputs = Outputs.active()
    if outputs is not None:
        temporary = outputs.stage(target)
        try:
            with _writing(target):
                yield temporary
        except BaseException:
            outputs.unstage(target)
            raise
        return
    temporary = None
    try:
        with signals_deferred(), _writing(target):
            temporary = _temporary_beside(target)
        with _writing(target):
            yield temporary
            os.chmod(temporary, 0o666 & ~_umask())
            os.replace(temporary, target)
    except BaseException:
        if temporary is not None:
            temporary.unlink(missing_ok=True)
        raise


def write_bytes(path: str | os.PathLike, content: bytes) -> None:
    """Write ``content`` to ``path`` so that a failure leaves no partial file, after checking
    that its file system has room for it."""
    with atomic_path(path) as temporary:
        _check_room(Path(path), len(content))
        temporary.write_bytes(content)


def write_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` so that a failure leaves no partial file."""
    write_bytes(path, text.encode("utf-8"))


def write_json(path: str | os.PathLike, result: dict) -> None:
    """Write ``result`` as JSON (non-finite numbers as null), atomically."""
    write_atomic(path, json.dumps(to_jsonable(result), indent=1, ensure_ascii=False) + "\n")


def write_netcdf(tree, path: str | os.PathLike) -> None:
    """Write an ArviZ DataTree as netCDF (h5netcdf), atomically: HDF5 makes the file in
    memory and Python writes it (HDF5's own write to a full disk crashed the process)."""
    image = io.BytesIO()
    tree.to_netcdf(image, engine="h5netcdf")
    # getvalue, not getbuffer: Python 3.12.1 crashes collecting a BytesIO whose buffer view
    # is in a reference cycle (the traceback of a failed write makes one).
    write_bytes(path, image.getvalue())


def write_csv(path: str | os.PathLike, columns) -> None:
    """A CSV file with one header row (the names as given, units in brackets where they
    carry them), every float written so that it reads back exactly, text columns as text;
    atomically. ``columns``: a dict name -> values, or (name, values) pairs (names may then
    repeat, as a file's header may)."""
    import csv
    import io

    import pyarrow as pa
    import pyarrow.csv as pa_csv

    pairs = list(columns.items()) if isinstance(columns, dict) else list(columns)
    header = io.StringIO()
    # Quotes a name only if needed.
    csv.writer(header, lineterminator="\n").writerow(name for name, _ in pairs)
    options = pa_csv.WriteOptions(include_header=False, quoting_style="needed")
    with atomic_path(path) as temporary, open(temporary, "wb") as handle:
        handle.write(header.getvalue().encode("utf-8"))
        arrays = [pa.array(np.asarray(values)) for _, values in pairs]
        pa_csv.write_csv(
            pa.table(arrays, names=[f"c{i}" for i in range(len(arrays))]), handle, options
        )
