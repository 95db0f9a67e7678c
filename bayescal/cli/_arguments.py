"""Arguments every command shares: value types that check themselves, the recording and its
window, the output folder, local gravity, and the one exit for a failed health check."""

import argparse
import math
import sys

from .._errors import InputError


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"{text} must be a positive number")
    return value


def confidence(text: str) -> float:
    value = positive_float(text)
    if not value < 1:
        raise argparse.ArgumentTypeError(f"{text} must lie between 0 and 1 (0.95 for 95 %)")
    return value


def seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if not 0 <= value < 2**32:
        raise argparse.ArgumentTypeError(f"{text} must be a whole number from 0 to 2^32 - 1")
    return value


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
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
        return values
    try:
        count = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"'{text}' is not 'all', 'octave', 'decade', a count or a list of seconds"
        ) from None
    if count < 2:
        raise argparse.ArgumentTypeError(f"{text}: ask for at least 2 taus")
    return count


def three_columns(text: str) -> tuple[str, str, str]:
    names = tuple(part.strip() for part in text.split(","))
    if len(names) != 3 or not all(names):
        raise argparse.ArgumentTypeError(f"'{text}' must name three columns X,Y,Z")
    return names


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
    ``--pad``); with ``temperature``, the temperature column."""
    group = parser.add_argument_group("recording")
    group.add_argument(
        "file",
        nargs="?" if file_optional else None,
        help="recording: .csv, .parquet or .npz, or a ROS bag (.bag, .db3, .mcap or a ROS 2 "
        "bag folder)",
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
        "--topic",
        help="sensor_msgs/Imu topic of a ROS bag (default: its only one); its columns are "
        "time, bag_time, gyro_x/y/z [rad/s], acc_x/y/z [m/s^2]",
    )
    group.add_argument(
        "--unit",
        help="unit of the channel (deg/s, rad/s, m/s^2, g, or a count unit such as LSB); "
        "default: from the header, e.g. gyro_x[deg/s]",
    )
    group.add_argument(
        "--rate",
        type=positive_float,
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
        type=float,
        metavar="S",
        help="start of the window, seconds from the first sample",
    )
    group.add_argument(
        "--stop", type=float, metavar="S", help="end of the window, seconds from the first sample"
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


def load(args, path=None):
    """The recording named by the arguments (``path`` instead of ``args.file`` when given)."""
    from ..recording._recording import load_recording

    path = path or args.file
    if not path:
        raise InputError("no recording given", fix="pass a FILE")
    return load_recording(path, topic=getattr(args, "topic", None))


def grid_options(args) -> dict:
    """How a channel is put on its sample grid, from the recording arguments."""
    return {
        "unit": args.unit,
        "rate": args.rate,
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
        rate=args.rate,
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
    channel = recording.channel(name, start=start, stop=stop, **grid_options(args), **extra)
    return channel, {"start_s": channel.start_s, "stop_s": channel.stop_s, **described}


def output_folder(path):
    """``--out DIR``: a folder that exists or whose parent does (checked before any work)."""
    from pathlib import Path

    if path is None:
        return None
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"--out {folder}: exists and is not a folder", fix="choose a folder")
    if not folder.parent.is_dir():
        raise InputError(
            f"--out {folder}: folder '{folder.parent}' does not exist",
            fix="create it or choose another path",
        )
    return folder


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


def health_exit(command: str, failures: list[str]) -> int:
    """1, after saying on stderr which checks failed, when any did; 0 otherwise."""
    if not failures:
        return 0
    print(f"bayescal {command}: HEALTH CHECK FAILED: " + "; ".join(failures), file=sys.stderr)
    return 1


def progress(args) -> bool:
    """A progress bar only on a terminal, and not with --quiet."""
    return not getattr(args, "quiet", False) and sys.stderr.isatty()
