"""A recording and one channel of it prepared for analysis.

The formats and checks are those of ../shared/DESIGN.md: CSV (one header row, optional leading
``#`` comment lines), Parquet and NPZ with named columns, ROS bags (:mod:`._readers`); a time
column ``time`` or ``t``
(``t_s``, ``time[ms]`` and ``timestamp_ms`` name their unit), or ``--rate``; units from the
command line, else from the header (``gyro_x[deg/s]``), else from a unit suffix of the name
(``gyro_x_dps``), else assumed from the kind of sensor — and then said so.

Every problem found in the analysed window is reported with its data row (1 = first row
under the header) and its time, and raises :class:`InputError`: non-finite values,
non-increasing or duplicated time stamps, gaps, irregular sampling, too few samples, a
constant channel, a channel stuck at a rail. Nothing is filled in: with ``gaps="split"``
missing samples become NaN, which the estimators leave out.
"""

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._errors import InputError
from ._columns import is_accel_name, is_gyro_name
from ._levels import RAIL_SIGMAS, rail_check
from ._readers import read_columns
from ._units import parse_unit, unit_from_column_suffix

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


@dataclass(frozen=True)
class Recording:
    """The numeric columns of a recording, by name, with the units its header gives
    (:func:`load_recording`); :meth:`channel` puts one of them on its sample grid."""

    source: str
    """The file (and, for a ROS bag, the topic) the columns come from."""
    columns: dict[str, np.ndarray]
    header_units: dict[str, str]
    other_columns: tuple[str, ...] = ()
    """Columns that are not numeric (text), kept only to name them in messages."""
    topic: str | None = None
    """The ``sensor_msgs/Imu`` topic of a ROS bag."""
    start_stamp_ns: int | None = None
    """A ROS bag's first ``header.stamp``, nanoseconds since the epoch."""

    @property
    def n_rows(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0

    def require(self, name: str, role: str = "column") -> np.ndarray:
        """The column ``name``, or an :class:`InputError` that lists the columns there are."""
        if name in self.columns:
            return self.columns[name]
        if name in self.other_columns:
            raise InputError(
                f"{role} '{name}' is not numeric",
                source=self.source,
                column=name,
                fix="choose a column of numbers",
            )
        raise InputError(
            f"no {role} '{name}'",
            source=self.source,
            fix=f"columns are: {', '.join(self.columns) or '(none)'}",
        )

    def channel(self, name: str, **options) -> "Channel":
        """Column ``name`` checked and put on a regular sample grid; ``options`` are those of
        :func:`prepare_channel` (unit, rate, time_column, time_unit, start, stop, gaps,
        temperature)."""
        return prepare_channel(self, name, **options)


def load_recording(path: str | Path, *, topic: str | None = None) -> Recording:
    """Read a recording: CSV, Parquet or NPZ with named columns, or the ``sensor_msgs/Imu``
    topic ``topic`` of a ROS bag (its only one when None).

    Parameters
    ----------
    path : str or Path
        The file, or a ROS 2 bag folder.
    topic : str, optional
        The IMU topic of a bag with several.

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
    return Recording(**read_columns(path, topic))


@dataclass(frozen=True)
class Channel:
    """One channel of a recording, checked and on a regular sample grid, ready for analysis
    (:meth:`Recording.channel`)."""

    source: str
    """The recording it comes from."""
    channel: str
    """The column's name."""
    unit: str
    values: np.ndarray
    """Samples on the grid, in ``unit``; NaN where a sample is missing (only with
    gaps="split")."""
    rate_hz: float
    start_s: float
    """Time of the first sample, from the first sample of the file."""
    temperature: np.ndarray | None = None
    """The temperature column on the same grid, when one was asked for."""
    notes: tuple[str, ...] = field(default=())
    """What the loader inferred or noticed (units assumed, gaps split ...)."""
    grid: dict = field(default_factory=dict, repr=False)
    """How it was put on its grid (rate, time column and unit, window, gaps): another column
    of the recording prepared alike lands on the same samples."""

    @property
    def n_samples(self) -> int:
        return int(np.count_nonzero(~np.isnan(self.values)))

    @property
    def duration_s(self) -> float:
        return self.values.size / self.rate_hz

    @property
    def stop_s(self) -> float:
        return self.start_s + self.duration_s

    @property
    def time_s(self) -> np.ndarray:
        return self.start_s + np.arange(self.values.size) / self.rate_hz


def resolve_unit(table: Recording, column: str, given: str | None) -> tuple[str, str | None]:
    """The unit of ``column`` and, when it had to be inferred, a note that says how."""
    if given:
        return parse_unit(given).name, None
    if column in table.header_units:
        return parse_unit(table.header_units[column]).name, None
    from_suffix = unit_from_column_suffix(column)
    if from_suffix:
        return (
            from_suffix,
            f"unit of '{column}' read from its name as {from_suffix}; pass --unit to override",
        )
    if is_gyro_name(column):
        assumed = "deg/s"
    elif is_accel_name(column):
        assumed = "m/s^2"
    else:
        return "unit", f"unit of '{column}' unknown; numbers are in its own unit (pass --unit)"
    return assumed, f"unit of '{column}' not given; assumed {assumed} (pass --unit to override)"


def find_time_column(table: Recording, given: str | None) -> str | None:
    if given:
        table.require(given, "time column")
        return given
    lowered = {name.lower(): name for name in table.columns}
    for base in _TIME_NAMES:
        for candidate in (base, *(f"{base}_{u}" for u in ("s", "ms", "us", "ns"))):
            if candidate in lowered:
                return lowered[candidate]
    return None


def _time_in_seconds(
    table: Recording, name: str, time_unit: str | None
) -> tuple[np.ndarray, str | None]:
    raw = table.columns[name]
    unit_text = time_unit or table.header_units.get(name) or unit_from_column_suffix(name)
    note = None
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
            fix="pass --time-unit s, ms, us or ns",
        )
    return raw * unit.to_si, note


def _row_and_time(index: int, relative_time: np.ndarray | None) -> str:
    """``index`` counts data rows of the file from 0; ``relative_time`` is the whole file's."""
    where = f"data row {index + 1}"
    if relative_time is not None and np.isfinite(relative_time[index]):
        where += f" (t = {relative_time[index]:.6g} s)"
    return where


def _check_finite(values, relative_time, offset, source, column):
    bad = ~np.isfinite(values)
    if bad.any():
        first = offset + int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{int(bad.sum())} missing or non-finite value(s) (NaN/inf/empty), "
            f"first at {_row_and_time(first, relative_time)}",
            source=source,
            column=column,
            fix="pick a window without them (--start/--stop) or repair the file",
        )


def _check_time_order(time, source, column):
    _check_finite(time, None, 0, source, column)
    steps = np.diff(time)
    not_increasing = np.flatnonzero(steps <= 0)
    if not_increasing.size:
        index = int(not_increasing[0]) + 1
        what = "duplicated" if steps[index - 1] == 0 else "decreasing"
        raise InputError(
            f"{what} time stamp at {_row_and_time(index, time - time[0])}; "
            f"{not_increasing.size} interval(s) do not increase",
            source=source,
            column=column,
            fix="sort or de-duplicate the time stamps upstream",
        )


def _grid_positions(relative_time, window, source, column, gaps):
    """Sample-grid index of each sample in ``window`` and the sample rate, from the time
    stamps; checks gaps and jitter. The period is refitted (least squares of time against
    grid index) until the grid and the stamps agree on the record's length."""
    from ._grid import track_grid

    time = relative_time[window] - relative_time[window][0]
    period = float(np.median(np.diff(time)))
    for _ in range(3):
        index, residual = track_grid(time, period, _LAG_GAIN)
        period = float(np.polyfit(index, time, 1)[0])
    off_grid = np.abs(residual) > 0.5
    notes = []
    if off_grid.mean() > _IRREGULAR_SHARE:
        first = window.start + int(np.flatnonzero(off_grid)[0])
        raise InputError(
            f"irregular sampling: {100 * off_grid.mean():.1f}% of the time stamps are more than "
            f"half a period off a {period:.6g} s grid, first at "
            f"{_row_and_time(first, relative_time)}",
            source=source,
            column=column,
            fix="pass --rate HZ to treat the samples as evenly spaced, or resample upstream",
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
        raise InputError(
            f"gap of {step:.6g} s ({step / period:.1f} sample periods) at "
            f"{_row_and_time(window.start + first + 1, relative_time)}; {gap_index.size} gap(s) "
            "in all",
            source=source,
            column=column,
            fix="pass --gaps split to analyse the segments without bridging the gaps, or pick a "
            "window with --start/--stop",
        )
    if gap_index.size:
        notes.append(
            f"{gap_index.size} gap(s) split: the analysis uses the segments between "
            "them and no average spans a gap"
        )
    dropped = int(np.sum(jumps - 1))
    if dropped:
        notes.append(f"{dropped} missing sample(s) left out (not interpolated)")
    # Twelve digits: a fitted period carries float noise that would print as 100.00000000000003.
    return index, float(f"{1.0 / period:.12g}"), notes


def _check_constant_and_rail(values, relative_time, offset, source, column, unit):
    if np.ptp(values) == 0:
        raise InputError(
            f"the channel is constant at {values[0]:g} {unit}",
            source=source,
            column=column,
            fix="check the column and that the sensor was recording",
        )
    median = np.median(values)
    spread = 1.4826 * np.median(np.abs(values - median)) or np.std(values)
    for rail in (values.max(), values.min()):
        if abs(rail - median) <= RAIL_SIGMAS * spread:
            continue
        at_rail = np.concatenate(([0], (values == rail).astype(np.int8), [0]))
        edges = np.flatnonzero(np.diff(at_rail))
        runs = edges[1::2] - edges[::2]
        long_runs = np.flatnonzero(runs >= _RAIL_RUN)
        if long_runs.size:
            first = offset + int(edges[::2][long_runs[0]])
            raise InputError(
                f"stuck at a rail: {int(runs[long_runs[0]])} consecutive samples at {rail:g} "
                f"{unit} from {_row_and_time(first, relative_time)}, far outside the rest of the "
                "record (saturation)",
                source=source,
                column=column,
                fix="exclude the saturated part with --start/--stop",
            )


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


def seconds_from_start(
    table: Recording,
    time_column: str | None,
    time_unit: str | None,
    rate: float | None,
    *,
    n_rows: int,
) -> tuple[np.ndarray, str | None, list[str]]:
    """Seconds from the first sample for every row, the time column used, and notes."""
    time_name = find_time_column(table, time_column)
    if rate is not None:
        if not (rate > 0 and math.isfinite(rate)):
            raise InputError(f"--rate {rate} must be a positive sample rate in Hz")
        notes = (
            [
                f"--rate {rate:g} Hz given: samples taken as evenly spaced; time column "
                f"'{time_name}' not used"
            ]
            if time_name
            else []
        )
        return np.arange(n_rows) / rate, None, notes
    if time_name is None:
        raise InputError(
            "no time column ('time' or 't') and no --rate",
            source=table.source,
            fix=f"pass --rate HZ or --time-column NAME (columns: {', '.join(table.columns)})",
        )
    time, time_note = _time_in_seconds(table, time_name, time_unit)
    _check_time_order(time, table.source, time_name)
    return time - time[0], time_name, [time_note] if time_note else []


def prepare_channel(
    table: Recording,
    channel: str,
    *,
    unit: str | None = None,
    rate: float | None = None,
    time_column: str | None = None,
    time_unit: str | None = None,
    start: float | None = None,
    stop: float | None = None,
    gaps: str = "error",
    temperature: str | None = None,
) -> Channel:
    """Select ``channel`` in the window [start, stop) seconds from the first sample, check it
    and put it on a regular sample grid."""
    if gaps not in ("error", "split"):
        raise InputError(f"--gaps {gaps!r} must be 'error' or 'split'")
    if start is not None and stop is not None and stop <= start:
        raise InputError(f"--stop {stop:g} s must come after --start {start:g} s")
    values = table.require(channel, "channel")
    resolved_unit, unit_note = resolve_unit(table, channel, unit)
    notes = [unit_note] if unit_note else []
    temperature_values = table.require(temperature, "temperature column") if temperature else None
    given_rate = rate

    relative, time_name, time_notes = seconds_from_start(
        table, time_column, time_unit, rate, n_rows=values.size
    )
    notes.extend(time_notes)
    first = int(np.searchsorted(relative, start)) if start is not None else 0
    last = int(np.searchsorted(relative, stop)) if stop is not None else values.size
    if last - first < MIN_SAMPLES:
        raise InputError(
            f"only {max(0, last - first)} samples in the window [{start or 0:g}, "
            f"{'end' if stop is None else f'{stop:g}'}) s; at least {MIN_SAMPLES} are needed "
            f"(the record lasts {relative[-1]:.6g} s)",
            source=table.source,
            column=channel,
            fix="widen the window (--start/--stop) or record longer",
        )
    window = slice(first, last)
    _check_finite(values[window], relative, first, table.source, channel)
    if rate is None:
        positions, rate, grid_notes = _grid_positions(
            relative, window, table.source, time_name, gaps
        )
        notes.extend(grid_notes)
        if not 1.0 <= rate <= 1e6:
            raise InputError(
                f"the time stamps give a sample rate of {rate:.6g} Hz",
                source=table.source,
                column=time_name,
                fix="pass --time-unit (s, ms, us, ns) or --rate HZ",
            )
    else:
        positions = np.arange(last - first)
    _check_constant_and_rail(values[window], relative, first, table.source, channel, resolved_unit)
    notes.extend(_clipping_notes(values[window], resolved_unit))
    grid = np.full(int(positions[-1]) + 1, np.nan)
    grid[positions] = values[window]
    grid_temperature = None
    if temperature_values is not None:
        _check_finite(temperature_values[window], relative, first, table.source, temperature)
        grid_temperature = np.full(grid.size, np.nan)
        grid_temperature[positions] = temperature_values[window]
    return Channel(
        source=table.source,
        channel=channel,
        unit=resolved_unit,
        values=grid,
        rate_hz=float(rate),
        start_s=float(relative[first]),
        temperature=grid_temperature,
        notes=tuple(notes),
        grid={
            "rate": given_rate,
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
        series = prepare_channel(table, channel.channel, temperature=temperature, **channel.grid)
        series = series.temperature
        finite = series[np.isfinite(series)]
        if series.size != channel.values.size or finite.size == 0 or np.ptp(finite) == 0:
            series = None
    accelerometers, units = {}, {}
    columns = find_accelerometer_columns(table)
    if parse_unit(channel.unit).quantity == "angular_rate" and columns:
        for name in columns:
            column = prepare_channel(table, name, **channel.grid)
            if column.values.size == channel.values.size:
                accelerometers[name] = column.values
                units[name] = column.unit
    return series, accelerometers, units
