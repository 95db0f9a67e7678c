"""A recording and one channel of it prepared for analysis.

The formats and checks are those of ../shared/DESIGN.md: text tables, Parquet, NumPy and
MATLAB arrays, ROS bags (:mod:`._readers`); a time column ``time`` or ``t`` (``t_s``,
``time[ms]`` and ``timestamp_ms`` name their unit), or ``--rate``; units from the command
line, else from the header (``gyro_x[deg/s]``), else from a unit suffix of the name
(``gyro_x_dps``), else assumed from the kind of sensor — and then said so. Raw counts become
the unit with ``scale`` (``--scale``).

Every problem found in the analysed window is reported with its data row (1 = first row
under the header) and its time, and raises :class:`InputError`: non-finite values,
non-increasing or duplicated time stamps, gaps, irregular sampling, too few samples, a
constant channel, a channel stuck at a rail, a glitch thousands of noise sd from its
neighbours, values too large or too small for float64 arithmetic. Nothing is filled in: with
``gaps="split"`` missing samples become NaN, which the estimators leave out.

Plausibility, decided case by case (an error where the answer would be wrong, a note where
the input is odd but may be meant):

- time stamps too coarse for the rate they imply (float32 stamps far from zero, a millisecond
  clock at 800 Hz): the rate is taken from the mean step, and a note says so;
- a time column without a unit that gives an IMU rate below 5 Hz: an error that offers both
  readings (``--time-unit ms`` or ``--time-unit s``); from 5 to 20 Hz, a note;
- a static gyro reading hundreds of deg/s (more than 100 deg/s), an accelerometer more than
  4 g: raw counts, probably — an error when the unit was assumed, a note when it was given;
- a unit bayescal does not know (other than counts: LSB, counts, V ...), a unit of the other
  kind of sensor than the name says, ``--unit`` overriding the header: notes;
- a logger's placeholder rows — 0 in every sensor column (gyros and accelerometers, by name
  or header unit; every column but time where none is named so) while the rows beside them
  are not, 0 being far from the rest of the record: left out by :func:`load_recording`, with
  a note; those leading the file are dropped, those further on become missing samples, kept
  in their place on the grid (a time column's stamps or an even rate alike).
"""

import functools
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .._errors import InputError
from ._columns import is_accel_name, is_gyro_name
from ._levels import RAIL_SIGMAS, rail_check
from ._readers import read_columns
from ._units import DEG, STANDARD_GRAVITY, is_count_unit, parse_unit, unit_from_column_suffix

_TIME_NAMES = ("time", "t", "timestamp")
# A jump of more than this many periods between grid positions is a gap ("longer than a few
# sample periods", DESIGN.md); shorter jumps are dropped samples, left out all the same.
_GAP_PERIODS = 3
# Sampling is irregular when more than this share of the time stamps sit more than half a
# period off the sample grid; the grid follows the stamps' lag with this gain per sample.
_IRREGULAR_SHARE = 0.05
_LAG_GAIN = 0.02
MIN_SAMPLES = 16
_RAIL_RUN = 5
MIN_RATE_HZ, MAX_RATE_HZ = 1e-3, 1e7
"""The sample rates ``--rate`` may give."""
# A glitch: a run shorter than _RAIL_RUN samples this many noise sd (read from the sample to
# sample differences, which steps between poses do not move) from the record's median.
GLITCH_SIGMAS = 1000.0
# What a sensor at rest cannot read: more than this many deg/s, or g (raw counts, probably).
STATIC_GYRO_LIMIT_DEG_S = 100.0
STATIC_ACCEL_LIMIT_G = 4.0
# An IMU rate read from stamps without a unit: below the first, an error; below the second, a
# note (a millisecond clock read as seconds gives a thousandth of the rate).
IMPLAUSIBLE_RATE_HZ = 5.0
UNUSUAL_RATE_HZ = 20.0
# Magnitudes float64 arithmetic handles through squares, sums and spectra of a record: the
# values and their spread must stay inside these (see tests/test_bad_input.py).
LARGEST_VALUE = 1e100
SMALLEST_SPREAD = 1e-100
# Leading rows of zeros dropped as a logger's placeholder, at most.
_PLACEHOLDER_ROWS = 10


@dataclass(frozen=True)
class Recording:
    """The numeric columns of a recording, by name, with the units its header gives
    (:func:`load_recording`); :meth:`channel` puts one of them on its sample grid."""

    source: str
    """The file (and, for a ROS bag, the topic) the columns come from."""
    columns: dict[str, np.ndarray]
    """The numeric columns: name -> values, as the file holds them (float64)."""
    header_units: dict[str, str]
    """Column name -> the unit its header gives (``gyro_x[deg/s]``), for those that give one."""
    other_columns: tuple[str, ...] = ()
    """Columns that are not numeric (text), kept only to name them in messages."""
    topic: str | None = None
    """The ``sensor_msgs/Imu`` topic of a ROS bag."""
    start_stamp_ns: int | None = None
    """A ROS bag's first ``header.stamp``, nanoseconds since the epoch."""
    unusable: dict = field(default_factory=dict)
    """Columns that cannot be analysed: name -> (why, what to do) — a text cell in a numeric
    column, a name used twice, complex numbers, another length ..."""
    file_columns: tuple = ()
    """Every column of the file in its order, text as text: (name, values) pairs (what
    ``thermal compensate`` writes back)."""
    notes: tuple[str, ...] = ()
    """What the reader inferred (an encoding, generated names, a placeholder row left out)."""
    row_offset: int = 0
    """Data rows of the file left out before the first row here (a placeholder row)."""
    metadata: dict = field(default_factory=dict)
    """What a text table's metadata lines state: ``rate_hz`` and ``unit``, each with the
    line it comes from (``rate_line``, ``unit_line``); used where the file gives no time
    column, no header unit."""
    placeholder_rows: tuple[int, ...] = ()
    """Rows (from 0, here) that held a logger's placeholder — 0 in every sensor column while
    their neighbours do not — now missing samples (NaN in the sensor columns)."""

    @property
    def n_rows(self) -> int:
        """The number of data rows (samples) of the columns."""
        return len(next(iter(self.columns.values()))) if self.columns else 0

    def require(self, name: str, role: str = "column") -> np.ndarray:
        """The column ``name``, or an error that lists the columns there are.

        Parameters
        ----------
        name : str
            The column's name.
        role : str
            What the column is for, as the message names it ("time column", ...).

        Returns
        -------
        numpy.ndarray
            The column's values, in the file's unit.

        Raises
        ------
        InputError
            No such column, or one that is not numeric or not usable (the reason and what
            to do are in the message).
        """
        if name in self.columns:
            return self.columns[name]
        if name in self.unusable:
            problem, fix = self.unusable[name]
            if role == "time column" and name in self.other_columns:
                fix = (
                    "write it in seconds, or as ISO 8601 dates and times "
                    "(2024-05-01T12:00:00.010), or pass rate_hz=HZ"
                )
            raise InputError(
                f"{role} '{name}' {problem}",
                source=self.source,
                column=name,
                fix=fix or "choose another column",
            )
        if name in self.other_columns:
            raise InputError(
                f"{role} '{name}' is not numeric",
                source=self.source,
                column=name,
                fix="choose a column of numbers",
            )
        others = [*self.unusable, *self.other_columns]
        raise InputError(
            f"no {role} '{name}'",
            source=self.source,
            fix=f"columns are: {', '.join(self.columns) or '(none)'}"
            + (
                f" (not numeric or not usable: {', '.join(dict.fromkeys(others))})"
                if others
                else ""
            ),
        )

    def has(self, name: str) -> bool:
        """Whether the file has a column ``name`` (numeric or not).

        Parameters
        ----------
        name : str
            The column's name.

        Returns
        -------
        bool
            True when the file has it, even as text or unusable.
        """
        return name in self.columns or name in self.unusable or name in self.other_columns

    def channel(
        self,
        name: str,
        *,
        unit: str | None = None,
        scale: float | None = None,
        rate_hz: float | None = None,
        time_column: str | None = None,
        time_unit: str | None = None,
        start: float | None = None,
        stop: float | None = None,
        gaps: str = "error",
        temperature: str | None = None,
        at_rest: bool = True,
    ) -> "Channel":
        """Column ``name`` checked and put on a regular sample grid.

        Parameters
        ----------
        name : str
            The column's name.
        unit : str, optional
            The channel's unit (else the header's, else read from the name).
        scale : float, optional
            A factor the values are multiplied by (raw counts to ``unit``: 1/131 for a gyro
            giving 131 LSB per deg/s).
        rate_hz : float, optional
            Sample rate, Hz: take the samples as evenly spaced, ignoring the time stamps.
        time_column, time_unit : str, optional
            The time column (default: ``time`` or ``t``) and its unit (s, ms, us, ns).
        start, stop : float, optional
            The window, seconds from the first sample of the file.
        gaps : "error" or "split"
            On a gap in the time stamps: refuse, or keep the segments with NaN between them.
        temperature : str, optional
            A temperature column to put on the same grid (:attr:`Channel.temperature`).
        at_rest : bool
            The sensor is still throughout; False (a calibration session, moved between
            poses) leaves out the glitch check, which a fast turn of the hand would fail.

        Returns
        -------
        Channel
            The samples on their grid, with rate, unit and the notes of what was inferred.

        Raises
        ------
        InputError
            No such column, a gap (unless ``gaps="split"``), irregular sampling, a rail,
            a glitch, too few samples ... each with what to do.

        Examples
        --------
        >>> import bayescal as bc
        >>> gyro = bc.load_recording("imu.csv").channel("gyro_x", unit="deg/s")  # doctest: +SKIP
        """
        return prepare_channel(
            self,
            name,
            unit=unit,
            scale=scale,
            rate_hz=rate_hz,
            time_column=time_column,
            time_unit=time_unit,
            start=start,
            stop=stop,
            gaps=gaps,
            temperature=temperature,
            at_rest=at_rest,
        )


def load_recording(
    path: str | Path,
    *,
    topic: str | None = None,
    skip_rows: int = 0,
    names: list[str] | dict[str, list[str]] | None = None,
    samples_axis: int | None = None,
    channels_axis: int | None = None,
) -> Recording:
    """Read a recording: a text table (CSV, semicolon, tab or space separated), Parquet,
    NumPy (.npz, .npy) or MATLAB (.mat v4/5/7.3) arrays, or the ``sensor_msgs/Imu`` topic
    ``topic`` of a ROS bag (its only one when None).

    A logger's placeholder rows (0 in every sensor column while the rows beside them are not,
    far from the rest of the record) are left out with a note: those leading the file are
    dropped, those further on become missing samples; messages still count rows as the file
    does.

    Parameters
    ----------
    path : str or Path
        The file, or a ROS 2 bag folder.
    topic : str, optional
        The IMU topic of a bag with several.
    skip_rows : int
        Lines of a text table to skip before its header (logger metadata).
    names : list of str, or dict of array name -> list of str, optional
        Names of the columns of a text table, or of the channels of an array of two or more
        axes (see :mod:`bayescal.recording._arrays`).
    samples_axis, channels_axis : int, optional
        The axes of an array that hold the samples and the channels.

    Returns
    -------
    Recording
        Its columns by name, with the units the header writes.

    Raises
    ------
    InputError
        The file is missing, of an unknown type, or not readable as its type.

    Examples
    --------
    >>> import bayescal as bc
    >>> recording = bc.load_recording("imu.csv")  # doctest: +SKIP
    >>> gyro = recording.channel("gyro_x", unit="deg/s")  # doctest: +SKIP
    """
    content = read_columns(
        path,
        topic,
        skip_rows=skip_rows,
        names=names,
        samples_axis=samples_axis,
        channels_axis=channels_axis,
    )
    recording = Recording(**content)
    if recording.n_rows == 0:
        raise InputError("the file holds no data rows", source=recording.source)
    return _without_placeholder(recording)


def _is_time_column(name: str, units: dict) -> bool:
    lowered = name.lower()
    if lowered in (*_TIME_NAMES, "bag_time"):
        return True
    unit = units.get(name) or unit_from_column_suffix(name)
    return unit is not None and parse_unit(unit).quantity == "time"


def _robust_spread(values: np.ndarray) -> float:
    median = np.median(values)
    return float(1.4826 * np.median(np.abs(values - median)) or np.std(values))


def _sensor_columns(recording: Recording) -> list[str]:
    """The columns of a gyro or an accelerometer (by name, or by the unit the header gives
    them); every column but time where none is named so."""
    units = recording.header_units
    candidates = [name for name in recording.columns if not _is_time_column(name, units)]
    sensors = [
        name
        for name in candidates
        if is_gyro_name(name)
        or is_accel_name(name)
        or (name in units and parse_unit(units[name]).quantity in ("angular_rate", "acceleration"))
    ]
    return sensors or candidates


def _placeholder_mask(recording: Recording, sensors: list[str]) -> np.ndarray:
    """Rows that hold exactly 0 in every sensor column, in runs of at most
    :data:`_PLACEHOLDER_ROWS` beside rows that do not, where 0 is far from the rest of the
    record in at least one of those columns (a logger's placeholder, not a reading)."""
    zero = np.ones(recording.n_rows, dtype=bool)
    for name in sensors:
        zero &= recording.columns[name] == 0
    if not zero.any() or zero.all():
        return np.zeros(recording.n_rows, dtype=bool)
    far = False
    for name in sensors:
        rest = recording.columns[name][~zero]
        rest = rest[np.isfinite(rest)]
        if rest.size and abs(np.median(rest)) > RAIL_SIGMAS * _robust_spread(rest):
            far = True
            break
    if not far:
        return np.zeros(recording.n_rows, dtype=bool)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], zero.astype(np.int8), [0]))))
    mask = np.zeros(recording.n_rows, dtype=bool)
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        if stop - start <= _PLACEHOLDER_ROWS:
            mask[start:stop] = True
    return mask


def _rows_text(rows: np.ndarray, offset: int) -> str:
    """'data row 5 holds' or 'data rows 5, 9 and 12 hold' (the first ten), counting the
    file's rows."""
    numbers = [str(int(row) + 1 + offset) for row in rows[:10]]
    if len(numbers) == 1:
        return f"data row {numbers[0]} holds"
    more = f" and {rows.size - 10} more" if rows.size > 10 else ""
    return f"data rows {', '.join(numbers[:-1])} and {numbers[-1]}{more} hold"


def _without_placeholder(recording: Recording) -> Recording:
    """The recording without a logger's placeholder rows (:func:`_placeholder_mask`), with a
    note: those that lead the file are left out; those further on become missing samples
    (NaN in the sensor columns: :func:`prepare_channel` keeps their place on the grid)."""
    sensors = _sensor_columns(recording)
    if not sensors or recording.n_rows <= MIN_SAMPLES + 1:
        return recording
    mask = _placeholder_mask(recording, sensors)
    if not mask.any():
        return recording
    leading = int(np.argmin(mask)) if not mask.all() else mask.size
    named = ", ".join(sensors[:6]) + (" ..." if len(sensors) > 6 else "")
    notes = list(recording.notes)
    columns = dict(recording.columns)
    file_columns = recording.file_columns
    if leading:
        rows = "data row 1 holds" if leading == 1 else f"data rows 1 to {leading} hold"
        notes.append(
            f"{rows} 0 in every sensor column ({named}), far from the rest of the record (a "
            "logger's placeholder before its first reading): left out"
        )
        columns = {name: values[leading:] for name, values in columns.items()}
        file_columns = tuple((name, values[leading:]) for name, values in file_columns)
    later = np.flatnonzero(mask[leading:])
    if later.size:
        notes.append(
            f"{_rows_text(later, recording.row_offset + leading)} 0 in every sensor "
            f"column ({named}) while the rows beside them do not (a logger's placeholder, "
            "not a reading): left out as missing samples"
        )
        for name in sensors:
            values = columns[name].copy()
            values[later] = np.nan
            columns[name] = values
    return replace(
        recording,
        columns=columns,
        file_columns=file_columns,
        notes=tuple(notes),
        row_offset=recording.row_offset + leading,
        placeholder_rows=tuple(int(row) for row in later),
    )


@dataclass(frozen=True)
class Channel:
    """One channel of a recording, checked and on a regular sample grid, ready for analysis
    (:meth:`Recording.channel`)."""

    source: str
    """The recording it comes from."""
    channel: str
    """The column's name."""
    unit: str
    """The samples' unit (deg/s, m/s^2, LSB ...)."""
    values: np.ndarray
    """Samples on the grid, in ``unit``; NaN where a sample is missing (only with
    gaps="split")."""
    rate_hz: float
    """Sample rate, Hz."""
    start_s: float
    """Time of the first sample, from the first sample of the file."""
    temperature: np.ndarray | None = None
    """The temperature column on the same grid, when one was asked for."""
    notes: tuple[str, ...] = field(default=())
    """What the loader inferred or noticed (units assumed, gaps split ...)."""
    scale: float | None = None
    """The factor the file's numbers were multiplied by (``--scale``), if any."""
    grid: dict = field(default_factory=dict, repr=False)
    """How it was put on its grid (rate, time column and unit, window, gaps): another column
    of the recording prepared alike lands on the same samples."""

    @property
    def n_samples(self) -> int:
        """The number of samples present (missing ones, NaN, not counted)."""
        return int(np.count_nonzero(~np.isnan(self.values)))

    @property
    def duration_s(self) -> float:
        """The length of the grid, s (missing samples included)."""
        return self.values.size / self.rate_hz

    @property
    def stop_s(self) -> float:
        """Time of the end of the grid, s from the first sample of the file."""
        return self.start_s + self.duration_s

    @property
    def time_s(self) -> np.ndarray:
        """The time of each sample on the grid, s from the first sample of the file."""
        return self.start_s + np.arange(self.values.size) / self.rate_hz


def _resolve_unit(table: Recording, column: str, given: str | None) -> tuple[str, str | None, str]:
    """The unit of ``column``, a note when it had to be inferred, and where it came from:
    given, header, name or assumed."""
    if given:
        return parse_unit(given).name, None, "given"
    if column in table.header_units:
        return parse_unit(table.header_units[column]).name, None, "header"
    stated = table.metadata.get("unit")
    if stated and _unit_fits_name(stated, column):
        unit = parse_unit(stated).name
        return (
            unit,
            f"unit of '{column}' from the file's metadata ({table.metadata['unit_line']})",
            "header",
        )
    from_suffix = unit_from_column_suffix(column)
    if from_suffix:
        return (
            from_suffix,
            f"unit of '{column}' read from its name as {from_suffix}; pass --unit to override",
            "name",
        )
    if is_gyro_name(column):
        assumed = "deg/s"
    elif is_accel_name(column):
        assumed = "m/s^2"
    else:
        return (
            "unit",
            f"unit of '{column}' unknown; numbers are in its own unit (pass --unit)",
            "assumed",
        )
    return (
        assumed,
        f"unit of '{column}' not given; assumed {assumed} (pass --unit to override)",
        "assumed",
    )


def _unit_fits_name(unit: str, column: str) -> bool:
    """Whether a unit stated for the whole file suits ``column``: of the kind its name says
    (a rate for a gyro, an acceleration for an accelerometer), or of either kind for a name
    that says neither."""
    quantity = parse_unit(unit).quantity
    if is_gyro_name(column) and not is_accel_name(column):
        return quantity == "angular_rate"
    if is_accel_name(column) and not is_gyro_name(column):
        return quantity == "acceleration"
    return quantity in ("angular_rate", "acceleration")


def resolve_unit(table: Recording, column: str, given: str | None) -> tuple[str, str | None]:
    """The unit of ``column`` and, when it had to be inferred, a note that says how."""
    unit, note, _ = _resolve_unit(table, column, given)
    return unit, note


def unit_notes(table: Recording, column: str, given: str | None, unit: str) -> list[str]:
    """Notes on a unit that looks odd for the column: one bayescal does not know, one of the
    other kind of sensor than the name says, ``--unit`` overriding the header."""
    notes = []
    parsed = parse_unit(unit)
    header = table.header_units.get(column)
    if given and header and parse_unit(header).name != parsed.name:
        notes.append(f"--unit {given} overrides the unit the header gives '{column}', {header}")
    if not parsed.known and not is_count_unit(unit) and unit != "unit":
        notes.append(
            f"unit '{unit}' is not one bayescal knows (deg/s, rad/s, m/s^2, g, ... or counts "
            "such as LSB): numbers are carried in it as given, never converted"
        )
    kind = {"angular_rate": "an angular rate", "acceleration": "an acceleration"}
    if parsed.quantity == "acceleration" and is_gyro_name(column) and not is_accel_name(column):
        notes.append(
            f"'{column}' is named like a gyro, but its unit {unit} is {kind['acceleration']}"
        )
    elif parsed.quantity == "angular_rate" and is_accel_name(column) and not is_gyro_name(column):
        notes.append(
            f"'{column}' is named like an accelerometer, but its unit {unit} is "
            f"{kind['angular_rate']}"
        )
    elif parsed.known and parsed.quantity not in kind:
        notes.append(
            f"unit {unit} of '{column}' is a {parsed.quantity.replace('_', ' ')}, not an angular "
            "rate or an acceleration"
        )
    return notes


def find_time_column(table: Recording, given: str | None) -> str | None:
    if given:
        table.require(given, "time column")
        return given
    names = [*table.columns, *table.unusable, *table.other_columns]
    lowered = {name.lower(): name for name in reversed(names)}
    for base in _TIME_NAMES:
        for candidate in (base, *(f"{base}_{u}" for u in ("s", "ms", "us", "ns"))):
            if candidate in lowered:
                name = lowered[candidate]
                table.require(name, "time column")  # text or a name used twice: say so
                return name
    return None


def _time_in_seconds(
    table: Recording, name: str, time_unit: str | None
) -> tuple[np.ndarray, str | None, bool]:
    """The time column in seconds, a note, and whether its unit was declared."""
    raw = table.columns[name]
    unit_text = time_unit or table.header_units.get(name) or unit_from_column_suffix(name)
    note, declared = None, unit_text is not None
    if unit_text is None:
        unit_text = "s"
        if name.lower() not in ("time", "t"):  # DESIGN.md: 'time' and 't' are in seconds
            note = f"time column '{name}' has no unit; read as seconds (pass --time-unit)"
    unit = parse_unit(unit_text)
    if unit.quantity != "time":
        raise InputError(
            f"'{unit_text}' is not a unit of time",
            source=table.source,
            column=name,
            fix='pass time_unit="s", "ms", "us" or "ns"',
        )
    return (raw if unit.to_si == 1 else raw * unit.to_si), note, declared


@dataclass(frozen=True)
class _Place:
    """Where a sample lies in the file, for messages: its data row (1 = the first row under
    the header, counting rows the reader left out) and its time."""

    relative_time: np.ndarray | None = None
    row_offset: int = 0

    def __call__(self, index: int) -> str:
        where = f"data row {index + 1 + self.row_offset}"
        if self.relative_time is not None and np.isfinite(self.relative_time[index]):
            where += f" (t = {self.relative_time[index]:.6g} s)"
        return where


def _check_finite(values, place: _Place, offset, source, column) -> tuple[float, float]:
    """The smallest and largest value, once none is NaN or infinite (both are finite exactly
    then: NaN propagates through both reductions, which allocate nothing)."""
    if values.size == 0:
        return math.nan, math.nan
    smallest, largest = float(np.min(values)), float(np.max(values))
    if math.isfinite(smallest) and math.isfinite(largest):
        return smallest, largest
    bad = ~np.isfinite(values)
    raise InputError(
        f"{int(bad.sum())} missing or non-finite value(s) (NaN/inf/empty), "
        f"first at {place(offset + int(np.flatnonzero(bad)[0]))}",
        source=source,
        column=column,
        fix="pick a window without them (start=/stop=) or repair the file",
    )


def _stamp_resolution(steps: np.ndarray) -> float:
    """The grid the positive time steps sit on (their resolution), or 0 when they sit on
    none coarser than float noise."""
    positive = steps[steps > 0]
    if np.unique(positive[:4096]).size > 64:  # already too many: the whole record has more
        return 0.0
    distinct = np.unique(positive)
    if distinct.size == 0:
        return 0.0
    if distinct.size == 1:
        return float(distinct[0])
    if distinct.size > 64:
        return 0.0
    resolution = float(min(distinct[0], np.min(np.diff(distinct))))
    ratio = distinct / resolution
    return resolution if np.all(np.abs(ratio - np.round(ratio)) < 1e-3 * ratio) else 0.0


def _float32_note(raw_time: np.ndarray, resolution: float) -> str:
    """'(float32 ...)' when the stamps are float32 numbers whose precision is their
    resolution."""
    largest = float(np.max(np.abs(raw_time)))
    if np.all(raw_time.astype(np.float32) == raw_time):
        spacing = float(np.spacing(np.float32(largest)))
        if spacing >= 0.5 * resolution:
            return f" (float32 stamps: {spacing:.3g} apart at {largest:.6g})"
    return ""


def _check_time_order(time, place: _Place, source, column) -> np.ndarray:
    """The steps between the stamps, once they are finite and increasing."""
    _check_finite(time, place, 0, source, column)
    steps = np.diff(time)
    if steps.size == 0 or steps.min() > 0:
        return steps
    not_increasing = np.flatnonzero(steps <= 0)
    if not_increasing.size:
        index = int(not_increasing[0]) + 1
        what = "duplicated" if steps[index - 1] == 0 else "decreasing"
        coarse = ""
        fix = "sort or de-duplicate the time stamps upstream"
        repeated = np.count_nonzero(steps == 0)
        if repeated > 0.01 * steps.size:
            resolution = _stamp_resolution(steps)
            coarse = (
                f"; {repeated} stamps repeat the one before: the clock is coarser than the "
                f"sample period{_float32_note(time, resolution)}"
            )
            fix = "pass rate_hz=HZ to take the samples as evenly spaced, or store finer stamps"
        raise InputError(
            f"{what} time stamp at {replace(place, relative_time=time - time[0])(index)}; "
            f"{not_increasing.size} interval(s) do not increase{coarse}",
            source=source,
            column=column,
            fix=fix,
        )


_EVEN_STEPS = 1e-6
"""Steps that differ by less than this part of the shortest are evenly spaced."""


def _even_period(times: np.ndarray, steps: np.ndarray) -> float | None:
    """The sample period of stamps whose ``steps`` are all the same to a part in 10^6 (a
    clock that counts samples, a simulation), else None. It is the mean step, which differs
    from the least-squares slope of the stamps by less than that part: the slope costs six
    passes over 10^7 stamps (0.2 s) and changes no digit a rate is printed to."""
    if steps.size == 0:
        return None
    shortest, longest = steps.min(), steps.max()
    if longest - shortest < _EVEN_STEPS * shortest:
        return float((times[-1] - times[0]) / steps.size)
    return None


def _slope(index: np.ndarray, time: np.ndarray) -> float:
    """The least-squares slope of time against grid index (the sample period), its sums
    pairwise (np.sum): a BLAS dot product of millions of positive terms loses ~1e-12."""
    centred = index - index.mean()
    return float(np.sum(centred * (time - time.mean())) / np.sum(centred * centred))


def _rate(period: float) -> float:
    """The sample rate of a fitted period, to twelve digits: a fitted period carries float
    noise that would print as 100.00000000000003."""
    return float(f"{1.0 / period:.12g}")


def gap_error(step: float, periods: float, where: str, source, column) -> InputError:
    """The refusal of a gap in the time stamps (``--gaps error``): how long, where, and what
    to do."""
    return InputError(
        f"gap of {step:.6g} s ({periods:.1f} sample periods) at {where}",
        source=source,
        column=column,
        fix='pass gaps="split" to analyse the segments without bridging the gaps, or pick a '
        "window with start=/stop=",
    )


def _grid_positions(relative_time, window, place: _Place, source, column, gaps, raw_time):
    """Sample-grid index of each sample in ``window`` (None: each sample in its own place, the
    stamps evenly spaced) and the sample rate, from the time stamps; checks gaps and jitter.
    The period is refitted (least squares of time against grid index) until the grid and the
    stamps agree on the record's length. Stamps rounded coarser than a quarter of the period
    (float32 far from zero, a millisecond clock at hundreds of Hz) start from the mean step
    instead of the median, and say so."""
    even = _even_period(relative_time[window], np.diff(relative_time[window]))
    if even is not None:
        # Every sample is on the grid and none is missing: the search below would return
        # exactly the samples' own order after a second pass over 10^7 stamps.
        return None, _rate(even), []
    from ._grid import track_grid

    time = relative_time[window] - relative_time[window][0]
    steps = np.diff(time)
    shortest, longest = steps.min(), steps.max()
    # Steps within a quarter of the shortest of each other sit on no grid coarser than a
    # quarter period (the one case the resolution changes below), and the sort that finds
    # their grid costs a third of a second at 10^7 samples.
    regular = longest - shortest < 0.25 * shortest
    # The resolution before the median reorders the steps in place.
    resolution = 0.0 if regular else _stamp_resolution(steps)
    period = float(np.median(steps, overwrite_input=True))
    notes = []
    if resolution > 0.25 * period and np.unique(steps).size > 1:
        typical = steps[steps < 3 * period]
        period = float(np.mean(typical))
        notes.append(
            f"the time stamps are rounded to {resolution:.3g} s"
            f"{_float32_note(raw_time[window], resolution)}, too coarse to read a "
            f"{period:.3g} s period from one step: the rate is their mean step"
        )
    index = None
    for _ in range(3):
        previous, (index, residual) = index, track_grid(time, period, _LAG_GAIN)
        if previous is not None and np.array_equal(index, previous):
            break  # the same grid again: the refit would give the same period
        period = _slope(index, time)
    off_grid = np.abs(residual) > 0.5
    if off_grid.mean() > _IRREGULAR_SHARE:
        first = window.start + int(np.flatnonzero(off_grid)[0])
        raise InputError(
            f"irregular sampling: {100 * off_grid.mean():.1f}% of the time stamps are more than "
            f"half a period off a {period:.6g} s grid, first at {place(first)}",
            source=source,
            column=column,
            fix=f"pass rate_hz=HZ to treat the samples as evenly spaced (their mean rate is "
            f"{(time.size - 1) / time[-1]:.6g} Hz), or resample upstream",
        )
    if off_grid.any():
        notes.append(
            f"{100 * off_grid.mean():.2g}% of the time stamps are more than half a "
            "period off the sample grid (jitter or bursts); samples kept in order"
        )
    jumps = np.diff(index)
    gap_index = np.flatnonzero(jumps > _GAP_PERIODS)
    if gap_index.size and gaps == "error":
        first = int(gap_index[0])
        step = time[first + 1] - time[first]
        raise gap_error(
            step,
            step / period,
            f"{place(window.start + first + 1)}; {gap_index.size} gap(s) in all",
            source,
            column,
        )
    if gap_index.size:
        notes.append(
            f"{gap_index.size} gap(s) split: the analysis uses the segments between "
            "them and no average spans a gap"
        )
    dropped = int(np.sum(jumps - 1))
    if dropped:
        notes.append(f"{dropped} missing sample(s) left out (not interpolated)")
    return index, _rate(period), notes


def _check_rate(rate, declared: bool, source, column) -> list[str]:
    """A rate read from the stamps that no IMU has: an error; an unusual one from stamps
    without a unit: a note."""
    if not 1.0 <= rate <= 1e6 or (not declared and rate < IMPLAUSIBLE_RATE_HZ):
        hint = (
            f" (in milliseconds, {1000 * rate:.6g} Hz)"
            if not declared and rate < IMPLAUSIBLE_RATE_HZ
            else ""
        )
        confirm = ', or time_unit="s" if the stamps are seconds' if not declared else ""
        raise InputError(
            f"the time stamps give a sample rate of {rate:.6g} Hz{hint}, not an IMU's",
            source=source,
            column=column,
            fix=f"pass time_unit= (s, ms, us, ns) or rate_hz=HZ{confirm}",
        )
    if not declared and rate < UNUSUAL_RATE_HZ:
        return [
            f"time column '{column}' has no unit: read as seconds, the rate is {rate:.6g} Hz "
            f"(if it is in milliseconds, {1000 * rate:.6g} Hz: pass --time-unit ms)"
        ]
    return []


def _check_magnitude(values, extremes, place: _Place, offset, source, column, unit):
    """Values float64 arithmetic can square and sum: neither too large nor too finely
    spread (``extremes``: their smallest and largest)."""
    smallest, largest_value = extremes
    spread = largest_value - smallest
    if max(-smallest, largest_value) > LARGEST_VALUE:
        largest = int(np.argmax(np.abs(values)))
        raise InputError(
            f"value {values[largest]:.3g} {unit} at {place(offset + largest)} is beyond "
            f"{LARGEST_VALUE:.0e}: its square overflows float64",
            source=source,
            column=column,
            fix="check the column; for raw numbers in another scale pass scale=FACTOR",
        )
    if 0 < spread < SMALLEST_SPREAD:
        raise InputError(
            f"the values spread over only {spread:.3g} {unit}, below {SMALLEST_SPREAD:.0e}: "
            "their squares underflow float64",
            source=source,
            column=column,
            fix="pass scale=FACTOR to express them in a larger unit",
        )


def _check_constant_and_rail(values, extremes, median, place: _Place, offset, source, column, unit):
    """A constant channel, or a run of samples at a rail far outside the rest (saturation);
    ``median()``: the record's median."""
    smallest, largest = extremes
    if largest == smallest:
        raise InputError(
            f"the channel is constant at {values[0]:g} {unit}",
            source=source,
            column=column,
            fix="check the column and that the sensor was recording",
        )
    spread = None
    for rail in (largest, smallest):
        at_rail = values == rail
        if np.count_nonzero(at_rail) < _RAIL_RUN:  # too few for a run: most records' extremes
            continue
        edges = np.flatnonzero(np.diff(np.concatenate(([0], at_rail.astype(np.int8), [0]))))
        runs = edges[1::2] - edges[::2]
        long_runs = np.flatnonzero(runs >= _RAIL_RUN)
        if not long_runs.size:
            continue
        # The spread (a median of the record) only where a run at the rail asks whether
        # that rail is far outside it: most records have none.
        if spread is None:
            deviations = np.abs(values - median())
            spread = 1.4826 * np.median(deviations, overwrite_input=True) or np.std(values)
        if abs(rail - median()) > RAIL_SIGMAS * spread:
            first = offset + int(edges[::2][long_runs[0]])
            raise InputError(
                f"stuck at a rail: {int(runs[long_runs[0]])} consecutive samples at {rail:g} "
                f"{unit} from {place(first)}, far outside the rest of the record (saturation)",
                source=source,
                column=column,
                fix="exclude the saturated part with start=/stop=",
            )


def _no_sample_far(values: np.ndarray, extremes) -> bool:
    """True when no sample can be more than GLITCH_SIGMAS noise sd (:func:`_noise_sd`) from
    the record's median, shown without a median: none is farther from it than the extremes
    are apart, and if more than half the steps are at least t, their median is at least t
    and the sd at least 1.4826 t / sqrt(2); t is the smallest step for which that sd puts
    the extremes' distance within GLITCH_SIGMAS of it. False: it takes the medians to tell."""
    farthest = extremes[1] - extremes[0]
    # A part in 10^9 above: the rounding of the sd's arithmetic then never undoes the bound.
    least = farthest * np.sqrt(2) / (GLITCH_SIGMAS * 1.4826) * (1 + 1e-9)
    if values.size < 2 or not GLITCH_SIGMAS * (1.4826 * least / np.sqrt(2)) >= farthest:
        return False
    steps = np.diff(values)
    return np.count_nonzero(np.abs(steps, out=steps) >= least) >= steps.size // 2 + 1


def _noise_sd(values: np.ndarray) -> float:
    """The sample noise sd read from sample-to-sample differences (steps between poses and
    slow drifts do not move it), at least half the resolution of a quantized channel."""
    steps = np.diff(values)
    sizes = np.abs(steps, out=steps)
    smallest = float(sizes.min())
    if smallest == 0:  # a quantized channel repeats values: its smallest real step
        moving = sizes[sizes > 0]
        smallest = float(moving.min()) if moving.size else 0.0
    sd = 1.4826 * float(np.median(sizes, overwrite_input=True)) / np.sqrt(2)
    return max(sd, 0.5 * smallest)


def _check_glitches(values, extremes, median, place: _Place, offset, source, column, unit):
    """Samples thousands of noise sd from the record's median (``median()``) in runs too
    short to be a pose, a rail or a motion: glitches (a logger's error code, a bit flip)."""
    if _no_sample_far(values, extremes):
        return
    level = median()
    sd = _noise_sd(values)
    if sd == 0:
        return
    far = np.abs(values - level) > GLITCH_SIGMAS * sd
    if not far.any():
        return
    edges = np.flatnonzero(np.diff(np.concatenate(([0], far.astype(np.int8), [0]))))
    starts, runs = edges[::2], edges[1::2] - edges[::2]
    short = runs < _RAIL_RUN
    if not short.any():
        return
    first = int(starts[short][0])
    count = int(runs[short].sum())
    raise InputError(
        f"{count} glitch sample(s) more than {GLITCH_SIGMAS:g} noise sd from the rest "
        f"(median {level:.6g} {unit}, noise sd {sd:.3g}), first {values[first]:.6g} {unit} "
        f"at {place(offset + first)}",
        source=source,
        column=column,
        fix="repair or remove those rows, or pick a window without them (start=/stop=)",
    )


def _static_plausibility(
    extremes, median, unit: str, how: str, scaled: bool, source, column
) -> list[str]:
    """A reading no sensor at rest gives (hundreds of deg/s, tens of g) at the record's
    median (``median()``, asked only where the larger extreme exceeds the limit): raw counts,
    probably. An error when the unit was assumed, a note when it was given."""
    parsed = parse_unit(unit)
    if parsed.quantity == "angular_rate":
        unit_si, limit, label = DEG, STATIC_GYRO_LIMIT_DEG_S, "deg/s"
        factor, per = "1/131", "131 LSB per deg/s"
    elif parsed.quantity == "acceleration":
        unit_si, limit, label = STANDARD_GRAVITY, STATIC_ACCEL_LIMIT_G, "g"
        factor, per = "1/16384", "16384 LSB per g"
    else:
        return []
    if max(abs(extremes[0]), abs(extremes[1])) * parsed.to_si / unit_si <= limit:
        return []
    level = median()
    if abs(level) * parsed.to_si / unit_si <= limit:
        return []
    problem = (
        f"reads {level:.6g} {unit} at its median, more than the {limit:g} {label} a sensor at "
        "rest can read: raw counts?"
    )
    if how == "assumed":
        raise InputError(
            f"{problem} (the unit {unit} was assumed)",
            source=source,
            column=column,
            fix=f"pass scale=FACTOR and unit= (e.g. scale={factor} for {per}), or "
            'unit="LSB" to analyse the counts as they are',
        )
    if scaled:
        return [
            f"'{column}' {problem[: -len(' raw counts?')]} after --scale: counts with an offset "
            "(unsigned, centred on mid-scale)? The noise figures do not depend on it; the bias does"
        ]
    return [f"'{column}' {problem} If so, pass --scale FACTOR (e.g. --scale {factor} for {per})"]


def _clipping_notes(values, unit) -> list[str]:
    """A rail inside the noise (the loader refuses one far outside it): the samples may be
    clipped at the sensor's range, which biases a mean and a spread computed from them.
    Heavy tails on a coarse converter step can pile samples on the extreme too, so this is a
    note; discovery decides (:func:`bayescal._saturation.saturation_scan`)."""
    check = rail_check(values, 1.0, unit)
    if check["p_value"] >= 0.01:
        return []
    where = check["location"]
    return [
        f"{where['samples']} samples ({100 * where['fraction']:.2g}%) sit on the record's "
        f"{'largest' if where['side'] == 'upper' else 'smallest'} value, {where['rail']:g} "
        f"{unit}, more than a normal spread puts there: the channel may be clipped at its "
        "range (saturation), which biases its mean and spread; `bayescal discover` tests for it"
    ]


def _time_base(
    table: Recording,
    time_column: str | None,
    time_unit: str | None,
    rate: float | None,
    n_rows: int,
) -> tuple[np.ndarray, str | None, list[str], bool, np.ndarray | None]:
    """Seconds from the first sample for every row, the time column used, notes, whether
    its unit was declared, and the stamps as the file writes them."""
    time_name = find_time_column(table, time_column)
    if rate is not None:
        if not (MIN_RATE_HZ <= rate <= MAX_RATE_HZ):
            raise InputError(
                f"rate_hz={rate:g} must be a sample rate from {MIN_RATE_HZ:g} to {MAX_RATE_HZ:g} Hz"
            )
        notes = (
            [
                f"--rate {rate:g} Hz given: samples taken as evenly spaced; time column "
                f"'{time_name}' not used"
            ]
            if time_name
            else []
        )
        return np.arange(n_rows) / rate, None, notes, True, None
    if time_name is None and "rate_hz" in table.metadata:
        rate = table.metadata["rate_hz"]
        note = (
            f"sample rate {rate:g} Hz from the file's metadata ({table.metadata['rate_line']}): "
            "samples taken as evenly spaced"
        )
        return np.arange(n_rows) / rate, None, [note], True, None
    if time_name is None:
        raise InputError(
            "no time column ('time' or 't') and no rate_hz=",
            source=table.source,
            fix=f"pass rate_hz=HZ or time_column=NAME (columns: {', '.join(table.columns)})",
        )
    if time_unit is not None and parse_unit(time_unit).quantity != "time":
        raise InputError(
            f"time_unit={time_unit!r} is not a unit of time", fix="give s, ms, us or ns"
        )
    time, time_note, declared = _time_in_seconds(table, time_name, time_unit)
    steps = _check_time_order(time, _Place(row_offset=table.row_offset), table.source, time_name)
    if steps.size == 0:  # one row: no step to read a rate from
        raise InputError(
            f"only {time.size} sample(s); at least {MIN_SAMPLES} are needed",
            source=table.source,
            column=time_name,
            fix="record longer",
        )
    shortest = float(steps.min())
    # The unit of the stamps judged on the whole record, before any window is cut from it.
    period = _even_period(time, steps) or float(np.median(steps, overwrite_input=True))
    _check_rate(1.0 / period, declared, table.source, time_name)
    relative = time - time[0]
    # A stamp far off the others (a corrupt row) leaves, taken from the first, steps that
    # rounding has lost: no grid can be read from them. Each difference is rounded by at most
    # half a unit of the span's last place, so only a step as short as that unit can be lost:
    # the stamps are read again only then.
    span = float(time[-1] - time[0])
    lost = (
        np.flatnonzero(np.diff(relative) <= 0)
        if shortest <= np.spacing(span)
        else np.empty(0, dtype=int)
    )
    if lost.size:
        raise InputError(
            f"the time stamps span {span:.6g} s, too wide for their "
            f"{period:.6g} s steps to be told apart from "
            f"{_Place(row_offset=table.row_offset)(int(lost[0]) + 1)} on",
            source=table.source,
            column=time_name,
            fix="repair the stamp far from the others, or pass rate_hz=HZ",
        )
    raw = table.columns[time_name]
    return relative, time_name, [time_note] if time_note else [], declared, raw


def seconds_from_start(
    table: Recording,
    time_column: str | None,
    time_unit: str | None,
    rate: float | None,
    *,
    n_rows: int,
) -> tuple[np.ndarray, str | None, list[str]]:
    """Seconds from the first sample for every row, the time column used, and notes."""
    relative, name, notes, _, _ = _time_base(table, time_column, time_unit, rate, n_rows)
    return relative, name, notes


def _on_grid(values: np.ndarray, positions: np.ndarray | None) -> np.ndarray:
    """``values`` at their grid ``positions`` (None: in order, none missing), NaN where the
    grid has no sample; a new array."""
    if positions is None:
        return np.array(values, dtype=float)
    grid = np.full(int(positions[-1]) + 1, np.nan)
    grid[positions] = values
    return grid


def _check_window(start, stop) -> None:
    for argument, value in (("start", start), ("stop", stop)):
        if value is not None and not math.isfinite(value):
            raise InputError(f"{argument}={value} must be a finite number of seconds")
    if start is not None and stop is not None and stop <= start:
        raise InputError(f"stop={stop:g} s must come after start={start:g} s")


def _placeholders_filled(table: Recording, values: np.ndarray, first: int, last: int):
    """The window's values as the checks read them: a placeholder row's missing sample
    (:func:`_without_placeholder`) stands at the median of the others there, so that the
    checks neither refuse it nor count it; the grid leaves it out (NaN). The window's values
    themselves when it holds none."""
    rows = np.asarray(table.placeholder_rows, dtype=int)
    inside = rows[(rows >= first) & (rows < last)] - first
    window = values[first:last]
    if not inside.size or not np.all(np.isnan(window[inside])):
        return window
    checked = window.copy()
    present = np.ones(window.size, dtype=bool)
    present[inside] = False
    checked[inside] = np.median(window[present])
    return checked


def prepare_channel(
    table: Recording,
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
    temperature: str | None = None,
    at_rest: bool = True,
) -> Channel:
    """Select ``channel`` in the window [start, stop) seconds from the first sample, check it
    and put it on a regular sample grid.

    ``scale`` multiplies the channel's values (raw counts to ``unit``: 1/131 for a gyro
    giving 131 LSB per deg/s); ``temperature`` names a temperature column put on the same
    grid. The checks and notes are those of this module's docstring; ``at_rest=False`` (a
    calibration session, moved between poses) leaves out the glitch check, which a fast
    turn of the hand would fail: the still sections a calibration uses leave glitches out.

    One function (over 80 lines) on purpose: the checks run in the order of this module's
    docstring, each on what the previous one left, and each names the row and time of what it
    refuses.
    """
    if gaps not in ("error", "split"):
        raise InputError(f"gaps={gaps!r} must be 'error' or 'split'")
    _check_window(start, stop)
    if scale is not None and not (math.isfinite(scale) and scale != 0):
        raise InputError(f"scale={scale!r} must be a finite number other than 0")
    values = table.require(channel, "channel")
    if temperature is not None and temperature == channel:
        raise InputError(
            f"temperature={temperature!r} names the analysed channel",
            source=table.source,
            fix="name the temperature column",
        )
    resolved_unit, unit_note, how = _resolve_unit(table, channel, unit)
    notes = [*table.notes, *([unit_note] if unit_note else [])]
    notes.extend(unit_notes(table, channel, unit, resolved_unit))
    if scale is not None:
        values = values * scale
        notes.append(f"'{channel}' multiplied by {scale:.6g} (--scale): values in {resolved_unit}")
    temperature_values = table.require(temperature, "temperature column") if temperature else None
    rate = rate_hz

    relative, time_name, time_notes, declared, raw_time = _time_base(
        table, time_column, time_unit, rate, values.size
    )
    if time_name == channel:
        raise InputError(
            f"'{channel}' is the time column, not a channel to analyse",
            source=table.source,
            column=channel,
            fix="name a sensor's column as the channel",
        )
    notes.extend(time_notes)
    place = _Place(relative, table.row_offset)
    first = int(np.searchsorted(relative, start)) if start is not None else 0
    last = int(np.searchsorted(relative, stop)) if stop is not None else values.size
    if last - first < MIN_SAMPLES:
        raise InputError(
            f"only {max(0, last - first)} samples in the window [{start or 0:g}, "
            f"{'end' if stop is None else f'{stop:g}'}) s; at least {MIN_SAMPLES} are needed "
            f"(the record lasts {relative[-1]:.6g} s)",
            source=table.source,
            column=channel,
            fix="widen the window (start=/stop=) or record longer",
        )
    window = slice(first, last)
    checked = _placeholders_filled(table, values, first, last)
    extremes = _check_finite(checked, place, first, table.source, channel)
    _check_magnitude(checked, extremes, place, first, table.source, channel, resolved_unit)
    if rate is None:
        positions, rate, grid_notes = _grid_positions(
            relative, window, place, table.source, time_name, gaps, raw_time
        )
        notes.extend(_check_rate(rate, declared, table.source, time_name))
        notes.extend(grid_notes)
        stated = table.metadata.get("rate_hz")
        if time_name is not None and stated and abs(rate / stated - 1) > 0.01:
            notes.append(
                f"the file's metadata states {stated:g} Hz ({table.metadata['rate_line']}); "
                f"its time stamps give {rate:.6g} Hz, which is used"
            )
    else:
        positions = None
    # One median for the three checks, and only where one asks for it (~10 ms a million
    # samples): each decides from the extremes, which bound it, where they can.
    median = functools.cache(lambda: float(np.median(checked)))
    _check_constant_and_rail(
        checked, extremes, median, place, first, table.source, channel, resolved_unit
    )
    if at_rest:
        _check_glitches(
            checked, extremes, median, place, first, table.source, channel, resolved_unit
        )
    notes.extend(
        _static_plausibility(
            extremes, median, resolved_unit, how, scale is not None, table.source, channel
        )
    )
    notes.extend(_clipping_notes(checked, resolved_unit))
    grid = _on_grid(values[window], positions)
    grid_temperature = None
    if temperature_values is not None:
        _check_finite(temperature_values[window], place, first, table.source, temperature)
        grid_temperature = _on_grid(temperature_values[window], positions)
    return Channel(
        source=table.source,
        channel=channel,
        unit=resolved_unit,
        values=grid,
        rate_hz=float(rate),
        start_s=float(relative[first]),
        temperature=grid_temperature,
        notes=tuple(dict.fromkeys(notes)),
        scale=scale,
        grid={
            "rate_hz": rate_hz,
            "time_column": time_column,
            "time_unit": time_unit,
            "start": start,
            "stop": stop,
            "gaps": gaps,
        },
    )


def companions(
    table: Recording, channel: Channel, *, temperature: str | None = None
) -> tuple[np.ndarray | None, dict, dict]:
    """The series a channel may depend on, on its grid: the temperature (column
    ``temperature``, else one found by name; None when there is none or it does not vary)
    and, for a gyro, the accelerometer axes found by name (with their units)."""
    from ._columns import find_accelerometer_columns, find_temperature_column

    if temperature is None:
        try:
            temperature = find_temperature_column(table, None)
        except InputError:
            temperature = None
    else:
        find_temperature_column(table, temperature)
    series = None
    if temperature is not None:
        series = prepare_channel(
            table,
            channel.channel,
            temperature=temperature,
            unit=channel.unit,
            scale=channel.scale,
            **channel.grid,
        )
        series = series.temperature
        finite = series[np.isfinite(series)]
        if series.size != channel.values.size or finite.size == 0 or np.ptp(finite) == 0:
            series = None
    accelerometers, units = {}, {}
    columns = find_accelerometer_columns(table)
    if parse_unit(channel.unit).quantity == "angular_rate" and columns:
        for name in columns:
            try:
                column = prepare_channel(table, name, **channel.grid)
            except InputError:
                continue  # an accelerometer that cannot be used is no evidence (none is asked)
            if column.values.size == channel.values.size:
                accelerometers[name] = column.values
                units[name] = column.unit
    return series, accelerometers, units
