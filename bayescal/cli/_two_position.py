"""``bayescal two-position``: scale and offset of one accelerometer axis from an up and a down
section."""

import numpy as np

from .._errors import InputError
from ._arguments import (
    add_recording_arguments,
    confidence,
    declare_outputs,
    gravity,
    grid_options,
    health_exit,
    height,
    latitude,
    load,
    parse_sections,
    require_acceleration,
    sampler,
    seed,
)


def add_parser(commands) -> None:
    parser = commands.add_parser(
        "two-position",
        help="accelerometer scale and offset from an up and a down section",
        description="Two-position calibration of one accelerometer axis: classical (means, "
        "span, scale 2 g/span, offset) and Bayesian, with local gravity from latitude and height.",
    )
    add_recording_arguments(parser, file_optional=True, window=False)
    parser.add_argument("--up", metavar="FILE", help="recording of the axis pointing up")
    parser.add_argument("--down", metavar="FILE", help="recording of the axis pointing down")
    parser.add_argument(
        "--sections",
        metavar="U0:U1,D0:D1",
        help="up and down sections of FILE in seconds (default: found)",
    )
    parser.add_argument("--latitude", type=latitude, metavar="DEG", help="geodetic latitude")
    parser.add_argument("--height", type=height, metavar="M", help="height above the ellipsoid")
    parser.add_argument("--g-local", metavar="VALUE[±U]", help="local gravity in m/s^2 instead")
    parser.add_argument("--confidence", type=confidence, default=0.95)
    parser.add_argument(
        "--terms",
        default="white,bias_instability,rate_random_walk",
        help="noise terms of the Bayesian model (as for noise)",
    )
    parser.add_argument("--seed", type=seed, default=0)
    parser.add_argument("--classical-only", action="store_true")
    parser.add_argument("--quiet", action="store_true")
    parser.add_argument("--json", metavar="PATH")
    parser.set_defaults(run=run)


def _sections(args):
    """The up and down sections, where they came from, and the time between their starts
    (known only when both are in one file)."""
    from ..classical._two_position import Section, sections_from_channel
    from ..recording._columns import find_accelerometer_columns

    if args.file and (args.up or args.down):
        raise InputError("give one FILE or --up and --down, not both")
    if args.file:
        recording = load(args)
        channel = recording.channel(args.channel, at_rest=False, **grid_options(args, args.channel))
        require_acceleration(channel, "two-position")
        columns = find_accelerometer_columns(recording)
        still_on = None
        if (
            columns
            and not np.isnan(channel.values).any()
            and channel.values.size == recording.n_rows
        ):
            still_on = np.column_stack([recording.columns[name] for name in columns])
            # The other axes only help to find the still stretches (the channel is checked
            # on reading, they are not): one not finite, and the channel judges alone.
            if not np.isfinite(still_on).all():
                still_on = None
        up, down, found_by = sections_from_channel(channel, still_on, args.sections)
        return up, down, found_by, down.start_s - up.start_s, channel
    if not (args.up and args.down):
        missing = "--down" if args.up else "--up"
        raise InputError(
            f"one section is missing: no {missing} recording",
            fix="give --up FILE and --down FILE, or one FILE holding both",
        )
    up_channel, down_channel = (
        load(args, path).channel(args.channel, **grid_options(args, args.channel))
        for path in (args.up, args.down)
    )
    require_acceleration(up_channel, "two-position")
    if (
        abs(up_channel.rate_hz / down_channel.rate_hz - 1) > 0.01
        or up_channel.unit != down_channel.unit
    ):
        raise InputError(
            f"--up and --down differ: {up_channel.rate_hz:g} Hz {up_channel.unit} "
            f"against {down_channel.rate_hz:g} Hz {down_channel.unit}",
            fix="record both positions with the same settings",
        )
    up, down = (
        Section(channel.values, channel.start_s, channel.source)
        for channel in (up_channel, down_channel)
    )
    return up, down, "--up and --down files", None, up_channel


def check_sections(text: str | None) -> None:
    """``--sections U0:U1,D0:D1``: two windows in seconds, each ending after it starts."""
    if text is None:
        return
    sections = parse_sections(text, form="U0:U1,D0:D1")
    if len(sections) != 2:
        raise InputError(
            f"--sections {text!r} gives {len(sections)} section(s)",
            fix="give two: the up and the down section, U0:U1,D0:D1",
        )


def run(args) -> int:
    from .._output import write_json
    from ..models._terms import parse_terms

    if not args.channel:
        raise InputError("--channel is required", fix="name the accelerometer column, e.g. acc_z")
    parse_terms(args.terms)
    check_sections(args.sections)
    declare_outputs([args.file, args.up, args.down], {"--json": args.json})
    local = gravity(args.latitude, args.height, args.g_local)
    up, down, found_by, gap_s, channel = _sections(args)
    # The analysis's modules load once the input is known to be good.
    from ..capabilities._two_position import calibrate_two_position
    from ..report._two_position import two_position_result, two_position_text

    calibration = calibrate_two_position(
        up,
        down,
        channel.rate_hz,
        gravity=local,
        unit=channel.unit,
        channel=args.channel,
        gap_s=gap_s,
        terms=args.terms,
        confidence=args.confidence,
        bayesian=not args.classical_only,
        seed=args.seed,
        sampler=sampler(args),
    )
    result = two_position_result(calibration, found_by)
    if args.json:
        write_json(args.json, result)
    print(two_position_text(calibration, found_by))
    failures = list(calibration.failures)
    return health_exit("two-position", failures)
