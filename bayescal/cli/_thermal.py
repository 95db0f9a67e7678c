"""``bayescal thermal fit | update | compensate | infield``: the thermal bias of a gyro, and its
in-field update from a strapdown system's own alignment."""

import math
import sys

import numpy as np

from .._errors import InputError
from ._arguments import (
    add_recording_arguments,
    confidence,
    declare_outputs,
    finite_float,
    grid_options,
    health_exit,
    height,
    latitude,
    load,
    require_bayesian_run,
    sampler,
    seed,
    unit_and_scale,
)

NOISE_TERMS = "white,bias_instability,rate_random_walk"
MAX_DEGREE = 4


def add_parser(commands) -> None:
    thermal = commands.add_parser(
        "thermal", help="thermal bias of a gyro: fit, update, compensate, update in the field"
    )
    steps = thermal.add_subparsers(dest="step", required=True, parser_class=type(thermal))

    def recording(parser):
        add_recording_arguments(parser, window=False, temperature=True)

    fit = steps.add_parser("fit", help="fit a thermal bias polynomial")
    recording(fit)
    fit.add_argument("--degree", default="auto", help="polynomial degree, or auto (default)")
    fit.add_argument(
        "--reference",
        type=finite_float,
        metavar="T0",
        help="reference temperature (default: the middle of the range)",
    )
    fit.add_argument(
        "--terms",
        default=NOISE_TERMS,
        help="noise terms beside the thermal bias (as for noise; no ramp)",
    )
    fit.add_argument(
        "--latitude", type=latitude, metavar="DEG", help="take the Earth rate off (with --axis)"
    )
    fit.add_argument(
        "--axis",
        default="up",
        help="direction of the gyro axis: up, down, north, "
        "south, east, west or east,north,up components (default up)",
    )
    fit.add_argument("--confidence", type=confidence, default=0.95)
    fit.add_argument("--seed", type=seed, default=0)
    fit.add_argument("--quiet", action="store_true")
    fit.add_argument("--json", metavar="PATH", required=True, help="calibration file to write")
    fit.set_defaults(run=run_fit)

    update = steps.add_parser("update", help="update a calibration with alignment data")
    recording(update)
    update.add_argument("--calibration", required=True, metavar="PATH")
    update.add_argument(
        "--offset-measurement",
        metavar="M±U[,M±U...]",
        help="the common offset of each alignment period, measured separately, "
        "in the channel's unit",
    )
    update.add_argument(
        "--periods",
        metavar="T0:T1,...",
        help="alignment periods in seconds (default: the record's gap-free runs)",
    )
    update.add_argument(
        "--drift",
        default="auto",
        metavar="S|auto",
        help="how far the bias may have moved since the calibration, in the channel's unit "
        "(about that much at T0, each polynomial term about that much at the edge of the "
        "calibrated range); auto (default) learns it from the data, 0 assumes no change",
    )
    update.add_argument("--latitude", type=latitude, metavar="DEG")
    update.add_argument("--axis", default="up")
    update.add_argument("--seed", type=seed, default=0)
    update.add_argument("--quiet", action="store_true")
    update.add_argument("--json", metavar="PATH", required=True, help="updated calibration file")
    update.set_defaults(run=run_update)

    compensate = steps.add_parser("compensate", help="subtract the thermal bias from the output")
    recording(compensate)
    compensate.add_argument("--calibration", required=True, metavar="PATH")
    compensate.add_argument("--out", required=True, metavar="CSV", help="compensated recording")
    compensate.set_defaults(run=run_compensate)
    _add_infield(steps)


def _add_infield(steps) -> None:
    infield = steps.add_parser(
        "infield",
        help="update every gyro's thermal calibration from a strapdown system's own alignment",
        description="The in-field update of US 5,527,003 at rest: the recording's body rates, "
        "specific forces and gyro temperatures during an extended alignment, mechanized and "
        "filtered; the north-projected bias and the thermal slopes are updated, the east level "
        "stays confounded with the heading error until a taxi tells the heading; the vertical gyro "
        "from the computed heading's turn over the park.",
    )
    add_recording_arguments(infield, channel="many", window=False, temperature=True)
    infield.add_argument(
        "--calibration",
        required=True,
        metavar="PATH",
        help="the old thermal calibration of the three gyros (one file of several channels)",
    )
    infield.add_argument(
        "--latitude", type=latitude, required=True, metavar="DEG", help="geodetic latitude"
    )
    infield.add_argument("--height", type=height, default=0.0, metavar="M")
    infield.add_argument(
        "--align",
        required=True,
        metavar="T0:T1",
        help="the still alignment window, seconds from the first sample (at least 300 s)",
    )
    infield.add_argument(
        "--taxi",
        metavar="T0:T1",
        help="the taxi after the park, seconds from the first sample: with --track-heading it "
        "tells the heading error, and so the east bias level",
    )
    infield.add_argument(
        "--track-heading",
        metavar="DEG[,DEG...]",
        help="the taxiway's known track heading, deg from north, one per straight leg",
    )
    infield.add_argument(
        "--positions",
        metavar="NORTH_COL,EAST_COL",
        help="a position reference (GNSS) in the taxi: the north and east position columns "
        "(latitude and longitude in deg or rad, or north and east in m, as the header says; "
        "empty where no fix); with --taxi it tells the heading error without a known track",
    )
    infield.add_argument(
        "--position-sd",
        type=finite_float,
        metavar="M",
        help="sd of a position fix's north and east error, m (default 2: a single GNSS receiver's)",
    )
    infield.add_argument(
        "--wander",
        metavar="SD:TAU",
        default="0.5:20",
        help="the vehicle's wander about the taxiway's centre line: its sd (m) and time "
        "constant (s) (default 0.5:20)",
    )
    infield.add_argument(
        "--accel-unit", metavar="UNIT", help="unit of the accelerometers (default m/s^2)"
    )
    infield.add_argument(
        "--accel-instability",
        type=finite_float,
        default=1e-5,
        metavar="M/S2",
        help="the accelerometers' bias instability, m/s^2 (default 1e-5: navigation grade)",
    )
    infield.add_argument(
        "--drift",
        default="auto",
        metavar="S|auto",
        help="how far each gyro's bias may have aged since the calibration, in the gyros' unit "
        "(a datasheet's bias repeatability, say); auto (default) learns it from the "
        "alignment, 0 assumes no aging",
    )
    infield.add_argument("--seed", type=seed, default=0)
    infield.add_argument("--quiet", action="store_true")
    infield.add_argument("--json", metavar="PATH", required=True, help="the result (JSON)")
    infield.add_argument(
        "--save", metavar="PATH", help="the updated calibrations of the three gyros (one file)"
    )
    infield.add_argument(
        "--report",
        metavar="PAGE.html",
        help="the update's page (self-contained HTML): the park and taxi track, the points "
        "before and after the heading correction, the old and updated calibrations, the 1 h "
        "free-inertial error each leaves",
    )
    infield.set_defaults(run=run_infield)


def _channel(args):
    """The gyro channel with its temperature on its grid, the temperature column and its
    unit."""
    from ..recording._columns import find_temperature_column, temperature_unit

    if not args.channel:
        raise InputError("--channel is required", fix="name the gyro column, e.g. --channel gyro_z")
    recording = load(args)
    column = find_temperature_column(recording, args.temperature)
    channel = recording.channel(
        args.channel, temperature=column, **grid_options(args, args.channel)
    )
    return channel, column, temperature_unit(recording, column)[0]


def _degree(text: str) -> int | str:
    if text == "auto":
        return text
    try:
        degree = int(text)
    except ValueError:
        degree = -1
    if not 0 <= degree <= MAX_DEGREE:
        raise InputError(f"--degree {text!r}", fix=f"give auto or a whole number 0..{MAX_DEGREE}")
    return degree


def run_fit(args) -> int:
    declare_outputs([args.file], {"--json": args.json})
    degree = _degree(args.degree)
    channel, column, temperature_in = _channel(args)
    require_bayesian_run(channel)
    # The analysis's modules load once the input is known to be good.
    from ..capabilities._thermal_fit import fit_thermal
    from ..report._thermal import thermal_text

    calibration = fit_thermal(
        channel.values,
        channel.temperature,
        channel.rate_hz,
        degree=degree,
        reference=args.reference,
        terms=args.terms,
        unit=channel.unit,
        temperature_unit=temperature_in,
        channel=channel.channel,
        latitude=args.latitude,
        axis=args.axis,
        confidence=args.confidence,
        seed=args.seed,
        source=channel.source,
        temperature_name=column,
        sampler=sampler(args),
    )
    calibration.save(args.json)
    print(thermal_text(calibration))
    return health_exit("thermal fit", [] if calibration.passed else calibration.failures)


def _parse_measurements(text: str | None, count: int) -> list:
    from ..recording._units import parse_measurement

    if not text:
        return [None] * count
    parsed = []
    for part in text.split(","):
        try:
            value, uncertainty = parse_measurement(part)
        except ValueError:
            value, uncertainty = math.nan, None
        if not (math.isfinite(value) and uncertainty and uncertainty > 0):
            raise InputError(
                f"--offset-measurement {part!r}",
                fix="write it like 0.002±0.001 (a value and a positive uncertainty)",
            )
        parsed.append((value, uncertainty))
    if len(parsed) == 1:
        parsed = parsed * count
    if len(parsed) != count:
        raise InputError(
            f"--offset-measurement gives {len(parsed)} values for {count} periods",
            fix="give one for all periods or one per period",
        )
    return parsed


def _periods(channel, given: str | None) -> tuple[tuple[int, int], ...]:
    from ..capabilities._thermal import gap_free_runs

    if not given:
        return gap_free_runs(channel.values)
    time = channel.time_s
    periods = []
    for part in given.split(","):
        try:
            start, stop = (float(x) for x in part.split(":"))
        except ValueError:
            raise InputError(f"--periods {given!r}", fix="write T0:T1,T0:T1 in seconds") from None
        keep = np.flatnonzero((time >= start) & (time < stop))
        if keep.size < 16:
            raise InputError(f"--periods: {part} holds {keep.size} samples", fix="widen it")
        periods.append((int(keep[0]), int(keep[-1]) + 1))
    return tuple(periods)


def _parse_drift(text: str) -> float | str | None:
    if text.strip().lower() == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise InputError(
            f"--drift {text!r}",
            fix="give auto, 0 (no change since the calibration) or a positive scale in the "
            "channel's unit",
        )
    return value or None


def _same_earth_rate(args, calibration, unit: str) -> None:
    """An update takes off the Earth rate its calibration took off; ``--latitude`` and
    ``--axis`` may only confirm it."""
    from ..models.effects.earth_rotation import earth_rate_on_axis

    given = earth_rate_on_axis(args.latitude, args.axis, unit)
    taken = (calibration.earth_rate or {}).get("value")
    if taken is None or not math.isclose(given, taken, rel_tol=1e-9, abs_tol=1e-15):
        had = f"{taken:.6g} {unit}" if taken is not None else "none"
        raise InputError(
            f"--latitude {args.latitude:g} --axis {args.axis}: an Earth rate of {given:.6g} "
            f"{unit}, but the calibration took off {had}",
            source=args.calibration,
            fix="leave --latitude and --axis out: the update takes off what its calibration did",
        )


def run_update(args) -> int:
    declare_outputs([args.file, args.calibration], {"--json": args.json})
    drift = _parse_drift(args.drift)
    channel, _, temperature_in = _channel(args)
    require_bayesian_run(channel)
    # The analysis's modules load once the input is known to be good.
    from ..capabilities._thermal import load_thermal_calibration
    from ..report._thermal import thermal_text

    calibration = load_thermal_calibration(
        args.calibration,
        unit=channel.unit,
        channel=channel.channel,
        temperature_unit=temperature_in,
    )
    if args.latitude is not None:
        _same_earth_rate(args, calibration, channel.unit)
    periods = _periods(channel, args.periods)
    updated = calibration.update(
        channel.values,
        channel.temperature,
        channel.rate_hz,
        periods=periods,
        offsets=_parse_measurements(args.offset_measurement, len(periods)),
        drift=drift,
        seed=args.seed,
        source=channel.source,
        sampler=sampler(args),
    )
    updated.save(args.json)
    print(thermal_text(updated))
    return health_exit("thermal update", [] if updated.passed else updated.failures)


def run_compensate(args) -> int:
    from .._output import write_csv
    from ..capabilities._thermal import load_thermal_calibration
    from ..recording._columns import find_temperature_column, temperature_unit
    from ..recording._recording import resolve_unit

    declare_outputs([args.file, args.calibration], {"--out": args.out})
    if not args.channel:
        raise InputError("--channel is required", fix="name the gyro column, e.g. --channel gyro_z")
    recording = load(args)
    column = find_temperature_column(recording, args.temperature)
    if column == args.channel:
        raise InputError(
            f"--temperature {column} names the compensated channel",
            source=recording.source,
            fix="name the temperature column",
        )
    unit, factor = unit_and_scale(args, args.channel)
    values = recording.require(args.channel, "channel")
    if factor is not None:
        values = values * factor
    unit, note = resolve_unit(recording, args.channel, unit)
    calibration = load_thermal_calibration(
        args.calibration,
        unit=unit,
        channel=args.channel,
        temperature_unit=temperature_unit(recording, column)[0],
    )
    temperature = recording.require(column, "temperature column")
    compensated, spread = calibration.compensate(values, temperature)
    warnings = [note] if note else []
    missing = ~(np.isfinite(values) & np.isfinite(temperature))
    if missing.any():
        first = int(np.flatnonzero(missing)[0]) + 1 + recording.row_offset
        warnings.append(
            f"{int(missing.sum())} row(s) lack the channel or the temperature (first: data row "
            f"{first}): their compensated value is left empty"
        )
    outside = calibration.outside_range(temperature)
    if outside.any():
        low, high = calibration.temperature_range
        distance = float(np.max(np.maximum(low - temperature, temperature - high)[outside]))
        warnings.append(
            f"{int(outside.sum())} samples ({100 * outside.mean():.3g}%) lie outside the "
            f"calibrated range [{low:.4g}, {high:.4g}] {calibration.temperature_unit}, by up to "
            f"{distance:.3g}: the polynomial is extrapolated there"
        )
    columns = list(recording.file_columns or recording.columns.items())
    columns += [
        (f"{args.channel}_compensated", compensated),
        (f"{args.channel}_compensated_sd", spread),
    ]
    write_csv(args.out, columns)
    for line in [*recording.notes, *warnings]:
        print(f"bayescal thermal compensate: note: {line}", file=sys.stderr)
    print(
        f"bayescal thermal compensate: wrote {args.out} ({values.size} rows, every column of "
        f"the recording; {args.channel} minus the thermal bias of {args.calibration}, with "
        "its sd)"
    )
    return 0


def _span(text: str, option: str) -> tuple[float, float]:
    try:
        start, stop = (float(part) for part in text.split(":"))
    except ValueError:
        start = stop = math.nan
    if not (math.isfinite(start) and math.isfinite(stop) and stop > start):
        raise InputError(f"{option} {text!r}", fix="write T0:T1 in seconds, T1 after T0")
    return start, stop


def _pair(text: str, option: str) -> tuple[float, float]:
    try:
        first, second = (float(part) for part in text.split(":"))
    except ValueError:
        raise InputError(f"{option} {text!r}", fix="write two numbers as A:B") from None
    return first, second


def _infield_columns(args) -> dict:
    if not args.channels:
        return {}
    names = [part.strip() for part in args.channels.split(",")]
    if len(names) != 6 or not all(names):
        raise InputError(
            f"--channels {args.channels!r}",
            fix="name the three gyros then the three accelerometers, e.g. "
            "gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z",
        )
    return {"gyro_columns": tuple(names[:3]), "accel_columns": tuple(names[3:])}


def run_infield(args) -> int:
    from .._output import write_atomic, write_json

    declare_outputs(
        [args.file, args.calibration],
        {"--json": args.json, "--save": args.save, "--report": args.report},
    )
    align = _span(args.align, "--align")
    drift = _parse_drift(args.drift)
    taxi = _span(args.taxi, "--taxi") if args.taxi else None
    if args.accel_instability < 0:
        raise InputError(f"--accel-instability {args.accel_instability:g} must not be negative")
    if args.scale is not None or args.gaps != "error":
        raise InputError(
            "thermal infield takes the gyros in a rate unit and a gap-free window",
            fix="leave out --scale and --gaps (pass --unit for the gyros' unit)",
        )
    recording = load(args)
    # The analysis's modules load once the input is known to be good.
    from ..capabilities._infield import infield_update
    from ..report._infield import infield_page, infield_text

    result = infield_update(
        recording,
        args.calibration,
        latitude=args.latitude,
        align=align,
        taxi=taxi,
        track_heading=args.track_heading,
        positions=args.positions,
        **({} if args.position_sd is None else {"position_sd": args.position_sd}),
        wander=_pair(args.wander, "--wander"),
        seed=args.seed,
        drift=drift or 0.0,
        temperature=args.temperature,
        unit=args.unit,
        accel_unit=args.accel_unit,
        rate_hz=args.rate,
        time_column=args.time_column,
        time_unit=args.time_unit,
        height=args.height,
        accel_instability=args.accel_instability,
        sampler=sampler(args),
        **_infield_columns(args),
    )
    document = result.to_document()
    write_json(args.json, document)
    if args.save:
        result.save(args.save)
    if args.report:
        write_atomic(args.report, infield_page(result, source=recording.source))
    print(infield_text(document))
    if args.report:
        print(f"  report: {args.report}")
    return health_exit("thermal infield", result.checks["failures"])
