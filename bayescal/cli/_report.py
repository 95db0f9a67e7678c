"""``bayescal report`` and ``bayescal demo``: the HTML report of a sensor, and the report of a
simulated one."""

from pathlib import Path

from .._errors import InputError
from ._arguments import (
    add_recording_arguments,
    channel_units,
    confidence,
    declare_outputs,
    grid_options,
    health_exit,
    load,
    max_steps,
    minutes,
    progress,
    require_bayesian_run,
    sampler,
    seed,
    taus,
    unit_and_scale,
    walker_note,
    walkers,
    window,
)

DEFAULT_TERMS = "auto"


def add_parser(commands) -> None:
    report = commands.add_parser(
        "report",
        help="HTML report of a sensor: noise of every channel, classical and Bayesian",
        description="Run the noise analysis (classical and Bayesian) on each channel of one "
        "recording and write one self-contained HTML page (figures embedded, opens offline) "
        "with the JSON and the ArviZ netCDF behind it.",
    )
    add_recording_arguments(report, channel="many")
    report.add_argument(
        "--units",
        type=channel_units,
        metavar="CHANNEL=UNIT,...",
        help="each channel's unit, e.g. gyro_x=deg/s,acc_x=g (over --unit and the header's); "
        "a channel not named takes --unit, else its header's",
    )
    report.add_argument(
        "--out", default="report", metavar="DIR", help="output folder (default: report)"
    )
    report.add_argument(
        "--sensor",
        metavar="NAME",
        help="sensor card: its datasheet figures become priors and the page compares the "
        "measured unit with them (bayescal sensors)",
    )
    report.add_argument("--title", help="title of the page (default: from the file name)")
    report.add_argument("--confidence", type=confidence, default=0.95)
    report.add_argument("--taus", type=taus, default="octave")
    report.add_argument(
        "--terms",
        default=DEFAULT_TERMS,
        help=f"noise terms (as for noise; default {DEFAULT_TERMS})",
    )
    report.add_argument("--seed", type=seed, default=0)
    report.add_argument("--walkers", type=walkers, default=32)
    report.add_argument("--max-steps", type=max_steps, default=40_000)
    report.add_argument("--quiet", action="store_true", help="no progress bar")
    report.add_argument(
        "--discover",
        action="store_true",
        help="also run discovery (bayescal discover) on each channel and show its findings",
    )
    report.set_defaults(run=run)

    demo = commands.add_parser(
        "demo",
        help="simulate a 6-axis IMU and write its report (start here)",
        description="Simulate a MEMS 6-axis IMU with bayescal's own noise model (100 Hz, "
        "25 minutes, with an effect hidden in it), write the recording as CSV and its report.",
    )
    demo.add_argument(
        "--out", default="bayescal-demo", metavar="DIR", help="folder (default: bayescal-demo)"
    )
    demo.add_argument("--seed", type=seed, default=0, help="seed of the simulation and the fit")
    demo.add_argument(
        "--minutes",
        type=minutes,
        default=25.0,
        help="length of the simulated recording (default 25)",
    )
    demo.add_argument("--quiet", action="store_true", help="no progress bar")
    demo.set_defaults(run=run_demo)


def _health(outcome, command: str) -> int:
    return health_exit(
        command,
        [f"{a.channel}: {', '.join(a.failures)}" for a in outcome.failed],
    )


def run(args) -> int:
    from ..recording._columns import default_channels
    from ..report._discovery import discover_channel
    from ..report._report import report_recording, summary_text

    (folder,) = declare_outputs([args.file], folders={"--out": args.out})
    recording = load(args)
    channels = (
        [part.strip() for part in args.channels.split(",") if part.strip()]
        if args.channels
        else default_channels(recording)
    )
    start, stop, described = window(args, recording)
    unknown = [name for name in args.units or {} if name not in channels]
    if unknown:
        raise InputError(
            f"--units names {', '.join(unknown)}, not among the channels reported "
            f"({', '.join(channels)})",
            fix="name the channels of --channels (or those found by name), e.g. "
            f"{channels[0]}=deg/s"
            if channels
            else "name a channel of the recording",
        )
    for name in dict.fromkeys(channels):
        options = grid_options(args, name)
        require_bayesian_run(recording.channel(name, start=start, stop=stop, **options))
    discoveries = None
    if args.discover:

        def discoveries(recording, channel):
            return discover_channel(recording, channel, seed=args.seed)

    outcome = report_recording(
        recording,
        channels,
        folder,
        stem=Path(args.file).stem,
        title=args.title,
        sensor=args.sensor,
        terms=args.terms,
        confidence=args.confidence,
        taus=args.taus,
        seed=args.seed,
        sampler=sampler(args),
        rate=args.rate,
        time_column=args.time_column,
        time_unit=args.time_unit,
        gaps=args.gaps,
        start=start,
        stop=stop,
        options={
            name: dict(zip(("unit", "scale"), unit_and_scale(args, name), strict=True))
            for name in channels
        },
        window=described,
        discoveries=discoveries,
    )
    print(f"bayescal report: {recording.source}")
    print(summary_text(outcome))
    for analysis in outcome.analyses:
        for note in walker_note(analysis.fit.diagnostics.n_walkers, args.walkers):
            print(f"  note: {analysis.channel}: {note}")
    return _health(outcome, "report")


def run_demo(args) -> int:
    from ..report._demo import write_demo
    from ..report._report import summary_text

    (folder,) = declare_outputs(folders={"--out": args.out})
    csv_path, outcome = write_demo(
        folder, seed=args.seed, minutes=args.minutes, progress=progress(args)
    )
    print(f"bayescal demo: simulated recording {csv_path} (truth in {folder / 'demo_truth.json'})")
    print(summary_text(outcome))
    print(f"open {outcome.html.resolve().as_uri()}")
    return _health(outcome, "demo")
