"""Writing results: JSON with units beside numbers, and every file written atomically.

One writer for every file bayescal writes (:func:`atomic_path`): the content goes to a
temporary file beside the target, which replaces the target only once it is complete — a
failed or interrupted write leaves no partial file — with the mode the umask allows (a
temporary file is private, a result is made to be shared).
"""

import contextlib
import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np

from ._errors import InputError


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


def check_writable(path: str | os.PathLike, argument: str) -> Path:
    """Fail early, before any work, when an output cannot be written."""
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise InputError(
            f"{argument} {target}: folder '{folder}' does not exist",
            fix="create it or choose another path",
        )
    if not os.access(folder, os.W_OK):
        raise InputError(
            f"{argument} {target}: folder '{folder}' is not writable", fix="choose another path"
        )
    return target


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike):
    """A temporary path beside ``path`` to write to; it replaces ``path`` when the block
    ends without an error, and is removed when it does not."""
    target = Path(path)
    descriptor, temporary = tempfile.mkstemp(
        dir=target.parent if str(target.parent) else ".",
        prefix=f".{target.name}.",
        suffix=target.suffix,
    )
    os.close(descriptor)
    try:
        yield Path(temporary)
        os.chmod(temporary, 0o666 & ~_umask())
        os.replace(temporary, target)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def write_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` so that a failure leaves no partial file."""
    with atomic_path(path) as temporary:
        temporary.write_text(text, encoding="utf-8")


def write_json(path: str | os.PathLike, result: dict) -> None:
    """Write ``result`` as JSON (non-finite numbers as null), atomically."""
    write_atomic(path, json.dumps(to_jsonable(result), indent=1, ensure_ascii=False) + "\n")


def write_netcdf(tree, path: str | os.PathLike) -> None:
    """Write an ArviZ DataTree as netCDF (h5netcdf), atomically."""
    with atomic_path(path) as temporary:
        tree.to_netcdf(temporary, engine="h5netcdf")


def write_csv(path: str | os.PathLike, columns: dict) -> None:
    """A CSV file with one header row (the names as given, units in brackets where they
    carry them), every float written so that it reads back exactly; atomically."""
    import csv
    import io

    import pyarrow as pa
    import pyarrow.csv as pa_csv

    header = io.StringIO()
    csv.writer(header, lineterminator="\n").writerow(columns)  # quotes a name only if needed
    options = pa_csv.WriteOptions(include_header=False, quoting_style="needed")
    with atomic_path(path) as temporary, open(temporary, "wb") as handle:
        handle.write(header.getvalue().encode("utf-8"))
        pa_csv.write_csv(pa.table(list(columns.values()), names=list(columns)), handle, options)
