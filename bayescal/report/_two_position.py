"""A two-position calibration rendered: the JSON document of ``bayescal two-position``
(:func:`two_position_result`) and the table it prints (:func:`two_position_text`), both read
from the :class:`~bayescal.TwoPositionCalibration`."""

from importlib.metadata import version

import numpy as np

from ..capabilities._two_position import TwoPositionCalibration
from ..classical._two_position import Section
from ..recording._units import parse_unit

_CLASSICAL = ("mean_up", "mean_down", "span", "scale", "offset")
"""The classical answer's entries, in the order shown."""


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
        return {
            "source": s.source,
            "start_s": s.start_s,
            "stop_s": _stop_s(s, rate_hz),
            "n_samples": _present(s),
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
        parameters = calibration.summary
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
                {key: value for key, value in check.as_dict().items() if key != "statistic"}
                for check in bayesian.checks
            ],
            "fits": not bayesian.misfits,
            "comparison": _comparison(calibration),
        }
        if bayesian.selection is not None:
            result["bayesian"]["term_selection"] = bayesian.selection.table
    return result


def _stop_s(section: Section, rate_hz: float) -> float:
    return section.start_s + section.values.size / rate_hz


def _present(section: Section) -> int:
    return int(np.count_nonzero(~np.isnan(section.values)))


def _comparison(calibration: TwoPositionCalibration) -> list[str]:
    """Where the posterior's uncertainty of the scale and offset exceeds the classical one
    by half again, and why."""
    from scipy import stats

    notes = []
    z = float(stats.norm.ppf(0.5 + calibration.confidence / 2))
    parameters = calibration.summary
    for name in ("scale", "offset"):
        classical_sd = calibration.classical[name][1] / z
        ratio = parameters[name]["sd"] / classical_sd if classical_sd > 0 else float("inf")
        if ratio > 1.5:
            notes.append(
                f"{name}: the posterior's uncertainty is {ratio:.3g}x the classical one: "
                "the noise is correlated (the sections' levels wander), which the RMS of "
                "Student-t uncertainties, built on independent samples, leaves out"
            )
    return notes


def two_position_text(calibration: TwoPositionCalibration, found_by: str) -> str:
    """The table ``bayescal two-position`` prints; ``found_by`` says where the sections came
    from."""
    percent = f"{100 * calibration.confidence:g}%"
    rate_hz, gravity, bayesian = calibration.rate_hz, calibration.gravity, calibration.bayesian
    lines = [f"bayescal two-position: channel {calibration.channel} [{calibration.unit}]"]
    for name, section in (("up  ", calibration.up), ("down", calibration.down)):
        lines.append(
            f"  {name} {section.start_s:.6g}-{_stop_s(section, rate_hz):.6g} s, "
            f"{_present(section)} samples ({section.source})"
        )
    lines += [
        f"  sections: {found_by}",
        f"  g_local {gravity.value:.7g} +- {gravity.uncertainty:.2g} "
        f"m/s^2 (1 sd; {gravity.source})",
        "",
        f"  {'':10}{'classical (' + percent + ' half-width)':<42}"
        f"{'Bayesian mean [90%]' if bayesian is not None else ''}",
    ]
    parameters = {} if bayesian is None else calibration.summary
    for name in _CLASSICAL:
        value, uncertainty = calibration.classical[name]
        unit = calibration.scale_unit if name == "scale" else calibration.unit
        row = f"  {name:<10}{value:.7g} +- {uncertainty:.3g} {unit:<14}"
        if name in parameters:
            p = parameters[name]
            row = f"{row:<54}{p['mean']:.7g} [{p['q05']:.7g}, {p['q95']:.7g}]"
        lines.append(row)
    if bayesian is not None:
        noise = bayesian.noise
        lines.append(
            "  noise: "
            + ", ".join(f"{n} {p.mean:.3g}" for n, p in noise.parameters.items() if n != "bias")
        )
        diagnostics = noise.diagnostics
        lines.append(
            "  posterior checks "
            + ("passed" if diagnostics.passed else "FAILED: " + "; ".join(diagnostics.failures))
        )
        if not bayesian.misfits:
            lines.append("  the noise model fits the sections (Allan deviation, spectrum, lag-1)")
        else:
            lines.append("  NOISE MODEL MISFIT — its intervals do not describe these sections:")
            lines += [f"    - {misfit}" for misfit in bayesian.misfits]
        lines += [f"  - {note}" for note in _comparison(calibration)]
    return "\n".join(lines)
