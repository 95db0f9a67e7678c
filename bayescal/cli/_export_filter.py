"""``bayescal export-filter``: a navigation filter's IMU noise from a static recording, in the
named estimator's convention and file, with its JSON."""

import argparse

from ._arguments import (
    add_recording_arguments,
    channel_of,
    declare_outputs,
    health_exit,
    load,
    max_steps,
    positive_float,
    rate,
    require_bayesian_run,
    sampler,
    seed,
    walkers,
)


def aiding(text: str):
    """``KIND:SD@SECONDS`` -> :class:`~bayescal.Aiding`."""
    from .._errors import InputError
    from ..navigation._aiding import Aiding

    kind, _, rest = text.partition(":")
    sd, _, interval = rest.partition("@")
    try:
        return Aiding(kind.strip(), float(sd), float(interval))
    except InputError as error:
        raise argparse.ArgumentTypeError(f"{text!r}: {error}") from None
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not KIND:SD@SECONDS, e.g. position:1@1 (m, s) or velocity:0.05@0.1 "
            "(m/s, s)"
        ) from None


def add_parser(commands) -> None:
    from ..capabilities._estimators import ESTIMATORS

    parser = commands.add_parser(
        "export-filter",
        help="IMU noise for a navigation filter's config (Kalibr, OpenVINS, ORB-SLAM3, VINS, "
        "GTSAM, PX4)",
        description="Fit the noise model of each channel of a static recording and write the "
        "white noise and bias random walk a navigation filter needs, in the estimator's own "
        "convention (continuous density or per-sample sd, its units and names) and file, "
        "each number itemised: the posterior's upper quantile of N and K, the bias "
        "instability as the random walk that bounds it over the filter's horizon (given, or "
        "following from its aiding), and a vibration record's extra noise.",
    )
    add_recording_arguments(parser, channel="many")
    parser.add_argument(
        "--estimator", required=True, choices=tuple(ESTIMATORS), help="the estimator"
    )
    horizon = parser.add_mutually_exclusive_group()
    horizon.add_argument(
        "--horizon",
        type=positive_float,
        metavar="SECONDS",
        help="time over which the bias instability is bounded by a random walk, for every "
        "channel: the time the filter's bias estimate averages over (a sliding window's "
        "length); default: each channel's from --aiding",
    )
    horizon.add_argument(
        "--aiding",
        type=aiding,
        metavar="KIND:SD@SECONDS",
        help="the filter's aiding, e.g. position:1@1 (position fixes of 1 m sd every second) "
        "or velocity:0.05@0.1 (m/s): each channel's horizon is the span over which it reveals "
        "that channel's bias (default position:1@1, GNSS-class)",
    )
    parser.add_argument(
        "--vibration",
        metavar="RECORDING",
        help="a recording of the same channels with the motors running: its extra noise",
    )
    parser.add_argument(
        "--quantile",
        type=positive_float,
        default=0.95,
        help="the posterior's upper quantile of N, K and B (default 0.95)",
    )
    parser.add_argument(
        "--filter-rate",
        type=rate,
        metavar="HZ",
        help="the rate the filter steps at, for per-sample values (default: PX4's EKF 100 Hz, "
        "else the recording's)",
    )
    parser.add_argument("--out", required=True, metavar="FILE", help="the estimator's file")
    parser.add_argument("--json", metavar="PATH", help="values and items as JSON")
    parser.add_argument("--terms", default="auto", help="noise terms (as for noise; default auto)")
    parser.add_argument("--seed", type=seed, default=0, help="seed of the posteriors")
    parser.add_argument("--walkers", type=walkers, default=32, help="emcee walkers (default 32)")
    parser.add_argument("--max-steps", type=max_steps, default=40_000)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(run=run)


def run(args) -> int:
    from .._output import write_atomic, write_json
    from ..recording._columns import default_channels

    inputs = [args.file] + ([args.vibration] if args.vibration else [])
    declare_outputs(inputs, {"--out": args.out, "--json": args.json})
    recording = load(args)
    names = (
        [part.strip() for part in args.channels.split(",") if part.strip()]
        if args.channels
        else default_channels(recording)
    )
    channels = {}
    for name in dict.fromkeys(names):
        channels[name], _ = channel_of(args, recording, name)
        require_bayesian_run(channels[name])
    vibration = None
    if args.vibration:
        shaking = load(args, args.vibration)
        vibration = {name: channel_of(args, shaking, name)[0] for name in channels}
    from ..capabilities._estimators import sensor_of_unit
    from ..capabilities._filter_noise import filter_noise
    from ..capabilities._noise import fit_noise
    from ..report._filter_config import filter_document, filter_file, filter_text

    for name, channel in channels.items():  # a channel in counts is refused before any fit
        sensor_of_unit(channel.unit, name, channel.source)
    fits = [
        fit_noise(channel, terms=args.terms, seed=args.seed, sampler=sampler(args))
        for channel in channels.values()
    ]
    noise = filter_noise(
        fits,
        estimator=args.estimator,
        horizon=args.horizon,
        aiding=args.aiding,
        quantile=args.quantile,
        filter_rate_hz=args.filter_rate,
        vibration=vibration,
    )
    write_atomic(args.out, filter_file(noise, getattr(args, "topic", None)))
    if args.json:
        write_json(args.json, filter_document(noise, args.out))
    print(filter_text(noise, args.out))
    return health_exit("export-filter", list(noise.failures))
