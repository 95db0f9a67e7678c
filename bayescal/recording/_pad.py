"""Finding the quiet pad window before liftoff in a flight log.

A rocket on the pad reads 1 g of specific force; at ignition the magnitude of the
accelerometer vector departs from it. The pad level and its scatter are taken from the first
second of the log, liftoff is the first sustained rise of the magnitude by more than
``LIFTOFF_RISE`` above that level, traced back to where the magnitude first left the pad
scatter, and the pad window is the longest stretch before that whose running mean stays at the pad
level and whose running scatter stays within three times its typical value (handling,
walking the rocket or ignition transients break it).
"""

from dataclasses import dataclass

import numpy as np

from .._errors import InputError
from ._columns import find_accelerometer_columns
from ._recording import Recording, seconds_from_start
from ._units import STANDARD_GRAVITY, parse_unit, unit_from_column_suffix

LIFTOFF_RISE = 0.5  # g above the pad level, held for SUSTAIN_S
SUSTAIN_S = 0.05
QUIET_WINDOW_S = 0.25
MIN_PAD_S = 1.0


@dataclass(frozen=True)
class PadWindow:
    """The quiet window on the launch pad before liftoff (:func:`find_pad_window`).

    Attributes
    ----------
    start_s, stop_s : float
        The window, s from the first sample of the file.
    liftoff_s : float
        Where the accelerometer magnitude left the pad scatter before liftoff, s.
    pad_level_g : float
        The accelerometer magnitude at rest on the pad (its median over the first second), g.
    pad_scatter_g : float
        Its robust sd over the first second, g.
    accel_columns : tuple of str
        The x, y, z accelerometer columns used.
    notes : tuple of str
        What was inferred (the accelerometer's unit from its magnitude, ...).
    """

    start_s: float
    stop_s: float
    liftoff_s: float
    pad_level_g: float
    pad_scatter_g: float
    accel_columns: tuple[str, str, str]
    notes: tuple[str, ...]


def _running_mean(values: np.ndarray, width: int) -> np.ndarray:
    total = np.concatenate(([0.0], np.cumsum(values)))
    return (total[width:] - total[:-width]) / width


def find_pad_window(
    table: Recording,
    *,
    accel_columns: tuple[str, str, str] | None = None,
    accel_unit: str | None = None,
    time_column: str | None = None,
    time_unit: str | None = None,
    rate_hz: float | None = None,
) -> PadWindow:
    """Locate liftoff and the quiet window before it (seconds from the first sample).

    The magnitude of the accelerometer vector sits at 1 g on the pad; liftoff is the first
    rise of more than 0.5 g held for 0.05 s, traced back to where the magnitude left the pad
    scatter; the window is the longest stretch before it whose 0.25 s running mean stays at
    the pad level and whose running scatter stays within three times its typical value.

    Parameters
    ----------
    table : Recording
        The flight log (:func:`load_recording`).
    accel_columns : tuple of str, optional
        The x, y, z accelerometer columns (default: found by name).
    accel_unit : str, optional
        Their unit (default: the header's, else g or m/s^2 recognised from the magnitude at
        rest, with a note).
    time_column, time_unit : str, optional
        The time stamps' column and unit (default: ``time`` / ``t`` in seconds).
    rate_hz : float, optional
        Sample rate, Hz: take the samples as evenly spaced, ignoring the time stamps.

    Returns
    -------
    PadWindow
        The window, the liftoff time and the pad level.

    Raises
    ------
    InputError
        No accelerometer columns, a log that does not start at rest, no liftoff, or less
        than 1 s of quiet pad before it.

    Notes
    -----
    One function (over 80 lines) on purpose: its steps — columns, unit, liftoff, the pad level,
    the quiet stretch — each refine the previous one's result and refuse with their own message,
    in this order.
    """
    columns = accel_columns or find_accelerometer_columns(table)
    if columns is None:
        raise InputError(
            "a pad window needs the accelerometer, and no x/y/z accelerometer columns were "
            "found by name",
            source=table.source,
            fix='pass accel_columns=("X", "Y", "Z")',
        )
    raw = np.column_stack([table.require(name, "accelerometer column") for name in columns])
    time, _, notes = seconds_from_start(table, time_column, time_unit, rate_hz, n_rows=raw.shape[0])
    if not np.isfinite(raw).all():
        row = int(np.flatnonzero(~np.isfinite(raw).all(axis=1))[0])
        raise InputError(
            f"non-finite accelerometer value at data row {row + 1}",
            source=table.source,
            column=columns[0],
            fix="repair the file",
        )
    magnitude = np.linalg.norm(raw, axis=1)
    first_second = magnitude[time < 1.0] if np.count_nonzero(time < 1.0) >= 10 else magnitude[:10]

    declared = {
        accel_unit or table.header_units.get(name) or unit_from_column_suffix(name)
        for name in columns
    }
    unit = parse_unit(declared.pop()) if len(declared) == 1 and None not in declared else None
    if unit is not None and unit.quantity == "acceleration":
        to_g = unit.to_si / STANDARD_GRAVITY
    else:
        level = float(np.median(first_second))
        if abs(level - 1.0) < 0.2:
            to_g = 1.0
        elif abs(level - STANDARD_GRAVITY) < 2.0:
            to_g = 1.0 / STANDARD_GRAVITY
        else:
            raise InputError(
                f"cannot tell the accelerometer unit: its magnitude at the start is "
                f"{level:.4g}, neither about 1 (g) nor 9.8 (m/s^2)",
                source=table.source,
                column=columns[0],
                fix="pass accel_unit=",
            )
        notes.append(
            f"accelerometer unit taken as {'g' if to_g == 1.0 else 'm/s^2'} from its "
            f"magnitude at rest ({level:.4g}); pass --accel-unit to override"
        )
    magnitude = magnitude * to_g
    first_second = first_second * to_g
    pad_level = float(np.median(first_second))
    pad_scatter = (
        float(1.4826 * np.median(np.abs(first_second - pad_level)))
        or float(np.std(first_second))
        or 1e-6
    )
    if abs(pad_level - 1.0) > 0.2:
        raise InputError(
            f"the log does not start at rest: accelerometer magnitude "
            f"{pad_level:.3f} g in its first second",
            source=table.source,
            column=columns[0],
            fix="pick the pad window with start=/stop=",
        )

    period = float(np.median(np.diff(time)))
    sustain = max(1, round(SUSTAIN_S / period))
    above = magnitude > pad_level + LIFTOFF_RISE
    held = _running_mean(above.astype(float), sustain) >= 0.999
    if not held.any():
        raise InputError(
            f"no liftoff found: the accelerometer magnitude never stays "
            f"{LIFTOFF_RISE} g above its pad level ({pad_level:.3f} g) for "
            f"{SUSTAIN_S} s",
            source=table.source,
            column=columns[0],
            fix="use start=/stop= to choose the window",
        )
    trigger = int(np.flatnonzero(held)[0])
    settled = np.flatnonzero(np.abs(magnitude[:trigger] - pad_level) <= 5 * pad_scatter)
    onset = int(settled[-1]) + 1 if settled.size else 0

    width = max(2, round(QUIET_WINDOW_S / period))
    before = magnitude[:onset]
    if before.size < 2 * width:
        raise InputError(
            f"liftoff at t = {time[onset]:.3f} s leaves no pad data before it",
            source=table.source,
            column=columns[0],
            fix="use start=/stop= to choose the window",
        )
    mean = _running_mean(before, width)
    scatter = np.sqrt(np.maximum(_running_mean(before**2, width) - mean**2, 0.0))
    typical = float(np.median(scatter))
    quiet = (np.abs(mean - pad_level) <= 3 * pad_scatter) & (scatter <= 3 * typical)
    # A running window that starts at i covers samples i .. i + width - 1.
    edges = np.flatnonzero(np.diff(np.concatenate(([0], quiet.astype(np.int8), [0]))))
    if edges.size == 0:
        raise InputError(
            f"no quiet stretch before liftoff at t = {time[onset]:.3f} s",
            source=table.source,
            column=columns[0],
            fix="use start=/stop= to choose the window",
        )
    starts, stops = edges[::2], edges[1::2] - 1 + width
    best = int(np.argmax(stops - starts))
    start_index, stop_index = int(starts[best]), int(min(stops[best], onset))
    start_s, stop_s = float(time[start_index]), float(time[stop_index - 1] + period)
    if stop_s - start_s < MIN_PAD_S:
        raise InputError(
            f"the quiet pad window before liftoff at t = {time[onset]:.3f} s lasts "
            f"only {stop_s - start_s:.2f} s (at least {MIN_PAD_S} s is needed)",
            source=table.source,
            column=columns[0],
            fix="use start=/stop= to choose the window",
        )
    notes.append(
        f"pad window {start_s:.3f}–{stop_s:.3f} s before liftoff at "
        f"t = {time[onset]:.3f} s (accelerometer {', '.join(columns)})"
    )
    return PadWindow(
        start_s, stop_s, float(time[onset]), pad_level, pad_scatter, columns, tuple(notes)
    )
