"""``bayescal plan``: how long to record, from a pilot recording's noise posterior."""

import re

from .._errors import InputError
from ._arguments import (
    add_recording_arguments,
    channel_of,
    declare_outputs,
    load,
    require_bayesian_run,
    sampler,
    seed,
)

_LENGTH = re.compile(r"\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(s|min|h|d|days?)?\s*")
_SECONDS = {None: 1.0, "s": 1.0, "min": 60.0, "h": 3600.0, "d": 86400.0, "day": 86400.0}
_SECONDS["days"] = 86400.0


def length(text: str) -> float:
    """``--length 2h``: a record length (s, min, h or days; seconds when bare)."""
    import argparse

    match = _LENGTH.fullmatch(text)
    if match is None or not float(match[1]) > 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not a length such as 7200, 30min or 2h")
    return float(match[1]) * _SECONDS[match[2]]


def target(text: str) -> dict:
    """``--target K=0.2,N=5%``: relative half-widths by parameter."""
    import argparse

    found = {}
    for item in text.split(","):
        name, _, value = item.partition("=")
        value = value.strip()
        try:
            number = float(value[:-1]) / 100 if value.endswith("%") else float(value)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{item.strip()!r} is not PARAMETER=WIDTH (K=0.2 or K=20%)"
            ) from None
        found[name.strip()] = number
    return found


def add_parser(commands) -> None:
    parser = commands.add_parser(
        "plan",
        help="how long to record: the length each noise term needs, from a pilot recording",
        description="Fit the noise model of a pilot recording, then predict, from its "
        "posterior, how wide each parameter's interval will be after a record of any length, "
        "and the length a stated precision needs.",
    )
    add_recording_arguments(parser)
    parser.add_argument(
        "--target",
        type=target,
        default={},
        metavar="P=W,...",
        help="relative half-widths wanted, e.g. K=0.2,N=0.05 (or K=20%%)",
    )
    parser.add_argument(
        "--length", type=length, help="also say what a record of this length gives (e.g. 2h)"
    )
    parser.add_argument(
        "--confidence", type=float, default=0.9, help="confidence of the intervals (0.9)"
    )
    parser.add_argument(
        "--terms",
        default="auto",
        help="the pilot's noise terms (as for noise; default auto: chosen by evidence)",
    )
    parser.add_argument("--seed", type=seed, default=0, help="seed of the posterior and plan")
    parser.add_argument("--json", metavar="PATH", help="write the plan as JSON")
    parser.add_argument("--plot", metavar="PATH", help="draw the widths against length (PNG)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(run=run)


def run(args) -> int:
    from .._output import atomic_path, write_json

    declare_outputs([args.file], {"--json": args.json, "--plot": args.plot})
    if not args.channel:
        raise InputError("no channel given", fix="pass --channel NAME")
    recording = load(args)
    channel, _ = channel_of(args, recording, args.channel)
    require_bayesian_run(channel)
    from ..capabilities._noise import fit_noise
    from ..capabilities._plan import plan_recording
    from ..report._plan import plan_document, plan_figure, plan_text

    fit = fit_noise(channel, terms=args.terms, seed=args.seed, sampler=sampler(args))
    plan = plan_recording(
        fit, args.target, confidence=args.confidence, length_s=args.length, seed=args.seed
    )
    if args.json:
        write_json(args.json, plan_document(plan, channel.source))
    if args.plot:
        with atomic_path(args.plot) as temporary:
            plan_figure(plan, temporary)
    print(plan_text(plan, channel.source))
    return 0
