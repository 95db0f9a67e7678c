"""``bayescal two-position``: sections, gravity, classical and Bayesian calibration as data
and as the table the command prints."""

from importlib.metadata import version

import numpy as np

from ._errors import InputError
from ._gravity import LocalGravity
from ._mcmc import summarize
from ._recording import ChannelData
from ._sections import find_static_sections
from ._two_position import BayesianTwoPosition, Section
from ._units import parse_unit


def sections_from_file(
    data: ChannelData, accelerometer: np.ndarray | None, given: str | None
) -> tuple[Section, Section, str]:
    """The up and down sections of one recording: from ``--sections UP_START:UP_STOP,...``
    (seconds) or found as the longest still stretches at the channel's highest and lowest
    levels (still-ness judged on the whole accelerometer when there is one)."""
    time = data.time_s
    if given:
        try:
            (up_start, up_stop), (down_start, down_stop) = (
                tuple(float(x) for x in part.split(":")) for part in given.split(",")
            )
        except ValueError:
            raise InputError(
                f"--sections {given!r}",
                fix="write UP_START:UP_STOP,DOWN_START:DOWN_STOP in seconds from the first sample",
            ) from None

        def cut(start, stop):
            keep = (time >= start) & (time < stop)
            return Section(
                data.values[keep], float(time[keep][0]) if keep.any() else start, data.source
            )

        return cut(up_start, up_stop), cut(down_start, down_stop), "--sections"
    if np.isnan(data.values).any():
        raise InputError(
            "static sections cannot be found across gaps",
            source=data.source,
            column=data.channel,
            fix="give them with --sections",
        )
    still = find_static_sections(
        data.values if accelerometer is None else accelerometer, data.rate_hz
    )
    levels = np.array([data.values[s.start : s.stop].mean() for s in still])
    if levels.size < 2:
        raise InputError(
            f"found {levels.size} still section(s); two are needed (up and down)",
            source=data.source,
            column=data.channel,
            fix="hold the sensor still in each position for a few seconds, or "
            "give the sections with --sections",
        )
    middle, half = (levels.max() + levels.min()) / 2, (levels.max() - levels.min()) / 2
    chosen = {}
    for name, sign in (("up", 1), ("down", -1)):
        near = [
            s
            for s, level in zip(still, levels, strict=True)
            if sign * (level - middle) > 0.8 * half
        ]
        chosen[name] = max(near, key=lambda s: s.stop - s.start)
    up, down = (
        Section(data.values[s.start : s.stop], float(time[s.start]), data.source)
        for s in (chosen["up"], chosen["down"])
    )
    return up, down, f"{len(still)} still sections found; the longest at each extreme"


def _entry(value, uncertainty, unit):
    return {"value": value, "uncertainty": uncertainty, "unit": unit}


def two_position_result(
    channel: str,
    unit: str,
    rate_hz: float,
    up: Section,
    down: Section,
    found_by: str,
    gravity: LocalGravity,
    confidence: float,
    classical: dict,
    bayesian: BayesianTwoPosition | None,
) -> dict:
    """The JSON document of ``bayescal two-position``."""
    parsed = parse_unit(unit)
    scale_unit = f"m/s^2/({unit})" if "/" in unit else f"m/s^2/{unit}"

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
            "comparison": _comparison(classical, parameters, confidence),
        }
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
        lines += [f"  - {note}" for note in bayesian["comparison"]]
    return "\n".join(lines)
