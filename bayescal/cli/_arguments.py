"""Arguments every command shares: value types that check themselves, the recording and its
window, the output folder, local gravity, and the one exit for a failed health check."""

import argparse
import math
import sys

from .._errors import InputError


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text} must be a finite number")
    return value


def _whole(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None


def bounded_float(low: float, high: float, what: str = ""):
    """An argument type: a finite number from ``low`` to ``high``."""

    def parse(text: str) -> float:
        value = _number(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{text} must lie between {low:g} and {high:g}{what}")
        return value

    parse.__name__ = "number"
    return parse


def bounded_int(low: int, high: int):
    """An argument type: a whole number from ``low`` to ``high``."""

    def parse(text: str) -> int:
        value = _whole(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{text} must be a whole number from {low} to {high}")
        return value

    parse.__name__ = "whole number"
    return parse


def finite_float(text: str) -> float:
    return _number(text)


def positive_float(text: str) -> float:
    value = _number(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"{text} must be a positive number")
    return value


latitude = bounded_float(-90.0, 90.0, " degrees")
height = bounded_float(-500.0, 20_000.0, " m (the gravity formula's range)")
rate = bounded_float(1e-3, 1e7, " Hz")
minutes = bounded_float(0.5, 24 * 60.0, " minutes")
walkers = bounded_int(2, 10_000)
max_steps = bounded_int(1, 10**8)
max_effects = bounded_int(1, 20)
row_count = bounded_int(0, 10**9)
axis = bounded_int(0, 31)


def confidence(text: str) -> float:
    value = _number(text)
    if not 0.5 <= value <= 0.9999:
        raise argparse.ArgumentTypeError(f"{text} must lie between 0.5 and 0.9999 (0.95 for 95 %)")
    return value


def seed(text: str) -> int:
    value = _whole(text)
    if not 0 <= value < 2**32:
        raise argparse.ArgumentTypeError(f"{text} must be a whole number from 0 to 2^32 - 1")
    return value


def positive_int(text: str) -> int:
    value = _whole(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text} must be at least 1")
    return value


def taus(text: str):
    if text in ("all", "octave", "decade"):
        return text
    if "," in text or "." in text:
        try:
            values = [float(part) for part in text.split(",") if part.strip()]
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{text}' is not a list of seconds") from None
        if not values:
            raise argparse.ArgumentTypeError(f"'{text}' names no averaging time")
        if not all(math.isfinite(v) and v > 0 for v in values):
            raise argparse.ArgumentTypeError(f"'{text}': averaging times must be positive seconds")
        return values
    count = _whole(text) if text.strip().lstrip("+-").isdigit() else None
    if count is None:
        raise argparse.ArgumentTypeError(
            f"'{text}' is not 'all', 'octave', 'decade', a count or a list of seconds"
        )
    if not 2 <= count <= 10_000:
        raise argparse.ArgumentTypeError(f"{text}: ask for 2 to 10000 taus")
    return count


def scale(text: str) -> float | str:
    """``--scale``: a factor (``0.061``, ``1/131``) or the name of a sensor card."""
    numerator, slash, denominator = text.partition("/")
    try:
        value = float(numerator) / float(denominator) if slash else float(text)
    except ValueError:
        if any(ch.isdigit() for ch in numerator[:1]) or slash:
            raise argparse.ArgumentTypeError(
                f"'{text}' is neither a factor (0.061, 1/131) nor a sensor card's name"
            ) from None
        return text.strip()
    except ZeroDivisionError:
        raise argparse.ArgumentTypeError(f"'{text}' divides by zero") from None
    if not (math.isfinite(value) and value != 0):
        raise argparse.ArgumentTypeError(f"{text} must be a finite factor other than 0")
    return value


def column_names(text: str) -> list[str] | dict[str, list[str]]:
    """``--names a,b,c`` or ``--names VAR:a,b,c``."""
    variable, colon, rest = text.partition(":")
    if colon and "," not in variable and "[" not in variable:
        listed = rest
    else:
        variable, listed = None, text
    names = [part.strip() for part in listed.split(",")]
    if not all(names):
        raise argparse.ArgumentTypeError(f"'{text}': a name is empty")
    if len(set(names)) != len(names):
        raise argparse.ArgumentTypeError(f"'{text}' names a column twice")
    return {variable.strip(): names} if variable else names


def channel_units(text: str) -> dict[str, str]:
    """``--units``: each channel's unit, ``gyro_x=deg/s,acc_x=g``."""
    units = {}
    for part in text.split(","):
        name, equals, unit = (piece.strip() for piece in part.partition("="))
        if not (equals and name and unit):
            raise argparse.ArgumentTypeError(
                f"'{part.strip()}' is not CHANNEL=UNIT (e.g. gyro_x=deg/s,acc_x=g)"
            )
        if name in units:
            raise argparse.ArgumentTypeError(f"'{name}' is given two units")
        units[name] = unit
    return units


def three_columns(text: str) -> tuple[str, str, str]:
    names = tuple(part.strip() for part in text.split(","))
    if len(names) != 3 or not all(names):
        raise argparse.ArgumentTypeError(f"'{text}' must name three columns X,Y,Z")
    return names


def add_reading_arguments(group) -> None:
    """How a file is read and its channel scaled, for every command that reads recordings: a
    ROS bag's topic, raw counts' scale, a logger's lines before the header, the names of a
    headerless table's or an array's columns, and an N-D array's axes."""
    group.add_argument(
        "--topic",
        help="sensor_msgs/Imu topic of a ROS bag (default: its only one); its columns are "
        "time, bag_time, gyro_x/y/z [rad/s], acc_x/y/z [m/s^2]",
    )
    group.add_argument(
        "--scale",
        type=scale,
        metavar="FACTOR|SENSOR",
        help="multiply the channel by FACTOR (raw counts to --unit: 1/131 for 131 LSB per "
        "deg/s), or by the resolution a sensor card gives (bayescal sensors), which also "
        "sets the unit",
    )
    group.add_argument(
        "--skip-rows",
        type=row_count,
        default=0,
        metavar="N",
        help="text table: lines before the header to skip (logger metadata); lines that "
        "start with '#' are skipped anyway",
    )
    group.add_argument(
        "--names",
        type=column_names,
        metavar="[VAR:]A,B,...",
        help="names of the columns of a table without a header, or of the channels of an "
        "array (.npz/.npy/.mat; VAR: which array), e.g. t,gyro_x,gyro_y,gyro_z; a unit may "
        "follow in brackets, gyro_x[deg/s] (default: column_0 ..., or VAR_0 ...)",
    )
    group.add_argument(
        "--samples-axis",
        type=axis,
        metavar="K",
        help="array of two or more axes: the axis that holds the samples, from 0 (default: "
        "the longest)",
    )
    group.add_argument(
        "--channels-axis",
        type=axis,
        metavar="K",
        help="array of two or more axes: the axis that holds the channels (default: the last "
        "other axis); further axes become records, named NAME_rec0, NAME_rec1, ...",
    )


def add_recording_arguments(
    parser: argparse.ArgumentParser,
    *,
    channel: str = "one",
    file_optional: bool = False,
    window: bool = True,
    temperature: bool = False,
) -> None:
    """The recording and how to read it: the file, its channel(s) (``channel``: "one" for
    ``--channel``, "three" for ``--channels X,Y,Z``, "many" for ``--channels A,B,...``), the
    unit, the time base, gaps; with ``window``, the analysed window (``--start/--stop`` or
    ``--pad``); with ``temperature``, the temperature column.

    Over 80 lines: a list of argument declarations, one per option, each with its help.
    """
    group = parser.add_argument_group("recording")
    group.add_argument(
        "file",
        nargs="?" if file_optional else None,
        help="recording: a text table (.csv, .txt, .tsv: comma, semicolon, tab or space "
        "separated), .parquet, .npz, .npy, .mat (v4/5/7.3), or a ROS bag (.bag, .db3, .mcap "
        "or a ROS 2 bag folder)",
    )
    if channel == "one":
        group.add_argument("--channel", help="column to analyse, e.g. gyro_x")
    elif channel == "three":
        group.add_argument(
            "--channels",
            type=three_columns,
            required=True,
            metavar="X,Y,Z",
            help="the three accelerometer columns, e.g. acc_x,acc_y,acc_z",
        )
    else:
        group.add_argument(
            "--channels",
            help="comma-separated columns, e.g. gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z "
            "(default: every gyro and accelerometer column, found by name)",
        )
    group.add_argument(
        "--unit",
        help="unit of the channel (deg/s, rad/s, m/s^2, g, or a count unit such as LSB); "
        "default: from the header, e.g. gyro_x[deg/s]",
    )
    add_reading_arguments(group)
    group.add_argument(
        "--rate",
        type=rate,
        metavar="HZ",
        help="sample rate; samples are then taken as evenly spaced",
    )
    group.add_argument("--time-column", metavar="NAME", help="time column (default: time or t)")
    group.add_argument(
        "--time-unit", metavar="UNIT", help="unit of the time column (s, ms, us, ns)"
    )
    group.add_argument(
        "--gaps",
        choices=("error", "split"),
        default="error",
        help="on a gap in the time stamps: stop with an error (default) or "
        "analyse the segments without bridging it",
    )
    if temperature:
        group.add_argument(
            "--temperature", metavar="COL", help="temperature column (default: found by name)"
        )
    if not window:
        return
    group = parser.add_argument_group("window")
    group.add_argument(
        "--start",
        type=finite_float,
        metavar="S",
        help="start of the window, seconds from the first sample",
    )
    group.add_argument(
        "--stop",
        type=finite_float,
        metavar="S",
        help="end of the window, seconds from the first sample",
    )
    group.add_argument(
        "--pad",
        action="store_true",
        help="flight log: use the quiet window on the pad before liftoff",
    )
    group.add_argument(
        "--accel-columns",
        type=three_columns,
        metavar="X,Y,Z",
        help="accelerometer columns for --pad (default: found by name)",
    )
    group.add_argument(
        "--accel-unit",
        metavar="UNIT",
        help="unit of the accelerometer columns for --pad (g or m/s^2)",
    )


def reading_options(args) -> dict:
    """How the file is read, from the recording arguments (:func:`add_reading_arguments`)."""
    return {
        "topic": getattr(args, "topic", None),
        "skip_rows": getattr(args, "skip_rows", 0),
        "names": getattr(args, "names", None),
        "samples_axis": getattr(args, "samples_axis", None),
        "channels_axis": getattr(args, "channels_axis", None),
    }


def load(args, path=None):
    """The recording named by the arguments (``path`` instead of ``args.file`` when given)."""
    from ..recording._recording import load_recording

    path = path or args.file
    if not path:
        raise InputError("no recording given", fix="pass a FILE")
    return load_recording(path, **reading_options(args))


def unit_and_scale(args, name: str | None) -> tuple[str | None, float | None]:
    """The unit and scale factor of channel ``name``: its ``--units`` entry (``report``), else
    ``--unit``, and ``--scale`` as given, or, for ``--scale SENSOR``, the resolution of that
    sensor card's gyro or accelerometer (chosen by the unit, else by the channel's name) in
    that unit or in its own."""
    given = getattr(args, "scale", None)
    unit = (getattr(args, "units", None) or {}).get(name) or args.unit
    if not isinstance(given, str):
        return unit, given
    from ..recording._columns import is_accel_name, is_gyro_name
    from ..recording._sensor_cards import find_card
    from ..recording._units import parse_unit

    card = find_card(given)
    quantity = parse_unit(unit).quantity if unit else None
    if quantity is None and name is not None:
        if is_gyro_name(name) and not is_accel_name(name):
            quantity = "angular_rate"
        elif is_accel_name(name) and not is_gyro_name(name):
            quantity = "acceleration"
    section = {"angular_rate": "gyro", "acceleration": "accelerometer"}.get(quantity)
    if section is None:
        raise InputError(
            f"--scale {given}: is '{name}' a gyro or an accelerometer?",
            fix="pass --unit deg/s (or another rate) or --unit g (or another acceleration)",
        )
    entry = card.content.get(section, {}).get("resolution")
    if not isinstance(entry, dict) or "value" not in entry or "unit" not in entry:
        raise InputError(
            f"--scale {given}: the sensor card gives no [{section}] resolution",
            fix="pass the factor itself, e.g. --scale 1/131",
        )
    resolution = parse_unit(entry["unit"].replace("ug", "µg"))
    if not unit:
        return resolution.name, float(entry["value"])
    target = parse_unit(unit)
    return target.name, float(entry["value"]) * resolution.to_si / target.to_si


def grid_options(args, name: str | None = None) -> dict:
    """How channel ``name`` is read and put on its sample grid, from the recording
    arguments."""
    unit, factor = unit_and_scale(args, name)
    return {
        "unit": unit,
        "scale": factor,
        "rate_hz": args.rate,
        "time_column": args.time_column,
        "time_unit": args.time_unit,
        "gaps": getattr(args, "gaps", "error"),
    }


def window(args, recording) -> tuple[float | None, float | None, dict]:
    """The analysed window: ``--pad`` (the quiet pad window before liftoff), ``--start/--stop``
    or the whole record; and what to report of it."""
    if not getattr(args, "pad", False):
        start, stop = getattr(args, "start", None), getattr(args, "stop", None)
        chosen = "start/stop" if start is not None or stop is not None else "whole record"
        return start, stop, {"selected_by": chosen}
    if args.start is not None or args.stop is not None:
        raise InputError("use either --pad or --start/--stop, not both")
    from ..recording._pad import find_pad_window

    pad = find_pad_window(
        recording,
        accel_columns=args.accel_columns,
        accel_unit=args.accel_unit,
        time_column=args.time_column,
        time_unit=args.time_unit,
        rate_hz=args.rate,
    )
    return (
        pad.start_s,
        pad.stop_s,
        {
            "selected_by": "pad",
            "liftoff_s": pad.liftoff_s,
            "pad_level_g": pad.pad_level_g,
            "accel_columns": list(pad.accel_columns),
            "notes": list(pad.notes),
        },
    )


def channel_of(args, recording, name: str, **extra):
    """Column ``name`` of ``recording`` on its grid, in the window the arguments choose; the
    channel and the window's description."""
    start, stop, described = window(args, recording)
    channel = recording.channel(name, start=start, stop=stop, **grid_options(args, name), **extra)
    return channel, {"start_s": channel.start_s, "stop_s": channel.stop_s, **described}


def output_folder(path):
    """``--out DIR``: a folder that exists or whose parent does (checked before any work).
    :func:`declare_outputs` also makes it one of the run's outputs."""
    from .._output import check_folder

    return None if path is None else check_folder(path, "--out")


def declare_outputs(inputs=(), files: dict | None = None, folders: dict | None = None):
    """Before any work: the run's input files, its output files (argument -> path) and
    folders (argument -> path), checked — writable, no output an input or another output —
    and held by the run's :class:`~bayescal._output.Outputs` (which creates the folders now
    and removes them again if the run fails). Returns the folders as paths (None where not
    given), in the order given."""
    from .._output import Outputs

    outputs = Outputs.active() or Outputs()
    outputs.add_inputs(*inputs)
    for argument, path in (files or {}).items():
        if path is not None:
            outputs.claim(path, argument)
    made = []
    for argument, path in (folders or {}).items():
        made.append(outputs.folder(path, argument) if path is not None else None)
    return made


def gravity(latitude: float | None, height: float | None, given: str | None):
    """Local gravity from ``--g-local VALUE[±U]`` (m/s^2) or ``--latitude/--height``."""
    from ..classical._gravity import LocalGravity, local_gravity
    from ..recording._units import parse_measurement

    if given is not None:
        if latitude is not None:
            raise InputError("give --g-local or --latitude/--height, not both")
        try:
            value, uncertainty = parse_measurement(given)
        except ValueError:
            raise InputError(
                f"--g-local {given!r} is not VALUE or VALUE±UNCERTAINTY",
                fix="write it like 9.80123±0.00002",
            ) from None
        try:
            measured = LocalGravity.measured(value, uncertainty or 0.0)
        except InputError as error:
            raise InputError(f"--g-local {given!r}: {error.problem}", fix=error.fix) from None
        return LocalGravity(measured.value, measured.uncertainty, f"given: {given.strip()} m/s^2")
    if latitude is None:
        raise InputError(
            "local gravity needed", fix="pass --latitude DEG (and --height M) or --g-local VALUE±U"
        )
    return local_gravity(latitude, height or 0.0)


def require_acceleration(channel, command: str) -> None:
    """An accelerometer calibration needs a channel in a unit of acceleration (g, m/s^2 ...)
    or in counts; an angular rate or another physical unit is a mistake."""
    from ..recording._units import parse_unit

    quantity = parse_unit(channel.unit).quantity
    if quantity not in ("acceleration", "unknown"):
        raise InputError(
            f"{command} calibrates an accelerometer, and the unit {channel.unit} is a unit of "
            f"{quantity.replace('_', ' ')}, not of acceleration",
            source=channel.source,
            fix="pass --unit g or --unit m/s^2 (or a count unit such as LSB)",
        )


def require_bayesian_run(channel, alternative: str | None = None) -> None:
    """The Bayesian noise model reads the spectrum of gap-free runs longer than
    ``MIN_INCREMENTS`` samples: refuse a channel without one, before the model is built."""
    from ..models._whittle import MIN_INCREMENTS
    from ..recording._series import gap_free_runs

    runs = gap_free_runs(channel.values)
    longest = int(max(runs[:, 1] - runs[:, 0], default=0))
    if longest <= MIN_INCREMENTS:
        raise InputError(
            f"the Bayesian model needs a run of at least {MIN_INCREMENTS + 1} samples without "
            f"a gap, and the longest here has {longest}",
            source=channel.source,
            column=channel.channel,
            fix="record longer or widen the window"
            + (f", or {alternative}" if alternative else ""),
        )


def walker_note(used: int, requested: int) -> list[str]:
    """A note when the sampler ran more walkers (``used``) than ``--walkers`` asked for."""
    if used == requested:
        return []
    return [
        f"--walkers {requested} raised to {used}: emcee needs more than twice the model's "
        "parameters, in a multiple of the R-hat groups"
    ]


def health_exit(command: str, failures: list[str]) -> int:
    """1, after saying on stderr which checks failed, when any did; 0 otherwise."""
    if not failures:
        return 0
    print(f"bayescal {command}: HEALTH CHECK FAILED: " + "; ".join(failures), file=sys.stderr)
    return 1


def progress(args) -> bool:
    """A progress bar only on a terminal, and not with --quiet."""
    return not getattr(args, "quiet", False) and sys.stderr.isatty()


def sampler(args, *, bar: bool = True):
    """The :class:`~bayescal.Sampler` of a command: ``--walkers`` and ``--max-steps`` where it
    has them (else the defaults), and a progress bar as :func:`progress` says (none with
    ``bar=False``)."""
    from ..inference._sampler import Sampler

    settings = {"progress": bar and progress(args)}
    if getattr(args, "walkers", None) is not None:
        settings["n_walkers"] = args.walkers
    if getattr(args, "max_steps", None) is not None:
        settings["max_steps"] = args.max_steps
    return Sampler(**settings)


def parse_sections(text: str, form: str = "START:STOP,START:STOP,...") -> list[tuple[float, float]]:
    """``--sections T0:T1,T0:T1,...`` in seconds from the first sample, each ending after it
    starts; ``form`` is how the command writes them, for the message."""
    sections = []
    for part in text.split(","):
        try:
            start, stop = (float(x) for x in part.split(":"))
        except ValueError:
            start = stop = math.nan
        if not (math.isfinite(start) and math.isfinite(stop)):
            raise InputError(
                f"--sections {text!r}: cannot read {part.strip()!r}",
                fix=f"write {form} in seconds from the first sample",
            )
        if not stop > start:
            raise InputError(f"--sections: {part.strip()} ends before it starts")
        sections.append((start, stop))
    return sections
