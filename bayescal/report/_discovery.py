"""A discovery rendered: its JSON document, the text ``bayescal discover`` prints, the curves
behind its figures, the files of ``--out`` and its final posterior as ArviZ data.

One home each: a :class:`~bayescal.Discovery` and the curves drawn from its fits
(:class:`DiscoveryCurves`, computed once by :func:`discovery_curves`) travel together as
:class:`Findings`; the document (:func:`discovery_document`), the text
(:func:`discovery_text`), the page's section (:func:`bayescal.report._html.discovery_section`)
and the figures (:mod:`._figures`, drawn once for the page and for ``--out``) all read them,
never the document.
"""

import json
from dataclasses import dataclass
from importlib.metadata import version
from pathlib import Path

import numpy as np
from scipy import stats

from .._output import atomic_path, file_stem, to_jsonable, write_json, write_netcdf
from ..capabilities._discovery import CheckResult, Discovery, discover
from ..inference._discovery_search import SearchResult
from ..inference._mcmc import summarize
from ..models._composite import bin_ratios
from ..recording._recording import Channel, Recording, companions
from ._figures import DISCOVERY_FIGURES, FILE_DPI, png

DECISION_RULE = (
    "a term is accepted when its Schwarz (BIC) log Bayes factor against "
    "the current model exceeds log(100) = 4.6 (decisive); delta_elpd is the AIC-penalised "
    "gain in log predictive density, pointwise over independent frequency bins of the "
    "increments and one-block-ahead predictions of 128 block means, with its standard "
    "error; saturation and outliers are decided first, on the samples' distribution "
    "(censored and contaminated normal against the normal), at the same threshold"
)


def _listed(values) -> list:
    return np.asarray(values).tolist()


@dataclass(frozen=True)
class AllanCurves:
    """The overlapping Allan deviation of the baseline's residual (``adev``) and of the
    final model's (``final_adev``), each model's pointwise 90 % band at those taus and the
    bounds of its check (``*_check_low``, ``*_check_high``: a point outside them fails the
    Allan deviation check, Bonferroni-corrected over the taus), channel unit."""

    tau_s: np.ndarray
    adev: np.ndarray
    baseline_low: np.ndarray
    baseline_high: np.ndarray
    final_adev: np.ndarray
    final_low: np.ndarray
    final_high: np.ndarray
    unit: str
    baseline_check_low: np.ndarray = ()
    baseline_check_high: np.ndarray = ()
    final_check_low: np.ndarray = ()
    final_check_high: np.ndarray = ()

    def as_dict(self) -> dict:
        return {
            "tau_s": _listed(self.tau_s),
            "adev": _listed(self.adev),
            "baseline_low": _listed(self.baseline_low),
            "baseline_high": _listed(self.baseline_high),
            "baseline_check_low": _listed(self.baseline_check_low),
            "baseline_check_high": _listed(self.baseline_check_high),
            "final_adev": _listed(self.final_adev),
            "final_low": _listed(self.final_low),
            "final_high": _listed(self.final_high),
            "final_check_low": _listed(self.final_check_low),
            "final_check_high": _listed(self.final_check_high),
            "unit": self.unit,
        }


@dataclass(frozen=True)
class SpectrumCurves:
    """The binned periodogram of the increments (mean ordinate per bin) before and after the
    deterministic terms are taken out, and each model's expected one, (channel unit)^2 per
    increment."""

    frequency_hz: np.ndarray
    power: np.ndarray
    baseline_model: np.ndarray
    final_power: np.ndarray
    final_model: np.ndarray
    unit: str
    """The channel's unit."""

    def as_dict(self) -> dict:
        return {
            "frequency_hz": _listed(self.frequency_hz),
            "power": _listed(self.power),
            "baseline_model": _listed(self.baseline_model),
            "final_power": _listed(self.final_power),
            "final_model": _listed(self.final_model),
            "unit": f"({self.unit})^2 per increment",
        }


@dataclass(frozen=True)
class ResidualCurves:
    """Block means of the residual of each model over time, channel unit."""

    time_s: np.ndarray
    baseline: np.ndarray
    final: np.ndarray
    unit: str

    def as_dict(self) -> dict:
        return {
            "time_s": _listed(self.time_s),
            "baseline": _listed(self.baseline),
            "final": _listed(self.final),
            "unit": self.unit,
        }


@dataclass(frozen=True)
class TemperatureCurves:
    """Block means of the residual of each model against the temperature's block means."""

    temperature: np.ndarray
    baseline: np.ndarray
    final: np.ndarray
    unit: str
    temperature_unit: str

    def as_dict(self) -> dict:
        return {
            "temperature": _listed(self.temperature),
            "baseline": _listed(self.baseline),
            "final": _listed(self.final),
            "unit": self.unit,
            "temperature_unit": self.temperature_unit,
        }


@dataclass(frozen=True)
class DistributionCurves:
    """Histogram of the samples as recorded and with the clipped ones imputed, on common
    bins, with the counts the fitted unclipped normal expects and the rails."""

    edges: np.ndarray
    recorded: np.ndarray
    unclipped: np.ndarray
    expected: np.ndarray
    rails: tuple[float, ...]
    unit: str

    def as_dict(self) -> dict:
        return {
            "edges": _listed(self.edges),
            "recorded": _listed(self.recorded),
            "unclipped": _listed(self.unclipped),
            "expected": _listed(self.expected),
            "rails": list(self.rails),
            "unit": self.unit,
        }


@dataclass(frozen=True)
class DiscoveryCurves:
    """The curves behind a discovery's figures, before (baseline) and after (final model):
    the JSON's ``diagnostics`` (:meth:`as_dict`) and what :mod:`._figures` draws."""

    allan: AllanCurves
    spectrum: SpectrumCurves
    residual_time: ResidualCurves
    residual_temperature: TemperatureCurves | None = None
    """With a temperature."""
    distribution: DistributionCurves | None = None
    """With a rail."""

    def as_dict(self) -> dict:
        out = {
            "allan": self.allan.as_dict(),
            "spectrum": self.spectrum.as_dict(),
            "residual": self.residual_time.as_dict(),
        }
        if self.residual_temperature is not None:
            out["temperature"] = self.residual_temperature.as_dict()
        if self.distribution is not None:
            out["distribution"] = self.distribution.as_dict()
        return out


def _curve(checks: list, name: str) -> dict:
    for check in checks:
        if check["name"] == name:
            return check.get("curve", {})
    return {}


def discovery_curves(discovery: Discovery) -> DiscoveryCurves:
    """The curves behind the figures, from the fits of the search: Allan deviation of the
    residual with the model's 90 % band, the binned spectrum of the increments with each
    model's, and the residual block means over time (and against the temperature) — before
    (baseline) and after (final); the distribution at a rail."""
    result = discovery.result
    before, after = result.baseline_checks, result.final_checks
    allan_before, allan_after = _curve(before, "allan_deviation"), _curve(after, "allan_deviation")
    summary = result.baseline.design.summary
    _, model_before = bin_ratios(result.baseline)
    ratio_after, model_after = bin_ratios(result.final)
    time_before, time_after = _curve(before, "residual_time"), _curve(after, "residual_time")
    unit = result.data.unit
    temperature = None
    temperature_before = _curve(before, "residual_vs_temperature")
    if temperature_before:
        temperature = TemperatureCurves(
            temperature=np.asarray(temperature_before["covariate"]),
            baseline=np.asarray(temperature_before["residual"]),
            final=np.asarray(_curve(after, "residual_vs_temperature").get("residual", [])),
            unit=unit,
            temperature_unit=result.data.temperature_unit,
        )
    return DiscoveryCurves(
        allan=AllanCurves(
            tau_s=np.asarray(allan_before.get("tau_s", [])),
            adev=np.asarray(allan_before.get("adev", [])),
            baseline_low=np.asarray(allan_before.get("model_low", [])),
            baseline_high=np.asarray(allan_before.get("model_high", [])),
            final_adev=np.asarray(allan_after.get("adev", [])),
            final_low=np.asarray(allan_after.get("model_low", [])),
            final_high=np.asarray(allan_after.get("model_high", [])),
            unit=unit,
            baseline_check_low=np.asarray(allan_before.get("check_low", [])),
            baseline_check_high=np.asarray(allan_before.get("check_high", [])),
            final_check_low=np.asarray(allan_after.get("check_low", [])),
            final_check_high=np.asarray(allan_after.get("check_high", [])),
        ),
        spectrum=SpectrumCurves(
            frequency_hz=np.asarray(summary.frequency_hz),
            power=np.asarray(summary.power / summary.count),
            baseline_model=np.asarray(model_before),
            final_power=np.asarray(ratio_after * model_after / summary.count),
            final_model=np.asarray(model_after),
            unit=unit,
        ),
        residual_time=ResidualCurves(
            time_s=np.asarray(time_before.get("time_s", [])),
            baseline=np.asarray(time_before.get("residual", [])),
            final=np.asarray(time_after.get("residual", [])),
            unit=unit,
        ),
        residual_temperature=temperature,
        distribution=_distribution(result) if result.saturation else None,
    )


def _distribution(result: SearchResult) -> DistributionCurves:
    recorded, unclipped = result.data.values, result.final.clean
    finite = unclipped[np.isfinite(unclipped)]
    edges = np.linspace(finite.min(), finite.max(), 61)
    expected = finite.size * np.diff(
        stats.norm.cdf(edges, result.saturation["mean"], result.saturation["sd"])
    )
    return DistributionCurves(
        edges=edges,
        recorded=np.histogram(recorded[np.isfinite(recorded)], edges)[0],
        unclipped=np.histogram(finite, edges)[0],
        expected=expected,
        rails=tuple(rail["value"] for rail in result.saturation["rails"].values()),
        unit=result.data.unit,
    )


@dataclass(frozen=True)
class Findings:
    """A discovery as the report renders it: the result, the curves behind its figures, the
    recording it ran on and, for ``--sim``, the simulation its baseline came from."""

    discovery: Discovery
    curves: DiscoveryCurves
    source: str
    simulation: dict | None = None

    @classmethod
    def of(cls, discovery: Discovery, *, source: str, simulation: dict | None = None):
        """The findings of ``discovery``, its curves computed once."""
        return cls(discovery, discovery_curves(discovery), source, simulation)

    @property
    def channel(self) -> str:
        return self.discovery.channel


def discovery_document(findings: Findings) -> dict:
    """The JSON document of ``bayescal discover`` (the contract of the discovery issue, with
    more keys)."""
    discovery = findings.discovery
    document = {
        "channel": discovery.channel,
        "unit": discovery.unit,
        "source": findings.source,
        "rate_hz": discovery.rate_hz,
        "duration_s": discovery.duration_s,
        "baseline": list(discovery.baseline),
        "effects": [
            {
                "name": effect.name,
                "explanation": effect.explanation,
                "location": effect.location,
                "evidence": effect.evidence,
                "delta_elpd": effect.delta_elpd,
                "delta_elpd_se": effect.delta_elpd_se,
                "parameters": effect.parameters,
            }
            for effect in discovery.effects
        ],
        "final_terms": list(discovery.final_terms),
        "checks": [_check_entry(check) for check in discovery.checks],
        "decision_rule": DECISION_RULE,
    }
    if discovery.unexplained is not None:
        document["unexplained"] = discovery.unexplained
    if discovery.posterior is not None:
        posterior = discovery.posterior
        document["posterior"] = {
            "parameters": {
                name: summarize(values, posterior.units[name])
                for name, values in posterior.draws.items()
            },
            "health": posterior.diagnostics.as_dict(),
        }
    if findings.simulation is not None:
        document["simulation"] = findings.simulation
    document["diagnostics"] = findings.curves.as_dict()
    return to_jsonable(document)


def discover_channel(
    recording: Recording, channel: Channel, *, seed: int = 0, baseline=("white",)
) -> Findings:
    """Discovery on one prepared channel of a recording, with the temperature and (for a
    gyro) the accelerometer axes found by name on its grid: what ``bayescal report
    --discover`` and the demo put on the page."""
    temperature, accelerometers, units = companions(recording, channel)
    found = discover(
        channel,
        temperature=temperature,
        accelerometers=accelerometers,
        accelerometer_unit=units,
        baseline=baseline,
        seed=seed,
    )
    return Findings.of(found, source=recording.source)


def _check_entry(check: CheckResult) -> dict:
    entry = {
        "name": check.name,
        "statistic": check.statistic,
        "p_value": check.p_value,
        "location": check.location,
        "passed_before": check.passed_before,
        "passed_after": check.passed_after,
    }
    if check.p_value_after is not None:
        entry["p_value_after"] = check.p_value_after
    return entry


def discovery_text(discovery: Discovery) -> str:
    """The lines ``bayescal discover`` prints: the effects named with their evidence and
    parameters, the final model, what is left unexplained, every check before and after."""
    lines = [
        f"discovery on {discovery.channel} ({discovery.unit}), "
        f"{discovery.duration_s:.0f} s at {discovery.rate_hz:g} Hz",
        f"baseline: {', '.join(discovery.baseline)}",
    ]
    if not discovery.effects:
        lines.append("nothing missing: no term improves the fit decisively")
    for number, effect in enumerate(discovery.effects, 1):
        lines += _effect_lines(number, effect)
    lines.append(f"final model: {', '.join(discovery.final_terms)}")
    if discovery.unexplained is not None:
        lines.append(f"still unexplained: {discovery.unexplained['explanation']}")
    for check in discovery.checks:
        mark = "ok" if check.passed_after else "MISMATCH"
        before = "ok" if check.passed_before else "failed"
        lines.append(f"   check {check.name:<28} before: {before:<7} after: {mark}")
    return "\n".join(lines)


def _effect_lines(number: int, effect) -> list[str]:
    """One found effect as text: its evidence, explanation and parameters (90 % intervals)."""
    evidence = effect.evidence
    if evidence["log_bayes_factor"] is None and "grid" in evidence:
        grid = evidence["grid"]
        lines = [
            f"{number}. {effect.name}: every one of {grid['samples']} samples on a grid "
            f"of {grid['lsb']:.6g} {grid['unit']} ({grid['levels']} levels)"
        ]
    else:
        lines = [
            f"{number}. {effect.name}: log Bayes factor "
            f"{evidence['log_bayes_factor']:.1f}, delta ELPD "
            f"{effect.delta_elpd:.1f} ± {effect.delta_elpd_se:.1f}"
        ]
    if "white_angle_noise" in evidence:
        lines.append(
            "   white angle noise beyond the rounding: log Bayes factor "
            f"{evidence['white_angle_noise']['log_bayes_factor']:.1f}"
        )
    lines.append(f"   {effect.explanation}")
    if effect.name == "saturation":
        for side, rail in evidence["rails"].items():
            lines.append(
                f"   {side} rail {rail['value']:.6g} {rail['unit']}: {rail['samples']} samples"
            )
        lines.append(
            f"   unclipped mean {evidence['unclipped_mean']:.6g} {evidence['unit']}, sd "
            f"{evidence['unclipped_sd']:.4g} (as recorded: {evidence['clipped_mean']:.6g}, "
            f"{evidence['clipped_sd']:.4g})"
        )
    for name, value in effect.parameters.items():
        lines += _parameter_lines(name, value)
    return lines


def _parameter_lines(name: str, value: dict) -> list[str]:
    if "q05" in value:
        digits = _digits(value["q05"], value["q95"])
        return [
            f"   {name} = {value['mean']:.{digits}g} [{value['q05']:.{digits}g}, "
            f"{value['q95']:.{digits}g}] {value['unit']} (90 %)"
        ]
    if "value" in value:
        shown = value["value"]
        shown = f"{shown:.6g}" if isinstance(shown, float) else shown
        return [f"   {name} = {shown} {value.get('unit', '')}".rstrip()]
    return []


def _digits(low: float, high: float) -> int:
    """Significant digits that show an interval's ends apart (four at least): two lines
    0.003 Hz apart near 38 Hz print as 37.991 and 37.994, not both 37.99."""
    if not (np.isfinite(low) and np.isfinite(high)) or high <= low:
        return 4
    magnitude = max(abs(low), abs(high))
    return int(max(4, min(12, np.ceil(np.log10(magnitude / (high - low))) + 2)))


def discovery_figures(findings: Findings) -> dict:
    """name -> figure of every curve the discovery has (:data:`._figures.DISCOVERY_FIGURES`),
    each with what it shows."""
    discovery, curves = findings.discovery, findings.curves
    found = bool(discovery.effects)
    figures = {}
    for name, (draw, alt) in DISCOVERY_FIGURES.items():
        shown = getattr(curves, name)
        if shown is not None:
            figures[name] = (draw(discovery.channel, discovery.unit, shown, found), alt)
    return figures


def final_datatree(findings: Findings):
    """The final posterior of a discovery as ArviZ data, units in the attributes."""
    import arviz_base

    discovery = findings.discovery
    posterior = discovery.posterior
    tree = arviz_base.from_dict(
        {"posterior": dict(posterior.draws)},
        attrs={
            "/": {
                "bayescal_version": version("bayescal"),
                "inference_library": "emcee",
                "channel": discovery.channel,
                "source": findings.source,
                "final_terms": ",".join(discovery.final_terms),
                "diagnostics": json.dumps(posterior.diagnostics.as_dict()),
                "note": "nonlinear parameters found by search (time constants, frequencies) "
                "are held at their located values; see the JSON for their intervals",
            }
        },
    )
    for name, unit in posterior.units.items():
        tree["posterior"][name].attrs["units"] = unit
    return tree


def write_folder(folder: Path, findings: Findings, document: dict) -> None:
    """Figures (PNG, the page's own), the curves and the findings (JSON), the final
    posterior (netCDF)."""
    folder = Path(folder)
    folder.mkdir(exist_ok=True)
    stem = f"discover_{file_stem(findings.channel)}"
    for name, (figure, _) in discovery_figures(findings).items():
        with atomic_path(folder / f"{stem}_{name}.png") as temporary:
            Path(temporary).write_bytes(png(figure, FILE_DPI, tight=True))
    if findings.discovery.posterior is not None:
        write_netcdf(final_datatree(findings), folder / f"{stem}_posterior.nc")
    write_json(folder / f"{stem}.json", document)
