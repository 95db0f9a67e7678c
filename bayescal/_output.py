"""Writing results: JSON with units beside numbers, written atomically."""

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


def write_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` so that a failure leaves no partial file."""
    target = Path(path)
    descriptor, temporary = tempfile.mkstemp(dir=target.parent or ".", prefix=f".{target.name}.")
    try:
        with os.fdopen(descriptor, "w", encoding="utf-8") as handle:
            handle.write(text)
        os.replace(temporary, target)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def write_json(path: str | os.PathLike, result: dict) -> None:
    write_atomic(path, json.dumps(to_jsonable(result), indent=1, ensure_ascii=False) + "\n")
