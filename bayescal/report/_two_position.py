"""A two-position calibration rendered: the JSON document of ``bayescal two-position`` and
the table it prints."""

from importlib.metadata import version

import numpy as np

from ..capabilities._two_position import TwoPositionCalibration
from ..classical._two_position import Section
from ..inference._mcmc import summarize
from ..recording._units import parse_unit


def _entry(value, uncertainty, unit):
    return {"value": value, "uncertainty": uncertainty, "unit": unit}


def two_position_result(calibration: TwoPositionCalibration, found_by: str) -> dict:
    """The JSON document of ``bayescal two-position``; ``found_by`` says where the sections
    came from.

    Over 80 lines: the document's layout, block after block, as the JSON holds it.
    """
    channel, unit, rate_hz = calibration.channel, calibration.unit, calibration.rate_hz
    up, down, gravity = calibration.up, calibration.down, calibration.gravity
    confidence, classical = calibration.confidence, calibration.classical
    bayesian = calibration.bayesian
    parsed = parse_unit(unit)
    scale_unit = calibration.scale_unit

    def section(s: Section):
        n = int(np.count_nonzero(~np.isnan(s.values)))
        return {
            "source": s.source,
            "start_s": s.start_s,
            "stop_s": s.start_s + s.values.size / rate_hz,
            "n_samples": n,
        }

    block = {
        name: _entry(*classical[name], unit) for name in ("mean_up", "mean_down", "span", "offset")
    }
    block["scale"] = _entry(*classical["scale"], scale_unit)
    block["confidence"] = confidence
    block["method"] = (
        "means with Student-t half-widths; span: RMS of the two; scale 2 g/span "
        "propagated to first order (gravity included); offset: half the RMS"
    )
    if parsed.quantity == "acceleration":
        to_si = parsed.to_si
        block["si"] = {
            name: _entry(classical[name][0] * to_si, classical[name][1] * to_si, "m/s^2")
            for name in ("mean_up", "mean_down", "span", "offset")
        }
        block["si"]["scale"] = _entry(
            classical["scale"][0] / to_si, classical["scale"][1] / to_si, "1"
        )
    result = {
        "bayescal_version": version("bayescal"),
        "command": "two-position",
        "channel": channel,
        "unit": unit,
        "rate_hz": rate_hz,
        "sections": {"up": section(up), "down": section(down), "found_by": found_by},
        "gravity": {
            "value": gravity.value,
            "uncertainty": gravity.uncertainty,
            "unit": "m/s^2",
            "uncertainty_is": "one standard deviation",
            "source": gravity.source,
        },
        "classical": block,
    }
    if bayesian is not None:
        draws, values, spread = bayesian.draws, bayesian.map_values, bayesian.map_sd
        units = {"scale": scale_unit, "offset": unit, "g_local": "m/s^2"}
        parameters = {
            name: summarize(draws[name], units[name], values[name], spread[name])
            for name in ("scale", "offset", "g_local")
        }
        noise = bayesian.noise
        result["bayesian"] = {
            "parameters": parameters,
            "model": "reading = offset +- g_local / scale + noise (stationary noise model, "
            f"terms {', '.join(noise.terms)}, shared by both sections)",
            "noise": {
                name: {"mean": p.mean, "q05": p.q05, "q95": p.q95}
                for name, p in noise.parameters.items()
                if name != "bias"
            },
            "diagnostics": {
                "passed": noise.diagnostics.passed,
                "failures": list(noise.diagnostics.failures),
                "n_steps": noise.diagnostics.n_steps,
                "rhat": noise.diagnostics.rhat,
                "ess_bulk": noise.diagnostics.ess_bulk,
            },
            "fit_checks": [
                {key: check[key] for key in ("name", "p_value", "location", "passed", "misfit")}
                for check in bayesian.checks
            ],
            "fits": not bayesian.misfits,
            "comparison": _comparison(classical, parameters, confidence),
        }
        if bayesian.selection is not None:
            result["bayesian"]["term_selection"] = bayesian.selection.table
    return result


def _comparison(classical: dict, parameters: dict, confidence: float) -> list[str]:
    from scipy import stats

    notes = []
    z = float(stats.norm.ppf(0.5 + confidence / 2))
    for name in ("scale", "offset"):
        classical_sd = classical[name][1] / z
        ratio = parameters[name]["sd"] / classical_sd if classical_sd > 0 else float("inf")
        if ratio > 1.5:
            notes.append(
                f"{name}: the posterior's uncertainty is {ratio:.3g}x the classical one: "
                "the noise is correlated (the sections' levels wander), which the RMS of "
                "Student-t uncertainties, built on independent samples, leaves out"
            )
    return notes


def two_position_text(result: dict) -> str:
    classical = result["classical"]
    percent = f"{100 * classical['confidence']:g}%"
    sections = result["sections"]
    lines = [
        f"bayescal two-position: channel {result['channel']} [{result['unit']}]",
        f"  up   {sections['up']['start_s']:.6g}-{sections['up']['stop_s']:.6g} s, "
        f"{sections['up']['n_samples']} samples ({sections['up']['source']})",
        f"  down {sections['down']['start_s']:.6g}-{sections['down']['stop_s']:.6g} s, "
        f"{sections['down']['n_samples']} samples ({sections['down']['source']})",
        f"  sections: {sections['found_by']}",
        f"  g_local {result['gravity']['value']:.7g} +- {result['gravity']['uncertainty']:.2g} "
        f"m/s^2 (1 sd; {result['gravity']['source']})",
        "",
        f"  {'':10}{'classical (' + percent + ' half-width)':<42}"
        f"{'Bayesian mean [90%]' if 'bayesian' in result else ''}",
    ]
    for name in ("mean_up", "mean_down", "span", "scale", "offset"):
        entry = classical[name]
        row = f"  {name:<10}{entry['value']:.7g} +- {entry['uncertainty']:.3g} {entry['unit']:<14}"
        if "bayesian" in result and name in result["bayesian"]["parameters"]:
            p = result["bayesian"]["parameters"][name]
            row = f"{row:<54}{p['mean']:.7g} [{p['q05']:.7g}, {p['q95']:.7g}]"
        lines.append(row)
    if "bayesian" in result:
        bayesian = result["bayesian"]
        lines.append(
            "  noise: " + ", ".join(f"{n} {v['mean']:.3g}" for n, v in bayesian["noise"].items())
        )
        diagnostics = bayesian["diagnostics"]
        lines.append(
            "  posterior checks "
            + (
                "passed"
                if diagnostics["passed"]
                else "FAILED: " + "; ".join(diagnostics["failures"])
            )
        )
        if bayesian["fits"]:
            lines.append("  the noise model fits the sections (Allan deviation, spectrum, lag-1)")
        else:
            lines.append("  NOISE MODEL MISFIT — its intervals do not describe these sections:")
            lines += [f"    - {c['misfit']}" for c in bayesian["fit_checks"] if c["misfit"]]
        lines += [f"  - {note}" for note in bayesian["comparison"]]
    return "\n".join(lines)
