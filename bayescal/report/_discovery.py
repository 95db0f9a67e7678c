"""A discovery rendered: its JSON document, the text ``bayescal discover`` prints, the
before/after curves and figures, and its final posterior as ArviZ data."""

import json
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


def discovery_document(
    discovery: Discovery, *, source: str, simulation: dict | None = None
) -> dict:
    """The JSON document of ``bayescal discover`` (the contract of the discovery issue, with
    more keys)."""
    document = {
        "channel": discovery.channel,
        "unit": discovery.unit,
        "source": source,
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
        "decision_rule": "a term is accepted when its Schwarz (BIC) log Bayes factor against "
        "the current model exceeds log(100) = 4.6 (decisive); delta_elpd is the AIC-penalised "
        "gain in log predictive density, pointwise over independent frequency bins of the "
        "increments and one-block-ahead predictions of 128 block means, with its standard "
        "error; saturation and outliers are decided first, on the samples' distribution "
        "(censored and contaminated normal against the normal), at the same threshold",
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
    if simulation is not None:
        document["simulation"] = simulation
    document["diagnostics"] = diagnostics(discovery.result)
    return to_jsonable(document)


def discovery_findings(
    recording: Recording, channel: Channel, *, seed: int = 0, baseline=("white",)
) -> dict:
    """Discovery on one prepared channel of a recording, with the temperature and (for a
    gyro) the accelerometer axes found by name on its grid: the document ``bayescal report
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
    return discovery_document(found, source=recording.source)


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


def discovery_text(document: dict) -> str:
    lines = [
        f"discovery on {document['channel']} ({document['unit']}), "
        f"{document['duration_s']:.0f} s at {document['rate_hz']:g} Hz",
        f"baseline: {', '.join(document['baseline'])}",
    ]
    if not document["effects"]:
        lines.append("nothing missing: no term improves the fit decisively")
    for number, effect in enumerate(document["effects"], 1):
        evidence = effect["evidence"]
        if evidence["log_bayes_factor"] is None and "grid" in evidence:
            grid = evidence["grid"]
            lines.append(
                f"{number}. {effect['name']}: every one of {grid['samples']} samples on a grid "
                f"of {grid['lsb']:.6g} {grid['unit']} ({grid['levels']} levels)"
            )
        else:
            lines.append(
                f"{number}. {effect['name']}: log Bayes factor "
                f"{evidence['log_bayes_factor']:.1f}, delta ELPD "
                f"{effect['delta_elpd']:.1f} ± {effect['delta_elpd_se']:.1f}"
            )
        if "white_angle_noise" in evidence:
            lines.append(
                "   white angle noise beyond the rounding: log Bayes factor "
                f"{evidence['white_angle_noise']['log_bayes_factor']:.1f}"
            )
        lines.append(f"   {effect['explanation']}")
        if effect["name"] == "saturation":
            evidence = effect["evidence"]
            for side, rail in evidence["rails"].items():
                lines.append(
                    f"   {side} rail {rail['value']:.6g} {rail['unit']}: {rail['samples']} samples"
                )
            lines.append(
                f"   unclipped mean {evidence['unclipped_mean']:.6g} {evidence['unit']}, sd "
                f"{evidence['unclipped_sd']:.4g} (as recorded: {evidence['clipped_mean']:.6g}, "
                f"{evidence['clipped_sd']:.4g})"
            )
        for name, value in effect["parameters"].items():
            if "q05" in value:
                digits = _digits(value["q05"], value["q95"])
                lines.append(
                    f"   {name} = {value['mean']:.{digits}g} [{value['q05']:.{digits}g}, "
                    f"{value['q95']:.{digits}g}] {value['unit']} (90 %)"
                )
            elif "value" in value:
                shown = value["value"]
                shown = f"{shown:.6g}" if isinstance(shown, float) else shown
                lines.append(f"   {name} = {shown} {value.get('unit', '')}".rstrip())
    lines.append(f"final model: {', '.join(document['final_terms'])}")
    if "unexplained" in document:
        lines.append(f"still unexplained: {document['unexplained']['explanation']}")
    for check in document["checks"]:
        mark = "ok" if check["passed_after"] else "MISMATCH"
        before = "ok" if check["passed_before"] else "failed"
        lines.append(f"   check {check['name']:<28} before: {before:<7} after: {mark}")
    return "\n".join(lines)


def _digits(low: float, high: float) -> int:
    """Significant digits that show an interval's ends apart (four at least): two lines
    0.003 Hz apart near 38 Hz print as 37.991 and 37.994, not both 37.99."""
    if not (np.isfinite(low) and np.isfinite(high)) or high <= low:
        return 4
    magnitude = max(abs(low), abs(high))
    return int(max(4, min(12, np.ceil(np.log10(magnitude / (high - low))) + 2)))


def _curve(checks: list, name: str) -> dict:
    for check in checks:
        if check["name"] == name:
            return check.get("curve", {})
    return {}


def diagnostics(result: SearchResult) -> dict:
    """The curves behind the figures: Allan deviation of the residual with the model's 90 %
    band, the binned spectrum of the increments with each model's, and the residual block
    means over time (and against the temperature) — before (baseline) and after (final)."""
    before, after = result.baseline_checks, result.final_checks
    allan_before, allan_after = _curve(before, "allan_deviation"), _curve(after, "allan_deviation")
    summary = result.baseline.design.summary
    _, model_before = bin_ratios(result.baseline)
    ratio_after, model_after = bin_ratios(result.final)
    time_before, time_after = _curve(before, "residual_time"), _curve(after, "residual_time")
    out = {
        "allan": {
            "tau_s": allan_before.get("tau_s", []),
            "adev": allan_before.get("adev", []),
            "baseline_low": allan_before.get("model_low", []),
            "baseline_high": allan_before.get("model_high", []),
            "final_adev": allan_after.get("adev", []),
            "final_low": allan_after.get("model_low", []),
            "final_high": allan_after.get("model_high", []),
            "unit": result.data.unit,
        },
        "spectrum": {
            "frequency_hz": summary.frequency_hz.tolist(),
            "power": (summary.power / summary.count).tolist(),
            "baseline_model": model_before.tolist(),
            "final_power": (ratio_after * model_after / summary.count).tolist(),
            "final_model": model_after.tolist(),
            "unit": f"({result.data.unit})^2 per increment",
        },
        "residual": {
            "time_s": time_before.get("time_s", []),
            "baseline": time_before.get("residual", []),
            "final": time_after.get("residual", []),
            "unit": result.data.unit,
        },
    }
    temperature_before = _curve(before, "residual_vs_temperature")
    if temperature_before:
        out["temperature"] = {
            "temperature": temperature_before["covariate"],
            "baseline": temperature_before["residual"],
            "final": _curve(after, "residual_vs_temperature").get("residual", []),
            "unit": result.data.unit,
            "temperature_unit": result.data.temperature_unit,
        }
    if result.saturation:
        out["distribution"] = _distribution(result)
    return out


def _distribution(result: SearchResult) -> dict:
    """Histogram of the samples as recorded and with the clipped ones imputed, on common bins,
    with the counts the fitted unclipped normal expects and the rails."""
    recorded, unclipped = result.data.values, result.final.clean
    finite = unclipped[np.isfinite(unclipped)]
    edges = np.linspace(finite.min(), finite.max(), 61)
    expected = finite.size * np.diff(
        stats.norm.cdf(edges, result.saturation["mean"], result.saturation["sd"])
    )
    return {
        "edges": edges.tolist(),
        "recorded": np.histogram(recorded[np.isfinite(recorded)], edges)[0].tolist(),
        "unclipped": np.histogram(finite, edges)[0].tolist(),
        "expected": expected.tolist(),
        "rails": [rail["value"] for rail in result.saturation["rails"].values()],
        "unit": result.data.unit,
    }


def _figures(curves: dict, channel: str) -> dict:
    """name -> matplotlib figure, each showing the baseline beside the final model."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    figures = {}
    allan = curves["allan"]
    figure, axis = plt.subplots(figsize=(6.4, 4.2))
    axis.loglog(allan["tau_s"], allan["adev"], "k.-", label="recording")
    axis.fill_between(
        allan["tau_s"],
        allan["baseline_low"],
        allan["baseline_high"],
        color="tab:red",
        alpha=0.3,
        label="baseline model, 90 % band",
    )
    if allan["final_adev"]:
        axis.loglog(
            allan["tau_s"][: len(allan["final_adev"])],
            allan["final_adev"],
            "b.--",
            label="recording less the added deterministic terms",
        )
        axis.fill_between(
            allan["tau_s"][: len(allan["final_low"])],
            allan["final_low"],
            allan["final_high"],
            color="tab:blue",
            alpha=0.3,
            label="final model, 90 % band",
        )
    axis.set(
        xlabel="τ [s]",
        ylabel=f"Allan deviation [{allan['unit']}]",
        title=f"{channel}: Allan deviation before and after",
    )
    axis.legend(fontsize=8)
    figures["allan"] = figure

    spectrum = curves["spectrum"]
    figure, axis = plt.subplots(figsize=(6.4, 4.2))
    axis.loglog(
        spectrum["frequency_hz"],
        spectrum["power"],
        color="0.5",
        lw=0.8,
        label="recording (increments, binned)",
    )
    axis.loglog(spectrum["frequency_hz"], spectrum["baseline_model"], "r", label="baseline model")
    axis.loglog(
        spectrum["frequency_hz"],
        spectrum["final_power"],
        color="tab:cyan",
        lw=0.8,
        label="recording less the deterministic terms",
    )
    axis.loglog(spectrum["frequency_hz"], spectrum["final_model"], "b--", label="final model")
    axis.set(
        xlabel="frequency [Hz]",
        ylabel=f"periodogram [{spectrum['unit']}]",
        title=f"{channel}: spectrum before and after",
    )
    axis.legend(fontsize=8)
    figures["spectrum"] = figure

    residual = curves["residual"]
    figure, axis = plt.subplots(figsize=(6.4, 4.2))
    axis.plot(residual["time_s"], residual["baseline"], "r.-", label="baseline residual")
    axis.plot(residual["time_s"], residual["final"], "b.-", label="final residual")
    axis.axhline(0, color="k", lw=0.5)
    axis.set(
        xlabel="time [s]",
        ylabel=f"block mean of residual [{residual['unit']}]",
        title=f"{channel}: residual over time",
    )
    axis.legend(fontsize=8)
    figures["residual_time"] = figure

    if "temperature" in curves:
        temperature = curves["temperature"]
        figure, axis = plt.subplots(figsize=(6.4, 4.2))
        axis.plot(temperature["temperature"], temperature["baseline"], "r.", label="baseline")
        axis.plot(temperature["temperature"], temperature["final"], "b.", label="final")
        axis.set(
            xlabel=f"temperature [{temperature['temperature_unit']}]",
            ylabel=f"block mean of residual [{temperature['unit']}]",
            title=f"{channel}: residual against temperature",
        )
        axis.legend(fontsize=8)
        figures["residual_temperature"] = figure

    if "distribution" in curves:
        distribution = curves["distribution"]
        edges = distribution["edges"]
        figure, axis = plt.subplots(figsize=(6.4, 4.2))
        axis.stairs(distribution["recorded"], edges, color="tab:red", label="as recorded")
        axis.stairs(
            distribution["unclipped"], edges, color="tab:blue", label="clipped samples imputed"
        )
        axis.stairs(distribution["expected"], edges, color="k", ls="--", label="unclipped normal")
        for rail in distribution["rails"]:
            axis.axvline(rail, color="0.4", lw=0.8)
        axis.set(
            yscale="log",
            ylim=(0.5, None),
            xlabel=f"sample value [{distribution['unit']}] (rail: grey line)",
            ylabel="samples per bin",
            title=f"{channel}: distribution at the rail",
        )
        axis.legend(fontsize=8)
        figures["distribution"] = figure
    return figures


def final_datatree(posterior, document: dict):
    """The final posterior of a discovery as ArviZ data, units in the attributes."""
    import arviz_base

    tree = arviz_base.from_dict(
        {"posterior": dict(posterior.draws)},
        attrs={
            "/": {
                "bayescal_version": version("bayescal"),
                "inference_library": "emcee",
                "channel": document["channel"],
                "source": document["source"],
                "final_terms": ",".join(document["final_terms"]),
                "diagnostics": json.dumps(posterior.diagnostics.as_dict()),
                "note": "nonlinear parameters found by search (time constants, frequencies) "
                "are held at their located values; see the JSON for their intervals",
            }
        },
    )
    for name, unit in posterior.units.items():
        tree["posterior"][name].attrs["units"] = unit
    return tree


def write_folder(folder: Path, discovery: Discovery, document: dict) -> None:
    """Figures (PNG), the curves and the findings (JSON), the final posterior (netCDF)."""
    folder = Path(folder)
    folder.mkdir(exist_ok=True)
    stem = f"discover_{file_stem(document['channel'])}"
    curves = document.get("diagnostics") or diagnostics(discovery.result)
    for name, figure in _figures(curves, document["channel"]).items():
        with atomic_path(folder / f"{stem}_{name}.png") as temporary:
            figure.savefig(temporary, format="png", dpi=110, bbox_inches="tight")
        figure.clear()
    if discovery.posterior is not None:
        write_netcdf(final_datatree(discovery.posterior, document), folder / f"{stem}_posterior.nc")
    write_json(folder / f"{stem}.json", document)
