"""Recordings saved as arrays: NumPy ``.npz`` and ``.npy`` (memory-mapped), MATLAB ``.mat``
(version 4/5 through SciPy, version 7.3 through h5py; a ``.mat`` that is in fact text, as some
tools write, is read as a text table).

How arrays become columns
-------------------------
Every numeric variable of the file is read (MATLAB structs field by field, named
``struct.field``):

- a vector (one axis longer than 1: NumPy 1-D, MATLAB n x 1 or 1 x n) is one column named
  after its variable;
- an array of two or more axes has a **samples axis** — ``--samples-axis`` (numbered from 0,
  as NumPy shows the array and, for a ``.mat`` file, as MATLAB shows it: rows are axis 0),
  else its longest axis — and a **channels axis** — ``--channels-axis``, else the last other
  axis. Its channels are named ``VAR_0``, ``VAR_1``, ... or by ``--names`` (``--names
  t,gyro_x,gyro_y,gyro_z``; ``--names VAR:...`` when the file holds several such arrays).
  Any further axes index separate records of those channels, numbered in C order as a
  suffix: ``gyro_x_rec0``, ``gyro_x_rec1``, ... (a recordings x axes x samples array).

The recording's length is the longest samples axis; a variable of another length (a
calibration matrix, a scalar setting), text, complex numbers, cell arrays and pickled objects
are kept out of the columns, each with the reason it is refused should a command ask for it.
"""

from pathlib import Path

import numpy as np

from .._errors import InputError

_MAT_NUMERIC = {
    "double",
    "single",
    "int8",
    "uint8",
    "int16",
    "uint16",
    "int32",
    "uint32",
    "int64",
    "uint64",
    "logical",
}


_COMPLEX = (
    "holds complex numbers, which bayescal does not analyse",
    "save its real part (numpy.real) or its magnitude",
)
_SAVE_NUMBERS = "save the channel as a numeric array"


def _classify(array) -> np.ndarray | tuple[str, str]:
    """A real numeric array as is, or why it cannot be a column (problem, fix)."""
    if isinstance(array, str):
        return array, _SAVE_NUMBERS
    if isinstance(array, tuple):
        return array
    array = np.asarray(array) if not isinstance(array, np.ndarray) else array
    if np.iscomplexobj(array):
        return _COMPLEX
    if array.dtype.kind in "US":
        return "holds text, not numbers", _SAVE_NUMBERS
    if array.dtype.kind == "O":
        return "holds Python objects (or a MATLAB cell array), not numbers", _SAVE_NUMBERS
    if array.dtype.kind not in "biuf":
        return f"holds values of type {array.dtype}, not numbers", _SAVE_NUMBERS
    if array.ndim == 0:
        return "is a single number, not a column of samples", "choose a column of samples"
    if array.size == 0:
        return "is empty", "choose a column of samples"
    return array


def read_npz(path: Path, source: str) -> dict:
    try:
        archive = np.load(path, allow_pickle=False)
        keys = list(archive.files)
    except Exception as error:  # a damaged archive raises many kinds
        raise InputError(
            f"cannot read it as NPZ: {_one_line(error)}",
            source=source,
            fix="save it with numpy.savez",
        ) from None
    arrays = {}
    with archive:
        for key in keys:
            try:
                arrays[key] = archive[key]
            except ValueError:
                arrays[key] = "holds pickled Python objects, which bayescal does not load"
            except Exception as error:
                arrays[key] = f"cannot be read ({_one_line(error)})"
    return arrays


def read_npy(path: Path, source: str) -> dict:
    try:
        array = np.load(path, mmap_mode="r", allow_pickle=False)
    except ValueError as error:
        if "allow_pickle" in str(error):
            array = "holds pickled Python objects, which bayescal does not load"
        else:
            raise InputError(f"cannot read it as NPY: {_one_line(error)}", source=source) from None
    except Exception as error:
        raise InputError(
            f"cannot read it as NPY: {_one_line(error)}",
            source=source,
            fix="save it with numpy.save",
        ) from None
    return {path.stem: array}


def _one_line(error: Exception, limit: int = 160) -> str:
    text = " ".join(str(error).split()) or type(error).__name__
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _mat_v5(path: Path, source: str) -> dict:
    from scipy import io as scipy_io

    content = scipy_io.loadmat(path, simplify_cells=True)
    arrays: dict = {}

    def visit(name, value):
        if isinstance(value, dict):
            for field, item in value.items():
                visit(f"{name}.{field}", item)
        elif isinstance(value, str):
            arrays[name] = "holds text, not numbers"
        elif isinstance(value, list):
            arrays[name] = "is a MATLAB cell array, not numbers"
        elif hasattr(value, "toarray"):
            arrays[name] = "is a sparse matrix; save it full"
        else:
            arrays[name] = value

    for key, value in content.items():
        if not key.startswith("__"):
            visit(key, value)
    return arrays


def _mat_v73(path: Path, source: str) -> dict:
    import h5py

    arrays: dict = {}

    def visit(name, node):
        kind = node.attrs.get("MATLAB_class", b"")
        kind = kind.decode() if isinstance(kind, bytes) else str(kind)
        if isinstance(node, h5py.Group):
            for key in node:
                if not key.startswith("#"):
                    visit(f"{name}.{key}", node[key])
            return
        if node.attrs.get("MATLAB_empty", 0):
            arrays[name] = "is empty"
        elif kind == "char":
            arrays[name] = "holds text, not numbers"
        elif kind == "cell":
            arrays[name] = "is a MATLAB cell array, not numbers"
        elif node.dtype.names and {"real", "imag"} <= set(node.dtype.names):
            arrays[name] = _COMPLEX
        elif kind and kind not in _MAT_NUMERIC:
            arrays[name] = f"is a MATLAB {kind}, not numbers"
        else:
            # HDF5 stores MATLAB's column-major array with its axes reversed.
            arrays[name] = np.asarray(node[()]).T

    with h5py.File(path, "r") as handle:
        for key in handle:
            if not key.startswith("#"):
                visit(key, handle[key])
    return arrays


def looks_like_text(path: Path) -> bool:
    with path.open("rb") as handle:
        head = handle.read(4096)
    if not head or b"\x00" in head:
        return False
    printable = sum(32 <= byte < 127 or byte in b"\t\r\n" for byte in head)
    return printable / len(head) > 0.95


def read_mat(path: Path, source: str) -> dict | None:
    """The variables of a MATLAB file, or None when the file is text."""
    import h5py

    if h5py.is_hdf5(path):
        reader, version = _mat_v73, "7.3"
    else:
        reader, version = _mat_v5, "4/5"
    try:
        return reader(path, source)
    except Exception as error:  # SciPy and h5py raise many kinds on a damaged file
        if version == "4/5" and looks_like_text(path):
            return None
        raise InputError(
            f"cannot read it as a MATLAB (v{version}) file: {_one_line(error)}",
            source=source,
            fix="save it from MATLAB with save(..., '-v7') or '-v7.3', or as CSV",
        ) from None


def _axes(array: np.ndarray, samples_axis, channels_axis) -> tuple[int, int] | str:
    """The samples and channels axes of an array of two or more axes, or why not."""
    ndim = array.ndim
    for argument, axis in (("samples_axis", samples_axis), ("channels_axis", channels_axis)):
        if axis is not None and not 0 <= axis < ndim:
            return f"has {ndim} axes (0 .. {ndim - 1}); {argument}={axis} is not one of them"
    if samples_axis is None:
        longest = max(array.shape)
        candidates = [axis for axis, n in enumerate(array.shape) if n == longest]
        if len(candidates) > 1:
            return (
                f"has axes {' and '.join(map(str, candidates))} of equal length {longest}; "
                "pass samples_axis= to say which holds the samples"
            )
        samples_axis = candidates[0]
    if channels_axis is None:
        channels_axis = max(axis for axis in range(ndim) if axis != samples_axis)
    if channels_axis == samples_axis:
        return f"samples_axis= and channels_axis= both name axis {samples_axis}"
    return samples_axis, channels_axis


def array_columns(
    arrays: dict,
    source: str,
    *,
    names: list[str] | dict[str, list[str]] | None = None,
    samples_axis: int | None = None,
    channels_axis: int | None = None,
) -> dict:
    """Columns (name -> float array, one common length), the raw names, and the variables
    that are not columns with the reason (see the module's docstring)."""
    unusable: dict[str, str] = {}
    vectors: dict[str, np.ndarray] = {}
    blocks: dict[str, tuple[np.ndarray, int, int]] = {}
    undecided: dict[str, tuple[np.ndarray, str]] = {}
    for name, value in arrays.items():
        array = _classify(value)
        if isinstance(array, tuple):
            unusable[name] = array
        elif sum(n > 1 for n in array.shape) <= 1:
            vectors[name] = array.reshape(-1)
        else:
            axes = _axes(array, samples_axis, channels_axis)
            if isinstance(axes, str):
                undecided[name] = (array, axes)
            else:
                blocks[name] = (array, *axes)
    if (samples_axis is not None or channels_axis is not None) and not blocks:
        raise InputError(
            "samples_axis= and channels_axis= choose the axes of an array of two or more "
            "axes, and the file holds none that can be read",
            source=source,
            fix="leave them out",
        )
    named = _names_by_array(names, blocks, source)
    lengths = [v.size for v in vectors.values()] + [a.shape[s] for a, s, _ in blocks.values()]
    if not lengths:
        for name, (_, why) in undecided.items():
            unusable[name] = (why, "pass samples_axis=")
        listed = "; ".join(f"'{k}' {why}" for k, (why, _) in unusable.items()) or "no variables"
        raise InputError(
            f"no numeric column of samples in the file ({listed})",
            source=source,
            fix="save each channel as a numeric array",
        )
    length = max(lengths)
    for name, (array, tie) in undecided.items():
        short = f"has at most {max(array.shape)} samples where the recording has {length}"
        unusable[name] = (
            short if max(array.shape) < length else tie,
            "pass samples_axis= / channels_axis=, or save it in its own file",
        )
    raw: dict[str, np.ndarray] = {}
    for name, vector in vectors.items():
        if vector.size != length:
            unusable[name] = (
                f"has {vector.size} samples where the recording has {length}",
                "save channels of other lengths (other rates) in their own files",
            )
        else:
            raw[name] = vector
    for name, (array, samples, channels) in blocks.items():
        if array.shape[samples] != length:
            unusable[name] = (
                f"has {array.shape[samples]} samples (axis {samples}) where the recording "
                f"has {length}",
                "choose its samples axis with samples_axis=, or save it in its own file",
            )
            continue
        others = [axis for axis in range(array.ndim) if axis not in (samples, channels)]
        moved = np.moveaxis(array, [samples, *others, channels], range(array.ndim))
        records = int(np.prod([array.shape[axis] for axis in others], dtype=int))
        moved = moved.reshape(length, records, array.shape[channels])
        labels = named.get(name) or [f"{name}_{i}" for i in range(array.shape[channels])]
        if len(labels) != array.shape[channels]:
            raise InputError(
                f"names= gives {len(labels)} name(s) for the {array.shape[channels]} "
                f"channels of '{name}' (axis {channels} of its shape {array.shape})",
                source=source,
                fix="name every channel, or choose the axis with channels_axis=",
            )
        for record in range(records):
            for i, label in enumerate(labels):
                column = label if records == 1 else f"{label}_rec{record}"
                raw[column] = moved[:, record, i]
    return {"raw": raw, "unusable": unusable}


def _names_by_array(names, blocks: dict, source: str) -> dict[str, list[str]]:
    if names is None:
        return {}
    if isinstance(names, dict):
        missing = [name for name in names if name not in blocks]
        if missing:
            raise InputError(
                f"names= names an array '{missing[0]}', and the file holds no array of two or "
                "more axes of that name",
                source=source,
                fix=f"arrays with channels: {', '.join(blocks) or '(none)'}",
            )
        return dict(names)
    if len(blocks) != 1:
        raise InputError(
            f"names= needs one array of channels to name, and the file holds {len(blocks)}"
            + (f" ({', '.join(blocks)})" if blocks else ""),
            source=source,
            fix='say which with names={"VAR": ["a", "b", "c"]}' if blocks else "leave names= out",
        )
    return {next(iter(blocks)): list(names)}
