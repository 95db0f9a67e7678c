"""A long recording read block by block, its channel spooled to disk: memory bounded by a
block, whatever the record's length.

:func:`stream_channel` does for a Parquet file or a text table what
:meth:`Recording.channel` does for one in memory, a block of rows at a time: each block is a
small :class:`Recording` put on its grid by :func:`prepare_channel` — the same checks, notes
and messages (rows counted from the file's first data row) — and the blocks are joined on one
grid, the samples a stamp jump between them skipped left as gaps (or refused, as a gap inside a
block is). The channel's samples go to a :class:`~bayescal.recording._series.SpooledSeries`,
which every statistic of the noise analysis reads in blocks.

What is judged per block rather than on the whole record: the checks that compare a sample
with the record's median and spread (a glitch, a rail, clipping) compare it with its block's
(a million samples); the resolution of the time stamps and the unit plausibility are read on
the first block; the rate is the mean rate over the record (grid positions over the time they
span). Time of day columns and a ROS bag are read in memory; so is a ``--pad`` window, which
is found from the whole record's accelerometers.
"""

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np

from .._errors import InputError, MissingFileError
from ._recording import (
    _GAP_PERIODS,
    Channel,
    Recording,
    _time_in_seconds,
    _without_placeholder,
    find_time_column,
    gap_error,
    prepare_channel,
)
from ._series import BLOCK, SpoolWriter

LONG_RECORDING_BYTES = 256 << 20
"""A Parquet file or text table larger than this is streamed (:func:`is_long_recording`)."""
STREAMED_SUFFIXES = (".parquet", ".pq", ".csv", ".txt", ".tsv")
_MIN_BLOCK_ROWS = 1 << 16
"""A last block shorter than this is read with the one before it."""
_EXTRA_NOTES = 5
"""Notes of later blocks kept beyond the first block's (the rest are counted)."""


def is_long_recording(path) -> bool:
    """Whether ``path`` is a file the command line streams (:func:`stream_channel`).

    Parameters
    ----------
    path : str or Path
        A recording file.

    Returns
    -------
    bool
        True for a Parquet file or text table larger than 256 MB (about 1.6 * 10^7 rows of
        time and six float64 axes).
    """
    path = Path(path)
    return (
        path.suffix.lower() in STREAMED_SUFFIXES
        and path.is_file()
        and path.stat().st_size > LONG_RECORDING_BYTES
    )


def _parquet_batches(path: Path, source: str, columns, first_rows: int) -> Iterator:
    import pyarrow as pa
    import pyarrow.parquet as pa_parquet

    try:
        reader = pa_parquet.ParquetFile(path)
        # One iterator per row group: pyarrow keeps what an iterator decoded until it ends
        # (its memory would grow with the file), so none outlives its row group.
        for group in range(reader.metadata.num_row_groups):
            yield from reader.iter_batches(
                batch_size=first_rows, row_groups=[group], columns=columns
            )
    except (pa.ArrowException, OSError) as error:
        raise InputError(
            f"cannot read it as Parquet: {str(error).splitlines()[0]}",
            source=source,
            fix="check the file",
        ) from None


def _text_batches(path: Path, source: str, columns, skip_rows: int) -> Iterator:
    import pyarrow as pa
    import pyarrow.csv as pa_csv

    from ._text import text_arrow_options

    stream, read, parse, convert, _ = text_arrow_options(path, source, skip_rows, None)
    if columns is not None:
        convert.include_columns = columns
    try:
        reader = pa_csv.open_csv(
            stream, read_options=read, parse_options=parse, convert_options=convert
        )
        yield from reader
    except pa.ArrowInvalid as error:
        raise InputError(
            f"cannot read it as a table: {str(error).splitlines()[0][:160]}",
            source=source,
            fix="check that every line has the header's number of fields",
        ) from None


def _batches(path: Path, source: str, columns, skip_rows: int) -> Iterator:
    """pyarrow record batches of the file (``columns``: the raw column names to read, None
    for all)."""
    if path.suffix.lower() in (".parquet", ".pq"):
        if skip_rows:
            raise InputError(
                "skip_rows= applies to text tables, not Parquet",
                source=source,
                fix="leave it out",
            )
        return _parquet_batches(path, source, columns, BLOCK)
    return _text_batches(path, source, columns, skip_rows)


def _recording(batches: list, source: str, row_offset: int) -> Recording:
    import pyarrow as pa

    from ._readers import _arrow_columns

    notes: list[str] = []
    content = _arrow_columns(pa.Table.from_batches(batches), notes)
    return Recording(source=source, **content, notes=tuple(notes), row_offset=row_offset)


def _row_blocks(path: Path, source: str, columns, skip_rows: int) -> Iterator[Recording]:
    """The file as Recordings of about BLOCK rows each (a short last block joined to the
    one before), each knowing the rows before it."""
    pending, rows, offset = [], 0, 0
    held = None
    for batch in _batches(path, source, columns, skip_rows):
        pending.append(batch)
        rows += batch.num_rows
        if rows >= BLOCK:
            if held is not None:
                yield _recording(held[0], source, held[1])
            held, pending, offset, rows = (pending, offset), [], offset + rows, 0
    if held is not None and rows and rows < _MIN_BLOCK_ROWS:
        held, pending, rows = (held[0] + pending, held[1]), [], 0
    if held is not None:
        yield _recording(held[0], source, held[1])
    if rows:
        yield _recording(pending, source, offset)


def _rows(recording: Recording, first: int, last: int, row_offset: int) -> Recording:
    """Rows [first, last) of a recording."""
    return replace(
        recording,
        columns={name: values[first:last] for name, values in recording.columns.items()},
        file_columns=(),
        row_offset=row_offset,
    )


class _Joiner:
    """Joins the blocks' channels on one grid: the samples between blocks that the stamps
    skip become gaps (or an error with gaps="error"), the notes of later blocks kept when new."""

    def __init__(self, writer: SpoolWriter, gaps: str, source: str, time_name: str | None):
        self.writer, self.gaps, self.source, self.time_name = writer, gaps, source, time_name
        self.first_time = self.last_time = None
        self.notes: list[str] = []
        self.extra = 0
        self.rate = None

    def add(self, channel: Channel, first_time: float, last_time: float, row: int) -> None:
        if self.rate is None:
            self.rate, self.first_time = channel.rate_hz, first_time
            self.notes += channel.notes
        else:
            self._bridge(first_time, row)
            for note in channel.notes:
                if note in self.notes:
                    continue
                if self.extra < _EXTRA_NOTES:
                    self.notes.append(f"(from data row {row}) {note}")
                self.extra += 1
        self.writer.append(channel.values)
        self.last_time = last_time

    def _bridge(self, first_time: float, row: int) -> None:
        step = first_time - self.last_time
        periods = step * self.rate
        if not periods > 0.5:
            raise InputError(
                f"{'duplicated' if step == 0 else 'decreasing'} time stamp at data row {row} "
                f"(t = {first_time - self.first_time:.6g} s)",
                source=self.source,
                column=self.time_name,
                fix="sort or de-duplicate the time stamps upstream",
            )
        skipped = max(0, round(periods) - 1)
        if periods > _GAP_PERIODS and self.gaps == "error":
            where = f"data row {row} (t = {first_time - self.first_time:.6g} s)"
            raise gap_error(step, periods, where, self.source, self.time_name)
        if skipped:
            self.writer.fill(skipped)
            self.notes.append(f"{skipped} sample(s) missing at data row {row}: left as a gap")


def stream_channel(
    path,
    channel: str,
    *,
    unit: str | None = None,
    scale: float | None = None,
    rate_hz: float | None = None,
    time_column: str | None = None,
    time_unit: str | None = None,
    start: float | None = None,
    stop: float | None = None,
    gaps: str = "error",
    skip_rows: int = 0,
    at_rest: bool = True,
    progress: bool = False,
) -> Channel:
    """Column ``channel`` of a long recording on its sample grid, read block by block with
    its samples spooled to disk: the :class:`~bayescal.Channel` that
    ``bc.load_recording(path).channel(channel, ...)`` gives, in memory bounded by a block.

    Parameters
    ----------
    path : str or Path
        A Parquet file or a text table (CSV, semicolon, tab or space separated).
    channel : str
        The column to analyse.
    unit, scale, rate_hz, time_column, time_unit, start, stop, gaps, at_rest
        As :meth:`Recording.channel <bayescal.Recording.channel>`.
    skip_rows : int
        Lines of a text table to skip before its header.
    progress : bool
        A progress bar of the rows read, on stderr.

    Returns
    -------
    Channel
        Its ``values`` a :class:`~bayescal.recording.SpooledSeries` (8 bytes a sample in
        ``$BAYESCAL_SPOOL`` or the temporary folder, removed with it), which
        :func:`~bayescal.fit_noise`, :func:`~bayescal.classical_noise` and the Allan
        deviations read in blocks.

    Raises
    ------
    InputError
        As :meth:`Recording.channel`, naming the file, column and data row.

    Notes
    -----
    One function (over 80 lines) on purpose: one pass over the file's blocks, whose loop holds
    the state the grid is joined with; split, that state would travel between functions.
    """
    rate = rate_hz
    path = Path(path)
    source = str(path)
    if not path.exists():
        raise MissingFileError("no such file", source=source)
    if not path.is_file():
        raise InputError("is a folder, not a recording", source=source, fix="check the path")
    if path.suffix.lower() not in STREAMED_SUFFIXES:
        raise InputError(
            f"a {path.suffix} file is read in memory, not streamed",
            source=source,
            fix="load it with bc.load_recording, or convert it to Parquet",
        )
    options = {"unit": unit, "scale": scale, "time_column": time_column, "time_unit": time_unit}
    first_batch = next(iter(_batches(path, source, None, skip_rows)), None)
    if first_batch is None or first_batch.num_rows == 0:
        raise InputError("the file holds no data rows", source=source)
    head = _recording([first_batch], source, 0)
    head.require(channel, "channel")
    time_name = None if rate is not None else find_time_column(head, time_column)
    wanted = _raw_names(first_batch.schema.names, {channel, time_name} - {None})
    writer = bar = None
    try:
        writer = SpoolWriter(name=channel.replace("/", "_"))
        joiner = _Joiner(writer, gaps, source, time_name)
        bar = _progress_bar(path, progress)
        record_start, row = None, 0
        for number, read in enumerate(_row_blocks(path, source, wanted, skip_rows)):
            block = _without_placeholder(read) if number == 0 else read
            row = block.row_offset
            if bar is not None:
                bar.update(read.n_rows)
            if time_name is None:
                seconds = (row + np.arange(block.n_rows)) / rate
            else:
                seconds = _time_in_seconds(block, time_name, time_unit)[0]
            if record_start is None:
                record_start = float(seconds[0])
            relative = seconds - record_start
            first = 0 if start is None else int(np.searchsorted(relative, start))
            last = block.n_rows if stop is None else int(np.searchsorted(relative, stop))
            if last <= first:
                if stop is not None and relative[0] >= stop:
                    break
                continue
            part = _rows(block, first, last, row + first)
            prepared = prepare_channel(
                part, channel, rate_hz=rate, gaps=gaps, at_rest=at_rest, **options
            )
            joiner.add(prepared, float(seconds[first]), float(seconds[last - 1]), row + first + 1)
        if joiner.rate is None:
            raise InputError(
                f"no samples in the window [{start or 0:g}, {'end' if stop is None else stop}) s",
                source=source,
                column=channel,
                fix="widen the window (start=/stop=)",
            )
        spooled = writer.finish()
    except BaseException:
        if writer is not None:
            writer.abandon()
        raise
    finally:
        if bar is not None:
            bar.close()
    span = joiner.last_time - joiner.first_time
    rate_hz = rate if rate is not None else float(f"{(spooled.size - 1) / span:.12g}")
    notes = joiner.notes
    if joiner.extra > _EXTRA_NOTES:
        notes.append(f"{joiner.extra - _EXTRA_NOTES} more note(s) from later blocks not shown")
    return Channel(
        source=source,
        channel=channel,
        unit=prepared.unit,
        values=spooled,
        rate_hz=float(rate_hz),
        start_s=float(joiner.first_time - record_start),
        notes=tuple(dict.fromkeys(notes)),
        scale=scale,
        grid={
            "rate_hz": rate,
            "time_column": time_column,
            "time_unit": time_unit,
            "start": start,
            "stop": stop,
            "gaps": gaps,
        },
    )


def _progress_bar(path: Path, shown: bool):
    """A bar of the rows read (their total from a Parquet file's metadata), or None."""
    if not shown:
        return None
    import sys

    from tqdm import tqdm

    total = None
    if path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow.parquet as pa_parquet

        total = pa_parquet.ParquetFile(path).metadata.num_rows
    return tqdm(total=total, desc="reading", unit="row", unit_scale=True, file=sys.stderr)


def _raw_names(headers, names: set[str]) -> list[str]:
    """The file's own header names (units and all) of the columns ``names``: a Parquet
    column of lists ``vec`` holds the columns ``vec_0``, ``vec_1``, ..."""
    from ._readers import split_header

    def holds(name: str) -> bool:
        return name in names or any(
            wanted.startswith(f"{name}_") and wanted[len(name) + 1 :].isdigit() for wanted in names
        )

    headers = [str(name) for name in headers]
    split, _ = split_header(headers)
    return [header for header, name in zip(headers, split, strict=True) if holds(name)]
