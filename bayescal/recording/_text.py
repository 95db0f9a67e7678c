"""Text tables as loggers and spreadsheets write them.

What is read, and how it is told apart (from the first megabyte of the file):

- **Encoding**: UTF-8 (with or without a byte-order mark) or UTF-16 with its mark; a file that
  is neither is read as Latin-1, and a note says so (a header such as ``temp[°C]`` from a
  Windows logger is then read right).
- **Lines before the table**: ``--skip-rows N`` skips the first N lines (logger metadata);
  then lines that start with ``#`` and blank lines are skipped; Excel's ``sep=;`` first line
  is skipped and names the delimiter. A logger's metadata lines — a key and one value, such
  as ``Fs,100``, ``Sample rate (Hz): 819.2`` or ``Units,deg/s`` — are read wherever they
  stand before the header (skipped lines included): a sample rate or a unit they state is
  used where the file gives none of its own (a time column, a unit in the header) and a note
  says so (:data:`RATE_KEYS`, :data:`UNIT_KEYS`); other metadata lines are skipped with a
  note. Other lines before the header whose number of fields differs from the table's are
  refused with the count to pass to ``--skip-rows``: a guess could drop a real header.
- **A units row**: a line right after the header whose every field is a unit (or empty),
  ``s,deg/s,deg/s,g``, gives the columns' units, as ``gyro_x[deg/s]`` in the header would.
- **Delimiter**: the first of tab, semicolon, comma, ``|`` that splits the header and the
  first lines into the same number (> 1) of fields; else runs of spaces (a column-aligned
  table, as MATLAB's ``save -ascii`` writes).
- **Decimal commas**: with a tab, semicolon or space delimiter, numbers written ``0,125``
  are read as 0.125.
- **Header**: the first table line, unless every field of it is a number: then the table has
  no header and its columns are ``column_0``, ``column_1``, ... (a note says so) or the names
  given by ``--names``.
- **Time stamps**: a column of ISO 8601 dates and times (``2024-05-01T12:00:00.010``) or of
  times of day (``12:00:00.010``) becomes seconds from its first stamp (a day added where
  the clock passes midnight).
- A last line cut short (fewer fields than the header, no line end: a logger that stopped
  mid-line) is left out with a note; other lines of the wrong length are refused. Compressed
  or binary files are refused as such.
- A column with text in it is not numeric; when most of its cells are numbers, the first
  cell that is not is remembered (row and text) for the message that refuses it.
"""

import codecs
import csv
import io
import re
from collections import Counter
from pathlib import Path

import numpy as np

from .._errors import InputError

_HEAD_BYTES = 1 << 20
_DELIMITERS = ("\t", ";", ",", "|")
_NUMBER = re.compile(
    r"^\s*[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?\s*$|^\s*[-+]?(?:nan|inf)\s*$", re.I
)
_COMMA_NUMBER = re.compile(r"^\s*[-+]?\d+,\d+(?:[eE][-+]?\d+)?\s*$")
_TIME_OF_DAY = re.compile(r"^\s*(\d{1,2}):(\d{2}):(\d{2}(?:\.\d*)?)\s*$")
_SAMPLE_LINES = 20
_DAY_S = 86400.0
RATE_KEYS = re.compile(
    r"^(fs|sample[ _-]?rate|sampling[ _-]?(rate|frequency)|rate|odr|output[ _-]?data[ _-]?rate|"
    r"data[ _-]?rate|frequency|freq)\s*(\[?\(?\s*hz\s*\)?\]?)?$",
    re.I,
)
"""Metadata keys that state a sample rate (in Hz, or with the unit after the number)."""
UNIT_KEYS = re.compile(r"^units?$", re.I)
"""Metadata keys that state the channels' unit."""
_KEY = re.compile(r"^[A-Za-z][A-Za-z0-9 _()\[\]/.-]*$")
_RATE_VALUE = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(k?hz)?\s*$", re.I)


def _encoding(head: bytes) -> tuple[str, str | None]:
    """The encoding of the file, and a note when it is not UTF-8."""
    if head.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        return "utf-16", None
    try:
        head.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        if error.start < len(head) - 4:  # not just a character cut at the end of the head
            return "latin-1", "the file is not UTF-8; read as Latin-1 (ISO 8859-1)"
    return "utf-8", None


def _fields(line: str, delimiter: str) -> list[str]:
    if delimiter == " ":
        return line.split()
    return next(csv.reader([line], delimiter=delimiter), [])


def _choose_delimiter(lines: list[str]) -> tuple[str, int]:
    """The delimiter that splits the sampled lines (all but one, which may be a last line
    cut short) into the same number (> 1) of fields, and that number."""
    for delimiter in (*_DELIMITERS, " "):
        counts = Counter(len(_fields(line, delimiter)) for line in lines)
        width, count = counts.most_common(1)[0]
        if width > 1 and count >= len(lines) - 1:
            return delimiter, width
    return ",", Counter(len(_fields(line, ",")) for line in lines).most_common(1)[0][0]


def _refuse_binary(head: bytes, encoding: str, source: str) -> None:
    if head.startswith(b"\x1f\x8b"):
        raise InputError(
            "the file is gzip-compressed", source=source, fix="decompress it first (gunzip)"
        )
    if head.startswith(b"PK\x03\x04"):
        raise InputError(
            "the file is a zip archive", source=source, fix="extract the table from it first"
        )
    if encoding != "utf-16" and b"\x00" in head:
        raise InputError(
            "the file holds binary data, not a text table",
            source=source,
            fix="check the file (another format under a .csv or .txt name?)",
        )


def _is_number(text: str, decimal_comma: bool) -> bool:
    return bool(_NUMBER.match(text) or (decimal_comma and _COMMA_NUMBER.match(text)))


def _key_value(line: str, delimiter: str) -> tuple[str, str] | None:
    """(key, value) of a metadata line: a key and one value, split by the table's delimiter,
    ':' or '=' (empty fields after them allowed); None for any other line."""
    for separator in (delimiter, ":", "="):
        split = _fields(line, separator) if separator == delimiter else line.split(separator, 1)
        fields = [field.strip() for field in split]
        while fields and not fields[-1]:
            fields.pop()
        if len(fields) == 2 and _KEY.match(fields[0]) and fields[1]:
            return fields[0], fields[1]
    return None


def _metadata(pairs: list[tuple[int, str, str, str]]) -> tuple[dict, list[str]]:
    """What metadata lines ((line number, key, value, the line)) state — ``rate_hz`` and
    ``unit``, each with its line — and the notes on the lines it does not use."""
    from ._units import parse_unit

    metadata, skipped = {}, []
    for number, key, value, text in pairs:
        shown = text.strip() if len(text.strip()) <= 40 else text.strip()[:37] + "..."
        rate = _RATE_VALUE.match(value)
        if RATE_KEYS.match(key) and rate and float(rate[1]) > 0:
            factor = 1000.0 if (rate[2] or "").lower() == "khz" else 1.0
            metadata["rate_hz"] = float(rate[1]) * factor
            metadata["rate_line"] = f"line {number}, '{shown}'"
            continue
        if UNIT_KEYS.match(key) and _known_unit(value, parse_unit):
            metadata["unit"] = value
            metadata["unit_line"] = f"line {number}, '{shown}'"
            continue
        skipped.append(f"'{shown}' (line {number})")
    notes = [f"metadata line(s) before the header skipped: {', '.join(skipped)}"] if skipped else []
    return metadata, notes


def _known_unit(text: str, parse_unit) -> bool:
    try:
        return parse_unit(text).known
    except ValueError:
        return False


def _units_row(line: str, delimiter: str, width: int) -> list[str] | None:
    """The units of a line that holds a unit (or nothing) in every field, at least one a unit
    bayescal knows; None for any other line."""
    from ._units import is_count_unit, parse_unit

    fields = [f.strip() for f in _fields(line, delimiter)]
    if len(fields) != width or any(_NUMBER.match(f) for f in fields if f):
        return None
    present = [field for field in fields if field]
    if not present or not all(_known_unit(f, parse_unit) or is_count_unit(f) for f in present):
        return None
    return fields


def sniff_table(path: Path, source: str, skip_rows: int) -> dict:
    """How to read the text table at ``path``: encoding, lines to skip, delimiter, decimal
    point, whether the first table line is a header; with the notes to give."""
    with path.open("rb") as handle:
        head = handle.read(_HEAD_BYTES)
        complete = handle.read(1) == b""
        handle.seek(max(0, path.stat().st_size - 4096))
        tail = handle.read()
    encoding, note = _encoding(head)
    _refuse_binary(head, encoding, source)
    text = head.decode(encoding, errors="replace").lstrip("\ufeff")
    lines = text.splitlines()
    if not complete and lines:
        lines = lines[:-1]  # the last line of the head may be cut
    separator = None
    if lines and lines[0].strip().lower().startswith("sep=") and len(lines[0].strip()) == 5:
        separator = lines[0].strip()[4]  # Excel's "sep=;" line names the delimiter
        skip_rows = max(skip_rows, 1)
    if skip_rows > len(lines):
        raise InputError(
            f"skip_rows={skip_rows}: the file has only {len(lines)} line(s)",
            source=source,
            fix="give the number of lines before the header",
        )
    skipped = skip_rows
    while skipped < len(lines) and (not lines[skipped].strip() or lines[skipped].startswith("#")):
        skipped += 1
    table = lines[skipped:]
    if not table:
        raise InputError("the file holds no table", source=source, fix="check the file")
    sample = [line for line in table[-_SAMPLE_LINES:] if line.strip()]
    delimiter, width = _choose_delimiter(sample)
    if separator is not None:
        delimiter = separator
        width = Counter(len(_fields(line, delimiter)) for line in sample).most_common(1)[0][0]
    # Metadata lines: among the lines skipped, and those that lead the table while a line
    # that is not one follows (the header).
    excel = 1 if separator is not None else 0  # Excel's sep= line is no metadata
    pairs = [
        (number + 1, *pair, line)
        for number, line in enumerate(lines[:skip_rows])
        if number >= excel and (pair := _key_value(line, delimiter)) is not None
    ]
    while len(table) > 1 and (pair := _key_value(table[0], delimiter)) is not None:
        if width == 2 and not _RATE_VALUE.match(pair[1]) and not UNIT_KEYS.match(pair[0]):
            break  # a header of two names, not a key and its value
        pairs.append((skipped + 1, *pair, table[0]))
        skipped += 1
        while skipped < len(lines) and (
            not lines[skipped].strip() or lines[skipped].startswith("#")
        ):
            skipped += 1
        table = lines[skipped:]
    metadata, metadata_notes = _metadata(pairs)
    last = tail.decode(encoding, errors="replace").splitlines()[-1:] if tail else []
    cut = (
        last[0]
        if last and not tail.endswith(b"\n") and len(_fields(last[0], delimiter)) < width
        else None
    )
    # The cut line's bytes, for a stream that ends before it (UTF-8 and Latin-1 end a line
    # with the byte 0x0A, which no other character holds; UTF-16 spends two bytes on each
    # of the line's code units, a bad one read as U+FFFD, also one unit).
    cut_bytes = 0
    if cut is not None:
        cut_bytes = (
            len(cut.encode("utf-16-le"))
            if encoding == "utf-16"
            else len(tail) - tail.rfind(b"\n") - 1
        )
    preamble = 0
    for line in table:
        if len(_fields(line, delimiter)) == width:
            break
        preamble += 1
    if preamble and preamble < len(table):
        shown = table[0].strip()
        shown = shown if len(shown) <= 40 else shown[:37] + "..."
        raise InputError(
            f"the first {preamble} line(s) of the table do not split into its {width} "
            f"columns (line {skipped + 1}: '{shown}'): logger metadata before the header?",
            source=source,
            fix=f"pass skip_rows={skipped + preamble} (or start those lines with '#')",
        )
    data_cells = [cell for line in sample[1:] for cell in _fields(line, delimiter)]
    decimal_comma = delimiter != "," and any(_COMMA_NUMBER.match(c) for c in data_cells)
    first = _fields(table[0], delimiter)
    has_header = not all(_is_number(cell, decimal_comma) for cell in first if cell.strip())
    units = _units_row(table[1], delimiter, width) if has_header and len(table) > 2 else None
    return {
        "metadata": metadata,
        "units_row": units,
        "encoding": encoding,
        "skip": skipped,
        "delimiter": delimiter,
        "decimal_point": "," if decimal_comma else ".",
        "has_header": has_header,
        "width": width,
        "cut_last_line": cut,
        "cut_last_line_bytes": cut_bytes,
        "notes": ([note] if note else []) + metadata_notes,
    }


def _spaces_to_commas(path: Path, encoding: str, skip: int, cut: str | None) -> io.BytesIO:
    """A column-aligned table (runs of spaces) as comma-separated UTF-8 bytes, without a last
    line cut short."""
    with path.open("r", encoding=encoding, errors="replace", newline="") as handle:
        lines = handle.read().lstrip("\ufeff").splitlines()[skip:]
    if cut is not None and lines and lines[-1] == cut:
        lines = lines[:-1]
    body = "\n".join(",".join(line.split()) for line in lines if line.strip())
    return io.BytesIO(body.encode("utf-8"))


def text_arrow_options(path: Path, source: str, skip_rows: int, names: list[str] | None):
    """How pyarrow reads the text table at ``path``: (source stream, read, parse and convert
    options, the reader's notes, what its metadata lines state) — for one read
    (:func:`read_text_arrow`) or a stream of blocks (:mod:`bayescal.recording._stream`)."""
    import pyarrow as pa
    import pyarrow.csv as pa_csv

    layout = sniff_table(path, source, skip_rows)
    notes = list(layout["notes"])
    width = layout["width"]
    if names is not None and len(names) != width:
        raise InputError(
            f"names= gives {len(names)} name(s) for a table of {width} columns",
            source=source,
            fix="name every column, in order",
        )
    column_names = names
    skip = layout["skip"]
    units = layout["units_row"]
    if units is not None and names is None:
        # The units row stands as each column's bracketed unit, as gyro_x[deg/s] would.
        header = [f.strip() for f in _fields(_line_at(path, layout, skip), layout["delimiter"])]
        column_names = [
            f"{name}[{unit}]" if unit and "[" not in name else name
            for name, unit in zip(header, units, strict=True)
        ]
        skip += 2
        notes.append(
            "the line under the header gives the columns' units ("
            + ", ".join(f"{n} {u}" for n, u in zip(header, units, strict=True) if u)
            + "): used"
        )
    elif not layout["has_header"]:
        if names is None:
            column_names = [f"column_{i}" for i in range(width)]
            notes.append(
                f"the table has no header row; its columns are named column_0 .. "
                f"column_{width - 1} (pass --names to name them)"
            )
    elif names is not None:
        skip += 1  # the header is replaced by --names
        notes.append("the header's names replaced by --names")
    delimiter, cut = layout["delimiter"], layout["cut_last_line"]
    if cut is not None:
        shown = cut if len(cut) <= 40 else cut[:37] + "..."
        notes.append(
            f"the last line ('{shown}') is cut short, as when a logger stops mid-line: left out"
        )
    if delimiter == " ":
        stream, encoding, delimiter, skip = (
            _spaces_to_commas(path, layout["encoding"], skip, cut),
            "utf-8",
            ",",
            0,
        )
        cut = None
    elif cut is not None:
        # The stream ends before the cut line. (Skipping it with pyarrow's handler of invalid
        # rows decoded every invalid row's text as UTF-8 first: a malformed row of other
        # bytes made pyarrow print an ignored exception on the user's terminal.)
        mapped = pa.memory_map(str(path))
        stream = pa.BufferReader(mapped.read_buffer(mapped.size() - layout["cut_last_line_bytes"]))
        encoding = layout["encoding"]
    else:
        stream, encoding = path, layout["encoding"]
    read = pa_csv.ReadOptions(
        skip_rows=skip,
        column_names=column_names,
        encoding=encoding,
        block_size=1 << 24,
    )
    parse = pa_csv.ParseOptions(delimiter=delimiter)
    convert = pa_csv.ConvertOptions(decimal_point=layout["decimal_point"])
    return stream, read, parse, convert, notes, layout["metadata"]


def _line_at(path: Path, layout: dict, index: int) -> str:
    """Line ``index`` (from 0) of the text file as ``layout`` reads it."""
    with path.open("r", encoding=layout["encoding"], errors="replace", newline="") as handle:
        for number, line in enumerate(handle):
            if number == index:
                return line.lstrip("\ufeff").rstrip("\r\n")
    return ""


def read_text_arrow(path: Path, source: str, skip_rows: int, names: list[str] | None):
    """The text table at ``path`` as a pyarrow Table, with its header names (or generated
    ones), the reader's notes and what its metadata lines state (``rate_hz``, ``unit``)."""
    import pyarrow as pa
    import pyarrow.csv as pa_csv

    stream, read, parse, convert, notes, metadata = text_arrow_options(
        path, source, skip_rows, names
    )
    try:
        table = pa_csv.read_csv(
            stream, read_options=read, parse_options=parse, convert_options=convert
        )
    except pa.ArrowInvalid as error:
        detail = str(error).splitlines()[0]
        detail = detail if len(detail) <= 160 else detail[:157] + "..."
        hint = ""
        row = detail.partition(": ")[2]
        if parse.delimiter == "," and "." not in row and re.search(r"\d,\d", row):
            hint = " (decimal commas in a comma-separated file?)"
        raise InputError(
            f"cannot read it as a table: {detail}{hint}",
            source=source,
            fix="check that every line has the header's number of fields; with decimal "
            "commas, separate the fields with ';' or a tab",
        ) from None
    return table, notes, metadata


def text_cell_problem(values: np.ndarray) -> tuple[str, str] | None:
    """What is wrong with a text column that was meant to hold numbers, and what to do, for
    a message: the first cell that is not a number (row and text) — numbers with decimal
    commas in a comma-separated file said as such — or None for an empty column."""
    present = [(i, str(v)) for i, v in enumerate(values) if v is not None and str(v).strip()]
    if not present:
        return None
    bad = [(i, text) for i, text in present if not _is_number(text, False)]
    if not bad:
        return None
    row, text = bad[0]
    shown = text if len(text) <= 30 else text[:27] + "..."
    if all(_COMMA_NUMBER.match(text) for _, text in bad):
        return (
            f"holds numbers written with a decimal comma ('{shown}' in data row {row + 1}) "
            "in a comma-separated file",
            "save the file with ';' (or tabs) between fields, or with decimal points",
        )
    if len(bad) <= 0.5 * len(present):
        return (
            f"is not numeric: data row {row + 1} holds '{shown}'" + _comma_decimal_hint(text),
            "repair that cell (an empty cell is read as a missing value)",
        )
    return (
        f"is not numeric: it holds text ('{shown}' in data row {row + 1})",
        "choose a column of numbers",
    )


def _comma_decimal_hint(text: str) -> str:
    return " (a decimal comma?)" if _COMMA_NUMBER.match(text) else ""


def time_of_day_seconds(values: np.ndarray) -> np.ndarray | None:
    """Seconds from the first stamp of a column of times of day (HH:MM:SS.fff), a day added
    each time the clock passes midnight; None when the column is not one."""
    seconds = np.empty(values.size)
    for i, value in enumerate(values):
        match = _TIME_OF_DAY.match(str(value)) if value is not None else None
        if match is None:
            return None
        hours, minutes, secs = int(match[1]), int(match[2]), float(match[3])
        seconds[i] = 3600 * hours + 60 * minutes + secs
    days = np.concatenate(([0], np.cumsum(np.diff(seconds) < -_DAY_S / 2)))
    seconds = seconds + _DAY_S * days
    return seconds - seconds[0]
