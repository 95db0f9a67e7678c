"""Reading the files a recording comes in: text tables (CSV and its cousins, :mod:`._text`),
Parquet, NumPy and MATLAB arrays (:mod:`._arrays`), and the ``sensor_msgs/Imu`` topics of ROS
bags (:mod:`._rosbag`). Each reader returns the numeric columns by name, the units their
header writes (``gyro_x[deg/s]``), the columns that cannot be analysed with the reason (text,
a text cell in a numeric column, a name used twice, complex numbers ...), every column of the
file in its order (what ``thermal compensate`` writes back), and notes on what it inferred."""

import re
from pathlib import Path

import numpy as np

from .._errors import InputError, MissingFileError
from ._rosbag import SUFFIXES as ROSBAG_SUFFIXES
from ._rosbag import read_rosbag

_HEADER_UNIT = re.compile(r"^\s*(?P<name>[^\[\]]*?)\s*\[(?P<unit>[^\[\]]+)\]\s*$")
TEXT_SUFFIXES = (".csv", ".txt", ".tsv", ".dat", ".log")
ARRAY_SUFFIXES = (".npz", ".npy", ".mat")
TABLE_SUFFIXES = (*TEXT_SUFFIXES, ".parquet", ".pq", *ARRAY_SUFFIXES)


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


def _duplicates(names: list[str]) -> dict[str, tuple[str, str]]:
    positions: dict[str, list[int]] = {}
    for position, name in enumerate(names):
        positions.setdefault(name, []).append(position + 1)
    return {
        name: (
            f"is the name of {len(where)} columns (columns {', '.join(map(str, where))})",
            "rename them in the header so that each name is used once",
        )
        for name, where in positions.items()
        if len(where) > 1 and name
    }


def _seconds_from_first(nanoseconds: np.ndarray) -> np.ndarray:
    """Integer nanoseconds (dates and times) as float seconds from the first, exactly."""
    valid = nanoseconds[nanoseconds != np.iinfo(np.int64).min]
    first = valid[0] if valid.size else 0
    return (nanoseconds - first).astype(float) * 1e-9


def _floats(column) -> np.ndarray:
    """A numeric pyarrow column as float64 with NaN for nulls, read from its buffers:
    pyarrow's ``to_numpy`` imports pandas to convert one (a third of a second per run)."""
    import pyarrow as pa
    import pyarrow.compute as pc

    out = np.empty(len(column))  # every sample written below: a value, or NaN
    start = 0
    for chunk in pc.cast(column, pa.float64(), safe=False).chunks:
        size = len(chunk)
        validity, data = chunk.buffers()
        if data is not None:
            values = np.frombuffer(data, np.float64, count=chunk.offset + size)[chunk.offset :]
            out[start : start + size] = values
        else:
            out[start : start + size] = np.nan
        if chunk.null_count and validity is not None:
            bits = np.unpackbits(np.frombuffer(validity, np.uint8), bitorder="little")
            out[start : start + size][bits[chunk.offset : chunk.offset + size] == 0] = np.nan
        start += size
    return out


def _numbers(column, name: str) -> tuple[np.ndarray | None, str | None]:
    """A pyarrow column as floats — numbers as they are, dates and times as seconds from the
    first stamp (with a note) — or None when it holds text."""
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.types as pa_types

    from ._text import time_of_day_seconds

    kind = column.type
    if pa_types.is_integer(kind) or pa_types.is_floating(kind) or pa_types.is_null(kind):
        return _floats(column), None
    if pa_types.is_decimal(kind):
        return column.cast(pa.float64()).to_numpy(zero_copy_only=False), None
    if pa_types.is_timestamp(kind) or pa_types.is_date(kind):
        missing = np.iinfo(np.int64).min
        stamps = pc.cast(column.cast(pa.timestamp("ns")), pa.int64()).fill_null(missing)
        stamps = stamps.to_numpy()
        values = _seconds_from_first(stamps)
        values[stamps == missing] = np.nan
        return values, f"'{name}' read as dates and times: seconds from its first stamp"
    if pa_types.is_time(kind) or pa_types.is_string(kind) or pa_types.is_large_string(kind):
        values = time_of_day_seconds(np.asarray(column.cast(pa.string()).to_pylist()))
        if values is not None:
            return values, f"'{name}' read as times of day: seconds from its first stamp"
    return None, None


def _nested(column) -> list[np.ndarray] | tuple[str, str]:
    """A Parquet column of lists as one float column per element (every row the same number
    of numbers, an empty cell a missing sample in each), or why a column of lists, structs
    or maps cannot be read (problem, fix): a vector per row is how a tool may store the
    three axes of a sensor."""
    import pyarrow.compute as pc
    import pyarrow.types as pa_types

    kind = column.type
    if not (
        pa_types.is_list(kind) or pa_types.is_large_list(kind) or pa_types.is_fixed_size_list(kind)
    ):
        return (f"holds {kind} values, not numbers", "save each channel as a column of numbers")
    element = kind.value_type
    if not (pa_types.is_integer(element) or pa_types.is_floating(element)):
        return (
            f"holds lists of {element}, not of numbers",
            "save each channel as a column of numbers",
        )
    lengths = pc.unique(pc.drop_null(pc.list_value_length(column))).to_pylist()
    if len(lengths) != 1 or lengths[0] == 0:
        described = f"of {min(lengths)} to {max(lengths)} numbers" if lengths else "with no numbers"
        return (
            f"holds lists {described} per row, not one number per row",
            "save each element of the list as its own column, of the same length in every row",
        )
    return [_floats(pc.list_element(column, index)) for index in range(lengths[0])]


def _as_text(column) -> np.ndarray:
    """A column's cells as text (None where empty), whatever its type."""
    import pyarrow as pa

    try:
        return np.asarray(column.cast(pa.string()).to_pylist(), dtype=object)
    except (pa.ArrowNotImplementedError, pa.ArrowInvalid):  # lists, structs, bytes ...
        return np.asarray(
            [None if cell is None else str(cell) for cell in column.to_pylist()], dtype=object
        )


def _arrow_columns(table, notes: list[str]) -> dict:
    """Columns of a pyarrow Table: numbers as float, dates and times as seconds from their
    first stamp, lists of numbers as one column per element (``NAME_0``, ``NAME_1``, ... as
    the channels of an array are named), the rest as text (a mostly numeric column with a
    text cell remembered)."""
    import pyarrow.types as pa_types

    from ._text import text_cell_problem

    headers = [str(name) for name in table.column_names]
    names, units = split_header(headers)
    nested = {
        name: _nested(column)
        for name, column in zip(names, table.columns, strict=True)
        if pa_types.is_nested(column.type)
    }
    expanded = {
        name: [f"{name}_{index}" for index in range(len(found))]
        for name, found in nested.items()
        if isinstance(found, list)
    }
    unusable = _duplicates([item for name in names for item in expanded.get(name, [name])])
    columns: dict[str, np.ndarray] = {}
    other: list[str] = []
    file_columns: list[tuple[str, np.ndarray]] = []
    for header, name, column in zip(headers, names, table.columns, strict=True):
        if pa_types.is_null(column.type) and not name:
            continue  # the empty column a trailing comma on every line makes
        if name in expanded:
            unusable.setdefault(
                name,
                (
                    f"holds a list of {len(expanded[name])} numbers per row, read as the "
                    f"columns {', '.join(expanded[name])}",
                    "choose one of them",
                ),
            )
            for element, values in zip(expanded[name], nested[name], strict=True):
                if name in units:
                    units[element] = units[name]
                unit = f"[{units[name]}]" if name in units else ""
                file_columns.append((element + unit, values))
                if element not in unusable:
                    columns[element] = values
            continue
        values, note = (None, None) if name in nested else _numbers(column, name)
        if values is None or note:
            cells = _as_text(column)
            file_columns.append((header, cells))  # text, and dates as the file writes them
        if values is None:
            other.append(name)
            problem = nested.get(name) or text_cell_problem(cells)
            if problem is not None and name not in unusable:
                unusable[name] = problem
            continue
        if note:
            notes.append(note)
            units.setdefault(name, "s")
        else:
            file_columns.append((header, values))
        if name not in unusable:
            columns[name] = values
    return {
        "columns": columns,
        "header_units": units,
        "other_columns": tuple(other),
        "unusable": unusable,
        "file_columns": tuple(file_columns),
    }


def _read_text(path: Path, source: str, options: dict) -> dict:
    from ._text import read_text_arrow

    names = options.get("names")
    if isinstance(names, dict):
        raise InputError(
            "names as {array: [names]} chooses an array of a .npz or .mat file; a text table has "
            "none",
            source=source,
            fix='give the names alone: names=["a", "b", "c"]',
        )
    table, notes, metadata = read_text_arrow(path, source, options.get("skip_rows") or 0, names)
    if table.num_rows == 0:
        raise InputError("the file holds no data rows", source=source)
    return {**_arrow_columns(table, notes), "notes": tuple(notes), "metadata": metadata}


def _read_parquet(path: Path, source: str) -> dict:
    import pyarrow as pa
    import pyarrow.parquet as pa_parquet

    try:
        # ParquetFile reads one file without importing pyarrow.dataset (0.4 s); a folder
        # (a partitioned dataset, as Spark writes it) needs read_table.
        table = (
            pa_parquet.read_table(path) if path.is_dir() else pa_parquet.ParquetFile(path).read()
        )
    except (pa.ArrowException, OSError) as error:
        detail = str(error).splitlines()[0]
        raise InputError(
            f"cannot read it as Parquet: {detail}", source=source, fix="check the file"
        ) from None
    if table.num_rows == 0:
        raise InputError("the file holds no data rows", source=source)
    notes: list[str] = []
    return {**_arrow_columns(table, notes), "notes": tuple(notes)}


def _read_arrays(path: Path, source: str, options: dict) -> dict:
    from ._arrays import array_columns, read_mat, read_npy, read_npz

    suffix = path.suffix.lower()
    notes = []
    if suffix == ".mat":
        arrays = read_mat(path, source)
        if arrays is None:
            result = _read_text(path, source, options)
            return {
                **result,
                "notes": ("the .mat file is text: read as a text table", *result["notes"]),
            }
    else:
        arrays = read_npz(path, source) if suffix == ".npz" else read_npy(path, source)
    if options.get("skip_rows"):
        raise InputError(
            "skip_rows= applies to text tables; this file holds arrays",
            source=source,
            fix="leave it out",
        )
    found = array_columns(
        arrays,
        source,
        names=options.get("names"),
        samples_axis=options.get("samples_axis"),
        channels_axis=options.get("channels_axis"),
    )
    names, units = split_header(list(found["raw"]))
    unusable = {**found["unusable"], **_duplicates(names)}
    columns = {
        name: np.asarray(values, dtype=float)
        for name, values in zip(names, found["raw"].values(), strict=True)
        if name not in unusable
    }
    return {
        "columns": columns,
        "header_units": units,
        "other_columns": (),
        "unusable": unusable,
        "file_columns": tuple(found["raw"].items()),
        "notes": tuple(notes),
    }


def read_columns(
    path: str | Path,
    topic: str | None = None,
    *,
    skip_rows: int = 0,
    names: list[str] | dict[str, list[str]] | None = None,
    samples_axis: int | None = None,
    channels_axis: int | None = None,
) -> dict:
    """The columns of a recording file, or of the ``sensor_msgs/Imu`` topic ``topic`` of a ROS
    bag: a dict with ``source``, ``columns`` (name -> float array), ``header_units``, and, as
    each format has them, ``other_columns``, ``unusable`` (name -> (problem, fix)),
    ``file_columns``, ``notes``, ``topic`` and ``start_stamp_ns``."""
    path = Path(path)
    source = str(path)
    options = {
        "skip_rows": skip_rows,
        "names": names,
        "samples_axis": samples_axis,
        "channels_axis": channels_axis,
    }
    if is_rosbag(path):
        if any(value for value in options.values()):
            raise InputError(
                "skip_rows=, names= and samples_axis=/channels_axis= do not apply to a ROS bag",
                source=source,
                fix="leave them out",
            )
        return read_rosbag(path, topic)
    if topic is not None:
        raise InputError(
            f"topic={topic!r}: only a ROS bag has topics", source=source, fix="leave topic= out"
        )
    if not path.exists():
        raise MissingFileError("no such file", source=source)
    if not path.is_file():
        raise InputError("is a folder, not a recording", source=source, fix="check the path")
    suffix = path.suffix.lower()
    if suffix not in TABLE_SUFFIXES:
        raise InputError(
            f"unknown file type '{path.suffix}'",
            source=source,
            fix="use a .csv (or .txt/.tsv), .parquet, .npz, .npy or .mat recording, or a ROS "
            "bag (.bag, .db3, .mcap)",
        )
    if suffix not in ARRAY_SUFFIXES and (samples_axis is not None or channels_axis is not None):
        raise InputError(
            "samples_axis= and channels_axis= apply to arrays (.npz, .npy, .mat)",
            source=source,
            fix="leave them out",
        )
    try:
        if suffix in ARRAY_SUFFIXES:
            content = _read_arrays(path, source, options)
        elif suffix in (".parquet", ".pq"):
            if skip_rows or names:
                raise InputError(
                    "skip_rows= and names= apply to text tables and arrays, not Parquet",
                    source=source,
                    fix="leave them out",
                )
            content = _read_parquet(path, source)
        else:
            content = _read_text(path, source, options)
    except PermissionError:
        raise InputError("cannot be read (permission denied)", source=source) from None
    except IsADirectoryError:
        raise InputError("is a folder, not a recording file", source=source) from None
    return {"source": source, **content}
