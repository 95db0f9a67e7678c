"""Reading the files a recording comes in: CSV (one header row, optional leading ``#`` comment
lines), Parquet and NPZ with named columns, and the ``sensor_msgs/Imu`` topics of ROS bags
(:mod:`._rosbag`). Each reader returns the numeric columns by name, the units their header
writes (``gyro_x[deg/s]``), and the names of the columns that are not numeric."""

import re
from pathlib import Path

import numpy as np

from .._errors import InputError
from ._rosbag import SUFFIXES as ROSBAG_SUFFIXES
from ._rosbag import read_rosbag

_HEADER_UNIT = re.compile(r"^\s*(?P<name>[^\[\]]*?)\s*\[(?P<unit>[^\[\]]+)\]\s*$")
TABLE_SUFFIXES = (".csv", ".txt", ".parquet", ".pq", ".npz")


def is_rosbag(path: Path) -> bool:
    """Whether ``path`` names a ROS bag: a .bag, .db3 or .mcap file, or a folder."""
    return path.suffix.lower() in ROSBAG_SUFFIXES or path.is_dir()


def split_header(raw_names: list[str]) -> tuple[list[str], dict[str, str]]:
    """Column names without their bracketed units, and the units by name."""
    names, units = [], {}
    for raw in raw_names:
        match = _HEADER_UNIT.match(raw)
        name = match["name"] if match else raw.strip()
        if match:
            units[name] = match["unit"].strip()
        names.append(name)
    return names, units


def _leading_comment_lines(path: Path) -> int:
    count = 0
    with path.open("rb") as handle:
        for line in handle:
            if not line.startswith(b"#"):
                break
            count += 1
    return count


def _read_arrow(path: Path, source: str):
    import pyarrow as pa
    import pyarrow.csv as pa_csv
    import pyarrow.parquet as pa_parquet

    try:
        if path.suffix.lower() in (".parquet", ".pq"):
            return pa_parquet.read_table(path)
        options = pa_csv.ReadOptions(skip_rows=_leading_comment_lines(path))
        return pa_csv.read_csv(path, read_options=options)
    except pa.ArrowInvalid as error:
        detail = str(error).splitlines()[0]
        raise InputError(
            f"cannot read it as {path.suffix.lstrip('.').upper()}: {detail}",
            source=source,
            fix="check that it is a table with one header row",
        ) from None


def _read_npz(path: Path, source: str) -> dict:
    try:
        archive = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as error:
        raise InputError(f"cannot read it as NPZ: {error}", source=source) from None
    arrays = {key: archive[key] for key in archive.files}
    lengths = {array.shape[0] for array in arrays.values() if array.ndim == 1}
    if len(lengths) != 1:
        raise InputError(
            "an NPZ recording needs 1-D arrays of one common length, one per "
            f"column; found lengths {sorted(lengths) or 'none'}",
            source=source,
            fix="save each channel as its own 1-D array",
        )
    raw = {key: array for key, array in arrays.items() if array.ndim == 1}
    names, units = split_header(list(raw))
    columns = {name: np.asarray(array) for name, array in zip(names, raw.values(), strict=True)}
    numeric = {k: v.astype(float) for k, v in columns.items() if np.issubdtype(v.dtype, np.number)}
    other = tuple(k for k in columns if k not in numeric)
    return {"columns": numeric, "header_units": units, "other_columns": other}


def _read_table(path: Path, source: str) -> dict:
    import pyarrow.types as pa_types

    table = _read_arrow(path, source)
    if table.num_rows == 0:
        raise InputError("the file holds no data rows", source=source)
    names, units = split_header(table.column_names)
    columns, other = {}, []
    for name, column in zip(names, table.columns, strict=True):
        kind = column.type
        if pa_types.is_null(kind) and not name:
            continue  # the empty column a trailing comma on every line makes
        if pa_types.is_integer(kind) or pa_types.is_floating(kind) or pa_types.is_null(kind):
            columns[name] = column.to_numpy(zero_copy_only=False).astype(float)
        else:
            other.append(name)
    return {"columns": columns, "header_units": units, "other_columns": tuple(other)}


def read_columns(path: str | Path, topic: str | None = None) -> dict:
    """The columns of a CSV, Parquet or NPZ recording, or of the ``sensor_msgs/Imu`` topic
    ``topic`` of a ROS bag: a dict with ``source``, ``columns`` (name -> float array),
    ``header_units`` and, as each format has them, ``other_columns``, ``topic`` and
    ``start_stamp_ns``."""
    path = Path(path)
    source = str(path)
    if is_rosbag(path):
        return read_rosbag(path, topic)
    if topic is not None:
        raise InputError(
            f"--topic {topic}: only a ROS bag has topics", source=source, fix="leave --topic out"
        )
    if not path.is_file():
        raise InputError("no such file", source=source, fix="check the path")
    suffix = path.suffix.lower()
    if suffix not in TABLE_SUFFIXES:
        raise InputError(
            f"unknown file type '{path.suffix}'",
            source=source,
            fix="use a .csv, .parquet or .npz recording, or a ROS bag (.bag, .db3, .mcap)",
        )
    content = _read_npz(path, source) if suffix == ".npz" else _read_table(path, source)
    return {"source": source, **content}
