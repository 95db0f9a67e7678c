"""The per-sensor report: one self-contained HTML page (figures embedded as PNG, no external
resource, opens offline) for the channels of one recording, classical and Bayesian side by
side, with the health checks of every posterior and the discovery findings; and the JSON
behind it.

What a channel's part of the page shows is one typed :class:`ChannelAnalysis`: its noise
(:class:`~bayescal.report._noise.NoiseAnalysis`), the posterior bands of its figures
(:func:`~bayescal.inference._bands.allan_band`, :func:`~bayescal.inference._bands.spectrum_band`),
the comparison with its sensor card (:class:`DatasheetComparison`) and its discovery
(:class:`~bayescal.report._discovery.Findings`). The page (:func:`build_report`) and the JSON
(:func:`report_document`: each channel's ``noise`` document with the numbers behind its
figures, the datasheet comparison and the discovery documents) both read those objects; the
figures are :mod:`._figures`'.
"""

import datetime
from dataclasses import dataclass, replace
from importlib.metadata import version

from .._errors import InputError
from ..capabilities._effect_noise import EffectNoise, noise_with_effects
from ..inference._bands import AllanBand, SpectrumBand, allan_band, spectrum_band
from ..inference._sampler import Sampler
from ..models._terms import PARAMETERS, card_values, display_values, parameter_unit
from ._discovery import Findings, discovery_document, discovery_figures
from ._figures import allan_figure, embedded, pair_figure, spectrum_figure
from ._filter_config import ReportFilterNoise, filter_section, report_filter_document
from ._format import (
    esc,
    interval,
    num,
    page_start,
    percent,
    pretty_unit,
    quantity,
    stacked,
)
from ._noise import (
    BIAS_DEFINITION,
    INTERVAL,
    NoiseAnalysis,
    display_summary,
    frequency_text,
    noise_document,
    read_at,
)
from ._noise import t_interval_explanation as explanation_of

DATASHEET_TOLERANCE = (0.8, 1.25)
_PARAMETER_NAMES = {"bias": "bias (turn-on)"} | {
    name: f"{name} {p.meaning}" for name, p in PARAMETERS.items()
}
DATASHEET_NOTE = (
    "the posterior used the card as its prior (log-normal, sd log 3); the "
    "classical reading is independent of it. Verdicts from the 90 % interval of "
    "measured / datasheet: better (worse) when it lies below 0.8 (above 1.25), as the "
    "datasheet when inside [0.8, 1.25]"
)


@dataclass(frozen=True)
class DatasheetRow:
    """One figure of a sensor card beside the unit's classical reading and posterior."""

    parameter: str
    datasheet: float
    """The card's value, in :attr:`unit`."""
    unit: str
    source: str
    """Where on the datasheet it comes from."""
    display: dict
    """The card's value in the units datasheets use (label -> value)."""
    classical: object | None = None
    """The IEEE 952 reading (:class:`~bayescal.SlopeReading`), when there is one."""
    bayesian: dict | None = None
    """The posterior's ``mean``, ``q05`` and ``q95``, when the model holds the term."""

    @property
    def ratio(self) -> dict | None:
        """Measured / datasheet: mean, q05 and q95 of the posterior over the card's value."""
        if self.bayesian is None:
            return None
        return {key: value / self.datasheet for key, value in self.bayesian.items()}

    @property
    def verdict(self) -> str | None:
        """Better or worse when the 90 % interval of measured / datasheet lies wholly below
        0.8 or above 1.25 (datasheets quote typical units, so a few percent is no verdict),
        as the datasheet when it lies within [0.8, 1.25], else not resolved."""
        ratio = self.ratio
        if ratio is None:
            return None
        low, high = DATASHEET_TOLERANCE
        if ratio["q95"] < low:
            return "better than the datasheet"
        if ratio["q05"] > high:
            return "worse than the datasheet"
        if ratio["q05"] >= low and ratio["q95"] <= high:
            return "as the datasheet (within -20 %/+25 %)"
        return "consistent with the datasheet, not resolved to ±25 %"

    def as_dict(self) -> dict:
        row = {
            "datasheet": self.datasheet,
            "unit": self.unit,
            "source": self.source,
            "display": self.display,
        }
        if self.classical is not None:
            row["classical"] = {
                key: getattr(self.classical, key) for key in ("value", "ci_low", "ci_high", "kind")
            }
        if self.bayesian is not None:
            row["bayesian"] = dict(self.bayesian)
            row["ratio"] = self.ratio
            row["verdict"] = self.verdict
        return row


@dataclass(frozen=True)
class DatasheetComparison:
    """How the measured unit compares with its sensor card, figure by figure
    (:func:`datasheet_comparison`); ``unavailable`` says why there is none."""

    card: str
    datasheet: str
    rows: tuple[DatasheetRow, ...] = ()
    unavailable: str | None = None

    def as_dict(self) -> dict:
        if self.unavailable is not None:
            return {"card": self.card, "datasheet": self.datasheet, "unavailable": self.unavailable}
        return {
            "card": self.card,
            "datasheet": self.datasheet,
            "parameters": {row.parameter: row.as_dict() for row in self.rows},
            "note": DATASHEET_NOTE,
        }


def _interval_of(summary) -> dict:
    """mean, q05, q95 of a posterior summary (typed or a dict)."""
    if isinstance(summary, dict):
        return {key: summary[key] for key in ("mean", "q05", "q95")}
    return {key: getattr(summary, key) for key in ("mean", "q05", "q95")}


def datasheet_comparison(card, analysis: NoiseAnalysis, effects=None) -> DatasheetComparison:
    """How the measured unit compares with its sensor card: for each figure the card gives,
    the datasheet value, the classical reading and the posterior (of the model with the
    effects discovery found, ``effects``, where it found any the noise model lacks), their
    ratio and a verdict (:attr:`DatasheetRow.verdict`); ``unavailable`` when the card has no
    section for this kind of channel."""
    unit = analysis.unit
    try:
        values = card_values(card, unit)
    except InputError as error:
        return DatasheetComparison(card.name, card.datasheet, unavailable=str(error))
    if effects is not None:
        posterior = effects.parameters
    else:
        posterior = {} if analysis.noise is None else analysis.noise.parameters
    posterior = {name: _interval_of(summary) for name, summary in posterior.items()}
    readings = analysis.classical.slope_readings
    rows = tuple(
        DatasheetRow(
            parameter=parameter,
            datasheet=value,
            unit=parameter_unit(parameter, unit),
            source=source,
            display=display_values(parameter, value, unit),
            classical=readings.get(parameter),
            bayesian=posterior.get(parameter),
        )
        for parameter, (value, source) in values.items()
    )
    return DatasheetComparison(card.name, card.datasheet, rows)


@dataclass(frozen=True)
class ChannelAnalysis:
    """Everything the page shows of one channel: its noise, the posterior bands of its
    figures (None without a posterior), how it compares with its sensor card and, where
    discovery found effects the noise model lacks, the noise in the model that holds them
    (:class:`~bayescal.capabilities._effect_noise.EffectNoise`): the channel's numbers then
    come from it, and the noise model's are shown as contaminated."""

    noise: NoiseAnalysis
    allan: AllanBand | None = None
    spectrum: SpectrumBand | None = None
    datasheet: DatasheetComparison | None = None
    effects: EffectNoise | None = None

    @property
    def channel(self) -> str:
        return self.noise.channel

    @property
    def unit(self) -> str:
        return self.noise.unit

    @property
    def fit(self):
        """The posterior (None: classical only)."""
        return self.noise.fit

    @property
    def failures(self) -> list[str]:
        """The failed sampler checks, then the misfits (of the model with the effects too)."""
        failures = [] if self.noise.noise is None else list(self.noise.noise.failures)
        if self.effects is not None:
            failures += [f"{_with(self.effects)}: {f}" for f in self.effects.failures]
        return failures

    @property
    def passed(self) -> bool:
        return not self.failures


def _with(effects: EffectNoise) -> str:
    """The model with the effects, in words: ``the model with thermal_bias``."""
    return "the model with " + " and ".join(effects.effects)


def with_bands(noise: NoiseAnalysis, *, seed: int = 0, card=None) -> ChannelAnalysis:
    """The page's view of a channel: its noise with the posterior bands of its figures and,
    with a sensor card, the datasheet comparison."""
    allan = spectrum = None
    if noise.fit is not None:
        allan = allan_band(noise.fit, noise.classical.allan, seed=seed)
        spectrum = spectrum_band(noise.fit, seed=seed)
    datasheet = None if card is None else datasheet_comparison(card, noise)
    return ChannelAnalysis(noise, allan, spectrum, datasheet)


def with_effects(
    analysis: ChannelAnalysis, findings: Findings, *, seed: int = 0, sampler=None, card=None
) -> ChannelAnalysis:
    """``analysis`` told with its discovery: where discovery found effects the noise model
    lacks, the noise of the model that holds them
    (:func:`~bayescal.capabilities._effect_noise.noise_with_effects`) and the datasheet
    comparison made from it; unchanged otherwise."""
    if analysis.noise.noise is None:
        return analysis
    effects = noise_with_effects(
        analysis.noise.noise, findings.discovery, seed=seed, sampler=sampler or Sampler()
    )
    if effects is None:
        return analysis
    datasheet = None if card is None else datasheet_comparison(card, analysis.noise, effects)
    return replace(analysis, effects=effects, datasheet=datasheet)


# ---------------------------------------------------------------------------------------------
# A channel's part of the page


def _posterior(summary, unit: str) -> str:
    """A posterior summary (mean [q05, q95]) with its unit."""
    return interval(summary.mean, summary.q05, summary.q95, unit)


def _classical_cell(name: str, noise: NoiseAnalysis) -> str:
    classical = noise.classical
    shown = percent(classical.confidence)
    if name == "bias":
        return (
            interval(classical.bias, classical.bias_ci_low, classical.bias_ci_high, noise.unit)
            + f" <span class='note'>(sample mean, {shown} Student-t)</span>"
        )
    reading = classical.slope_readings.get(name)
    if reading is None:
        return "—"
    unit = parameter_unit(name, noise.unit)
    if reading.kind == "upper_bound":
        return f"≤ {quantity(reading.ci_high, unit)} <span class='note'>(upper bound)</span>"
    return (
        interval(reading.value, reading.ci_low, reading.ci_high, unit)
        + f" <span class='note'>({esc(read_at(reading))}, {shown})</span>"
    )


def _display_cell(name: str, summary, unit: str) -> str:
    if summary is None:
        return "—"
    items = [
        interval(shown["mean"], shown["q05"], shown["q95"], label)
        for label, shown in display_summary(name, summary, unit).items()
    ]
    return "<br>".join(items) or "—"


def _t_interval_html(noise: NoiseAnalysis) -> str:
    classical = noise.classical
    explanation = esc(explanation_of(classical))
    if classical.t_interval.valid:
        return f"<p class='ok'>Student-t interval of the bias: valid — {explanation}.</p>"
    widening = num(classical.t_interval.widening, 3)
    low, high = classical.widened_interval
    return (
        f"<p class='bad'>Student-t interval of the bias NOT VALID — too narrow by ×{widening}: "
        f"{explanation}. Widened interval (half-width ×{widening}): "
        f"[{num(low)}, {num(high)}]&nbsp;{esc(pretty_unit(noise.unit))}.</p>"
    )


def _line_frequencies(fit) -> list[float]:
    """The frequencies (Hz) of the spectral lines the noise fit ``fit`` took out, if any."""
    block = None if fit.lines is None else fit.lines.as_dict()
    return [line["frequency"]["mean"] for line in block["lines"]] if block else []


def _lines_table(noise: NoiseAnalysis) -> str:
    """The spectral lines of the channel: frequency, amplitude (or power and width) with
    intervals, the test's ratio, aliased or not."""
    fit = noise.noise
    block = None if fit is None or fit.lines is None else fit.lines.as_dict()
    if not block or not block["lines"]:
        return ""
    rows = []
    for line in block["lines"]:
        kind = (
            f"broadened, {quantity(line['width_hz'], 'Hz')} wide"
            if line["kind"] == "broadened"
            else "sinusoid"
        )
        if line["aliased"]:
            kind += f"; aliased (the filter passes {percent(line['filter_gain'])} there)"
        amplitude, power = line["amplitude"], line["power"]
        cells = (
            esc(frequency_text(line["frequency"])),
            interval(amplitude["mean"], amplitude["q05"], amplitude["q95"], noise.unit),
            interval(power["mean"], power["q05"], power["q95"], power["unit"]),
            num(line["ratio_to_floor"], 3),
        )
        rows.append(
            "<tr>"
            + "".join(f"<td class='num'>{cell}</td>" for cell in cells)
            + f"<td>{kind}</td></tr>"
        )
    test = block["test"]
    return (
        f"<h4>Spectral lines ({len(block['lines'])}): taken out of the record the noise model "
        "was fitted to, so that N is the floor between them</h4><table><thead><tr>"
        "<th>frequency</th><th>amplitude (peak): mean [5 %, 95 %]</th><th>power</th>"
        "<th>× the floor</th><th>kind</th></tr></thead><tbody>"
        + "".join(rows)
        + f"</tbody></table><p class='note'>Found by {esc(test['method'])}, family-wise "
        f"{100 * test['family_wise_level']:g} % over {test['frequencies_searched']:,} "
        f"frequencies; resolution {quantity(test['resolution_hz'], 'Hz')}.</p>"
    )


def _side_by_side_table(noise: NoiseAnalysis) -> str:
    parameters = {} if noise.noise is None else noise.noise.parameters
    names = list(parameters) or ["bias", *noise.classical.slope_readings]
    rows = []
    for name in names:
        summary = parameters.get(name)
        unit = parameter_unit(name, noise.unit)
        bayesian = (
            _posterior(summary, unit) + f"<br><span class='note'>MAP {quantity(summary.map, unit)}"
            f" ± {quantity(summary.map_sd, unit)}</span>"
            if summary
            else "—"
        )
        rows.append(
            f"<tr><td>{esc(_PARAMETER_NAMES.get(name, name))}</td>"
            f"<td class='num'>{_classical_cell(name, noise)}</td><td class='num'>{bayesian}</td>"
            f"<td class='num'>{_display_cell(name, summary, noise.unit)}</td></tr>"
        )
    rows.append(
        f"<tr><td>standard deviation of the samples</td><td class='num'>"
        f"{quantity(noise.classical.std, noise.unit)}</td><td>—</td><td>—</td></tr>"
    )
    return (
        "<table><thead><tr><th>parameter</th><th>classical</th>"
        "<th>Bayesian: posterior mean [5 %, 95 %]</th><th>Bayesian in datasheet units</th>"
        "</tr></thead><tbody>" + "".join(rows) + "</tbody></table>"
    )


def _datasheet_html(comparison: DatasheetComparison | None) -> str:
    if comparison is None:
        return ""
    head = (
        f"<h4>Against the datasheet: {esc(comparison.card)}</h4>"
        f"<p class='note'>{esc(comparison.datasheet)}</p>"
    )
    if comparison.unavailable is not None:
        return head + f"<p>No comparison: {esc(comparison.unavailable)}</p>"
    rows = []
    for row in comparison.rows:
        unit = row.unit
        shown = "".join(
            f"<br><span class='note'>= {quantity(value, label)}</span>"
            for label, value in row.display.items()
        )
        classical = row.classical
        classical_text = (
            "—"
            if classical is None
            else f"≤ {quantity(classical.ci_high, unit)}"
            if classical.kind == "upper_bound"
            else interval(classical.value, classical.ci_low, classical.ci_high, unit)
        )
        posterior_text = (
            interval(row.bayesian["mean"], row.bayesian["q05"], row.bayesian["q95"], unit)
            if row.bayesian
            else "— (term not in the model)"
        )
        verdict = row.verdict or "—"
        ratio = row.ratio
        ratio_text = (
            f"{num(ratio['mean'], 3)} [{num(ratio['q05'], 3)}, {num(ratio['q95'], 3)}]"
            "&nbsp;(dimensionless)"
            if ratio
            else "—"
        )
        css = "bad" if verdict.startswith("worse") else "ok" if verdict.startswith("better") else ""
        rows.append(
            f"<tr><td>{esc(_PARAMETER_NAMES.get(row.parameter, row.parameter))}</td>"
            f"<td class='num'>{quantity(row.datasheet, unit)}{shown}<br>"
            f"<span class='note'>{esc(row.source)}</span></td>"
            f"<td class='num'>{classical_text}</td><td class='num'>{posterior_text}</td>"
            f"<td class='num'>{ratio_text}</td>"
            f"<td class='{css}'>{esc(verdict)}</td></tr>"
        )
    return (
        head + "<table><thead><tr><th>parameter</th><th>datasheet</th><th>classical reading</th>"
        "<th>posterior mean [5 %, 95 %]</th><th>measured / datasheet</th><th>verdict</th>"
        "</tr></thead><tbody>"
        + "".join(rows)
        + f"</tbody></table><p class='note'>{esc(DATASHEET_NOTE)}.</p>"
    )


def _link(effects: EffectNoise) -> str:
    """The effects, each linked to the channel's discovery section."""
    target = f"#discovery-{esc(effects.channel)}"
    return " and ".join(
        f"<a href='{target}'><code>{esc(name)}</code></a>" for name in effects.effects
    )


def _effects_html(analysis: ChannelAnalysis) -> str:
    """The channel's story where discovery found effects its noise model lacks: what was
    found, the noise and the effects' parameters from the model that holds them, its
    checks; and that the noise model below is contaminated."""
    effects, noise = analysis.effects, analysis.noise.noise
    rows = []
    for name, entry in effects.parameters.items():
        shown = "<br>".join(
            interval(values["mean"], values["q05"], values["q95"], label)
            for label, values in display_summary(name, entry, analysis.unit).items()
        )
        rows.append(
            f"<tr><td>{esc(_PARAMETER_NAMES.get(name, name))}</td><td class='num'>"
            f"{interval(entry['mean'], entry['q05'], entry['q95'], entry['unit'])}</td>"
            f"<td class='num'>{shown or '—'}</td></tr>"
        )
    d = effects.diagnostics
    health = (
        "<span class='ok'>passed</span>"
        if not d.failures
        else "<span class='bad'>FAILED: " + esc("; ".join(d.failures)) + "</span>"
    )
    failing = [check for check in effects.checks if not check.passed]
    fits = (
        "<span class='ok'>passed</span> ("
        + esc(", ".join(check.name.replace("_", " ") for check in effects.checks))
        + ")"
        if not failing
        else "<span class='bad'>FAILED: " + esc("; ".join(c.misfit for c in failing)) + "</span>"
    )
    added = (
        f" ({esc(', '.join(effects.added))} from the noise model, so that each of its numbers "
        "has its counterpart)"
        if effects.added
        else ""
    )
    return (
        f"<div class='story' id='story-{esc(analysis.channel)}'><p><b>Discovery found "
        f"{_link(effects)} on this channel</b>, which the noise model below (terms "
        f"{esc(', '.join(noise.terms))}) lacks: that model absorbed it into its own terms, and "
        "its noise numbers are <b>contaminated</b>. This channel's numbers (the summary's and "
        "the datasheet comparison's) come from the model that holds it: "
        f"<code>{esc(' + '.join(effects.terms))}</code>{added}.</p>"
        "<table><thead><tr><th>parameter</th><th>posterior mean [5 %, 95 %]</th>"
        "<th>in datasheet units</th></tr></thead><tbody>" + "".join(rows) + "</tbody></table>"
        f"<p class='note'>Its posterior checks: {health}: {d.n_steps}&nbsp;steps × "
        f"{d.n_walkers}&nbsp;walkers, max R-hat {num(max(d.rhat.values()), 4)}, min bulk ESS "
        f"{num(min(d.ess_bulk.values()), 4)}. Its checks against the record: {fits}.</p></div>"
    )


def _channel_section(analysis: ChannelAnalysis, findings: Findings | None) -> str:
    noise = analysis.noise
    classical, window = noise.classical, noise.window
    parts = [
        f"<section id='channel-{esc(analysis.channel)}'>",
        f"<h2>{esc(analysis.channel)} [{esc(pretty_unit(analysis.unit))}]</h2>",
        f"<p>{classical.n_samples}&nbsp;samples at {quantity(classical.rate_hz, 'Hz')}, "
        f"{quantity(classical.duration_s, 's')}; window {quantity(window.start_s, 's')} to "
        f"{quantity(window.stop_s, 's')} ({esc(window.selected_by)}).</p>",
    ]
    if analysis.fit is not None and not analysis.passed:
        parts.append(
            "<div class='alarm'><b>POSTERIOR CHECKS FAILED — do not use the Bayesian numbers "
            "of this channel:</b><ul>"
            + "".join(f"<li>{esc(f)}</li>" for f in analysis.failures)
            + "</ul></div>"
        )
    parts.append(_t_interval_html(noise))
    effects = analysis.effects
    if effects is not None:
        parts.append(_effects_html(analysis))
        parts.append(_datasheet_html(analysis.datasheet))
        parts.append(
            f"<h3>The noise model without {esc(' and '.join(effects.effects))} "
            "(contaminated)</h3><p class='bad'>Contaminated by "
            f"{_link(effects)}: the numbers and figures of this model, below, show the effect "
            "absorbed into its terms; do not report them.</p>"
        )
    parts.append(_side_by_side_table(noise))
    parts.append(_lines_table(noise))
    fit = noise.fit
    if fit is not None:
        parts.append(
            f"<p class='note'>Model terms: {esc(', '.join(fit.terms))}. Prior: "
            f"{esc(fit.problem.prior.description)}. Bias: {esc(BIAS_DEFINITION)}. "
            f"Seed {fit.seed}.</p>"
        )
        if noise.comparison:
            parts.append(
                "<p><b>Where classical and Bayesian disagree:</b></p><ul>"
                + "".join(f"<li>{esc(note)}</li>" for note in noise.comparison)
                + "</ul>"
            )
    if effects is None:
        parts.append(_datasheet_html(analysis.datasheet))
    channel, unit = analysis.channel, analysis.unit
    checks = () if noise.noise is None else noise.noise.checks
    allan_check = next((check for check in checks if check.name == "allan_deviation"), None)
    parts.append(
        embedded(
            allan_figure(channel, unit, classical.allan, analysis.allan, allan_check),
            f"{channel}: Allan deviation",
        )
    )
    if fit is not None:
        if analysis.spectrum is not None:
            parts.append(
                embedded(
                    spectrum_figure(
                        channel, unit, analysis.spectrum, _line_frequencies(noise.noise)
                    ),
                    f"{channel}: spectrum",
                )
            )
        parts.append(embedded(pair_figure(channel, unit, fit), f"{channel}: posterior pairs"))
    if noise.notes:
        parts.append(
            "<p class='note'>Notes:</p><ul class='note'>"
            + "".join(f"<li>{esc(note)}</li>" for note in noise.notes)
            + "</ul>"
        )
    if findings is not None:
        parts.append(discovery_section(findings, analysis.effects))
    parts.append("</section>")
    return "\n".join(parts)


# ---------------------------------------------------------------------------------------------
# Discovery


def _location_text(location) -> str:
    if isinstance(location, dict):
        return "; ".join(
            f"{esc(key)} = {_keyed_value(key, value)}" for key, value in location.items()
        )
    if isinstance(location, (list, tuple)):
        return ", ".join(num(item) for item in location)
    if location is None:
        return "—"
    return num(location) if isinstance(location, (int, float)) else esc(location)


_KEY_UNITS = (
    ("_hz", "Hz"),
    ("_s", "s"),
    ("_degc", "°C"),
    ("_deg", "deg"),
    ("p_value", "(probability)"),
)


def _keyed_value(key: str, value) -> str:
    """A value from a discovery's location or evidence, with the unit its key names
    (tau_s -> s)."""
    if isinstance(value, dict):
        return "{" + _location_text(value) + "}"
    if isinstance(value, (list, tuple)):
        text = ", ".join(num(item) for item in value[:8])
        if len(value) > 8:
            text += ", …"
        value_text = f"[{text}]"
    elif isinstance(value, bool) or not isinstance(value, (int, float)):
        return esc(value)
    else:
        value_text = num(value)
    lowered = key.lower()
    for suffix, unit in _KEY_UNITS:
        if lowered.endswith(suffix):
            return f"{value_text}&nbsp;{esc(unit)}"
    return f"{value_text}&nbsp;(as reported)"


def _parameters_text(parameters: dict) -> str:
    items = []
    for name, entry in parameters.items():
        if "q05" in entry:
            shown = interval(entry["mean"], entry["q05"], entry["q95"], entry["unit"])
        else:
            shown = quantity(entry.get("mean", entry.get("value")), entry.get("unit", ""))
        items.append(f"{esc(name)} = {shown}")
    return "<br>".join(items) or "—"


def discovery_section(findings: Findings, story: EffectNoise | None = None) -> str:
    """HTML of a channel's discovery: the effects found with their evidence, the checks
    before and after, and the figures (:func:`~bayescal.report._discovery.discovery_figures`).
    ``story``: the channel's model with the effects, when its numbers come from it (a note
    says where its parameters differ from discovery's final model's)."""
    discovery = findings.discovery
    channel = discovery.channel
    parts = [
        f'<section class="discovery" id="discovery-{esc(channel)}">'
        f"<h3>Discovery: {esc(channel)}</h3>",
        "<p>Baseline model: <code>"
        + esc(" + ".join(discovery.baseline))
        + "</code>; final model: <code>"
        + esc(" + ".join(discovery.final_terms))
        + "</code>.</p>",
    ]
    if not discovery.effects:
        parts.append(
            '<p class="ok">No effect found: the baseline model explains the recording.</p>'
        )
    else:
        parts.append(
            "<table><thead><tr><th>effect</th><th>explanation</th>"
            "<th>ΔELPD ± SE</th><th>parameters (mean [5 %, 95 %])</th>"
            "<th>where</th><th>evidence</th></tr></thead><tbody>"
        )
        for effect in discovery.effects:
            parts.append(
                f"<tr><td><code>{esc(effect.name)}</code></td>"
                f"<td>{esc(effect.explanation)}</td>"
                f"<td>{num(effect.delta_elpd)} ± {num(effect.delta_elpd_se)}&nbsp;nats</td>"
                f"<td>{_parameters_text(effect.parameters)}</td>"
                f"<td>{_location_text(effect.location)}</td>"
                f"<td>{_location_text(effect.evidence)}</td></tr>"
            )
        parts.append("</tbody></table>")
    if story is not None and story.added:
        parts.append(
            "<p class='note'>The parameters above are those of discovery's final model; the "
            f"channel's numbers (<a href='#story-{esc(channel)}'>above</a>) come from that "
            f"model with the noise model's {esc(', '.join(story.added))} added, whose "
            "intervals are wider where the terms compete for the same drift.</p>"
        )
    parts.append(
        "<h4>Checks of the baseline (posterior predictive)</h4><table><thead><tr>"
        "<th>check</th><th>statistic (as defined by the check)</th>"
        "<th>p-value (probability)</th><th>where</th><th>after the new terms</th>"
        "</tr></thead><tbody>"
    )
    for check in discovery.checks:
        after = "passes" if check.passed_after else '<span class="bad">still fails</span>'
        parts.append(
            f"<tr><td>{esc(check.name)}</td>"
            f"<td>{num(check.statistic)}&nbsp;(as reported)</td>"
            f"<td>{num(check.p_value)}&nbsp;(probability)</td>"
            f"<td>{_location_text(check.location)}</td><td>{after}</td></tr>"
        )
    parts.append("</tbody></table>")
    for figure, alt in discovery_figures(findings).values():
        parts.append(embedded(figure, f"{channel} discovery: {alt}"))
    parts.append("</section>")
    return "\n".join(parts)


# ---------------------------------------------------------------------------------------------
# The page


def _summary_table(analyses: list[ChannelAnalysis]) -> str:
    rows = []
    for analysis in analyses:
        noise = analysis.noise
        classical = noise.classical
        parameters = {} if noise.noise is None else noise.noise.parameters
        classical_bias = stacked(
            classical.bias, classical.bias_ci_low, classical.bias_ci_high, noise.unit
        )
        t_text = (
            "<span class='ok'>valid</span>"
            if classical.t_interval.valid
            else f"<span class='bad'>INVALID: ×{num(classical.t_interval.widening, 3)} too "
            "narrow</span>"
        )
        health = (
            "—"
            if analysis.fit is None
            else "<span class='ok'>passed</span>"
            if analysis.passed
            else "<span class='bad'>FAILED</span>"
        )
        cells = []
        effects = analysis.effects
        shown_parameters = parameters if effects is None else effects.parameters
        for name in ("bias", "N", "B", "K"):
            summary = shown_parameters.get(name)
            if summary is None:
                cells.append(
                    "<td>—<br><span class='note'>varies with the effect</span></td>"
                    if name == "bias" and effects is not None
                    else "<td>—</td>"
                )
                continue
            low_high = _interval_of(summary)
            shown = stacked(
                low_high["mean"], low_high["q05"], low_high["q95"], parameter_unit(name, noise.unit)
            )
            cells.append(f"<td class='num'>{shown}</td>")
        story = (
            ""
            if effects is None
            else f"<br><span class='note'>from the model with {_link(effects)}</span>"
        )
        rows.append(
            f"<tr{' class=failed' if not analysis.passed else ''}>"
            f"<td><a href='#channel-{esc(analysis.channel)}'>{esc(analysis.channel)}</a>"
            f"{story}</td>"
            f"<td class='num'>{quantity(classical.rate_hz, 'Hz')}<br>"
            f"{quantity(classical.duration_s, 's')}</td>"
            f"<td class='num'>{classical_bias}</td><td>{t_text}</td>"
            + "".join(cells)
            + f"<td>{health}</td></tr>"
        )
    shown = percent(analyses[0].noise.classical.confidence) if analyses else ""
    return (
        "<table><thead><tr><th>channel</th><th>rate, duration</th>"
        f"<th>bias, classical<br>(mean, {shown} Student-t)</th><th>Student-t interval</th>"
        "<th>bias, Bayesian<br>(mean [5 %, 95 %])</th><th>N white noise</th>"
        "<th>B bias instability</th><th>K rate random walk</th><th>posterior checks</th>"
        "</tr></thead><tbody>" + "".join(rows) + "</tbody></table>"
    )


def _health_table(analyses: list[ChannelAnalysis]) -> str:
    rows = []
    for analysis in analyses:
        if analysis.fit is None:
            continue
        d = analysis.fit.diagnostics
        rhat = max(d.rhat.values())
        ess = min(d.ess_bulk.values())
        tau = max(d.autocorr_time.values())
        criterion = "met" if d.converged else "<b>not met</b>"
        status = (
            "<span class='ok'>passed</span>"
            if analysis.passed
            else "<span class='bad'>FAILED: " + esc("; ".join(analysis.failures)) + "</span>"
        )
        fits = (
            "<span class='ok'>yes</span>"
            if analysis.noise.noise.fits
            else "<span class='bad'>MISFIT</span>"
        )
        rows.append(
            f"<tr{' class=failed' if not analysis.passed else ''}><td>{esc(analysis.channel)}</td>"
            f"<td class='num'>{d.n_steps}&nbsp;steps × {d.n_walkers}&nbsp;walkers</td>"
            f"<td class='num'>{num(tau, 3)} ({criterion})</td>"
            f"<td class='num'>{num(rhat, 4)}</td><td class='num'>{num(ess, 4)}</td>"
            f"<td class='num'>{num(d.acceptance_fraction, 3)}</td>"
            f"<td>{'yes' if d.map_converged else '<b>no</b>'}</td><td>{fits}</td>"
            f"<td>{status}</td></tr>"
        )
        if analysis.effects is not None:
            rows.append(_effects_health_row(analysis.effects))
    if not rows:
        return "<p>No posterior was sampled (classical analysis only).</p>"
    return (
        "<table><thead><tr><th>channel</th><th>chain length</th>"
        "<th>autocorrelation time [steps] (chain &gt; 50 τ)</th>"
        "<th>max R-hat [dimensionless] (≤ 1.01)</th><th>min bulk ESS [draws] (≥ 400)</th>"
        "<th>acceptance [fraction of proposals] (0.1–0.8)</th><th>MAP converged</th>"
        "<th>model fits the record (Allan, spectrum, lag-1)</th>"
        "<th>result</th></tr></thead><tbody>" + "".join(rows) + "</tbody></table>"
    )


def _effects_health_row(effects: EffectNoise) -> str:
    d = effects.diagnostics
    status = (
        "<span class='ok'>passed</span>"
        if effects.passed
        else "<span class='bad'>FAILED: " + esc("; ".join(effects.failures)) + "</span>"
    )
    fits = (
        "<span class='ok'>yes</span>"
        if all(check.passed for check in effects.checks)
        else "<span class='bad'>MISFIT</span>"
    )
    return (
        f"<tr{' class=failed' if not effects.passed else ''}><td>{esc(effects.channel)}, "
        f"{esc(_with(effects))}</td>"
        f"<td class='num'>{d.n_steps}&nbsp;steps × {d.n_walkers}&nbsp;walkers</td>"
        f"<td class='num'>{num(max(d.autocorr_time.values()), 3)} "
        f"({'met' if d.converged else '<b>not met</b>'})</td>"
        f"<td class='num'>{num(max(d.rhat.values()), 4)}</td>"
        f"<td class='num'>{num(min(d.ess_bulk.values()), 4)}</td>"
        f"<td class='num'>{num(d.acceptance_fraction, 3)}</td>"
        f"<td>{'yes' if d.map_converged else '<b>no</b>'}</td><td>{fits}</td>"
        f"<td>{status}</td></tr>"
    )


_FIGURES_NOTE = (
    "<p class='note'>Allan figures: black points are the measured overlapping Allan "
    "deviation with classical chi-square bars; the darker band is the model's exact Allan "
    "deviation over posterior draws (parameter uncertainty), the lighter band the "
    "posterior predictive band of what a recording like this one would measure (the same "
    "with the estimator's chi-square scatter), both pointwise 90 %: about one point in ten "
    "lies outside by chance; the dashed lines are the bounds of the model's Allan deviation "
    "check (p-value Bonferroni-corrected over the taus, departures within 10 % tolerated), "
    "outside which a point fails it. Spectrum figures: the binned periodogram "
    "the Whittle likelihood fits, as the two-sided amplitude spectral density of the "
    "samples (white noise reads N), against the model's expected periodogram.</p>"
)


def build_report(
    analyses: list[ChannelAnalysis],
    *,
    title: str,
    source: str,
    discoveries: dict | None = None,
    files: dict | None = None,
    settings: dict | None = None,
    navigation_filter: ReportFilterNoise | None = None,
) -> str:
    """The self-contained HTML page of one sensor's channels.

    ``discoveries`` maps a channel to its discovery (:class:`~bayescal.report._discovery.
    Findings`); ``files`` names the JSON and netCDF files written beside the page;
    ``settings`` are shown as given (name -> text); ``navigation_filter`` what the channels
    tell a navigation filter (:func:`~bayescal.report._filter_config.report_filter_noise`).
    """
    discoveries = discoveries or {}
    failed = [a for a in analyses if not a.passed]
    invalid = [a for a in analyses if not a.noise.classical.t_interval.valid]
    created = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    parts = [
        *page_start(title),
        f"<p class='note'>{esc(source)} — bayescal {esc(version('bayescal'))}, {created}</p>",
    ]
    if failed:
        parts.append(
            "<div class='alarm'><h2>HEALTH CHECK FAILED</h2><p>The posterior of "
            + ", ".join(f"<b>{esc(a.channel)}</b>" for a in failed)
            + " failed its checks; do not use those Bayesian numbers:</p><ul>"
            + "".join(f"<li>{esc(a.channel)}: {esc('; '.join(a.failures))}</li>" for a in failed)
            + "</ul></div>"
        )
    parts.append("<h2>Summary</h2>")
    parts.append(_summary_table(analyses))
    if invalid:
        parts.append(
            "<p class='bad'>The classical Student-t interval of the bias is too narrow for "
            + ", ".join(
                f"{esc(a.channel)} (×{num(a.noise.classical.t_interval.widening, 3)})"
                for a in invalid
            )
            + ": the samples are correlated; see each channel's section for the widened "
            "interval.</p>"
        )
    parts.append("<h2>Posterior health checks</h2>")
    parts.append(_health_table(analyses))
    if settings:
        parts.append(
            "<p class='note'>Settings: "
            + "; ".join(f"{esc(k)}: {esc(v)}" for k, v in settings.items())
            + "</p>"
        )
    if files:
        parts.append(
            "<p class='note'>Behind this page: "
            + "; ".join(f"{esc(k)}: <code>{esc(v)}</code>" for k, v in files.items())
            + "</p>"
        )
    if navigation_filter is not None:
        parts.append(filter_section(navigation_filter, source))
    parts.append(_FIGURES_NOTE)
    for analysis in analyses:
        parts.append(_channel_section(analysis, discoveries.get(analysis.channel)))
    shown = {a.channel for a in analyses}
    for channel, findings in discoveries.items():
        if channel not in shown:
            parts.append(discovery_section(findings))
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def effects_document(analysis: ChannelAnalysis) -> dict:
    """The JSON of a channel's model with the effects discovery found (``with_effects``): the
    numbers the summary shows for it, and why."""
    effects = analysis.effects
    return {
        "effects": list(effects.effects),
        "terms": list(effects.terms),
        "added_from_noise_model": list(effects.added),
        "parameters": {
            name: {**entry, **_display_entry(name, entry, analysis.unit)}
            for name, entry in effects.parameters.items()
        },
        "interval": INTERVAL,
        "diagnostics": effects.diagnostics.as_dict(),
        "fit_checks": [check.as_dict() for check in effects.checks],
        "passed": effects.passed,
        "explanation": f"discovery found {', '.join(effects.effects)}, which the noise model "
        f"({', '.join(analysis.noise.noise.terms)}) lacks and absorbed into its terms (its "
        "numbers, under bayesian, are contaminated): the channel's noise numbers are this "
        "model's, the noise model's terms and the effects together",
    }


def _display_entry(name: str, entry: dict, unit: str) -> dict:
    shown = display_summary(name, entry, unit)
    return {"display": shown} if shown else {}


def report_document(
    analyses: list[ChannelAnalysis],
    *,
    title: str,
    source: str,
    discoveries: dict | None = None,
    files: dict | None = None,
    navigation_filter: ReportFilterNoise | None = None,
) -> dict:
    """The JSON behind the page: each channel's noise document, the posterior bands the
    figures draw, the datasheet comparison, the discovery documents and what the channels
    tell a navigation filter."""
    channels = {}
    for a in analyses:
        figures = {}
        if a.allan is not None:
            figures = {
                "allan": a.allan.as_dict(a.unit),
                "spectrum": a.spectrum.as_dict(f"{a.unit}/sqrt(Hz)"),
            }
        channels[a.channel] = {
            **noise_document(a.noise),
            "figures": figures,
            **({"datasheet": a.datasheet.as_dict()} if a.datasheet else {}),
            **({"with_effects": effects_document(a)} if a.effects else {}),
        }
    return {
        "schema": "bayescal.report",
        "schema_version": 1,
        "bayescal_version": version("bayescal"),
        "title": title,
        "source": source,
        "files": files or {},
        "passed": all(a.passed for a in analyses),
        "channels": channels,
        **(
            {"navigation_filter": report_filter_document(navigation_filter)}
            if navigation_filter is not None
            else {}
        ),
        "discoveries": {
            channel: discovery_document(findings)
            for channel, findings in (discoveries or {}).items()
        },
    }
