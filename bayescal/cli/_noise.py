"""``bayescal noise``: the noise of one static channel, classical and Bayesian."""

import argparse
import sys
import time

from .._errors import InputError
from ._arguments import (
    add_recording_arguments,
    channel_of,
    confidence,
    declare_outputs,
    grid_options,
    health_exit,
    load,
    max_steps,
    progress,
    require_bayesian_run,
    sampler,
    seed,
    taus,
    walker_note,
    walkers,
)

DEFAULT_TERMS = "auto"


def add_parser(commands) -> None:
    parser = commands.add_parser(
        "noise",
        help="noise of one static channel: bias, Allan deviation, IEEE 952 terms",
        description="Classical noise analysis of one static channel: bias with its Student-t "
        "interval and a check of its validity, Allan deviation with chi-square intervals, "
        "and the IEEE Std 952 slope readings of Q, N, B and K; beside them the posterior of "
        "the noise model.",
    )
    add_recording_arguments(parser, file_optional=True)
    parser.add_argument(
        "--example",
        action="store_true",
        help="analyse a built-in simulated gyro recording instead of a file",
    )
    parser.add_argument(
        "--stream",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="read a Parquet file or text table block by block, the channel spooled to disk "
        "(memory bounded by a block; the default for files over 256 MB), or --no-stream to "
        "read it into memory",
    )
    parser.add_argument(
        "--seed",
        type=seed,
        default=0,
        help="seed of the posterior (and of the --example recording)",
    )
    parser.add_argument(
        "--confidence",
        type=confidence,
        default=0.95,
        help="confidence of every interval (default 0.95)",
    )
    parser.add_argument(
        "--taus",
        type=taus,
        default="octave",
        help="averaging times: octave (default), decade, all, a number of "
        "log-spaced taus, or seconds such as 0.1,1,10",
    )
    parser.add_argument("--json", metavar="PATH", help="write the result as JSON")
    parser.add_argument(
        "--export",
        nargs=2,
        action="append",
        metavar=("FORMAT", "PATH"),
        help="also write the channel's noise for another tool: kalibr (imu.yaml) or matlab "
        "(gyroparams/accelparams script); a file already at PATH keeps the other sensor's "
        "entries and the other axes of this one (repeatable)",
    )
    parser.add_argument(
        "--export-axes",
        choices=("largest", "rms"),
        default="largest",
        help="one value per sensor covers every axis exported to a file: the largest of "
        "them (default) or their RMS",
    )
    bayes = parser.add_argument_group("Bayesian model")
    bayes.add_argument(
        "--terms",
        default=DEFAULT_TERMS,
        help="noise terms beside the bias: auto (the default: white noise and every term "
        "the record holds decisive evidence for), a comma-separated list of terms "
        "('bayescal terms' lists them and their other names), or all",
    )
    bayes.add_argument(
        "--sensor",
        metavar="NAME",
        help="use a sensor card's datasheet figures as priors (bayescal sensors)",
    )
    bayes.add_argument(
        "--out", metavar="DIR", help="write the posterior (ArviZ netCDF) and the JSON into DIR"
    )
    bayes.add_argument("--walkers", type=walkers, default=32, help="emcee walkers (default 32)")
    bayes.add_argument(
        "--max-steps",
        type=max_steps,
        default=40_000,
        help="most emcee steps before the convergence check fails",
    )
    bayes.add_argument("--classical-only", action="store_true", help="skip the Bayesian model")
    bayes.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument(
        "--profile",
        action="store_true",
        help="after the run, print the time each stage took on stderr",
    )
    parser.set_defaults(run=run)


def _require_channel(args) -> None:
    if not args.channel:
        raise InputError(
            "--channel is required",
            source=args.file,
            fix="name the column to analyse, e.g. --channel gyro_x",
        )


def _recording(args):
    if args.example:
        if args.file:
            raise InputError("give a FILE or --example, not both")
        from ..capabilities._examples import example_recording

        return example_recording(args.seed), args.channel or "gyro_x"
    if not args.file:
        raise InputError("no recording given", fix="pass a FILE, or --example to try bayescal")
    _require_channel(args)
    return load(args), args.channel


def _streamed(args) -> bool:
    """Whether the recording is read block by block (``--stream``, or a long file)."""
    if args.example or not args.file:
        return False
    from ..recording._stream import STREAMED_SUFFIXES, is_long_recording

    if args.stream is None:
        return is_long_recording(args.file) and not args.pad
    if args.stream and not args.file.lower().endswith(STREAMED_SUFFIXES):
        raise InputError(
            "--stream reads Parquet files and text tables",
            source=args.file,
            fix="leave --stream out, or convert the recording to Parquet",
        )
    if args.stream and args.pad:
        raise InputError(
            "--pad finds the pad window in the whole recording in memory; --stream reads it in "
            "blocks",
            source=args.file,
            fix="give the window with --start/--stop, or leave --stream out",
        )
    return bool(args.stream)


def _streamed_channel(args):
    """The channel of a long recording, spooled to disk, and its window's description."""
    from ..recording._stream import stream_channel

    _require_channel(args)
    for given, argument in ((args.topic, "--topic"), (args.names, "--names")):
        if given:
            raise InputError(
                f"{argument} does not apply to a streamed Parquet file or text table",
                source=args.file,
                fix=f"leave {argument} out, or read the recording in memory with --no-stream",
            )
    chosen = "start/stop" if args.start is not None or args.stop is not None else "whole record"
    channel = stream_channel(
        args.file,
        args.channel,
        start=args.start,
        stop=args.stop,
        skip_rows=args.skip_rows,
        progress=progress(args),
        **grid_options(args, args.channel),
    )
    window = {"start_s": channel.start_s, "stop_s": channel.stop_s, "selected_by": chosen}
    return channel, window


def run(args) -> int:
    if not args.profile:
        return _analyse(args)
    from .._stages import timing

    start = time.perf_counter()
    with timing() as times:
        code = _analyse(args)
    print(profile_table(times, time.perf_counter() - start), file=sys.stderr)
    return code


def profile_table(times: list[tuple[str, int, float]], total: float) -> str:
    """The stages' times (:func:`bayescal._stages.timing`), a stage inside another indented
    under it, and what the stages leave of the run's ``total`` (imports, JAX's start-up)."""
    pending: list[tuple[int, list[str]]] = []
    # Stages end inner first: an outer stage takes the rows of those that ended inside it.
    for name, depth, seconds in times:
        rows = [f"  {seconds:8.2f}  {'  ' * depth}{name}"]
        rows += [row for inner, block in pending if inner > depth for row in block]
        pending = [item for item in pending if item[0] <= depth] + [(depth, rows)]
    lines = ["profile (s):", *(row for _, block in pending for row in block)]
    outer = sum(seconds for _, depth, seconds in times if depth == 0)
    lines.append(f"  {total - outer:8.2f}  other (imports, JAX's start-up, the text)")
    lines.append(f"  {total:8.2f}  total")
    return "\n".join(lines)


def _analyse(args) -> int:
    from .._output import file_stem, write_json, write_netcdf
    from .._stages import stage

    terms = None
    if not args.classical_only or args.terms != DEFAULT_TERMS:
        # The registry of terms loads JAX (about 1 s): loaded where there is a model to fit,
        # or a --terms to check.
        from ..models._terms import parse_terms

        terms = parse_terms(args.terms)
    exports = {f"--export {fmt}": path for fmt, path in args.export or ()}
    (folder,) = declare_outputs([args.file], {"--json": args.json, **exports}, {"--out": args.out})
    topic = None
    with stage("reading the recording"):
        if _streamed(args):
            channel, window = _streamed_channel(args)
            name = channel.channel
        else:
            recording, name = _recording(args)
            channel, window = channel_of(args, recording, name)
            topic = recording.topic
    # The analysis's modules load once the input is known to be good.
    from ..classical._noise import classical_noise
    from ..report._export import plan_exports, write_exports
    from ..report._noise import NoiseAnalysis, Window, noise_document, noise_text

    exports = plan_exports(args.export, channel.unit, name, channel.source, topic, args.export_axes)
    fit = None
    if args.classical_only:
        try:
            with stage("classical (bias, Allan deviation with intervals, readings)"):
                classical = classical_noise(
                    channel.values, channel.rate_hz, confidence=args.confidence, taus=args.taus
                )
        except InputError as error:
            raise InputError(
                error.problem, source=channel.source, column=name, fix=error.fix
            ) from None
    else:
        require_bayesian_run(channel, "pass --classical-only")
        from ..capabilities._noise import fit_noise

        fit = fit_noise(
            channel,
            terms=terms,
            sensor=args.sensor,
            seed=args.seed,
            confidence=args.confidence,
            taus=args.taus,
            sampler=sampler(args),
        )
        classical = fit.classical
    described, window_notes = Window.described(window)
    analysis = NoiseAnalysis.of(
        fit or channel,
        classical,
        described,
        fit,
        notes=window_notes,
        extra_notes=[] if fit is None else walker_note(fit.diagnostics.n_walkers, args.walkers),
    )
    with stage("writing the outputs"):
        result = noise_document(analysis)
        if args.json:
            write_json(args.json, result)
        exported = write_exports(exports, analysis)
        if folder is not None:
            stem = f"noise_{file_stem(name)}"
            if fit is not None:
                write_netcdf(fit.posterior, folder / f"{stem}_posterior.nc")
            write_json(folder / f"{stem}.json", result)
    print(noise_text(analysis))
    for line in exported:
        print(line)
    failures = [] if fit is None else [f"{name}: {failure}" for failure in fit.failures]
    return health_exit("noise", failures)
