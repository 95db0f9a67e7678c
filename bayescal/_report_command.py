"""``bayescal report`` (and ``bayescal demo``): the noise analysis of every channel of one
recording, classical and Bayesian, written as one self-contained HTML page per sensor plus the
JSON and the ArviZ netCDF behind it.

Files in the output folder, for a recording ``imu.csv``: ``imu_report.html`` (the page),
``imu_report.json`` (every channel's ``noise`` document, the numbers behind the figures, the
datasheet comparison, the discovery findings) and ``imu_<channel>_posterior.nc`` per channel.
Each is written atomically. Exit code 1 when a posterior failed its health checks (the page
says which, loudly, and is written all the same).
"""

import sys
from dataclasses import dataclass
from pathlib import Path

from ._errors import InputError

DEFAULT_TERMS = "white,bias_instability,rate_random_walk"


def add_parser(commands) -> None:
    from ._cli import _columns, _confidence, _positive_float, _taus

    report = commands.add_parser(
        "report",
        help="HTML report of a sensor: noise of every channel, classical and Bayesian",
        description="Run the noise analysis (classical and Bayesian) on each channel of one "
        "recording and write one self-contained HTML page (figures embedded, opens offline) "
        "with the JSON and the ArviZ netCDF behind it.",
    )
    report.add_argument("file", help="recording: .csv, .parquet or .npz")
    report.add_argument(
        "--channels",
        help="comma-separated columns, e.g. gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z "
        "(default: every gyro and accelerometer column, found by name)",
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
    report.add_argument("--rate", type=_positive_float, metavar="HZ")
    report.add_argument("--time-column", metavar="NAME")
    report.add_argument("--time-unit", metavar="UNIT")
    report.add_argument("--gaps", choices=("error", "split"), default="error")
    report.add_argument("--start", type=float, metavar="S")
    report.add_argument("--stop", type=float, metavar="S")
    report.add_argument("--pad", action="store_true", help="flight log: the pad window")
    report.add_argument("--accel-columns", type=_columns, metavar="X,Y,Z")
    report.add_argument("--accel-unit", metavar="UNIT")
    report.add_argument("--confidence", type=_confidence, default=0.95)
    report.add_argument("--taus", type=_taus, default="octave")
    report.add_argument(
        "--terms",
        default=DEFAULT_TERMS,
        help=f"noise terms (as for noise; default {DEFAULT_TERMS})",
    )
    report.add_argument("--seed", type=int, default=0)
    report.add_argument("--walkers", type=int, default=32)
    report.add_argument("--max-steps", type=int, default=40_000)
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
    demo.add_argument("--seed", type=int, default=0, help="seed of the simulation and the fit")
    demo.add_argument(
        "--minutes",
        type=_positive_float,
        default=25.0,
        help="length of the simulated recording (default 25)",
    )
    demo.add_argument("--quiet", action="store_true", help="no progress bar")

    def run_demo(args) -> int:
        from ._demo import run_demo

        return run_demo(args)

    demo.set_defaults(run=run_demo)


@dataclass
class ReportOutcome:
    html: Path
    json: Path
    posteriors: dict
    analyses: list
    failed: list

    @property
    def passed(self) -> bool:
        return not self.failed


def default_channels(table) -> list[str]:
    from ._recording import _is_accel_name, _is_gyro_name

    return [
        name
        for name in table.columns
        if name not in ("time", "t", "timestamp") and (_is_gyro_name(name) or _is_accel_name(name))
    ]


def _card_prior(card, terms, unit, allan):
    """The card's prior for this channel, or None with the reason (no section for this kind
    of channel, no figure for the fitted terms)."""
    from ._sensors import card_prior

    try:
        return card_prior(card, terms, unit, allan), None
    except InputError as error:
        return None, f"sensor card not used as prior: {error.problem}"


def analyse_channel(
    data,
    *,
    terms: tuple[str, ...],
    confidence: float = 0.95,
    taus="octave",
    card=None,
    seed: int = 0,
    n_walkers: int = 32,
    max_steps: int = 40_000,
    progress: bool = False,
    window: dict | None = None,
):
    """Classical and Bayesian noise of one prepared channel, with the posterior bands of the
    figures and, with a sensor card, the datasheet comparison."""
    from ._classical import classical_noise
    from ._noise_command import noise_result
    from ._noise_fit import fit_noise
    from ._report import ChannelAnalysis, datasheet_comparison, posterior_bands

    try:
        classical = classical_noise(data.values, data.rate_hz, confidence=confidence, taus=taus)
    except InputError as error:
        raise InputError(
            error.problem, source=data.source, column=data.channel, fix=error.fix
        ) from None
    prior, prior_note = (None, None)
    if card is not None:
        prior, prior_note = _card_prior(card, terms, data.unit, classical.allan)
    fit = fit_noise(
        data.values,
        data.rate_hz,
        classical.allan,
        terms=terms,
        prior=prior,
        seed=seed,
        n_walkers=n_walkers,
        max_steps=max_steps,
        progress=progress,
    )
    window = {"start_s": data.start_s, "stop_s": data.stop_s, **(window or {})}
    window_notes = window.pop("notes", [])
    result = noise_result(data, classical, window, fit)
    result["notes"] = list(window_notes) + result["notes"] + ([prior_note] if prior_note else [])
    analysis = ChannelAnalysis(data=data, classical=classical, result=result, fit=fit)
    posterior_bands(analysis, seed=seed)
    if card is not None:
        analysis.datasheet = datasheet_comparison(card, analysis)
    return analysis


def report_recording(
    table,
    channels: list[str],
    folder,
    *,
    stem: str,
    title: str | None = None,
    sensor: str | None = None,
    terms: str = DEFAULT_TERMS,
    confidence: float = 0.95,
    taus="octave",
    seed: int = 0,
    n_walkers: int = 32,
    max_steps: int = 40_000,
    rate: float | None = None,
    time_column: str | None = None,
    time_unit: str | None = None,
    gaps: str = "error",
    start: float | None = None,
    stop: float | None = None,
    window: dict | None = None,
    discoveries=None,
    progress: bool = False,
) -> ReportOutcome:
    """Analyse ``channels`` of ``table`` and write the page, its JSON and the posteriors into
    ``folder``.

    ``discoveries``: discovery findings to show on the page and keep in the JSON, either a
    dict channel -> findings, or a function ``(table, data) -> findings or None`` called for
    each channel with the recording and the channel's prepared data
    (:class:`~bayescal._recording.ChannelData`), after its noise analysis.
    """
    from ._noise_fit import parse_terms
    from ._recording import prepare_channel
    from ._sensors import find_card

    parsed_terms = parse_terms(terms)
    card = find_card(sensor) if sensor else None
    if not channels:
        raise InputError(
            "no channels to report",
            source=table.source,
            fix="name them with --channels gyro_x,gyro_y,...",
        )
    if len(set(channels)) != len(channels):
        raise InputError("--channels names a column twice", fix="name each column once")
    prepared = [
        prepare_channel(
            table,
            channel,
            rate=rate,
            time_column=time_column,
            time_unit=time_unit,
            start=start,
            stop=stop,
            gaps=gaps,
        )
        for channel in channels
    ]
    folder = Path(folder)
    folder.mkdir(exist_ok=True)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(prepared) + 1, desc="report", unit="step", file=sys.stderr)
    settings = {
        "terms": ", ".join(parsed_terms),
        "sensor card": card.name if card else "none (weakly informative priors)",
        "confidence of classical intervals": f"{100 * confidence:g} %",
        "seed": str(seed),
    }
    analyses, found_by_channel = [], {}
    try:
        for data in prepared:
            if bar is not None:
                bar.set_postfix_str(data.channel)
            analyses.append(
                analyse_channel(
                    data,
                    terms=parsed_terms,
                    confidence=confidence,
                    taus=taus,
                    card=card,
                    seed=seed,
                    n_walkers=n_walkers,
                    max_steps=max_steps,
                    progress=progress,
                    window=dict(window or {"selected_by": "whole record"}),
                )
            )
            if callable(discoveries):
                found = discoveries(table, data)
                if found is not None:
                    found_by_channel[data.channel] = found
            if bar is not None:
                bar.update(1)
        if not callable(discoveries):
            found_by_channel = dict(discoveries or {})
        if bar is not None:
            bar.set_postfix_str("figures and files")
        outcome = write_report(
            folder,
            analyses,
            stem=stem,
            title=title or f"bayescal report: {Path(stem).name}",
            source=table.source,
            discoveries=found_by_channel,
            settings=settings,
        )
        if bar is not None:
            bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return outcome


def _discovery_hook(args):
    if not args.discover:
        return None
    from ._discover_command import findings_for_report

    return lambda table, data: findings_for_report(table, data, seed=args.seed)


def write_report(
    folder,
    analyses: list,
    *,
    stem: str,
    title: str,
    source: str,
    discoveries: dict | None = None,
    settings: dict | None = None,
) -> ReportOutcome:
    """Write the page, its JSON and each channel's posterior (ArviZ netCDF) into ``folder``,
    each atomically."""
    from ._output import write_atomic, write_json
    from ._posterior_data import noise_datatree, write_netcdf
    from ._report import build_report, report_document

    folder = Path(folder)
    html_path = folder / f"{stem}_report.html"
    json_path = folder / f"{stem}_report.json"
    posteriors = {}
    for analysis in analyses:
        if analysis.fit is None:
            continue
        path = folder / f"{stem}_{analysis.channel}_posterior.nc"
        tree = noise_datatree(
            analysis.fit, analysis.unit, channel=analysis.channel, source=analysis.data.source
        )
        write_netcdf(tree, path)
        posteriors[analysis.channel] = path
    files = {
        "JSON": json_path.name,
        **{f"posterior {channel} (ArviZ netCDF)": p.name for channel, p in posteriors.items()},
    }
    page = build_report(
        analyses,
        title=title,
        source=source,
        discoveries=discoveries,
        files=files,
        settings=settings,
    )
    write_json(
        json_path,
        report_document(analyses, title=title, source=source, discoveries=discoveries, files=files),
    )
    write_atomic(html_path, page)
    for path in (html_path, json_path, *posteriors.values()):
        readable_by_all(path)
    failed = [a for a in analyses if not a.passed]
    return ReportOutcome(html_path, json_path, posteriors, analyses, failed)


def readable_by_all(path) -> None:
    """Give a written file the mode the umask allows (atomic writes go through a private
    temporary file, mode 0600): a report is made to be shared."""
    import os

    umask = os.umask(0)
    os.umask(umask)
    Path(path).chmod(0o666 & ~umask)


def summary_text(outcome: ReportOutcome) -> str:
    """The lines the command prints: one per channel, then where the page is."""
    lines = []
    for analysis in outcome.analyses:
        result = analysis.result
        parameters = result["bayesian"]["parameters"]
        unit = result["unit"]
        noise = "  ".join(
            f"{name} {parameters[name]['mean']:.3g} {parameters[name]['unit']}"
            for name in ("N", "B", "K")
            if name in parameters
        )
        classical = result["classical"]
        t_text = (
            "t-interval valid"
            if classical["t_interval_valid"]
            else f"t-interval too narrow x{classical['t_interval_widening']:.3g}"
        )
        health = "checks passed" if analysis.passed else "HEALTH CHECK FAILED"
        lines.append(
            f"  {analysis.channel:<8} bias {parameters['bias']['mean']:.6g} {unit}  {noise}  "
            f"({t_text}; {health})"
        )
    lines.append(f"report: {outcome.html}")
    return "\n".join(lines)


def run(args) -> int:
    from ._cli import _output_folder, _window
    from ._recording import load_table

    folder = _output_folder(args.out)
    table = load_table(args.file)
    channels = (
        [part.strip() for part in args.channels.split(",") if part.strip()]
        if args.channels
        else default_channels(table)
    )
    start, stop, window = _window(args, table)
    outcome = report_recording(
        table,
        channels,
        folder,
        stem=Path(args.file).stem,
        title=args.title,
        sensor=args.sensor,
        terms=args.terms,
        confidence=args.confidence,
        taus=args.taus,
        seed=args.seed,
        n_walkers=args.walkers,
        max_steps=args.max_steps,
        rate=args.rate,
        time_column=args.time_column,
        time_unit=args.time_unit,
        gaps=args.gaps,
        start=start,
        stop=stop,
        window=window,
        discoveries=_discovery_hook(args),
        progress=not args.quiet and sys.stderr.isatty(),
    )
    print(f"bayescal report: {table.source}")
    print(summary_text(outcome))
    return _health_exit(outcome, "report")


def _health_exit(outcome: ReportOutcome, command: str) -> int:
    if outcome.failed:
        print(
            f"bayescal {command}: HEALTH CHECK FAILED for "
            + "; ".join(
                f"{a.channel}: {', '.join(a.fit.diagnostics.failures)}" for a in outcome.failed
            ),
            file=sys.stderr,
        )
        return 1
    return 0
