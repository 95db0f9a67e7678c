"""The ``bayescal`` command line.

Exit codes (../shared/DESIGN.md): 0 success, 1 an analysis ran but a health check failed,
2 bad input or usage, 3 an internal error (a bug: please report it; set BAYESCAL_DEBUG=1
to see the traceback).
"""

import argparse
import os
import sys

import numpy as np

from ._errors import BayescalError, InputError

INTERNAL_ERROR = 3


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}; see '{self.prog} --help'\n")


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"{text} must be positive")
    return value


def _confidence(text: str) -> float:
    value = _positive_float(text)
    if not value < 1:
        raise argparse.ArgumentTypeError(f"{text} must lie between 0 and 1 (0.95 for 95 %)")
    return value


def _taus(text: str):
    if text in ("all", "octave", "decade"):
        return text
    if "," in text or "." in text:
        try:
            return [float(part) for part in text.split(",") if part.strip()]
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{text}' is not a list of seconds") from None
    try:
        count = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"'{text}' is not 'all', 'octave', 'decade', a count or a list of seconds"
        ) from None
    if count < 2:
        raise argparse.ArgumentTypeError(f"{text}: ask for at least 2 taus")
    return count


def _columns(text: str) -> tuple[str, str, str]:
    names = tuple(part.strip() for part in text.split(","))
    if len(names) != 3 or not all(names):
        raise argparse.ArgumentTypeError(f"'{text}' must name three columns X,Y,Z")
    return names


def _add_recording_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("recording")
    group.add_argument(
        "file",
        nargs="?",
        help="recording: .csv, .parquet or .npz, or a ROS bag (.bag, .db3, .mcap or a ROS 2 "
        "bag folder)",
    )
    group.add_argument("--channel", help="column to analyse, e.g. gyro_x")
    group.add_argument(
        "--topic",
        help="sensor_msgs/Imu topic of a ROS bag (default: its only one); its columns are "
        "time, bag_time, gyro_x/y/z [rad/s], acc_x/y/z [m/s^2]",
    )
    group.add_argument(
        "--unit",
        help="unit of the channel (deg/s, rad/s, m/s^2, g ...); "
        "default: from the header, e.g. gyro_x[deg/s]",
    )
    group.add_argument(
        "--rate",
        type=_positive_float,
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
    window = parser.add_argument_group("window")
    window.add_argument(
        "--start",
        type=float,
        metavar="S",
        help="start of the window, seconds from the first sample",
    )
    window.add_argument(
        "--stop", type=float, metavar="S", help="end of the window, seconds from the first sample"
    )
    window.add_argument(
        "--pad",
        action="store_true",
        help="flight log: use the quiet window on the pad before liftoff",
    )
    window.add_argument(
        "--accel-columns",
        type=_columns,
        metavar="X,Y,Z",
        help="accelerometer columns for --pad (default: found by name)",
    )
    window.add_argument(
        "--accel-unit",
        metavar="UNIT",
        help="unit of the accelerometer columns for --pad (g or m/s^2)",
    )


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="bayescal",
        description="Bayesian uncertainty quantification of "
        "inertial sensors. Run 'bayescal noise --example' to try it.",
    )
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    noise = commands.add_parser(
        "noise",
        help="noise of one static channel: bias, Allan deviation, IEEE 952 terms",
        description="Classical noise analysis of one static channel: bias with its Student-t "
        "interval and a check of its validity, Allan deviation with chi-square intervals, "
        "and the IEEE Std 952 slope readings of Q, N, B and K.",
    )
    _add_recording_arguments(noise)
    noise.add_argument(
        "--example",
        action="store_true",
        help="analyse a built-in simulated gyro recording instead of a file",
    )
    noise.add_argument("--seed", type=int, default=0, help="seed of the --example recording")
    noise.add_argument(
        "--confidence",
        type=_confidence,
        default=0.95,
        help="confidence of every interval (default 0.95)",
    )
    noise.add_argument(
        "--taus",
        type=_taus,
        default="octave",
        help="averaging times: octave (default), decade, all, a number of "
        "log-spaced taus, or seconds such as 0.1,1,10",
    )
    noise.add_argument("--json", metavar="PATH", help="write the result as JSON")
    noise.add_argument(
        "--export",
        nargs=2,
        action="append",
        metavar=("FORMAT", "PATH"),
        help="also write the channel's noise for another tool: kalibr (imu.yaml) or matlab "
        "(gyroparams/accelparams script); a file already at PATH keeps the other sensor's "
        "entries (repeatable)",
    )
    bayes = noise.add_argument_group("Bayesian model")
    bayes.add_argument(
        "--terms",
        default="white,bias_instability,rate_random_walk",
        help="noise terms beside the bias: white, bias_instability (flicker), "
        "rate_random_walk (rrw), quantization, rate_ramp (ramp), or all "
        "(default: white,bias_instability,rate_random_walk)",
    )
    bayes.add_argument(
        "--sensor",
        metavar="NAME",
        help="use a sensor card's datasheet figures as priors (bayescal sensors)",
    )
    bayes.add_argument(
        "--out", metavar="DIR", help="write the posterior (ArviZ netCDF) and the JSON into DIR"
    )
    bayes.add_argument("--walkers", type=int, default=32, help="emcee walkers (default 32)")
    bayes.add_argument(
        "--max-steps",
        type=int,
        default=40_000,
        help="most emcee steps before the convergence check fails",
    )
    bayes.add_argument("--classical-only", action="store_true", help="skip the Bayesian model")
    bayes.add_argument("--quiet", action="store_true", help="no progress bar")
    noise.set_defaults(run=_run_noise)
    two = commands.add_parser(
        "two-position",
        help="accelerometer scale and offset from an up and a down section",
        description="Two-position calibration of one accelerometer axis: classical (means, "
        "span, scale 2 g/span, offset) and Bayesian, with local gravity from latitude and height.",
    )
    two.add_argument("file", nargs="?", help="one recording holding both positions")
    two.add_argument("--up", metavar="FILE", help="recording of the axis pointing up")
    two.add_argument("--down", metavar="FILE", help="recording of the axis pointing down")
    two.add_argument(
        "--sections",
        metavar="U0:U1,D0:D1",
        help="up and down sections of FILE in seconds (default: found)",
    )
    two.add_argument("--channel", required=True, help="accelerometer column, e.g. acc_z")
    two.add_argument("--unit", help="unit of the channel (m/s^2, g, or a count unit such as LSB)")
    two.add_argument("--rate", type=_positive_float, metavar="HZ")
    two.add_argument("--time-column", metavar="NAME")
    two.add_argument("--time-unit", metavar="UNIT")
    two.add_argument("--latitude", type=float, metavar="DEG", help="geodetic latitude")
    two.add_argument("--height", type=float, metavar="M", help="height above the ellipsoid")
    two.add_argument("--g-local", metavar="VALUE[±U]", help="local gravity in m/s^2 instead")
    two.add_argument("--confidence", type=_confidence, default=0.95)
    two.add_argument(
        "--terms",
        default="white,bias_instability,rate_random_walk",
        help="noise terms of the Bayesian model (as for noise)",
    )
    two.add_argument("--seed", type=int, default=0)
    two.add_argument("--classical-only", action="store_true")
    two.add_argument("--quiet", action="store_true")
    two.add_argument("--json", metavar="PATH")
    two.set_defaults(run=_run_two_position)
    from . import _multi_position_command, _thermal_command

    _thermal_command.add_parser(commands)
    from . import _report_command

    _report_command.add_parser(commands)
    _multi_position_command.add_parser(commands)
    from . import _discover_command

    _discover_command.add_parser(commands)
    sensors = commands.add_parser("sensors", help="list the sensor cards (datasheet priors)")
    sensors.set_defaults(run=_run_sensors)
    return parser


def _load(args):
    from ._examples import example_table
    from ._recording import load_table

    if getattr(args, "example", False):
        if args.file:
            raise InputError("give a FILE or --example, not both")
        return example_table(args.seed), args.channel or "gyro_x"
    if not args.file:
        raise InputError("no recording given", fix="pass a FILE, or --example to try bayescal")
    if not args.channel:
        raise InputError(
            "--channel is required",
            source=args.file,
            fix="name the column to analyse, e.g. --channel gyro_x",
        )
    return load_table(args.file, topic=getattr(args, "topic", None)), args.channel


def _window(args, table) -> tuple[float | None, float | None, dict]:
    from ._pad import find_pad_window

    if args.pad:
        if args.start is not None or args.stop is not None:
            raise InputError("use either --pad or --start/--stop, not both")
        pad = find_pad_window(
            table,
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
    selected = "start/stop" if args.start is not None or args.stop is not None else "whole record"
    return args.start, args.stop, {"selected_by": selected}


def _run_noise(args) -> int:
    from ._classical import classical_noise
    from ._export import plan_exports, write_exports
    from ._noise_command import noise_result, noise_text
    from ._noise_fit import parse_terms
    from ._output import check_writable, write_json
    from ._recording import prepare_channel

    terms = parse_terms(args.terms)
    out_folder = _output_folder(args.out)
    if args.json:
        check_writable(args.json, "--json")
    table, channel = _load(args)
    start, stop, window = _window(args, table)
    data = prepare_channel(
        table,
        channel,
        unit=args.unit,
        rate=args.rate,
        time_column=args.time_column,
        time_unit=args.time_unit,
        start=start,
        stop=stop,
        gaps=args.gaps,
    )
    exports = plan_exports(
        args.export, data.unit, channel, data.source, getattr(table, "topic", None)
    )
    window = {"start_s": data.start_s, "stop_s": data.stop_s, **window}
    try:
        classical = classical_noise(
            data.values, data.rate_hz, confidence=args.confidence, taus=args.taus
        )
    except InputError as error:
        raise InputError(error.problem, source=data.source, column=channel, fix=error.fix) from None
    fit = None if args.classical_only else _fit(args, data, classical, terms)
    result = noise_result(data, classical, window, fit)
    result["notes"] = window.pop("notes", []) + result["notes"]
    if args.json:
        write_json(args.json, result)
    exported = write_exports(exports, result)
    if out_folder is not None:
        _write_folder(out_folder, result, fit, data)
    print(noise_text(result))
    for line in exported:
        print(line)
    if fit is not None and not fit.diagnostics.passed:
        print(
            f"bayescal noise: HEALTH CHECK FAILED for {data.channel}: "
            + "; ".join(fit.diagnostics.failures),
            file=sys.stderr,
        )
        return 1
    return 0


def _output_folder(path):
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


def _fit(args, data, classical, terms):
    from ._noise_fit import fit_noise
    from ._sensors import card_prior, find_card

    prior = None
    if args.sensor:
        prior = card_prior(find_card(args.sensor), terms, data.unit, classical.allan)
    progress = not args.quiet and sys.stderr.isatty()
    return fit_noise(
        data.values,
        data.rate_hz,
        classical.allan,
        terms=terms,
        prior=prior,
        seed=args.seed,
        n_walkers=args.walkers,
        max_steps=args.max_steps,
        progress=progress,
    )


def _write_folder(folder, result, fit, data) -> None:
    from ._output import write_json
    from ._posterior_data import noise_datatree, write_netcdf

    folder.mkdir(exist_ok=True)
    stem = f"noise_{data.channel}"
    if fit is not None:
        tree = noise_datatree(fit, data.unit, channel=data.channel, source=data.source)
        write_netcdf(tree, folder / f"{stem}_posterior.nc")
    write_json(folder / f"{stem}.json", result)


def _read_channel(path, args):
    from ._recording import load_table, prepare_channel

    table = load_table(path)
    return table, prepare_channel(
        table,
        args.channel,
        unit=args.unit,
        rate=args.rate,
        time_column=args.time_column,
        time_unit=args.time_unit,
    )


def _run_two_position(args) -> int:
    from ._gravity import local_gravity
    from ._noise_fit import parse_terms
    from ._output import check_writable, write_json
    from ._pad import find_accelerometer_columns
    from ._two_position import (
        Section,
        bayesian_two_position,
        check_sections,
        classical_two_position,
    )
    from ._two_position_command import sections_from_file, two_position_result, two_position_text

    terms = parse_terms(args.terms)
    if args.json:
        check_writable(args.json, "--json")
    gravity = local_gravity(args.latitude, args.height, args.g_local)
    if args.file and (args.up or args.down):
        raise InputError("give one FILE or --up and --down, not both")
    if args.file:
        table, data = _read_channel(args.file, args)
        columns = find_accelerometer_columns(table)
        still_on = None
        if columns and not np.isnan(data.values).any() and data.values.size == table.n_rows:
            still_on = np.column_stack([table.columns[name] for name in columns])
        up, down, found_by = sections_from_file(data, still_on, args.sections)
        gap_s = down.start_s - up.start_s
        rate, unit = data.rate_hz, data.unit
    else:
        if not (args.up and args.down):
            missing = "--down" if args.up else "--up"
            raise InputError(
                f"one section is missing: no {missing} recording",
                fix="give --up FILE and --down FILE, or one FILE holding both",
            )
        _, up_data = _read_channel(args.up, args)
        _, down_data = _read_channel(args.down, args)
        if abs(up_data.rate_hz / down_data.rate_hz - 1) > 0.01 or up_data.unit != down_data.unit:
            raise InputError(
                f"--up and --down differ: {up_data.rate_hz:g} Hz {up_data.unit} "
                f"against {down_data.rate_hz:g} Hz {down_data.unit}",
                fix="record both positions with the same settings",
            )
        up = Section(up_data.values, up_data.start_s, up_data.source)
        down = Section(down_data.values, down_data.start_s, down_data.source)
        found_by, gap_s = "--up and --down files", None
        rate, unit = up_data.rate_hz, up_data.unit
    check_sections(up, down, unit, args.channel)
    classical = classical_two_position(up.values, down.values, gravity, args.confidence)
    bayesian = None
    if not args.classical_only:
        bayesian = bayesian_two_position(
            up,
            down,
            rate,
            gravity,
            terms=terms,
            gap_s=gap_s,
            seed=args.seed,
            progress=not args.quiet and sys.stderr.isatty(),
        )
    result = two_position_result(
        args.channel, unit, rate, up, down, found_by, gravity, args.confidence, classical, bayesian
    )
    if args.json:
        write_json(args.json, result)
    print(two_position_text(result))
    if bayesian is not None and not bayesian.noise.diagnostics.passed:
        print(
            "bayescal two-position: HEALTH CHECK FAILED: "
            + "; ".join(bayesian.noise.diagnostics.failures),
            file=sys.stderr,
        )
        return 1
    return 0


def _run_sensors(args) -> int:
    from ._sensors import sensor_cards

    for card in sensor_cards():
        sections = [name for name in ("gyro", "accelerometer") if name in card.content]
        print(
            f"{card.name:<14} {card.content.get('grade', ''):<18} {'+'.join(sections):<20} "
            f"{card.datasheet}"
        )
    return 0


def _enable_compilation_cache() -> None:
    """Keep JAX's compiled functions between runs (a second run starts in a second)."""
    from pathlib import Path

    import jax

    root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    folder = root / "bayescal" / "jax"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return
    jax.config.update("jax_compilation_cache_dir", str(folder))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.2)


def _command(args) -> str:
    return " ".join(part for part in (args.command, getattr(args, "step", None)) if part)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    _enable_compilation_cache()
    try:
        return args.run(args)
    except BayescalError as error:
        print(f"bayescal {_command(args)}: error: {error}", file=sys.stderr)
        return error.exit_code
    except Exception as error:
        if os.environ.get("BAYESCAL_DEBUG"):
            raise
        print(
            f"bayescal {_command(args)}: internal error (a bug, please report it): "
            f"{type(error).__name__}: {error}; set BAYESCAL_DEBUG=1 for the traceback",
            file=sys.stderr,
        )
        return INTERNAL_ERROR


if __name__ == "__main__":
    sys.exit(main())
