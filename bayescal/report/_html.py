"""The per-sensor report: one self-contained HTML page (figures embedded as PNG, no external
resource, opens offline) for the channels of one recording, classical and Bayesian side by
side, with the health checks of every posterior and the discovery findings.

Figures are drawn with matplotlib's Agg canvas (no display, no pyplot state):

- **Allan deviation**: the measured overlapping ADEV with its classical chi-square bars, and
  two posterior bands. The darker one is the spread over posterior draws of the model's
  *exact* Allan deviation (NoiseModel.allan_variance, closed form at every tau): the
  uncertainty of the parameters alone. The lighter one is the posterior predictive band of
  the *measured* ADEV: each draw's exact Allan variance times a chi-square variate with the
  same equivalent degrees of freedom as the classical bars (Greenhall), so it adds the
  estimator's scatter. Both pointwise, 90 %. This is exact for the model's mean and as good
  as the classical bars for the scatter, at no simulation cost (simulating a recording per
  draw would cost seconds per channel and add nothing the chi-square law does not carry).
- **Spectrum**: the binned periodogram of the increments that the Whittle likelihood fits
  (bins of 2 % relative width), shown as the amplitude spectral density of the samples
  (divided by |1 - e^{-2 pi i f / fs}|^2 fs, two-sided, so white noise reads N), against the
  expected periodogram of posterior draws (the tapered, debiased expectation the likelihood
  uses) and its predictive band (a bin's mean of k ordinates is Gamma(k) / k times it).
- **Posterior pairs**: every pair of sampled parameters, the noise scales on log axes.
"""

import base64
import datetime
import html
import io
import itertools
import math
from dataclasses import dataclass, field
from importlib.metadata import version

import numpy as np

from .._errors import InputError
from ..classical._noise import ClassicalNoise
from ..inference._bands import allan_band, draw_subset, spectrum_band
from ..inference._noise_posterior import NoisePosterior
from ..models._terms import PARAMETERS, card_values, display_values, parameter_unit
from ..recording._recording import Channel
from ._noise import frequency_text

DATASHEET_TOLERANCE = (0.8, 1.25)
PAIR_POINTS = 800
_POSITIVE = {name for name, p in PARAMETERS.items() if p.link in ("log", "log_logit")}
"""Parameters drawn on a log axis: the scales (and time constants) of the noise terms."""
_PARAMETER_NAMES = {"bias": "bias (turn-on)"} | {
    name: f"{name} {p.meaning}" for name, p in PARAMETERS.items()
}


@dataclass
class ChannelAnalysis:
    """Everything the page shows of one channel."""

    data: Channel
    classical: ClassicalNoise
    result: dict
    """The ``bayescal noise`` JSON document of the channel (classical and bayesian blocks)."""
    fit: NoisePosterior | None
    datasheet: dict | None = None
    """How the unit compares with its sensor card (:func:`datasheet_comparison`)."""
    bands: dict = field(default_factory=dict)
    """Numbers behind the figures' posterior bands (filled by :func:`posterior_bands`)."""

    @property
    def channel(self) -> str:
        return self.data.channel

    @property
    def unit(self) -> str:
        return self.data.unit

    @property
    def misfits(self) -> list[str]:
        """Where the fitted model does not describe the record."""
        checks = self.result.get("bayesian", {}).get("fit_checks", [])
        return [check["misfit"] for check in checks if check["misfit"]]

    @property
    def failures(self) -> list[str]:
        """The failed sampler checks, then the misfits."""
        if self.fit is None:
            return []
        return [*self.fit.diagnostics.failures, *(f"model misfit: {m}" for m in self.misfits)]

    @property
    def passed(self) -> bool:
        return not self.failures


# ---------------------------------------------------------------------------------------------
# Numbers behind the figures


def posterior_bands(analysis: ChannelAnalysis, *, seed: int = 0) -> dict:
    """Fill ``analysis.bands`` (Allan and spectrum) from its posterior; empty without one."""
    if analysis.fit is None:
        analysis.bands = {}
        return analysis.bands
    allan = allan_band(analysis.fit, analysis.classical.allan, seed=seed)
    allan["unit"] = analysis.unit
    spectrum = spectrum_band(analysis.fit, seed=seed)
    spectrum["unit"] = f"{analysis.unit}/sqrt(Hz)"
    analysis.bands = {"allan": allan, "spectrum": spectrum}
    return analysis.bands


def datasheet_comparison(card, analysis: ChannelAnalysis) -> dict | None:
    """How the measured unit compares with its sensor card: for each figure the card gives,
    the datasheet value, the classical reading and the posterior, their ratio and a verdict
    on the 90 % interval of measured / datasheet: better or worse when it lies wholly below
    0.8 or above 1.25 (datasheets quote typical units, so a few percent is no verdict), as the
    datasheet when it lies within [0.8, 1.25], else not resolved.
    ``{"unavailable": reason}`` when the card has no section for this kind of channel."""
    unit = analysis.unit
    try:
        values = card_values(card, unit)
    except InputError as error:
        return {"card": card.name, "datasheet": card.datasheet, "unavailable": str(error)}
    bayesian = analysis.result.get("bayesian", {}).get("parameters", {})
    readings = analysis.result["classical"]["slope_readings"]
    rows = {}
    for parameter, (value, source) in values.items():
        row = {
            "datasheet": value,
            "unit": parameter_unit(parameter, unit),
            "source": source,
            "display": display_values(parameter, value, unit),
        }
        if parameter in readings:
            reading = readings[parameter]
            row["classical"] = {key: reading[key] for key in ("value", "ci_low", "ci_high", "kind")}
        if parameter in bayesian:
            posterior = bayesian[parameter]
            row["bayesian"] = {key: posterior[key] for key in ("mean", "q05", "q95")}
            ratio = {key: posterior[key] / value for key in ("mean", "q05", "q95")}
            row["ratio"] = ratio
            low, high = DATASHEET_TOLERANCE
            if ratio["q95"] < low:
                row["verdict"] = "better than the datasheet"
            elif ratio["q05"] > high:
                row["verdict"] = "worse than the datasheet"
            elif ratio["q05"] >= low and ratio["q95"] <= high:
                row["verdict"] = "as the datasheet (within -20 %/+25 %)"
            else:
                row["verdict"] = "consistent with the datasheet, not resolved to ±25 %"
        rows[parameter] = row
    return {
        "card": card.name,
        "datasheet": card.datasheet,
        "parameters": rows,
        "note": "the posterior used the card as its prior (log-normal, sd log 3); the "
        "classical reading is independent of it. Verdicts from the 90 % interval of "
        "measured / datasheet: better (worse) when it lies below 0.8 (above 1.25), as the "
        "datasheet when inside [0.8, 1.25]",
    }


# ---------------------------------------------------------------------------------------------
# Formatting


def _esc(value) -> str:
    return html.escape(str(value), quote=True)


def _num(value, digits: int = 4) -> str:
    if value is None:
        return "n/a"
    try:
        number = float(value)
    except (TypeError, ValueError):
        return _esc(value)
    if not math.isfinite(number):
        return "n/a"
    return f"{number:.{digits}g}"


def pretty_unit(unit: str) -> str:
    """A unit as text for the page: sqrt(Hz) -> √Hz, ^2 -> ², degC -> °C, 1 -> (no unit)."""
    if unit in ("1", ""):
        return "(dimensionless)"
    text = unit.replace("sqrt(Hz)", "√Hz").replace("sqrt(h)", "√h").replace("^2", "²")
    return text.replace("^3", "³").replace("degC", "°C")


def _squared(unit: str) -> str:
    text = pretty_unit(unit)
    return f"({text})²" if any(mark in text for mark in "/*·") else f"{text}²"


def _q(value, unit: str, digits: int = 4) -> str:
    """A number with its unit, HTML-escaped."""
    return f"{_num(value, digits)}&nbsp;{_esc(pretty_unit(unit))}"


def _digits(value, low, high) -> int:
    """Significant digits that resolve an interval: a bias of 9.8 m/s^2 known to 1e-4 needs
    six, a noise density known to 1 % needs four."""
    try:
        value, width = abs(float(value)), abs(float(high) - float(low)) / 2
    except (TypeError, ValueError):
        return 4
    if not (math.isfinite(value) and math.isfinite(width)) or value == 0 or width == 0:
        return 4
    return min(10, max(4, math.ceil(math.log10(value / width)) + 2))


def _interval(value, low, high, unit: str) -> str:
    digits = _digits(value, low, high)
    return (
        f"{_num(value, digits)} [{_num(low, digits)}, {_num(high, digits)}]"
        f"&nbsp;{_esc(pretty_unit(unit))}"
    )


def _posterior(entry: dict, unit: str | None = None) -> str:
    """A posterior summary (mean, q05, q95) with its unit."""
    return _interval(
        entry.get("mean"), entry.get("q05"), entry.get("q95"), unit or entry.get("unit", "")
    )


def _stacked(value, low, high, unit: str) -> str:
    """Value with its unit, the interval below it (for narrow table cells)."""
    digits = _digits(value, low, high)
    return (
        f"{_q(value, unit, digits)}<br><span class='note'>[{_num(low, digits)}, "
        f"{_num(high, digits)}]&nbsp;{_esc(pretty_unit(unit))}</span>"
    )


def _percent(fraction) -> str:
    return f"{100 * float(fraction):g}&nbsp;%"


# ---------------------------------------------------------------------------------------------
# Figures


def _png(figure) -> str:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(figure)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=96)
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def _image(encoded: str, alt: str) -> str:
    return f'<img class="figure" alt="{_esc(alt)}" src="data:image/png;base64,{encoded}">'


def _new_figure(width: float, height: float, panels: int = 1):
    from matplotlib.figure import Figure

    figure = Figure(figsize=(width, height), layout="constrained")
    axes = figure.subplots(1, panels, squeeze=False)[0]
    return figure, list(axes)


def allan_figure(analysis: ChannelAnalysis) -> str:
    allan = analysis.classical.allan
    unit = pretty_unit(analysis.unit)
    percent = f"{100 * allan.confidence:g} %"
    figure, (axes,) = _new_figure(7.2, 4.4)
    tau, deviation = np.asarray(allan.tau), np.asarray(allan.deviation)
    usable = np.isfinite(deviation)
    band = analysis.bands.get("allan")
    if band:
        level = f"{100 * band['level']:g} %"
        axes.fill_between(
            band["tau_s"],
            band["predictive_low"],
            band["predictive_high"],
            color="#9ecae1",
            alpha=0.45,
            lw=0,
            label=f"posterior predictive of the measured ADEV ({level})",
        )
        axes.fill_between(
            band["fine_tau_s"],
            band["fine_expected_low"],
            band["fine_expected_high"],
            color="#3182bd",
            alpha=0.55,
            lw=0,
            label=f"model's exact ADEV over posterior draws ({level})",
        )
        axes.plot(
            band["fine_tau_s"],
            band["fine_expected_median"],
            color="#08519c",
            lw=1.2,
            label="model, posterior median",
        )
    low = np.asarray(allan.ci_low)[usable]
    high = np.asarray(allan.ci_high)[usable]
    centre = deviation[usable]
    axes.errorbar(
        tau[usable],
        centre,
        yerr=[np.maximum(centre - low, 0), np.maximum(high - centre, 0)],
        fmt="o",
        ms=3.5,
        color="black",
        ecolor="#444444",
        capsize=2,
        lw=1,
        label=f"measured (overlapping), classical {percent} chi-square bars",
    )
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("averaging time τ [s]")
    axes.set_ylabel(f"Allan deviation [{unit}]")
    axes.set_title(f"{analysis.channel}: Allan deviation")
    axes.grid(True, which="both", lw=0.3, alpha=0.6)
    axes.legend(fontsize=7.5, loc="best")
    return _png(figure)


def spectrum_figure(analysis: ChannelAnalysis) -> str:
    band = analysis.bands["spectrum"]
    unit = pretty_unit(analysis.unit)
    level = f"{100 * band['level']:g} %"
    figure, (axes,) = _new_figure(7.2, 4.4)
    frequency = band["frequency_hz"]
    axes.fill_between(
        frequency,
        band["predictive_low"],
        band["predictive_high"],
        color="#fdae6b",
        alpha=0.45,
        lw=0,
        label=f"posterior predictive of the binned periodogram ({level})",
    )
    axes.fill_between(
        frequency,
        band["expected_low"],
        band["expected_high"],
        color="#e6550d",
        alpha=0.6,
        lw=0,
        label=f"model spectrum over posterior draws ({level})",
    )
    axes.plot(
        frequency,
        band["measured_asd"],
        ".",
        ms=2.5,
        color="black",
        label="measured (binned periodogram, 2 % bins)",
    )
    axes.plot(
        frequency, band["expected_median"], color="#a63603", lw=1.2, label="model, posterior median"
    )
    found = analysis.result.get("bayesian", {}).get("spectral_lines", {}).get("lines", [])
    for index, line in enumerate(found):
        axes.axvline(
            line["frequency"]["mean"],
            color="#3182bd",
            lw=0.8,
            ls="--",
            label="spectral lines (taken out of the record fitted)" if index == 0 else None,
        )
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("frequency [Hz]")
    axes.set_ylabel(f"amplitude spectral density [{unit}/√Hz]")
    axes.set_title(f"{analysis.channel}: spectrum (two-sided; white noise reads N)")
    axes.grid(True, which="both", lw=0.3, alpha=0.6)
    axes.legend(fontsize=7.5, loc="best")
    return _png(figure)


def pair_figure(analysis: ChannelAnalysis) -> str:
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    fit = analysis.fit
    names = ["bias", *fit.problem.parameters]
    sample = draw_subset(fit, PAIR_POINTS, 7)
    size = len(names)
    figure = Figure(figsize=(1.9 * size + 0.8, 1.9 * size + 0.6))
    grid = figure.subplots(size, size, squeeze=False)
    inch = 1.0 / (1.9 * size + 0.8)
    figure.subplots_adjust(
        left=0.75 * inch,
        bottom=0.6 * inch,
        right=0.98,
        top=1 - 0.35 * inch,
        wspace=0.08,
        hspace=0.08,
    )
    values = {}
    for name in names:
        draw = sample[name]
        values[name] = np.log10(draw) if name in _POSITIVE and np.all(draw > 0) else draw
    for row, y_name in enumerate(names):
        for column, x_name in enumerate(names):
            axes = grid[row][column]
            if column > row:
                axes.set_axis_off()
                continue
            if column == row:
                axes.hist(values[x_name], bins=30, color="#3182bd", alpha=0.8)
            else:
                axes.plot(
                    values[x_name],
                    values[y_name],
                    ".",
                    ms=1.5,
                    alpha=0.35,
                    color="#08519c",
                    rasterized=True,
                )
            axes.tick_params(labelsize=6.5)
            axes.xaxis.set_major_locator(MaxNLocator(3))
            axes.yaxis.set_major_locator(MaxNLocator(4))
            if column == row:
                axes.set_yticks([])
            if row == size - 1:
                axes.set_xlabel(_pair_label(x_name, analysis.unit), fontsize=7.5)
            else:
                axes.set_xticklabels([])
            if column == 0 and row > 0:
                axes.set_ylabel(_pair_label(y_name, analysis.unit), fontsize=7.5)
            elif column != row:
                axes.set_yticklabels([])
    figure.suptitle(
        f"{analysis.channel}: posterior pairs ({sample['bias'].size} draws)", fontsize=10
    )
    return _png(figure)


def _pair_label(name: str, unit: str) -> str:
    shown = pretty_unit(parameter_unit(name, unit))
    if name in _POSITIVE:
        return f"log10 {name} [{shown}]"
    return f"{name} [{shown}]"


# ---------------------------------------------------------------------------------------------
# Discovery


def _location_text(location) -> str:
    if isinstance(location, dict):
        return "; ".join(
            f"{_esc(key)} = {_keyed_value(key, value)}" for key, value in location.items()
        )
    if isinstance(location, (list, tuple)):
        return ", ".join(_num(item) for item in location)
    if location is None:
        return "—"
    return _num(location) if isinstance(location, (int, float)) else _esc(location)


_KEY_UNITS = (
    ("_hz", "Hz"),
    ("_s", "s"),
    ("_degc", "°C"),
    ("_deg", "deg"),
    ("p_value", "(probability)"),
)


def _keyed_value(key: str, value) -> str:
    """A value from a discovery dict, with the unit its key names (tau_s -> s)."""
    if isinstance(value, dict):
        return "{" + _location_text(value) + "}"
    if isinstance(value, (list, tuple)):
        text = ", ".join(_num(item) for item in value[:8])
        if len(value) > 8:
            text += ", …"
        value_text = f"[{text}]"
    elif isinstance(value, bool) or not isinstance(value, (int, float)):
        return _esc(value)
    else:
        value_text = _num(value)
    lowered = key.lower()
    for suffix, unit in _KEY_UNITS:
        if lowered.endswith(suffix):
            return f"{value_text}&nbsp;{_esc(unit)}"
    return f"{value_text}&nbsp;(as reported)"


def _series(block: dict, key: str):
    values = block.get(key)
    if values is None:
        return None
    array = np.asarray(values, dtype=float).reshape(-1)
    return array if array.size else None


def _discovery_allan_figure(block: dict, unit: str, channel: str) -> str | None:
    tau, adev = _series(block, "tau_s"), _series(block, "adev")
    if tau is None or adev is None:
        return None
    stages = [
        (title, _series(block, f"{key}_low"), _series(block, f"{key}_high"))
        for title, key in (("before: baseline model", "baseline"), ("after: final model", "final"))
    ]
    stages = [stage for stage in stages if stage[1] is not None and stage[2] is not None] or [
        ("measured", None, None)
    ]
    figure, panels = _new_figure(4.2 * len(stages) + 0.4, 3.8, len(stages))
    for axes, (title, low, high) in zip(panels, stages, strict=True):
        if low is not None:
            axes.fill_between(
                tau, low, high, color="#9ecae1", alpha=0.7, lw=0, label="model's predictive band"
            )
        axes.plot(tau, adev, "o-", ms=3, lw=1, color="black", label="measured")
        axes.set_xscale("log")
        axes.set_yscale("log")
        axes.set_xlabel("τ [s]")
        axes.set_ylabel(f"Allan deviation [{pretty_unit(unit)}]")
        axes.set_title(f"{channel}: {title}", fontsize=9.5)
        axes.grid(True, which="both", lw=0.3, alpha=0.6)
        axes.legend(fontsize=7.5)
    return _png(figure)


def _discovery_spectrum_figure(block: dict, unit: str, channel: str) -> str | None:
    frequency, power = _series(block, "frequency_hz"), _series(block, "power")
    if frequency is None or power is None:
        return None
    stages = [
        (title, _series(block, key))
        for title, key in (
            ("before: baseline model", "baseline_model"),
            ("after: final model", "final_model"),
        )
    ]
    stages = [stage for stage in stages if stage[1] is not None] or [("measured", None)]
    figure, panels = _new_figure(4.2 * len(stages) + 0.4, 3.8, len(stages))
    positive = frequency > 0
    for axes, (title, model) in zip(panels, stages, strict=True):
        axes.plot(
            frequency[positive], power[positive], ".", ms=2, color="#555555", label="measured"
        )
        if model is not None:
            axes.plot(frequency[positive], model[positive], color="#e6550d", lw=1.4, label="model")
        axes.set_xscale("log")
        axes.set_yscale("log")
        axes.set_xlabel("frequency [Hz]")
        axes.set_ylabel(f"power spectral density [{_squared(unit)}/Hz]")
        axes.set_title(f"{channel}: {title}", fontsize=9.5)
        axes.grid(True, which="both", lw=0.3, alpha=0.6)
        axes.legend(fontsize=7.5)
    return _png(figure)


def _discovery_residual_figure(block: dict, unit: str, channel: str) -> str | None:
    time = _series(block, "time_s")
    stages = [
        (title, _series(block, key))
        for title, key in (
            ("before: baseline residual", "baseline"),
            ("after: final residual", "final"),
        )
    ]
    stages = [stage for stage in stages if stage[1] is not None]
    if time is None or not stages:
        return None
    figure, panels = _new_figure(4.2 * len(stages) + 0.4, 3.6, len(stages))
    for axes, (title, residual) in zip(panels, stages, strict=True):
        n = min(time.size, residual.size)
        t, r = time[:n], residual[:n]
        step = max(1, n // 4000)
        axes.plot(
            t[::step],
            r[::step],
            ".",
            ms=1.2,
            alpha=0.3,
            color="#888888",
            rasterized=True,
            label="residual",
        )
        bins = min(100, max(1, n // 20))
        edges = np.linspace(0, n, bins + 1).astype(int)
        centres = [t[a:b].mean() for a, b in itertools.pairwise(edges) if b > a]
        means = [r[a:b].mean() for a, b in itertools.pairwise(edges) if b > a]
        axes.plot(centres, means, color="#d62728", lw=1.5, label=f"mean of {bins} blocks")
        axes.axhline(0.0, color="black", lw=0.6)
        axes.set_xlabel("time [s]")
        axes.set_ylabel(f"residual [{pretty_unit(unit)}]")
        axes.set_title(f"{channel}: {title}", fontsize=9.5)
        axes.grid(True, lw=0.3, alpha=0.6)
        axes.legend(fontsize=7.5)
    return _png(figure)


def _parameters_text(parameters: dict) -> str:
    items = []
    for name, entry in (parameters or {}).items():
        if isinstance(entry, dict):
            unit = entry.get("unit", "(unit not given)")
            items.append(f"{_esc(name)} = {_posterior(entry, unit)}")
        else:
            items.append(f"{_esc(name)} = {_num(entry)}&nbsp;(as reported)")
    return "<br>".join(items) or "—"


def discovery_section(findings: dict, *, unit: str | None = None) -> str:
    """HTML of the discovery findings of one channel (the issue-6 JSON contract, plus
    ``diagnostics`` with ``allan``, ``spectrum`` and ``residual`` blocks for the before/after
    figures; every key may be missing): the effects found with their evidence, the checks
    before and after, and the figures."""
    channel = findings.get("channel", "")
    unit = unit or findings.get("unit") or "(unit not given)"
    effects = findings.get("effects") or []
    heading = f"Discovery: {_esc(channel)}" if channel else "Discovery"
    parts = [f'<section class="discovery"><h3>{heading}</h3>']
    baseline = findings.get("baseline")
    final = findings.get("final_terms")
    if baseline or final:
        parts.append(
            "<p>Baseline model: <code>"
            + _esc(" + ".join(baseline or []) or "—")
            + "</code>; final model: <code>"
            + _esc(" + ".join(final or []) or "—")
            + "</code>.</p>"
        )
    if not effects:
        parts.append(
            '<p class="ok">No effect found: the baseline model explains the recording.</p>'
        )
    else:
        parts.append(
            "<table><thead><tr><th>effect</th><th>explanation</th>"
            "<th>ΔELPD ± SE</th><th>parameters (mean [5 %, 95 %])</th>"
            "<th>where</th><th>evidence</th></tr></thead><tbody>"
        )
        for effect in effects:
            delta, spread = effect.get("delta_elpd"), effect.get("delta_elpd_se")
            parts.append(
                f"<tr><td><code>{_esc(effect.get('name', '?'))}</code></td>"
                f"<td>{_esc(effect.get('explanation', ''))}</td>"
                f"<td>{_num(delta)} ± {_num(spread)}&nbsp;nats</td>"
                f"<td>{_parameters_text(effect.get('parameters'))}</td>"
                f"<td>{_location_text(effect.get('location'))}</td>"
                f"<td>{_location_text(effect.get('evidence'))}</td></tr>"
            )
        parts.append("</tbody></table>")
    checks = findings.get("checks") or []
    if checks:
        parts.append(
            "<h4>Checks of the baseline (posterior predictive)</h4><table><thead><tr>"
            "<th>check</th><th>statistic (as defined by the check)</th>"
            "<th>p-value (probability)</th><th>where</th><th>after the new terms</th>"
            "</tr></thead><tbody>"
        )
        for check in checks:
            after = check.get("passed_after")
            after_text = {True: "passes", False: '<span class="bad">still fails</span>'}.get(
                after, "—"
            )
            parts.append(
                f"<tr><td>{_esc(check.get('name', '?'))}</td>"
                f"<td>{_num(check.get('statistic'))}&nbsp;(as reported)</td>"
                f"<td>{_num(check.get('p_value'))}&nbsp;(probability)</td>"
                f"<td>{_location_text(check.get('location'))}</td><td>{after_text}</td></tr>"
            )
        parts.append("</tbody></table>")
    diagnostics = findings.get("diagnostics") or {}
    figures = [
        (_discovery_allan_figure, "allan", "Allan deviation before and after"),
        (_discovery_spectrum_figure, "spectrum", "spectrum before and after"),
        (_discovery_residual_figure, "residual", "residual before and after"),
    ]
    for draw, key, alt in figures:
        block = diagnostics.get(key)
        if not isinstance(block, dict):
            continue
        encoded = draw(block, unit, channel or "channel")
        if encoded:
            parts.append(_image(encoded, f"{channel} discovery: {alt}"))
    parts.append("</section>")
    return "\n".join(parts)


# ---------------------------------------------------------------------------------------------
# The page

_STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 1.5em auto;
       max-width: 1180px; color: #222; line-height: 1.4; padding: 0 1em; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; } h2 { border-bottom: 2px solid #3182bd;
     padding-bottom: 0.15em; margin-top: 1.8em; } h3 { margin-top: 1.4em; }
table { border-collapse: collapse; margin: 0.6em 0 1em 0; font-size: 0.88em; display: block;
        overflow-x: auto; max-width: 100%; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.5em; vertical-align: top; text-align: left; }
th { background: #eef3f8; } td.num { font-variant-numeric: tabular-nums; }
.bad { color: #b00020; font-weight: bold; } .ok { color: #1b7a1b; }
.alarm { background: #fde8ea; border: 2px solid #b00020; padding: 0.6em 1em; margin: 1em 0; }
.alarm h2 { border: none; color: #b00020; margin-top: 0; }
tr.failed td { background: #fde8ea; } .note { color: #555; font-size: 0.9em; }
img.figure { display: block; max-width: 100%; margin: 0.6em 0; border: 1px solid #ddd; }
code { background: #f4f4f4; padding: 0 0.2em; }
"""


def _classical_cell(name: str, result: dict) -> str:
    classical = result["classical"]
    percent = _percent(classical["bias"]["confidence"])
    if name == "bias":
        bias = classical["bias"]
        return (
            _interval(bias["value"], bias["ci_low"], bias["ci_high"], bias["unit"])
            + f" <span class='note'>(sample mean, {percent} Student-t)</span>"
        )
    reading = classical["slope_readings"].get(name)
    if reading is None:
        return "—"
    if reading["kind"] == "upper_bound":
        bound = _q(reading["ci_high"], reading["unit"])
        return f"≤ {bound} <span class='note'>(upper bound)</span>"
    return (
        _interval(reading["value"], reading["ci_low"], reading["ci_high"], reading["unit"])
        + f" <span class='note'>({_esc(reading['read_at'])}, {percent})</span>"
    )


def _display_cell(name: str, result: dict) -> str:
    entry = result.get("bayesian", {}).get("parameters", {}).get(name, {})
    items = [_posterior(shown, label) for label, shown in entry.get("display", {}).items()]
    return "<br>".join(items) or "—"


def _t_interval_html(result: dict) -> str:
    classical = result["classical"]
    check = classical["t_interval_check"]
    bias = classical["bias"]
    unit = result["unit"]
    explanation = _esc(check["explanation"])
    if classical["t_interval_valid"]:
        return f"<p class='ok'>Student-t interval of the bias: valid — {explanation}.</p>"
    widening = _num(classical["t_interval_widening"], 3)
    return (
        f"<p class='bad'>Student-t interval of the bias NOT VALID — too narrow by ×{widening}: "
        f"{explanation}. Widened interval (half-width ×{widening}): "
        f"[{_num(bias['widened_ci_low'])}, {_num(bias['widened_ci_high'])}]"
        f"&nbsp;{_esc(pretty_unit(unit))}.</p>"
    )


def _summary_table(analyses: list[ChannelAnalysis]) -> str:
    rows = []
    for analysis in analyses:
        result = analysis.result
        classical = result["classical"]
        bias = classical["bias"]
        parameters = result.get("bayesian", {}).get("parameters", {})
        posterior_bias = parameters.get("bias")
        classical_bias = _stacked(bias["value"], bias["ci_low"], bias["ci_high"], bias["unit"])
        t_valid = classical["t_interval_valid"]
        t_text = (
            "<span class='ok'>valid</span>"
            if t_valid
            else f"<span class='bad'>INVALID: ×{_num(classical['t_interval_widening'], 3)} too "
            "narrow</span>"
        )
        health = (
            "—"
            if analysis.fit is None
            else "<span class='ok'>passed</span>"
            if analysis.passed
            else "<span class='bad'>FAILED</span>"
        )
        noise = []
        for name in ("N", "B", "K"):
            if name in parameters:
                entry = parameters[name]
                shown = _stacked(entry["mean"], entry["q05"], entry["q95"], entry["unit"])
                noise.append(f"<td class='num'>{shown}</td>")
            else:
                noise.append("<td>—</td>")
        rows.append(
            f"<tr{' class=failed' if not analysis.passed else ''}>"
            f"<td><a href='#channel-{_esc(analysis.channel)}'>{_esc(analysis.channel)}</a></td>"
            f"<td class='num'>{_q(result['rate_hz'], 'Hz')}<br>{_q(result['duration_s'], 's')}</td>"
            f"<td class='num'>{classical_bias}</td><td>{t_text}</td>"
            + (
                "<td class='num'>"
                + _stacked(
                    posterior_bias["mean"],
                    posterior_bias["q05"],
                    posterior_bias["q95"],
                    posterior_bias["unit"],
                )
                + "</td>"
                if posterior_bias
                else "<td>—</td>"
            )
            + "".join(noise)
            + f"<td>{health}</td></tr>"
        )
    percent = _percent(analyses[0].result["classical"]["bias"]["confidence"]) if analyses else ""
    return (
        "<table><thead><tr><th>channel</th><th>rate, duration</th>"
        f"<th>bias, classical<br>(mean, {percent} Student-t)</th><th>Student-t interval</th>"
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
            else "<span class='bad'>FAILED: " + _esc("; ".join(analysis.failures)) + "</span>"
        )
        fits = (
            "<span class='ok'>yes</span>"
            if not analysis.misfits
            else "<span class='bad'>MISFIT</span>"
        )
        rows.append(
            f"<tr{' class=failed' if not analysis.passed else ''}><td>{_esc(analysis.channel)}</td>"
            f"<td class='num'>{d.n_steps}&nbsp;steps × {d.n_walkers}&nbsp;walkers</td>"
            f"<td class='num'>{_num(tau, 3)} ({criterion})</td>"
            f"<td class='num'>{_num(rhat, 4)}</td><td class='num'>{_num(ess, 4)}</td>"
            f"<td class='num'>{_num(d.acceptance_fraction, 3)}</td>"
            f"<td>{'yes' if d.map_converged else '<b>no</b>'}</td><td>{fits}</td>"
            f"<td>{status}</td></tr>"
        )
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


def _side_by_side_table(analysis: ChannelAnalysis) -> str:
    result = analysis.result
    parameters = result.get("bayesian", {}).get("parameters", {})
    names = list(parameters) or ["bias", *result["classical"]["slope_readings"]]
    rows = []
    for name in names:
        entry = parameters.get(name)
        bayesian = (
            _posterior(entry) + f"<br><span class='note'>MAP {_q(entry['map'], entry['unit'])} ± "
            f"{_q(entry['map_sd'], entry['unit'])}</span>"
            if entry
            else "—"
        )
        rows.append(
            f"<tr><td>{_esc(_PARAMETER_NAMES.get(name, name))}</td>"
            f"<td class='num'>{_classical_cell(name, result)}</td><td class='num'>{bayesian}</td>"
            f"<td class='num'>{_display_cell(name, result)}</td></tr>"
        )
    std = result["classical"]["std"]
    rows.append(
        f"<tr><td>standard deviation of the samples</td><td class='num'>"
        f"{_q(std['value'], std['unit'])}</td><td>—</td><td>—</td></tr>"
    )
    return (
        "<table><thead><tr><th>parameter</th><th>classical</th>"
        "<th>Bayesian: posterior mean [5 %, 95 %]</th><th>Bayesian in datasheet units</th>"
        "</tr></thead><tbody>" + "".join(rows) + "</tbody></table>"
    )


def _lines_table(result: dict) -> str:
    """The spectral lines of the channel: frequency, amplitude (or power and width) with
    intervals, the test's ratio, aliased or not."""
    block = result.get("bayesian", {}).get("spectral_lines")
    if not block or not block["lines"]:
        return ""
    unit = result["unit"]
    rows = []
    for line in block["lines"]:
        kind = (
            f"broadened, {_q(line['width_hz'], 'Hz')} wide"
            if line["kind"] == "broadened"
            else "sinusoid"
        )
        if line["aliased"]:
            kind += f"; aliased (the filter passes {_percent(line['filter_gain'])} there)"
        rows.append(
            f"<tr><td class='num'>{_esc(frequency_text(line['frequency']))}</td>"
            f"<td class='num'>{_posterior(line['amplitude'], unit)}</td>"
            f"<td class='num'>{_posterior(line['power'], line['power']['unit'])}</td>"
            f"<td class='num'>{_num(line['ratio_to_floor'], 3)}</td><td>{_esc(kind)}</td></tr>"
        )
    test = block["test"]
    return (
        f"<h4>Spectral lines ({len(block['lines'])}): taken out of the record the noise model "
        "was fitted to, so that N is the floor between them</h4><table><thead><tr>"
        "<th>frequency</th><th>amplitude (peak): mean [5 %, 95 %]</th><th>power</th>"
        "<th>× the floor</th><th>kind</th></tr></thead><tbody>"
        + "".join(rows)
        + f"</tbody></table><p class='note'>Found by {_esc(test['method'])}, family-wise "
        f"{100 * test['family_wise_level']:g} % over {test['frequencies_searched']:,} "
        f"frequencies; resolution {_q(test['resolution_hz'], 'Hz')}.</p>"
    )


def _datasheet_html(comparison: dict | None) -> str:
    if not comparison:
        return ""
    head = (
        f"<h4>Against the datasheet: {_esc(comparison['card'])}</h4>"
        f"<p class='note'>{_esc(comparison['datasheet'])}</p>"
    )
    if "unavailable" in comparison:
        return head + f"<p>No comparison: {_esc(comparison['unavailable'])}</p>"
    rows = []
    for name, row in comparison["parameters"].items():
        unit = row["unit"]
        shown = "".join(
            f"<br><span class='note'>= {_q(value, label)}</span>"
            for label, value in row["display"].items()
        )
        classical = row.get("classical")
        classical_text = (
            "—"
            if not classical
            else f"≤ {_q(classical['ci_high'], unit)}"
            if classical["kind"] == "upper_bound"
            else _interval(classical["value"], classical["ci_low"], classical["ci_high"], unit)
        )
        posterior = row.get("bayesian")
        posterior_text = _posterior(posterior, unit) if posterior else "— (term not in the model)"
        verdict = row.get("verdict", "—")
        ratio = row.get("ratio")
        ratio_text = (
            f"{_num(ratio['mean'], 3)} [{_num(ratio['q05'], 3)}, {_num(ratio['q95'], 3)}]"
            "&nbsp;(dimensionless)"
            if ratio
            else "—"
        )
        css = "bad" if verdict.startswith("worse") else "ok" if verdict.startswith("better") else ""
        rows.append(
            f"<tr><td>{_esc(_PARAMETER_NAMES.get(name, name))}</td>"
            f"<td class='num'>{_q(row['datasheet'], unit)}{shown}<br>"
            f"<span class='note'>{_esc(row['source'])}</span></td>"
            f"<td class='num'>{classical_text}</td><td class='num'>{posterior_text}</td>"
            f"<td class='num'>{ratio_text}</td>"
            f"<td class='{css}'>{_esc(verdict)}</td></tr>"
        )
    return (
        head + "<table><thead><tr><th>parameter</th><th>datasheet</th><th>classical reading</th>"
        "<th>posterior mean [5 %, 95 %]</th><th>measured / datasheet</th><th>verdict</th>"
        "</tr></thead><tbody>"
        + "".join(rows)
        + f"</tbody></table><p class='note'>{_esc(comparison['note'])}.</p>"
    )


def _channel_section(analysis: ChannelAnalysis, findings: dict | None) -> str:
    result = analysis.result
    window = result["window"]
    parts = [
        f"<section id='channel-{_esc(analysis.channel)}'>",
        f"<h2>{_esc(analysis.channel)} [{_esc(pretty_unit(analysis.unit))}]</h2>",
        f"<p>{result['n_samples']}&nbsp;samples at {_q(result['rate_hz'], 'Hz')}, "
        f"{_q(result['duration_s'], 's')}; window {_q(window['start_s'], 's')} to "
        f"{_q(window['stop_s'], 's')} ({_esc(window['selected_by'])}).</p>",
    ]
    if analysis.fit is not None and not analysis.passed:
        parts.append(
            "<div class='alarm'><b>POSTERIOR CHECKS FAILED — do not use the Bayesian numbers "
            "of this channel:</b><ul>"
            + "".join(f"<li>{_esc(f)}</li>" for f in analysis.failures)
            + "</ul></div>"
        )
    parts.append(_t_interval_html(result))
    parts.append(_side_by_side_table(analysis))
    parts.append(_lines_table(result))
    bayesian = result.get("bayesian")
    if bayesian:
        parts.append(
            f"<p class='note'>Model terms: {_esc(', '.join(bayesian['terms']))}. Prior: "
            f"{_esc(bayesian['prior'])}. Bias: {_esc(bayesian['bias_definition'])}. "
            f"Seed {bayesian['seed']}.</p>"
        )
        if bayesian.get("comparison"):
            parts.append(
                "<p><b>Where classical and Bayesian disagree:</b></p><ul>"
                + "".join(f"<li>{_esc(note)}</li>" for note in bayesian["comparison"])
                + "</ul>"
            )
    parts.append(_datasheet_html(analysis.datasheet))
    parts.append(_image(allan_figure(analysis), f"{analysis.channel}: Allan deviation"))
    if analysis.fit is not None:
        if "spectrum" in analysis.bands:
            parts.append(_image(spectrum_figure(analysis), f"{analysis.channel}: spectrum"))
        parts.append(_image(pair_figure(analysis), f"{analysis.channel}: posterior pairs"))
    if result.get("notes"):
        parts.append(
            "<p class='note'>Notes:</p><ul class='note'>"
            + "".join(f"<li>{_esc(note)}</li>" for note in result["notes"])
            + "</ul>"
        )
    if findings is not None:
        parts.append(discovery_section(findings, unit=analysis.unit))
    parts.append("</section>")
    return "\n".join(parts)


def build_report(
    analyses: list[ChannelAnalysis],
    *,
    title: str,
    source: str,
    discoveries: dict | None = None,
    files: dict | None = None,
    settings: dict | None = None,
) -> str:
    """The self-contained HTML page of one sensor's channels.

    ``discoveries`` maps a channel to its discovery findings (:func:`discovery_section`);
    ``files`` names the JSON and netCDF files written beside the page; ``settings`` are shown
    as given (name -> text).
    """
    discoveries = discoveries or {}
    for analysis in analyses:
        if analysis.fit is not None and not analysis.bands:
            posterior_bands(analysis)
    failed = [a for a in analyses if not a.passed]
    invalid = [a for a in analyses if not a.result["classical"]["t_interval_valid"]]
    created = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{_esc(title)}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{_esc(title)}</h1>",
        f"<p class='note'>{_esc(source)} — bayescal {_esc(version('bayescal'))}, {created}</p>",
    ]
    if failed:
        parts.append(
            "<div class='alarm'><h2>HEALTH CHECK FAILED</h2><p>The posterior of "
            + ", ".join(f"<b>{_esc(a.channel)}</b>" for a in failed)
            + " failed its checks; do not use those Bayesian numbers:</p><ul>"
            + "".join(f"<li>{_esc(a.channel)}: {_esc('; '.join(a.failures))}</li>" for a in failed)
            + "</ul></div>"
        )
    parts.append("<h2>Summary</h2>")
    parts.append(_summary_table(analyses))
    if invalid:
        parts.append(
            "<p class='bad'>The classical Student-t interval of the bias is too narrow for "
            + ", ".join(
                f"{_esc(a.channel)} (×{_num(a.result['classical']['t_interval_widening'], 3)})"
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
            + "; ".join(f"{_esc(k)}: {_esc(v)}" for k, v in settings.items())
            + "</p>"
        )
    if files:
        parts.append(
            "<p class='note'>Behind this page: "
            + "; ".join(f"{_esc(k)}: <code>{_esc(v)}</code>" for k, v in files.items())
            + "</p>"
        )
    parts.append(
        "<p class='note'>Allan figures: black points are the measured overlapping Allan "
        "deviation with classical chi-square bars; the darker band is the model's exact Allan "
        "deviation over posterior draws (parameter uncertainty), the lighter band the "
        "posterior predictive band of what a recording like this one would measure (the same "
        "with the estimator's chi-square scatter). Spectrum figures: the binned periodogram "
        "the Whittle likelihood fits, as the two-sided amplitude spectral density of the "
        "samples (white noise reads N), against the model's expected periodogram.</p>"
    )
    for analysis in analyses:
        parts.append(_channel_section(analysis, discoveries.get(analysis.channel)))
    extra = [channel for channel in discoveries if channel not in {a.channel for a in analyses}]
    for channel in extra:
        parts.append(discovery_section(discoveries[channel]))
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def report_document(
    analyses: list[ChannelAnalysis],
    *,
    title: str,
    source: str,
    discoveries: dict | None = None,
    files: dict | None = None,
) -> dict:
    """The JSON behind the page: each channel's noise document, the posterior bands the
    figures draw, the datasheet comparison and the discovery findings."""
    return {
        "schema": "bayescal.report",
        "schema_version": 1,
        "bayescal_version": version("bayescal"),
        "title": title,
        "source": source,
        "files": files or {},
        "passed": all(a.passed for a in analyses),
        "channels": {
            a.channel: {
                **a.result,
                "figures": {
                    name: {key: value for key, value in band.items()}
                    for name, band in a.bands.items()
                },
                **({"datasheet": a.datasheet} if a.datasheet else {}),
            }
            for a in analyses
        },
        "discoveries": discoveries or {},
    }
