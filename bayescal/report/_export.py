"""``bayescal noise --export FORMAT PATH``: the noise of a channel in the files IMU tools read.

Formats
-------
``kalibr``
    Kalibr's ``imu.yaml`` (keys ``accelerometer_noise_density``, ``accelerometer_random_walk``,
    ``gyroscope_noise_density``, ``gyroscope_random_walk``, ``rostopic``, ``update_rate``).
    Kalibr's IMU noise model (Kalibr wiki, "IMU Noise Model",
    https://github.com/ethz-asl/kalibr/wiki/IMU-Noise-Model) is written in continuous time:
    ``*_noise_density`` is the white-noise density σ, the IEEE Std 952 angle/velocity random
    walk N in unit/√Hz; ``*_random_walk`` is σ_b, the density of the white noise whose
    integral is the bias, which is the rate random walk K in unit·√Hz (= unit/s/√Hz) — not
    the bias instability B, a flicker floor Kalibr does not model. Kalibr discretises them
    itself with ``update_rate`` (σ_d = σ·√rate, σ_bd = σ_b/√rate), so the file carries the
    continuous-time values; B goes into a comment only. Units are SI: rad/s and m/s².
``matlab``
    A MATLAB script that builds ``gyroparams`` / ``accelparams`` objects for ``imuSensor``
    (MATLAB Navigation / Sensor Fusion and Tracking Toolbox, "gyroparams" and "accelparams"
    reference pages): ``NoiseDensity`` = N in (rad/s)/√Hz or (m/s²)/√Hz, ``BiasInstability``
    = B in rad/s or m/s², ``RandomWalk`` = K in (rad/s)·√Hz or (m/s²)·√Hz — the mapping of
    MathWorks' example "Inertial Sensor Noise Analysis Using Allan Variance" — and
    ``TemperatureBias`` in (unit)/°C when a caller knows it (``bayescal noise`` does not, so
    the script says so instead of leaving MATLAB's silent default of 0).

Values are the Bayesian posterior means when the posterior was computed and passed its health
checks, else the classical IEEE 952 readings of the Allan deviation (an upper bound where the
curve has no stretch of the term's slope); the file says which, per value.

One channel, one sensor
-----------------------
``bayescal noise`` analyses one channel, and Kalibr and MATLAB want one value per sensor (all
three axes alike). So an export fills the entries of the channel's sensor — the gyroscope for
an angular rate, the accelerometer for an acceleration, from the channel's unit — and keeps
the other sensor's entries of the file already at PATH, if there is one that bayescal (or, for
Kalibr, anyone) wrote. Two runs complete a file::

    bayescal noise imu.bag --channel gyro_x --export kalibr imu.yaml
    bayescal noise imu.bag --channel acc_x --export kalibr imu.yaml

Until both have run, the missing sensor's entries are absent (with a comment that says how to
add them), so Kalibr or MATLAB stops rather than calibrating with invented numbers.

Every axis exported to one file is kept (in the file's ``bayescal`` notes for Kalibr, in a
``% bayescal axes:`` line for MATLAB, each with its values and where they come from; the same
channel exported again replaces its entry), and the sensor's one value covers them all: the
largest of the axes (``--export-axes largest``, the default: Kalibr's wiki advises erring
high) or their RMS (``--export-axes rms``). The file says which, per value. A file is read
again and rewritten under a lock (``.NAME.lock`` beside it), so that runs exporting to it at
the same time add to it rather than overwrite one another.
"""

import contextlib
import json
import math
import os
from dataclasses import dataclass
from importlib.metadata import version
from pathlib import Path

from .._errors import InputError
from .._output import Outputs, check_writable, to_jsonable, write_atomic
from ..capabilities._estimators import ESTIMATORS, SENSORS, SI, sensor_of_unit
from ._noise import INTERVAL, NoiseAnalysis, read_at

FORMATS = ("kalibr", "matlab")
_KALIBR = ESTIMATORS["kalibr"]
# Kalibr's units and keys, from the one home of the estimators' conventions.
_KALIBR_UNITS = {
    **{(s, p): _KALIBR.unit(s, p) for s in SENSORS for p in ("N", "K")},
    **{(s, "B"): SI[s] for s in SENSORS},
}
_KALIBR_KEYS = {p: _KALIBR.keys["gyroscope", p].removeprefix("gyroscope_") for p in ("N", "K")}
_KALIBR_TOP = ("rostopic", "update_rate", "bayescal")
_PLACEHOLDER_TOPIC = "/imu0"
_MATLAB_VARIABLE = {"gyroscope": "gyro", "accelerometer": "accel"}
_MATLAB_CLASS = {"gyroscope": "gyroparams", "accelerometer": "accelparams"}
_MATLAB_PROPERTY = {"N": "NoiseDensity", "B": "BiasInstability", "K": "RandomWalk"}
_MATLAB_UNITS = {
    ("gyroscope", "N"): "(rad/s)/sqrt(Hz)",
    ("gyroscope", "B"): "rad/s",
    ("gyroscope", "K"): "(rad/s)*sqrt(Hz)",
    ("gyroscope", "T"): "(rad/s)/degC",
    ("accelerometer", "N"): "(m/s^2)/sqrt(Hz)",
    ("accelerometer", "B"): "m/s^2",
    ("accelerometer", "K"): "(m/s^2)*sqrt(Hz)",
    ("accelerometer", "T"): "(m/s^2)/degC",
}
_MATLAB_MARK = "written by bayescal"
_NAMES = {"N": "white noise N", "K": "rate random walk K", "B": "bias instability B"}


@dataclass(frozen=True)
class Estimate:
    """One noise parameter in SI units, and where it came from."""

    value: float | None
    how: str
    interval: tuple[float, float] | None = None
    level: float | None = None
    """Probability of ``interval`` (0.90 for the posterior's, the Allan confidence else)."""

    def describe(self) -> str:
        if self.interval is None:
            return self.how
        low, high = self.interval
        return f"{self.how}, {100 * self.level:g}% interval [{low:.3e}, {high:.3e}]"


@dataclass(frozen=True)
class SensorNoise:
    """What an export says about one sensor (gyroscope or accelerometer), in SI units."""

    sensor: str
    channel: str
    source: str
    rate_hz: float
    estimates: dict[str, Estimate]
    temperature_bias: float | None = None
    """Linear temperature coefficient of the bias, SI unit per degC, when known."""


def _number(value: float) -> str:
    """A float every YAML reader (PyYAML's YAML 1.1 included) and MATLAB reads as one:
    mantissa with a point, exponent with a sign."""
    return f"{value:.9e}"


def noise_estimates(analysis: NoiseAnalysis, to_si: float) -> dict[str, Estimate]:
    """N, K and B of a channel's noise (:class:`~bayescal.report._noise.NoiseAnalysis`) in SI
    units: posterior means when the posterior passed its checks, else the classical slope
    readings."""
    noise = analysis.noise
    parameters = {}
    if noise is not None and noise.diagnostics.passed:
        parameters = noise.parameters
    failed = noise is not None and not noise.diagnostics.passed
    estimates = {}
    for name in ("N", "K", "B"):
        if name in parameters:
            summary = parameters[name]
            estimates[name] = Estimate(
                summary.mean * to_si,
                "posterior mean",
                (summary.q05 * to_si, summary.q95 * to_si),
                INTERVAL,
            )
            continue
        reading = analysis.classical.slope_readings.get(name)
        why = " (the posterior failed its health checks)" if failed else ""
        if reading is None:
            estimates[name] = Estimate(None, "not estimated")
        elif reading.kind == "reading" and reading.value is not None:
            low, high = reading.ci_low, reading.ci_high
            interval = (low * to_si, high * to_si) if None not in (low, high) else None
            estimates[name] = Estimate(
                reading.value * to_si,
                f"classical Allan slope reading{why}",
                interval,
                analysis.classical.allan.confidence,
            )
        elif reading.ci_high is not None:
            estimates[name] = Estimate(
                reading.ci_high * to_si, f"classical upper bound ({read_at(reading)}){why}"
            )
        else:
            estimates[name] = Estimate(None, "not estimated")
    return estimates


COMBINATIONS = ("largest", "rms")


def combine(values: list[float], how: str) -> float | None:
    """One value for a sensor from its axes' values: the largest, or their RMS (root of the
    mean square); None when no axis has one."""
    if not values:
        return None
    if how == "rms":
        return math.sqrt(sum(value * value for value in values) / len(values))
    return max(values)


def _axis_entry(noise: SensorNoise) -> dict:
    """What a file keeps of one exported axis (in its ``bayescal`` notes): SI values of N, K
    and B, how each was obtained, where the axis comes from."""
    return {
        "from": f"{noise.channel} of {noise.source} at {noise.rate_hz:.6g} Hz",
        "rate_hz": float(noise.rate_hz),
        **{name: noise.estimates[name].value for name in ("N", "K", "B")},
        "how": {name: noise.estimates[name].describe() for name in ("N", "K", "B")},
    }


def _is_value(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _valid_axes(axes) -> dict:
    """The axis entries of a file's notes that bayescal can combine."""
    if not isinstance(axes, dict):
        return {}
    return {
        str(name): entry
        for name, entry in axes.items()
        if isinstance(entry, dict) and isinstance(entry.get("from"), str)
    }


@dataclass
class _Plan:
    format: str
    path: Path
    sensor: str
    to_si: float
    topic: str | None
    combine: str = "largest"


def plan_exports(
    requests: list[list[str]] | None,
    unit: str,
    channel: str,
    source: str,
    topic: str | None,
    combine_axes: str = "largest",
) -> list[_Plan]:
    """Check every ``--export FORMAT PATH`` before the analysis runs: the format, that PATH
    can be written, that a file already there is one to add to, and that the channel is a
    gyro or accelerometer in a physical unit. ``combine_axes`` says how one value per sensor
    covers the axes exported to one file: ``largest`` or ``rms``."""
    if combine_axes not in COMBINATIONS:
        raise InputError(
            f"--export-axes {combine_axes!r}", fix=f"give one of {', '.join(COMBINATIONS)}"
        )
    plans = []
    for requested_format, path_text in requests or ():
        export_format = requested_format.lower()
        argument = f"--export {requested_format}"
        if export_format not in FORMATS:
            raise InputError(
                f"{argument}: unknown format '{requested_format}'",
                fix=f"use one of: {', '.join(FORMATS)}",
            )
        path = check_writable(path_text, argument)
        if path.exists() and not os.access(path, os.W_OK):
            raise InputError(f"{argument} {path}: the file is not writable")
        sensor, to_si = sensor_of_unit(unit, channel, source)
        if path.exists():
            _reader(export_format)(path, argument)  # refuse a file that is not ours now
        plans.append(_Plan(export_format, path, sensor, to_si, topic, combine_axes))
    return plans


def _reader(export_format: str):
    return _read_kalibr if export_format == "kalibr" else _read_matlab


@contextlib.contextmanager
def _locked(path: Path):
    """An exclusive lock beside ``path`` (``.NAME.lock``): held to the end of the run inside
    :class:`~bayescal._output.Outputs` (the file is replaced when the run succeeds), else
    for the block."""
    outputs = Outputs.active()
    if outputs is not None:
        outputs.lock(path)
        yield
        return
    import fcntl

    with open(path.with_name(f".{path.name}.lock"), "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        yield


def write_exports(plans: list[_Plan], analysis: NoiseAnalysis) -> list[str]:
    """Write every planned export of a channel's noise; one line per file. Each
    file is read again and rewritten under a lock, so that runs exporting other axes or the
    other sensor to it at the same time add to it rather than overwrite one another."""
    lines = []
    for plan in plans:
        noise = SensorNoise(
            plan.sensor,
            analysis.channel,
            analysis.source,
            analysis.classical.rate_hz,
            noise_estimates(analysis, plan.to_si),
        )
        argument = f"--export {plan.format}"
        with _locked(plan.path):
            existing = _reader(plan.format)(plan.path, argument) if plan.path.exists() else {}
            if plan.format == "kalibr":
                text, other = kalibr_yaml(noise, existing, plan.topic, plan.combine)
            else:
                text, other = matlab_script(noise, existing, plan.combine)
            write_atomic(plan.path, text)
        kept = f"; {other}" if other else ""
        lines.append(
            f"bayescal noise: wrote {plan.sensor} noise of {noise.channel} to {plan.path} "
            f"({plan.format}){kept}"
        )
    return lines


def _axes_summary(sensor: str, axes: dict, how: str) -> tuple[list[str], dict]:
    """Comment lines that list the axes, and the combined SI values of N, K and B."""
    combined = {
        name: combine([entry[name] for entry in axes.values() if _is_value(entry.get(name))], how)
        for name in ("N", "K", "B")
    }
    if len(axes) == 1:
        entry = next(iter(axes.values()))
        return [f"# {sensor.capitalize()}s: {entry['from']}"], combined
    rule = "the largest of them" if how == "largest" else "their RMS"
    lines = [
        f"# {sensor.capitalize()}s: {len(axes)} axes, each value below {rule} "
        f"(--export-axes {how}):"
    ]
    for entry in axes.values():
        values = "; ".join(
            f"{name} {entry[name]:.4e}" if _is_value(entry.get(name)) else f"{name} not estimated"
            for name in ("N", "K", "B")
        )
        lines.append(f"#   {entry['from']}: {values}")
    return lines, combined


def _how(axes: dict, name: str, how: str) -> str:
    """How the combined value of parameter ``name`` was obtained."""
    if len(axes) == 1:
        entry = next(iter(axes.values()))
        return entry.get("how", {}).get(name, "") if isinstance(entry.get("how"), dict) else ""
    having = [channel for channel, entry in axes.items() if _is_value(entry.get(name))]
    rule = "largest" if how == "largest" else "RMS"
    return f"{rule} of {', '.join(having)}" if having else "not estimated"


# --- Kalibr ------------------------------------------------------------------------------


def _read_kalibr(path: Path, argument: str) -> dict:
    """The entries, rostopic and bayescal's notes of an existing imu.yaml."""
    from ruamel.yaml import YAML, YAMLError

    try:
        content = YAML(typ="safe").load(path.read_text(encoding="utf-8"))
    except (YAMLError, UnicodeDecodeError) as error:
        raise InputError(
            f"{argument} {path}: exists and is not YAML ({str(error).splitlines()[0]})",
            fix="choose another path, or remove the file",
        ) from None
    if content is None:
        return {}
    known = {f"{s}_{key}" for s in SENSORS for key in _KALIBR_KEYS.values()} | set(_KALIBR_TOP)
    if not isinstance(content, dict) or set(content) - known:
        extra = sorted(map(str, set(content) - known)) if isinstance(content, dict) else []
        raise InputError(
            f"{argument} {path}: exists and is not a Kalibr imu.yaml that bayescal can add to"
            + (f" (it has {', '.join(map(str, extra))})" if extra else ""),
            fix="choose another path, or remove the file",
        )
    return content


def _kalibr_axes(sensor: str, existing: dict, *, recorded_only: bool = False) -> dict:
    """The axes of ``sensor`` a Kalibr file already holds: from bayescal's notes, or, for a
    file that has the values without them (unless ``recorded_only``), one entry for those
    values."""
    notes = existing.get("bayescal") if isinstance(existing.get("bayescal"), dict) else {}
    recorded = notes.get(sensor)
    if isinstance(recorded, dict):
        axes = _valid_axes(recorded.get("axes"))
        if axes or recorded_only:
            return axes
    if recorded_only:
        return {}
    values = {
        parameter: existing.get(f"{sensor}_{key}")
        for parameter, key in _KALIBR_KEYS.items()
        if _is_value(existing.get(f"{sensor}_{key}"))
    }
    if not values:
        return {}
    origin = recorded if isinstance(recorded, str) else "an earlier export"
    return {"(kept)": {"from": origin, **values, "how": {}}}


def _kalibr_sensor_lines(sensor: str, axes: dict, how: str) -> list[str]:
    lines, combined = _axes_summary(sensor, axes, how)
    for parameter in ("N", "K"):
        key = f"{sensor}_{_KALIBR_KEYS[parameter]}"
        unit = _KALIBR_UNITS[sensor, parameter]
        comment = f"[{unit}] {_NAMES[parameter]}: {_how(axes, parameter, how)}"
        if combined[parameter] is None:
            lines.append(f"# {key}: not estimated from this recording ({comment})")
        else:
            lines.append(f"{key}: {_number(combined[parameter])}  # {comment}")
    if combined["B"] is not None:
        lines.append(
            f"# {sensor} bias instability B = {combined['B']:.4e} {_KALIBR_UNITS[sensor, 'B']} "
            f"({_how(axes, 'B', how)}): not a Kalibr parameter, for reference only"
        )
    return lines


def _kept_kalibr_lines(sensor: str, axes: dict, how: str) -> list[str]:
    if not axes:
        return [
            f"# {sensor.capitalize()}s: not measured yet; run 'bayescal noise' on one of "
            "their channels with '--export kalibr' and this file to add them",
        ]
    _, combined = _axes_summary(sensor, axes, how)
    described = "; ".join(
        entry["from"]
        + (
            f", bias instability B = {entry['B']:.4e} {_KALIBR_UNITS[sensor, 'B']}"
            if _is_value(entry.get("B"))
            else ""
        )
        for entry in axes.values()
    )
    lines = [f"# {sensor.capitalize()}s: kept from the file as it was ({described})"]
    for parameter, key in _KALIBR_KEYS.items():
        if combined[parameter] is not None:
            lines.append(
                f"{sensor}_{key}: {_number(combined[parameter])}  "
                f"# [{_KALIBR_UNITS[sensor, parameter]}]"
            )
    return lines


def kalibr_yaml(
    noise: SensorNoise,
    existing: dict | None = None,
    topic: str | None = None,
    combine_axes: str = "largest",
) -> tuple[str, str | None]:
    """Kalibr's imu.yaml with ``noise``'s axis added to its sensor's (one value per sensor
    covering every axis exported: ``combine_axes`` "largest" or "rms"), the other sensor's
    entries kept from ``existing`` (a parsed imu.yaml); also a note on what was kept, or
    None."""
    existing = existing or {}
    other_sensor = next(s for s in SENSORS if s != noise.sensor)
    # The other sensor as the file has it; this sensor's axes that bayescal recorded (values
    # without bayescal's notes are replaced by the measured ones).
    axes = {
        other_sensor: _kalibr_axes(other_sensor, existing),
        noise.sensor: _kalibr_axes(noise.sensor, existing, recorded_only=True),
    }
    axes[noise.sensor].pop(noise.channel, None)
    earlier = set(axes[noise.sensor])
    axes[noise.sensor][noise.channel] = _axis_entry(noise)
    blocks = {
        noise.sensor: _kalibr_sensor_lines(noise.sensor, axes[noise.sensor], combine_axes),
        other_sensor: _kept_kalibr_lines(other_sensor, axes[other_sensor], combine_axes),
    }
    kept_notes = []
    if axes[other_sensor]:
        kept_notes.append(f"{other_sensor} entries kept from the existing file")
    if earlier:
        kept_notes.append(
            f"{noise.sensor} axes {', '.join(sorted(earlier))} kept beside {noise.channel} "
            f"({combine_axes} of the {len(axes[noise.sensor])} axes)"
        )
    topic_comment = "the IMU topic of the bag"
    if topic is None:
        topic = existing.get("rostopic") if isinstance(existing.get("rostopic"), str) else None
        topic_comment = "kept from the file as it was"
    if topic is None:
        topic, topic_comment = _PLACEHOLDER_TOPIC, "PLACEHOLDER: set the IMU topic of your bag"
    lines = [
        f"# Kalibr IMU configuration (imu.yaml), written by bayescal {version('bayescal')}.",
        "# Kalibr's noise model is continuous-time (Kalibr wiki, IMU Noise Model):",
        "#   *_noise_density = white-noise density N of IEEE Std 952 [unit/sqrt(Hz)];",
        "#   *_random_walk   = density of the white noise that drives the bias random walk:",
        "#                     the rate random walk K of IEEE Std 952 [unit*sqrt(Hz)], that is",
        "#                     [unit/s/sqrt(Hz)] -- NOT the bias instability B (flicker), which",
        "#                     Kalibr does not model; B is given in a comment for reference.",
        "# Kalibr discretises them with update_rate itself: sigma_d = N*sqrt(rate),",
        "# sigma_bd = K/sqrt(rate). One value per sensor applies to all three axes: with",
        "# several axes exported, it is the largest of them or their RMS, as said below. The",
        "# wiki advises inflating them for real-world calibration (unmodelled effects);",
        "# bayescal gives the measured values, uninflated.",
        "",
        *blocks["accelerometer"],
        "",
        *blocks["gyroscope"],
        "",
        f"rostopic: {json.dumps(topic)}  # {topic_comment}",
        f"update_rate: {float(noise.rate_hz)!r}  # Hz, the sample rate of {noise.channel}",
    ]
    rates = {
        f"{entry['from']}"
        for sensor in SENSORS
        for entry in axes[sensor].values()
        if _is_value(entry.get("rate_hz")) and abs(entry["rate_hz"] / noise.rate_hz - 1) > 1e-6
    }
    if rates:
        lines.append(f"# measured at another rate than update_rate: {'; '.join(sorted(rates))}")
    lines += ["", "# Where the values come from, axis by axis (ignored by Kalibr):", "bayescal:"]
    for sensor in SENSORS:
        if axes[sensor]:
            record = {"combined": combine_axes, "axes": axes[sensor]}
            lines.append(f"  {sensor}: {json.dumps(to_jsonable(record), ensure_ascii=False)}")
    return "\n".join(lines) + "\n", "; ".join(kept_notes) or None


# --- MATLAB ------------------------------------------------------------------------------

_MATLAB_AXES = "% bayescal axes: "


def _read_matlab(path: Path, argument: str) -> dict:
    """The blocks of a script bayescal wrote, by sensor, with the axes each covers."""
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        text = ""
    if _MATLAB_MARK not in text.split("\n", 1)[0]:
        raise InputError(
            f"{argument} {path}: exists and was not written by bayescal",
            fix="choose another path, or remove the file",
        )
    blocks = {}
    for sensor in SENSORS:
        start, end = f"%% {sensor}:", f"%% end of {sensor}"
        if start in text and end in text:
            begin = text.index(start)
            block = text[begin : text.index(end, begin) + len(end)]
            axes = {}
            for line in block.splitlines():
                if line.startswith(_MATLAB_AXES):
                    try:
                        axes = _valid_axes(json.loads(line[len(_MATLAB_AXES) :]))
                    except json.JSONDecodeError:
                        axes = {}
            blocks[sensor] = {"text": block, "axes": axes}
    return blocks


def _matlab_block(
    noise: SensorNoise, axes: dict | None = None, combine_axes: str = "largest"
) -> str:
    sensor, variable = noise.sensor, _MATLAB_VARIABLE[noise.sensor]
    axes = axes or {noise.channel: _axis_entry(noise)}
    summary, combined = _axes_summary(sensor, axes, combine_axes)
    lines = [
        f"%% {sensor}: {', '.join(axes)}",
        *(f"%{line[1:]}" for line in summary),
        f"{variable} = {_MATLAB_CLASS[sensor]};",
    ]
    for parameter in ("N", "B", "K"):
        prop = _MATLAB_PROPERTY[parameter]
        comment = (
            f"{_MATLAB_UNITS[sensor, parameter]}, {_NAMES[parameter]}: "
            f"{_how(axes, parameter, combine_axes)}"
        )
        if combined[parameter] is None:
            lines.append(f"% {variable}.{prop} not set: not estimated ({comment})")
        else:
            lines.append(f"{variable}.{prop} = {_number(combined[parameter])}; % {comment}")
    temperature_unit = _MATLAB_UNITS[sensor, "T"]
    if noise.temperature_bias is not None and math.isfinite(noise.temperature_bias):
        lines.append(
            f"{variable}.TemperatureBias = {_number(noise.temperature_bias)}; "
            f"% {temperature_unit}, linear thermal coefficient of the bias"
        )
    else:
        lines.append(
            f"% {variable}.TemperatureBias not set ({temperature_unit}): not measured by "
            "'bayescal noise'; 'bayescal thermal fit' estimates the bias against temperature"
        )
    lines.append(f"{variable}_sample_rate = {float(noise.rate_hz)!r}; % Hz")
    lines.append(_MATLAB_AXES + json.dumps(to_jsonable(axes), ensure_ascii=False))
    lines.append(f"%% end of {sensor}")
    return "\n".join(lines)


def matlab_script(
    noise: SensorNoise, existing: dict | None = None, combine_axes: str = "largest"
) -> tuple[str, str | None]:
    """A MATLAB script setting ``gyroparams``/``accelparams`` for ``noise``'s sensor (one value
    covering every axis exported to it: ``combine_axes`` "largest" or "rms"), with the other
    sensor's block kept from ``existing`` (blocks by sensor); also a note on what was kept,
    or None."""
    existing = existing or {}
    other_sensor = next(s for s in SENSORS if s != noise.sensor)
    previous = existing.get(noise.sensor, {}).get("axes", {}) if existing else {}
    axes = {name: entry for name, entry in previous.items() if name != noise.channel}
    earlier = sorted(axes)
    axes[noise.channel] = _axis_entry(noise)
    blocks = {noise.sensor: _matlab_block(noise, axes, combine_axes)}
    kept = []
    if other_sensor in existing:
        blocks[other_sensor] = existing[other_sensor]["text"]
        kept.append(f"{other_sensor} block kept from the existing file")
    else:
        blocks[other_sensor] = (
            f"% {other_sensor}: not measured yet; run 'bayescal noise' on one of its "
            "channels with '--export matlab' and this file to add it"
        )
    if earlier:
        kept.append(
            f"{noise.sensor} axes {', '.join(earlier)} kept beside {noise.channel} "
            f"({combine_axes} of the {len(axes)} axes)"
        )
    header = [
        f"% IMU noise parameters for MATLAB's imuSensor, {_MATLAB_MARK} {version('bayescal')}.",
        "% gyroparams / accelparams properties in SI units (MATLAB reference pages gyroparams,",
        "% accelparams): NoiseDensity = white noise N of IEEE Std 952, BiasInstability = bias",
        "% instability B (flicker floor / 0.664), RandomWalk = rate random walk K, as in",
        "% MathWorks' example 'Inertial Sensor Noise Analysis Using Allan Variance'.",
        "% One value per sensor applies to all three axes: with several axes exported, it is",
        "% the largest of them or their RMS, as said in each block. Use, once both are set:",
        "%   imu = imuSensor('accel-gyro', 'SampleRate', gyro_sample_rate, ...",
        "%                   'Gyroscope', gyro, 'Accelerometer', accel);",
        "",
    ]
    body = "\n\n".join(blocks[sensor] for sensor in ("gyroscope", "accelerometer"))
    return "\n".join(header) + body + "\n", "; ".join(kept) or None
