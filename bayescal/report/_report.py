"""The report of one recording: the noise analysis of every channel, classical and Bayesian,
written as one self-contained HTML page per sensor plus the JSON and the ArviZ netCDF behind
it (``bayescal report`` and ``bayescal demo``).

Files in the output folder, for a recording ``imu.csv``: ``imu_report.html`` (the page),
``imu_report.json`` (every channel's ``noise`` document, the numbers behind the figures, the
datasheet comparison, the discovery findings) and ``imu_<channel>_posterior.nc`` per channel.
Each is written atomically.
"""

import sys
from dataclasses import dataclass, field
from pathlib import Path

from .._errors import InputError
from .._output import file_stem, write_atomic, write_json, write_netcdf
from ..capabilities._noise import fit_noise
from ..inference._sampler import Sampler
from ..models._terms import parameter_unit, parse_terms
from ..recording._recording import Channel, prepare_channel
from ..recording._sensor_cards import find_card
from ._filter_config import report_filter_noise
from ._html import ChannelAnalysis, build_report, report_document, with_bands, with_effects
from ._noise import NoiseAnalysis, Window

DEFAULT_TERMS = "auto"


@dataclass(frozen=True)
class ReportOutcome:
    """What a report wrote (the page, its JSON, each channel's posterior) and what it
    shows: every channel's analysis, those whose checks failed, the discoveries by
    channel."""

    html: Path
    json: Path
    posteriors: dict
    analyses: list
    failed: list
    findings: dict = field(default_factory=dict)
    """channel -> its :class:`~bayescal.report._discovery.Findings`."""

    @property
    def passed(self) -> bool:
        return not self.failed


def analyse_channel(
    data: Channel,
    *,
    terms: tuple[str, ...],
    confidence: float = 0.95,
    taus="octave",
    card=None,
    seed: int = 0,
    sampler: Sampler = Sampler(),
    window: dict | None = None,
) -> ChannelAnalysis:
    """Classical and Bayesian noise of one prepared channel, with the posterior bands of the
    figures and, with a sensor card, the datasheet comparison. ``window``: how the window
    was chosen (``selected_by`` and what a pad search found, with its notes)."""
    fit = fit_noise(
        data,
        terms=terms,
        sensor=card,
        sensor_fallback=True,
        seed=seed,
        confidence=confidence,
        taus=taus,
        sampler=sampler,
    )
    described, notes = Window.described(
        {"start_s": data.start_s, "stop_s": data.stop_s, **(window or {})}
    )
    noise = NoiseAnalysis.of(fit, fit.classical, described, fit, notes=notes)
    return with_bands(noise, seed=seed, card=card)


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
    sampler: Sampler = Sampler(),
    rate: float | None = None,
    time_column: str | None = None,
    time_unit: str | None = None,
    gaps: str = "error",
    start: float | None = None,
    stop: float | None = None,
    options: dict | None = None,
    window: dict | None = None,
    discoveries=None,
) -> ReportOutcome:
    """Analyse ``channels`` of ``table`` and write the page, its JSON and the posteriors into
    ``folder``.

    ``options``: channel -> more arguments of :func:`~bayescal.recording._recording.
    prepare_channel` for it (its ``unit``, its ``scale``).

    ``discoveries``: discoveries to show on the page and keep in the JSON, either a dict
    channel -> :class:`~bayescal.report._discovery.Findings`, or a function ``(table, data)
    -> Findings or None`` called for each channel with the recording and the channel's
    prepared data (:class:`~bayescal.Channel`), after its noise analysis.

    ``sampler``: how every posterior is sampled; its ``progress`` also shows the report's own
    bar over the channels.

    Over 80 lines: one pass over the channels with the progress bar and the discoveries it
    interleaves, then the files.
    """
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
            rate_hz=rate,
            time_column=time_column,
            time_unit=time_unit,
            start=start,
            stop=stop,
            gaps=gaps,
            **(options or {}).get(channel, {}),
        )
        for channel in channels
    ]
    folder = Path(folder)
    folder.mkdir(exist_ok=True)
    bar = None
    if sampler.progress:
        from tqdm import tqdm

        bar = tqdm(total=len(prepared) + 1, desc="report", unit="step", file=sys.stderr)
    settings = {
        "terms": "chosen by evidence per channel (auto)"
        if parsed_terms == "auto"
        else ", ".join(parsed_terms),
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
                    sampler=sampler,
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
        # Where discovery found what a channel's noise model lacks, its numbers come from the
        # model that holds it (one more posterior for each such channel).
        if bar is not None and found_by_channel:
            bar.set_postfix_str("the models with discovery's effects")
        analyses = [
            with_effects(
                analysis, found_by_channel[analysis.channel], seed=seed, sampler=sampler, card=card
            )
            if analysis.channel in found_by_channel
            else analysis
            for analysis in analyses
        ]
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
    folder = Path(folder)
    html_path = folder / f"{stem}_report.html"
    json_path = folder / f"{stem}_report.json"
    posteriors = {}
    for analysis in analyses:
        if analysis.fit is None:
            continue
        path = folder / f"{stem}_{file_stem(analysis.channel)}_posterior.nc"
        write_netcdf(analysis.noise.noise.posterior, path)
        posteriors[analysis.channel] = path
    files = {
        "JSON": json_path.name,
        **{f"posterior {channel} (ArviZ netCDF)": p.name for channel, p in posteriors.items()},
    }
    navigation_filter = report_filter_noise(analyses)
    page = build_report(
        analyses,
        title=title,
        source=source,
        discoveries=discoveries,
        files=files,
        settings=settings,
        navigation_filter=navigation_filter,
    )
    write_json(
        json_path,
        report_document(
            analyses,
            title=title,
            source=source,
            discoveries=discoveries,
            files=files,
            navigation_filter=navigation_filter,
        ),
    )
    write_atomic(html_path, page)
    failed = [a for a in analyses if not a.passed]
    return ReportOutcome(
        html_path, json_path, posteriors, analyses, failed, dict(discoveries or {})
    )


def summary_text(outcome: ReportOutcome) -> str:
    """The lines the command prints: one per channel (its noise from the model that holds
    what discovery found on it, where it found something the noise model lacks), what
    discovery found, then where the page is."""
    lines = []
    for analysis in outcome.analyses:
        noise, unit, effects = analysis.noise, analysis.unit, analysis.effects
        parameters = noise.noise.parameters
        t_interval = noise.classical.t_interval
        t_text = (
            "t-interval valid"
            if t_interval.valid
            else f"t-interval too narrow x{t_interval.widening:.3g}"
        )
        health = "checks passed" if analysis.passed else "HEALTH CHECK FAILED"
        if effects is None:
            shown = "  ".join(
                f"{name} {parameters[name].mean:.3g} {parameter_unit(name, unit)}"
                for name in ("N", "B", "K")
                if name in parameters
            )
            lines.append(
                f"  {analysis.channel:<8} bias {parameters['bias'].mean:.6g} {unit}  {shown}  "
                f"({t_text}; {health})"
            )
        else:
            shown = "  ".join(
                f"{name} {entry['mean']:.3g} {entry['unit']}"
                for name, entry in effects.parameters.items()
            )
            lines.append(
                f"  {analysis.channel:<8} with {' and '.join(effects.effects)}: {shown}  "
                f"({t_text}; {health})"
            )
        findings = outcome.findings.get(analysis.channel)
        if findings is not None:
            lines += _discovery_lines(analysis, findings)
    lines.append(f"report: {outcome.html}")
    return "\n".join(lines)


def _discovery_lines(analysis: ChannelAnalysis, findings) -> list[str]:
    """What discovery found on a channel, and what the noise model read without it."""
    discovery, indent = findings.discovery, " " * 11
    if not discovery.effects:
        return [f"{indent}discovery: nothing found (its baseline explains the record)"]
    lines = []
    for effect in discovery.effects:
        score = effect.evidence.get("log_bayes_factor")
        evidence = "" if score is None else f" (log Bayes factor {score:.1f})"
        lines.append(f"{indent}discovery found {effect.name}{evidence}: {effect.explanation}")
    effects = analysis.effects
    if effects is not None:
        parameters, unit = analysis.noise.noise.parameters, analysis.unit
        absorbed = "  ".join(
            f"{name} {parameters[name].mean:.3g} {parameter_unit(name, unit)}"
            for name in ("N", "B", "K")
            if name in parameters
        )
        lines.append(
            f"{indent}the noise model without it ({', '.join(analysis.noise.noise.terms)}) "
            f"read {absorbed}: contaminated, not shown above"
        )
    return lines
