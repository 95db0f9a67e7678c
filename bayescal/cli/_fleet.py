"""``bayescal fleet``: the population of a fleet of sensors from a manifest of recordings,
each recording fitted on a Dask cluster.

Exit codes: 0 success; 1 a recording or the population failed its health checks (the output
says which; the rest is written); 2 bad input — the manifest or an option (nothing is run or
written), or a recording that could not be read or analysed as given (the rest is analysed,
written, and the recording named).
"""

import argparse
import sys

from .._errors import InputError
from ._arguments import (
    add_reading_arguments,
    declare_outputs,
    finite_float,
    health_exit,
    max_steps,
    positive_float,
    positive_int,
    reading_options,
    sampler,
    seed,
    unit_and_scale,
    walkers,
)

DEFAULT_TERMS = "white,bias_instability,rate_random_walk"


def add_parser(commands) -> None:
    parser = commands.add_parser(
        "fleet",
        help="population of a fleet of units: noise and bias across units and power-ups",
        description="Fit the noise of every recording a manifest lists (on a Dask cluster: a "
        "local one by default) and, on top, the population of the units: the median and "
        "spread across units of N, B and K, the turn-on bias's unit-to-unit and run-to-run "
        "sd, each unit shrunk toward the population, the next unit's predictive "
        "distribution, and the probability that a unit meets a specification.",
    )
    parser.add_argument(
        "manifest",
        help="CSV with one row per recording: path (relative to the manifest), unit, "
        "optionally run, rate, temperature",
    )
    group = parser.add_argument_group("recordings")
    group.add_argument("--channel", required=True, help="column to analyse, e.g. gyro_x")
    group.add_argument(
        "--unit", help="unit of the channel (deg/s, rad/s, m/s^2, g ...); default: the header"
    )
    add_reading_arguments(group)
    group.add_argument(
        "--rate",
        type=positive_float,
        metavar="HZ",
        help="sample rate of recordings whose manifest row gives none (and have no time column)",
    )
    group.add_argument("--time-column", metavar="NAME", help="time column (default: time or t)")
    group.add_argument(
        "--time-unit", metavar="UNIT", help="unit of the time column (s, ms, us, ns)"
    )
    group.add_argument(
        "--gaps",
        choices=("error", "split"),
        default="error",
        help="on a gap in a recording's time stamps: leave the recording out (error, the "
        "default) or analyse its segments",
    )
    group.add_argument(
        "--start", type=finite_float, metavar="S", help="start of each recording's window, seconds"
    )
    group.add_argument(
        "--stop", type=finite_float, metavar="S", help="end of each recording's window, seconds"
    )
    model = parser.add_argument_group("model")
    model.add_argument(
        "--terms",
        default=DEFAULT_TERMS,
        help=f"noise terms of every recording's fit, the same for each (default: "
        f"{DEFAULT_TERMS}; not auto); the population holds N, B and K among them where the "
        "recordings resolve them; add quantization or an output filter where the records "
        "need them",
    )
    model.add_argument(
        "--sensor", metavar="NAME", help="a sensor card's datasheet figures as each fit's priors"
    )
    model.add_argument(
        "--spec",
        action="append",
        metavar="LIMIT",
        help="a limit a unit should meet, 'N<0.3 deg/sqrt(h)', 'B<10 deg/h', 'K<...', "
        "'bias<0.5 deg/s' (in magnitude), or a sensor card's name (its datasheet N, B, K); "
        "repeatable",
    )
    model.add_argument("--seed", type=seed, default=0, help="seed of the fleet (default 0)")
    model.add_argument("--walkers", type=walkers, default=32, help="emcee walkers (default 32)")
    model.add_argument(
        "--max-steps",
        type=max_steps,
        default=40_000,
        help="most emcee steps before a convergence check fails",
    )
    cluster = parser.add_argument_group("cluster")
    cluster.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="a running Dask scheduler, e.g. tcp://host:8786 (its workers need bayescal and "
        "the recordings at the manifest's paths); default: a local cluster",
    )
    cluster.add_argument(
        "--workers",
        type=positive_int,
        metavar="K",
        help="worker processes of the local cluster (default: one per core)",
    )
    cluster.add_argument(
        "--batch",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="fit the recordings of one length and rate together in this process on JAX's "
        "default device (a GPU fits hundreds at once); --no-batch: one Dask task per "
        "recording; default: batched when JAX's default device is a GPU and neither "
        "--scheduler nor --workers is given",
    )
    output = parser.add_argument_group("output")
    output.add_argument("--json", metavar="PATH", help="write the result as JSON")
    output.add_argument(
        "--out",
        metavar="DIR",
        help="write the JSON, the fleet page (HTML) and the population's posterior (ArviZ "
        "netCDF) into DIR",
    )
    output.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(run=run)


def run(args) -> int:
    from ..models._terms import fleet_terms
    from ..recording._manifest import read_manifest

    terms = fleet_terms(args.terms)
    if args.scheduler is not None and args.workers is not None:
        raise InputError(
            "--workers sets the size of the local cluster; with --scheduler the cluster's own "
            "workers run the tasks",
            fix="leave --workers out",
        )
    (folder,) = declare_outputs([args.manifest], {"--json": args.json}, {"--out": args.out})
    manifest = read_manifest(args.manifest)
    # The analysis's modules load once the input is known to be good.
    from .._output import file_stem, write_atomic, write_json, write_netcdf
    from ..capabilities._fleet import fit_fleet
    from ..inference._population import population_datatree
    from ..report._fleet import fleet_page, fleet_result, fleet_text

    unit, scale = unit_and_scale(args, args.channel)
    fleet = fit_fleet(
        manifest,
        args.channel,
        terms=terms,
        sensor=args.sensor,
        spec=args.spec,
        seed=args.seed,
        unit=unit,
        scale=scale,
        rate_hz=args.rate,
        time_column=args.time_column,
        time_unit=args.time_unit,
        gaps=args.gaps,
        start=args.start,
        stop=args.stop,
        **reading_options(args),
        scheduler=args.scheduler,
        workers=args.workers,
        batch=args.batch,
        sampler=sampler(args),
    )
    result = fleet_result(fleet)
    if args.json:
        write_json(args.json, result)
    if folder is not None:
        stem = f"fleet_{file_stem(args.channel)}"
        write_json(folder / f"{stem}.json", result)
        write_netcdf(
            population_datatree(
                fleet.population, fleet.unit, source=fleet.source, channel=fleet.channel
            ),
            folder / f"{stem}_population.nc",
        )
        write_atomic(folder / f"{stem}.html", fleet_page(fleet))
    print(fleet_text(fleet))
    failures = [f"population: {failure}" for failure in fleet.failures]
    failures += [f"{f.source}: {f.message}" for f in fleet.failed if f.kind != "input"]
    code = health_exit("fleet", failures)
    bad = [f for f in fleet.failed if f.kind == "input"]
    if bad:
        print(
            "bayescal fleet: error: "
            + "; ".join(f"{f.source}: {f.message}" for f in bad)
            + " (left out of the population)",
            file=sys.stderr,
        )
        return 2
    return code
