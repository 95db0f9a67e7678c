"""``bayescal discover``: locate, name and model what a baseline model of a static channel
left out."""

import sys

from .._errors import InputError
from ._arguments import (
    add_recording_arguments,
    channel_of,
    declare_outputs,
    health_exit,
    load,
    max_effects,
    seed,
)

DEFAULT_BASELINE = "white"


def add_parser(commands) -> None:
    parser = commands.add_parser(
        "discover",
        help="find the physics a model left out: locate the mismatch, name it, model it",
    )
    add_recording_arguments(parser, temperature=True)
    parser.add_argument(
        "--baseline",
        metavar="TERMS",
        help="noise terms of the starting model besides the bias (default: white, the model "
        "behind the classical pad numbers), e.g. white,bias_instability",
    )
    parser.add_argument(
        "--sim",
        metavar="FILE",
        help="a recording made by your own simulator (same channel name): what it holds "
        "becomes the baseline, and discovery reports what the real recording holds beyond it",
    )
    parser.add_argument(
        "--max-effects", type=max_effects, default=4, metavar="N", help="stop after N effects (4)"
    )
    parser.add_argument("--json", metavar="PATH", help="write the findings as JSON")
    parser.add_argument(
        "--out", metavar="DIR", help="figures before/after and the final posterior (netCDF)"
    )
    parser.add_argument(
        "--seed",
        type=seed,
        default=0,
        help="seed of the posterior sampler (and of the imputation of clipped samples)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress messages")
    parser.set_defaults(run=run)


def _discover(
    args, path, baseline, *, max_effects: int, progress=None, seed: int = 0, posterior=True
):
    """Discovery on the channel of one recording, with its temperature and accelerometers."""
    from ..capabilities._discovery import discover
    from ..recording._recording import companions

    recording = load(args, path)
    channel, _ = channel_of(args, recording, args.channel)
    temperature, accelerometers, units = companions(
        recording, channel, temperature=args.temperature
    )
    return discover(
        channel,
        temperature=temperature,
        accelerometers=accelerometers,
        accelerometer_unit=units,
        baseline=baseline,
        max_effects=max_effects,
        log=progress,
        seed=seed,
        posterior=posterior,
    )


def _simulation_baseline(args) -> tuple[tuple[str, ...], dict]:
    """Discover on the user's simulation from white noise: what it holds is the baseline."""
    from ..models._composite import BASELINE_TERMS

    # Only the names of what the simulation holds are used: no posterior of its parameters.
    found = _discover(args, args.sim, ("white",), max_effects=args.max_effects, posterior=False)
    names = [effect.name for effect in found.effects]
    terms = ["white", *(name for name in names if name in BASELINE_TERMS)]
    others = [name for name in names if name not in BASELINE_TERMS]
    return tuple(terms), {
        "file": args.sim,
        "terms_found": ["bias", *terms, *others],
        "note": "the simulation's noise terms are the baseline; deterministic terms found in "
        "the simulation are listed but not carried over",
    }


def _check_baseline(baseline) -> None:
    from ..models._composite import BASELINE_TERMS

    unknown = [term for term in baseline if term not in BASELINE_TERMS]
    if unknown:
        raise InputError(
            f"--baseline: unknown term(s) {', '.join(unknown)}",
            fix=f"use terms among {', '.join(sorted(BASELINE_TERMS))}",
        )


def run(args) -> int:
    from .._output import write_json

    if not args.file:
        raise InputError("no recording given", fix="pass a FILE")
    if not args.channel:
        raise InputError("--channel is required", source=args.file, fix="e.g. --channel gyro_x")
    if args.sim and args.baseline is not None:
        raise InputError(
            "give --baseline or --sim, not both",
            fix="with --sim, the simulation's noise terms are the baseline",
        )
    (folder,) = declare_outputs([args.file, args.sim], {"--json": args.json}, {"--out": args.out})
    given = args.baseline if args.baseline is not None else DEFAULT_BASELINE
    baseline = tuple(part.strip() for part in given.split(",") if part.strip())
    if not baseline:
        raise InputError(f"--baseline {given!r} names no term", fix="e.g. --baseline white")
    _check_baseline(baseline)
    simulation = None
    if args.sim:
        baseline, simulation = _simulation_baseline(args)
    talk = (lambda m: print(f"discover: {m}", file=sys.stderr)) if not args.quiet else None
    found = _discover(
        args, args.file, baseline, max_effects=args.max_effects, progress=talk, seed=args.seed
    )
    from ..report._discovery import Findings, discovery_document, discovery_text, write_folder

    findings = Findings.of(found, source=str(args.file), simulation=simulation)
    document = discovery_document(findings)
    if folder is not None:
        write_folder(folder, findings, document)
    if args.json:
        write_json(args.json, document)
    print(discovery_text(found))
    return health_exit("discover", found.failures)
