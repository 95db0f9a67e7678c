"""``bayescal noise``: classical noise numbers of one static channel, as JSON-ready data and
as the table the command prints."""

from importlib.metadata import version

from ._classical import ClassicalNoise, SlopeReading
from ._recording import ChannelData
from ._units import display_values, noise_parameter_unit

_READ_AT = {
    "Q": "-1 line at tau = sqrt(3) s",
    "N": "-1/2 line at tau = 1 s",
    "B": "flat floor / 0.664",
    "K": "+1/2 line at tau = 3 s",
}


def _reading(parameter: str, reading: SlopeReading, unit: str) -> dict:
    parameter_unit = noise_parameter_unit(parameter, unit)
    return {
        "value": reading.value,
        "ci_low": reading.ci_low,
        "ci_high": reading.ci_high,
        "unit": parameter_unit,
        "kind": reading.kind,
        "tau_s": reading.tau_s,
        "local_slope": reading.local_slope,
        "read_at": _READ_AT[parameter],
        "display": {
            label: {
                "value": value,
                "ci_high": display_values(parameter, reading.ci_high, unit)[label],
            }
            for label, value in display_values(parameter, reading.value, unit).items()
        },
    }


def _t_interval_explanation(classical: ClassicalNoise) -> str:
    check = classical.t_interval
    if check.valid:
        return (
            f"consistent with independent samples: the Allan deviation at tau = "
            f"{check.tau_s:g} s is {check.ratio:.2f}x the white-noise prediction "
            f"(interval {check.ratio_ci_low:.2f}-{check.ratio_ci_high:.2f} includes 1)"
        )
    return (
        f"samples are correlated: the Allan deviation at tau = {check.tau_s:g} s is "
        f"{check.ratio:.2f}x (interval {check.ratio_ci_low:.2f}-{check.ratio_ci_high:.2f}) "
        f"what independent samples would give, so the Student-t interval is too narrow by "
        f"about that factor"
    )


def noise_result(data: ChannelData, classical: ClassicalNoise, window: dict) -> dict:
    """The JSON document of ``bayescal noise`` (contract in the README)."""
    unit = data.unit
    allan = classical.allan
    half_width = (classical.bias_ci_high - classical.bias_ci_low) / 2
    widening = classical.t_interval.widening
    return {
        "bayescal_version": version("bayescal"),
        "source": data.source,
        "channel": data.channel,
        "unit": unit,
        "n_samples": classical.n_samples,
        "rate_hz": classical.rate_hz,
        "duration_s": classical.duration_s,
        "window": window,
        "notes": list(data.notes),
        "classical": {
            "bias": {
                "value": classical.bias,
                "ci_low": classical.bias_ci_low,
                "ci_high": classical.bias_ci_high,
                "confidence": classical.confidence,
                "unit": unit,
                "method": "sample mean, Student-t interval",
                "widened_ci_low": classical.bias - widening * half_width,
                "widened_ci_high": classical.bias + widening * half_width,
            },
            "std": {"value": classical.std, "unit": unit},
            "t_interval_valid": classical.t_interval.valid,
            "t_interval_widening": widening,
            "t_interval_check": {
                "adev_ratio": classical.t_interval.ratio,
                "adev_ratio_ci_low": classical.t_interval.ratio_ci_low,
                "adev_ratio_ci_high": classical.t_interval.ratio_ci_high,
                "tau_s": classical.t_interval.tau_s,
                "explanation": _t_interval_explanation(classical),
            },
            "allan": {
                "estimator": "overlapping Allan deviation (NIST SP 1065 eq. 11)",
                "tau_s": allan.tau,
                "adev": allan.deviation,
                "ci_low": allan.ci_low,
                "ci_high": allan.ci_high,
                "confidence": allan.confidence,
                "n_terms": allan.n,
                "edf": allan.edf,
                "noise_alpha": allan.alpha,
                "unit": unit,
            },
            "slope_readings": {
                parameter: _reading(parameter, reading, unit)
                for parameter, reading in classical.slope_readings.items()
            },
        },
    }


def _number(value: float) -> str:
    return "n/a" if value is None else f"{value:.5g}"


def noise_text(result: dict) -> str:
    """The table ``bayescal noise`` prints, made from its JSON document."""
    classical = result["classical"]
    unit = result["unit"]
    bias = classical["bias"]
    window = result["window"]
    percent = f"{100 * bias['confidence']:g}%"
    lines = [
        f"bayescal noise: {result['source']}, channel {result['channel']} [{unit}]",
        f"  {result['n_samples']} samples at {result['rate_hz']:.6g} Hz, "
        f"{result['duration_s']:.6g} s (window {window['start_s']:.6g}-{window['stop_s']:.6g} s, "
        f"{window['selected_by']})",
        "",
        f"  bias          {_number(bias['value'])} {unit}   {percent} Student-t interval "
        f"[{_number(bias['ci_low'])}, {_number(bias['ci_high'])}]",
        f"  std           {_number(classical['std']['value'])} {unit}",
    ]
    check = classical["t_interval_check"]
    if classical["t_interval_valid"]:
        lines.append(f"  t-interval    valid: {check['explanation']}")
    else:
        lines.append(f"  t-interval    NOT VALID: {check['explanation']}")
        lines.append(
            f"                widened x{classical['t_interval_widening']:.3g}: "
            f"[{_number(bias['widened_ci_low'])}, {_number(bias['widened_ci_high'])}] {unit}"
        )
    allan = classical["allan"]
    lines += [
        "",
        f"  Allan deviation (overlapping), {100 * allan['confidence']:g}% chi-square "
        "intervals (Greenhall EDF)",
        f"  {'tau [s]':>12} {'ADEV [' + unit + ']':>18} {'low':>12} {'high':>12} {'alpha':>6}",
    ]
    for tau, dev, low, high, alpha in zip(
        allan["tau_s"],
        allan["adev"],
        allan["ci_low"],
        allan["ci_high"],
        allan["noise_alpha"],
        strict=True,
    ):
        lines.append(
            f"  {tau:>12.5g} {_number(dev):>18} {_number(low):>12} {_number(high):>12} {alpha:>6}"
        )
    lines += ["", "  IEEE 952 slope readings"]
    for parameter, reading in classical["slope_readings"].items():
        shown = f"{_number(reading['value'])} {reading['unit']}"
        if reading["kind"] == "upper_bound":
            shown = f"<= {_number(reading['ci_high'])} {reading['unit']}"
        shown_key = "value" if reading["kind"] == "reading" else "ci_high"
        extra = "".join(
            f" = {_number(item[shown_key])} {label}" for label, item in reading["display"].items()
        )
        how = (
            reading["read_at"]
            if reading["kind"] == "reading"
            else "no stretch of its slope: upper bound from the whole curve"
        )
        lines.append(f"  {parameter}  {shown}{extra}   ({how})")
    if result["notes"]:
        lines += ["", "  notes:"] + [f"  - {note}" for note in result["notes"]]
    return "\n".join(lines)
