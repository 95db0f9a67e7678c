"""``bayescal multi-position``: scale, offset and misalignment of a three-axis accelerometer
from many still poses."""

from .._errors import InputError
from ..recording._sections import MIN_DURATION_S as MIN_STILL_S
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
    positive_float,
    sampler,
    seed,
)


def add_parser(commands) -> None:
    parser = commands.add_parser(
        "multi-position",
        help="accelerometer scale, offset and misalignment from many static poses",
        description="Multi-position calibration of a three-axis accelerometer: per-axis scale, "
        "offset and the three misalignment angles from still poses, by gravity's magnitude "
        "alone (free orientations, imu_tk; 10 or more poses in 9 or more orientations) or with "
        "the six faces of a cube (six-face, Ferraris); classical least squares and Bayesian.",
    )
    add_recording_arguments(parser, channel="three", window=False)
    parser.add_argument(
        "--sections",
        metavar="T0:T1,...",
        help="the still poses in seconds from the first sample (default: found)",
    )
    parser.add_argument(
        "--min-still",
        type=positive_float,
        default=MIN_STILL_S,
        metavar="SECONDS",
        help=f"the shortest stillness that counts as a pose when the poses are found "
        f"(default {MIN_STILL_S:g} s; a hand-held session may need 1)",
    )
    parser.add_argument(
        "--orientations",
        default="free",
        help="free: any orientations, gravity's magnitude only (default); six-face: each pose "
        "on a face of a cube, every face at least once",
    )
    parser.add_argument("--latitude", type=latitude, metavar="DEG", help="geodetic latitude")
    parser.add_argument("--height", type=height, metavar="M", help="height above the ellipsoid")
    parser.add_argument("--g-local", metavar="VALUE[±U]", help="local gravity in m/s^2 instead")
    parser.add_argument("--confidence", type=confidence, default=0.95)
    parser.add_argument("--seed", type=seed, default=0)
    parser.add_argument("--classical-only", action="store_true", help="skip the Bayesian model")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--json", metavar="PATH", help="write the result as JSON")
    parser.set_defaults(run=run)


def _read(args):
    """The three channels on one time base: (values (n, 3), the first channel, notes)."""
    import numpy as np

    recording = load(args)
    if len(set(args.channels)) != len(args.channels):
        raise InputError(
            f"--channels {','.join(args.channels)} names a column twice",
            fix="name the three axes, e.g. acc_x,acc_y,acc_z",
        )
    channels = [
        recording.channel(name, at_rest=False, **grid_options(args, name)) for name in args.channels
    ]
    units = {channel.unit for channel in channels}
    if len(units) > 1:
        listed = ", ".join(f"{channel.channel} [{channel.unit}]" for channel in channels)
        raise InputError(
            f"the channels have different units: {listed}",
            source=recording.source,
            fix="give the unit of all three with --unit",
        )
    notes = list(dict.fromkeys(note for channel in channels for note in channel.notes))
    return np.column_stack([channel.values for channel in channels]), channels[0], notes


def run(args) -> int:
    """``bayescal multi-position``: 0 success, 1 a failed posterior health check, 2 bad input."""
    from .._output import write_json

    if args.orientations not in ("free", "six-face"):
        raise InputError(
            f"--orientations {args.orientations!r} is not known", fix="choose free or six-face"
        )
    declare_outputs([args.file], {"--json": args.json})
    local = gravity(args.latitude, args.height, args.g_local)
    sections = parse_sections(args.sections) if args.sections else None
    values, first, notes = _read(args)
    # The analysis's modules load once the input is known to be good.
    from ..capabilities._multi_position import calibrate_multi_position
    from ..report._multi_position import multi_position_result, multi_position_text

    try:
        calibration = calibrate_multi_position(
            values,
            first.rate_hz,
            gravity=local,
            unit=first.unit,
            orientations=args.orientations,
            sections=sections,
            min_still_s=args.min_still,
            start_s=first.start_s,
            confidence=args.confidence,
            bayesian=not args.classical_only,
            seed=args.seed,
            sampler=sampler(args),
        )
    except InputError as error:
        raise InputError(error.problem, source=first.source, fix=error.fix) from None
    result = multi_position_result(
        calibration, source=first.source, channels=args.channels, notes=notes
    )
    if args.json:
        write_json(args.json, result)
    print(multi_position_text(calibration, channels=args.channels, notes=notes))
    failures = [] if calibration.passed else list(calibration.bayesian.diagnostics.failures)
    return health_exit("multi-position", failures)
