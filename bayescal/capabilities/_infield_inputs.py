"""The inputs of an in-field update (:mod:`._infield`), checked: the alignment window, the
gyros, accelerometers and temperatures on one grid, the old calibration of each gyro, and the
priors the fine alignment takes from them."""

import math
from collections.abc import Mapping
from os import PathLike

import numpy as np

from .._errors import InputError
from ..models._components import Components
from ..models._terms import bounding_walk_variance
from ..models._thermal import _drift_shape
from ..models.effects._parameter import Context
from ..navigation._alignment import MIN_ALIGNMENT_S, GyroPrior
from ..navigation._earth import north_east
from ..recording._columns import find_temperature_column, temperature_unit
from ..recording._recording import Channel, Recording, seconds_from_start
from ..recording._units import parse_unit
from ._thermal import ThermalCalibration, load_thermal_calibration


def alignment_window(align) -> tuple[float, float]:
    try:
        start, stop = (float(value) for value in align)
    except (TypeError, ValueError):
        start = stop = math.nan
    if not (math.isfinite(start) and math.isfinite(stop) and stop > start >= 0):
        raise InputError(
            f"align {align!r}",
            fix="give the alignment window as (t0, t1), seconds from the first sample, t1 > t0",
        )
    if stop - start < MIN_ALIGNMENT_S:
        raise InputError(
            f"the alignment window {start:g}:{stop:g} lasts {stop - start:g} s, shorter than "
            f"the {MIN_ALIGNMENT_S:g} s the fine alignment can use",
            fix="give a longer still window (the patent's extended alignment: 10-20 minutes)",
        )
    return start, stop


def taxi_reference(taxi, track_heading, window) -> tuple[tuple[float, float] | None, tuple]:
    """The taxi's window (s from the first sample; None without one) and the known track
    headings (deg, a tuple; empty without them), checked."""
    if taxi is None:
        if track_heading is not None:
            raise InputError(
                "track_heading was given without a taxi",
                fix="give the taxi's window (t0, t1) too, or leave the track heading out",
            )
        return None, ()
    try:
        start, stop = (float(value) for value in taxi)
    except (TypeError, ValueError):
        start = stop = math.nan
    if not (math.isfinite(start) and math.isfinite(stop) and stop > start):
        raise InputError(
            f"taxi {taxi!r}", fix="give the taxi as (t0, t1), seconds from the first sample"
        )
    if start < window[1]:
        raise InputError(
            f"the taxi {start:g}:{stop:g} starts before the alignment window {window[0]:g}:"
            f"{window[1]:g} ends",
            fix="give a taxi that starts at or after the end of the still window",
        )
    if track_heading is None:
        return (start, stop), ()
    values = track_heading.split(",") if isinstance(track_heading, str) else track_heading
    try:
        headings = tuple(float(value) for value in np.atleast_1d(values))
    except (TypeError, ValueError):
        headings = ()
    if not headings or not all(math.isfinite(h) for h in headings):
        raise InputError(
            f"track_heading {track_heading!r}",
            fix="give the taxiway's heading in degrees from north, one per straight leg",
        )
    return (start, stop), headings


def position_names(positions, position_sd, taxi) -> tuple[tuple[str, str] | None, float]:
    """The position reference's two columns (north then east; None without one) and the sd of
    a fix (m), checked."""
    if not (isinstance(position_sd, (int, float)) and 0 < position_sd < math.inf):
        raise InputError(f"position_sd={position_sd!r}", fix="give the fixes' sd in m, e.g. 2")
    if positions is None:
        return None, float(position_sd)
    names = positions.split(",") if isinstance(positions, str) else list(np.atleast_1d(positions))
    names = [str(name).strip() for name in names]
    if len(names) != 2 or not all(names):
        raise InputError(
            f"positions={positions!r}",
            fix="name two columns: the north then the east position (latitude and longitude in "
            "deg or rad, or north and east in m)",
        )
    if taxi is None:
        raise InputError(
            "positions was given without a taxi",
            fix="give the taxi's window (t0, t1) too: the fixes tell the heading while it moves",
        )
    return (names[0], names[1]), float(position_sd)


def read_positions(recording: Recording, names, first: Channel, options: dict, height: float):
    """The position fixes on the alignment's sample grid (that of ``first``), north and east
    of the first fix, m, NaN where none: the columns' value at the row of each sample (NaN or
    empty where the receiver gave no fix). Latitude and longitude (an angle unit in the
    header) become north and east by the ellipsoid's radii
    (:func:`~bayescal.navigation._earth.north_east`); columns in m are north and east already.
    """
    values, units = [], []
    for name in names:
        try:
            values.append(np.asarray(recording.require(name, "position column"), dtype=float))
        except InputError as error:
            raise InputError(
                f"positions={','.join(names)}: {error.problem}",
                source=recording.source,
                fix=error.fix,
            ) from None
        units.append(recording.header_units.get(name))
    if units[0] != units[1] or units[0] is None:
        raise InputError(
            f"positions={','.join(names)}: the columns' units are {units[0]} and {units[1]}",
            source=recording.source,
            fix="declare one unit for both in the header: deg or rad (latitude, longitude) or m "
            "(north, east), e.g. gnss_latitude[deg]",
        )
    relative, _, _ = seconds_from_start(
        recording,
        options["time_column"],
        options["time_unit"],
        options["rate_hz"],
        n_rows=recording.n_rows,
    )
    times = first.time_s
    rows = np.clip(np.searchsorted(relative, times - 0.5 / first.rate_hz), 0, relative.size - 1)
    on_grid = np.abs(relative[rows] - times) < 0.5 / first.rate_hz
    fixes = np.stack([v[rows] for v in values], axis=1)
    fixes[~on_grid] = np.nan
    fixes[~np.isfinite(fixes).all(axis=1)] = np.nan
    if units[0] == "m":
        return fixes
    unit = parse_unit(units[0])
    if unit.quantity != "angle":
        raise InputError(
            f"positions={','.join(names)}: unit {units[0]} is neither an angle nor m",
            source=recording.source,
            fix="give latitude and longitude in deg or rad, or north and east in m",
        )
    angles = fixes * unit.to_si
    present = np.flatnonzero(np.isfinite(angles[:, 0]))
    if not present.size:
        return fixes
    origin = angles[present[0]]
    return north_east(angles[:, 0], angles[:, 1], height, origin=(origin[0], origin[1]))


def check_wander(wander) -> tuple[float, float]:
    """The taxi's wander about the centre line, (sd in m, time constant in s), checked."""
    try:
        sd, time_constant = (float(value) for value in wander)
    except (TypeError, ValueError):
        sd = time_constant = math.nan
    if not (0 < sd < math.inf and 0 < time_constant < math.inf):
        raise InputError(
            f"wander={wander!r}",
            fix="give the wander about the centre line as (sd in m, time constant in s), both "
            "positive, e.g. (0.5, 20)",
        )
    return sd, time_constant


def _temperature_columns(recording: Recording, temperature) -> list[str]:
    if temperature is None or (isinstance(temperature, str) and "," not in temperature):
        return [find_temperature_column(recording, temperature)] * 3
    names = temperature.split(",") if isinstance(temperature, str) else list(temperature)
    names = [name.strip() for name in names]
    if len(names) != 3:
        raise InputError(
            f"temperature {temperature!r}", fix="give one column, or one per gyro (x, y, z)"
        )
    return [find_temperature_column(recording, name) for name in names]


def read_alignment(recording: Recording, window, columns: dict, options: dict):
    """The gyros (their unit), accelerometers (m/s^2) and per-gyro temperatures in the window,
    on one grid; the gyro unit, the temperature unit and the channels' notes."""
    temperatures = _temperature_columns(recording, columns["temperature"])
    grid = {**options, "start": window[0], "stop": window[1], "at_rest": False}
    gyros = [
        recording.channel(name, unit=columns["unit"], temperature=temperatures[axis], **grid)
        for axis, name in enumerate(columns["gyro"])
    ]
    accels = [
        recording.channel(name, unit=columns["accel_unit"], **grid) for name in columns["accel"]
    ]
    kinds = [
        *(("angular_rate", "an angular rate"),) * 3,
        *(("acceleration", "an acceleration"),) * 3,
    ]
    for channel, (quantity, kind) in zip((*gyros, *accels), kinds, strict=True):
        if parse_unit(channel.unit).quantity != quantity:
            raise InputError(
                f"unit {channel.unit} is not {kind}",
                source=recording.source,
                column=channel.channel,
                fix='pass unit="deg/s" for the gyros (accel_unit="m/s^2" for the accelerometers)',
            )
    units = {g.unit for g in gyros}
    if len(units) > 1 or len({c.values.size for c in (*gyros, *accels)}) > 1:
        raise InputError(
            "the gyros and accelerometers do not share one unit and sample grid",
            source=recording.source,
            fix="give the gyros one unit and the same time column",
        )
    if gyros[0].duration_s < window[1] - window[0] - 1.5 / gyros[0].rate_hz:
        raise InputError(
            f"the recording ends at {gyros[0].stop_s:.6g} s, inside the window "
            f"{window[0]:g}:{window[1]:g} (the alignment, and the taxi if given)",
            source=recording.source,
            fix="give a window inside the recording",
        )
    heat_units = {temperature_unit(recording, name)[0] for name in temperatures}
    if len(heat_units) > 1:
        raise InputError("the temperature columns use different units", source=recording.source)
    gyro = np.stack([g.values for g in gyros], axis=1)
    accel = np.stack([a.values * parse_unit(a.unit).to_si for a in accels], axis=1)
    heat = np.stack([g.temperature for g in gyros], axis=1)
    notes = tuple(dict.fromkeys(note for c in (*gyros, *accels) for note in c.notes))
    return gyro, accel, heat, gyros[0], heat_units.pop(), notes


def old_calibrations(calibration, names, unit: str, heat_unit: str) -> dict:
    if isinstance(calibration, (str, PathLike)):
        return {
            name: load_thermal_calibration(
                calibration, channel=name, unit=unit, temperature_unit=heat_unit
            )
            for name in names
        }
    given = list(calibration.values() if isinstance(calibration, Mapping) else calibration)
    if not all(isinstance(item, ThermalCalibration) for item in given):
        raise InputError(
            "calibration: give a calibration file, or ThermalCalibration objects (a mapping or "
            "a list)"
        )
    found = {item.channel: item for item in given}
    for name in names:
        if name not in found:
            raise InputError(
                f"the calibration holds {', '.join(found) or 'no channel'}, not '{name}'",
                fix="give one thermal calibration per gyro, named as its column",
            )
        old = found[name]
        if old.unit != unit or old.temperature_unit != heat_unit:
            raise InputError(
                f"the calibration of '{name}' is in {old.unit} per {old.temperature_unit}, the "
                f"recording in {unit} per {heat_unit}",
                fix=f'pass unit="{old.unit}" to match, or give a calibration in the '
                "recording's units",
            )
    return {name: found[name] for name in names}


def gyro_priors(old: dict, heat, rate_hz: float, si: float) -> tuple[GyroPrior, ...]:
    """Each gyro's prior for the fine alignment, in SI units: its temperature powers, the
    calibration's covariance and drift shape, and its bias instability as an offset and a
    random walk (:mod:`bayescal.navigation._alignment`): the walk's Allan variance matches the
    flicker floor at a third of the alignment, the offset makes up the exact variance of the
    flicker's mean over it (:meth:`bayescal.models._components.Components.block_covariances`)."""
    count = heat.shape[0]
    duration = count / rate_hz
    components = Components.of(("bias_instability", "rate_random_walk"), Context(rate_hz, duration))
    window = components.block_covariances(np.array([0]), np.array([count]), rate_hz)[:, 0, 0]
    priors = []
    for axis, calibration in enumerate(old.values()):
        noise = calibration.noise
        flicker = noise.get("B", {}).get("mean", 0.0) * si
        walk = noise.get("K", {}).get("mean", 0.0) * si
        instability = walk**2 + bounding_walk_variance(
            "bias_instability", {"B": flicker}, duration, rate_hz
        )
        mean_variance = float(np.asarray(components.weights({"B": flicker, "K": walk})) @ window)
        powers = (heat[:, axis, None] - calibration.reference) ** np.arange(calibration.degree + 1)
        priors.append(
            GyroPrior(
                powers=powers,
                covariance=np.asarray(calibration.covariance) * si**2,
                drift_shape=_drift_shape(
                    calibration.degree, calibration.reference, calibration.temperature_range
                ),
                instability=instability,
                offset_variance=max(mean_variance - instability * duration / 3, 0.0),
            )
        )
    return tuple(priors)
