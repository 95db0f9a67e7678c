"""``bayescal export-filter``: a :class:`~bayescal.FilterNoise` written in its estimator's own
file, with a comment block that says how each number was made, and its JSON document.

Files (conventions: :mod:`bayescal.capabilities._estimators`):

- ``kalibr``: Kalibr's ``imu.yaml`` (YAML: the four noise keys, ``rostopic``,
  ``update_rate``);
- ``openvins``: OpenVINS's ``kalibr_imu_chain.yaml`` (OpenCV FileStorage YAML, ``%YAML:1.0``
  first): ``imu0`` with the four noise keys, identity intrinsics (``Tw``, ``R_IMUtoGYRO``,
  ``Ta``, ``R_IMUtoACC``, ``Tg``), ``T_i_b``, ``rostopic``, ``time_offset``, ``update_rate``,
  ``model: kalibr``;
- ``orbslam3``: the IMU block of an ORB-SLAM3 settings file (OpenCV YAML): ``IMU.NoiseGyro``,
  ``IMU.NoiseAcc``, ``IMU.GyroWalk``, ``IMU.AccWalk``, ``IMU.Frequency``, to merge into the
  camera's settings;
- ``vins``: the IMU block of a VINS-Mono / VINS-Fusion config (OpenCV YAML): ``acc_n``,
  ``gyr_n``, ``acc_w``, ``gyr_w``;
- ``gtsam``: YAML with ``PreintegrationCombinedParams``' four covariances as 3 x 3 matrices
  (GTSAM has no file of its own; the comment shows the Python that loads it);
- ``px4``: a QGroundControl parameter file (``Vehicle-Id Component-Id Name Value Type``, tab
  separated, type 9 = float), loadable from QGC's Parameters > Tools > Load from file.
"""

import json
from dataclasses import dataclass
from importlib.metadata import version

from .._errors import InputError
from ..capabilities._estimators import PX4_RANGES, SENSORS, sensor_of_unit
from ..capabilities._filter_noise import ITEMS, FilterNoise, filter_noise
from ._export import _number
from ._format import esc, num

_PLACEHOLDER_TOPIC = "/imu0"
SCHEMA = "bayescal.filter_noise"


def _explained(noise: FilterNoise, comment: str) -> list[str]:
    """The comment block: the convention, then each number and its items."""
    estimator = noise.estimator
    lines = [
        f"{estimator.title} IMU noise, written by bayescal {version('bayescal')}.",
        f"Convention ({estimator.reference}):",
    ]
    for sensor in SENSORS:
        for p in ("N", "K"):
            lines.append(
                f"  {estimator.keys[sensor, p]} [{estimator.unit(sensor, p)}] = "
                f"{estimator.formula(p)}"
            )
    if estimator.per_sample:
        lines.append(f"  per-sample values at f = {noise.filter_rate_hz:g} Hz, the filter's rate")
    lines += [
        "N is IEEE Std 952's white noise (angle/velocity random walk), K the bias's random walk.",
        "Each density is the root-sum-square of its items (continuous time, SI):",
        f"  posterior_quantile: N and K at the posterior's {100 * noise.quantile:g} % quantile;",
        "  bias_instability: each bias term as the random walk whose Allan variance equals its",
        "    own at a third of the horizon H, q^2 = 9 sigma_A^2(H/3)/H",
        "    (flicker: 9 (2 ln 2/pi) B^2 / H), added to K;",
        f"    H = {noise.horizon_s:g} s, given"
        if noise.horizon_s is not None
        else f"    H per channel: the span over which the aiding ({noise.aiding.describe()})",
        *(
            ()
            if noise.horizon_s is not None
            else ("    reveals the channel's bias as well as the bias wanders (see notes);",)
        ),
        "  vibration: the extra white density of a record with the motors running, added to N;",
        "  thermal: the compensated bias's change over the expected temperature excursion,",
        "    as a walk reaching it at the horizon, added to K.",
        "One value per sensor covers its three axes: the largest of its channels.",
        "",
    ]
    for key, entry in noise.values.items():
        channel = noise.channels[entry["channel"]]
        parameter = "N" if estimator.keys[channel.sensor, "N"] == key else "K"
        lines.append(f"{key} = {entry['value']:.4e} {entry['unit']}, from {channel.channel}:")
        for item in ITEMS:
            for part in channel.items[item]:
                if part.parameter == parameter:
                    lines.append(f"  {item}: {part.value:.4e} {part.unit} ({part.how})")
        lines.append(f"  = {parameter} {channel.density[parameter]:.4e} (root-sum-square)")
    for channel in noise.channels.values():
        for note in channel.notes:
            lines.append(f"note, {channel.channel}: {note}")
    for note in noise.notes:
        lines.append(f"note: {note}")
    if noise.failures:
        lines.append("HEALTH CHECK FAILED: " + "; ".join(noise.failures))
    return [f"{comment} {line}".rstrip() for line in lines]


def _missing(noise: FilterNoise, comment: str) -> list[str]:
    present = {c.sensor for c in noise.channels.values()}
    return [
        f"{comment} {sensor}: not measured; export its channels too, or the estimator will "
        "stop on the missing entries"
        for sensor in SENSORS
        if sensor not in present
    ]


def _entries(noise: FilterNoise, indent: str = "") -> list[str]:
    return [
        f"{indent}{key}: {_number(entry['value'])}  # [{entry['unit']}]"
        for key, entry in noise.values.items()
    ]


def _rate(noise: FilterNoise) -> float:
    return float(max(c.rate_hz for c in noise.channels.values()))


def _kalibr(noise: FilterNoise, topic: str | None) -> str:
    topic_line = (
        f"rostopic: {json.dumps(topic)}"
        if topic
        else f"rostopic: {json.dumps(_PLACEHOLDER_TOPIC)}  # PLACEHOLDER: your bag's IMU topic"
    )
    return "\n".join(
        [
            *_explained(noise, "#"),
            "",
            *_missing(noise, "#"),
            *_entries(noise),
            topic_line,
            f"update_rate: {_rate(noise)!r}  # Hz",
        ]
    )


_IDENTITY_3 = ["    - [1.0, 0.0, 0.0]", "    - [0.0, 1.0, 0.0]", "    - [0.0, 0.0, 1.0]"]


def _openvins(noise: FilterNoise, topic: str | None) -> str:
    def matrix(name: str, rows: list[str]) -> list[str]:
        return [f"  {name}:", *rows]

    zero = [f"    - [{', '.join(['0.0'] * 3)}]"] * 3
    return "\n".join(
        [
            "%YAML:1.0",
            *_explained(noise, "#"),
            "",
            *_missing(noise, "#"),
            "imu0:",
            *matrix(
                "T_i_b",
                [
                    f"    - [{', '.join('1.0' if i == j else '0.0' for j in range(4))}]"
                    for i in range(4)
                ],
            ),
            *_entries(noise, "  "),
            f"  rostopic: {json.dumps(topic or _PLACEHOLDER_TOPIC)}"
            + ("" if topic else "  # PLACEHOLDER: your IMU topic"),
            "  time_offset: 0.0",
            f"  update_rate: {_rate(noise)!r}  # Hz",
            '  model: "kalibr"  # intrinsics below: identity (none calibrated)',
            *matrix("Tw", _IDENTITY_3),
            *matrix("R_IMUtoGYRO", _IDENTITY_3),
            *matrix("Ta", _IDENTITY_3),
            *matrix("R_IMUtoACC", _IDENTITY_3),
            *matrix("Tg", zero),
        ]
    )


def _orbslam3(noise: FilterNoise, topic: str | None) -> str:
    return "\n".join(
        [
            "%YAML:1.0",
            *_explained(noise, "#"),
            "# Merge these lines into your ORB-SLAM3 settings file (camera, IMU.T_b_c1 ...).",
            "",
            *_missing(noise, "#"),
            *_entries(noise),
            f"IMU.Frequency: {_rate(noise)!r}  # Hz",
        ]
    )


def _vins(noise: FilterNoise, topic: str | None) -> str:
    return "\n".join(
        [
            "%YAML:1.0",
            *_explained(noise, "#"),
            "# Merge these lines into your VINS config (cameras, extrinsics, g_norm ...).",
            "",
            *_missing(noise, "#"),
            *_entries(noise),
        ]
    )


def _gtsam(noise: FilterNoise, topic: str | None) -> str:
    lines = [
        *_explained(noise, "#"),
        "# Load it (Python):",
        "#   import numpy as np, yaml, gtsam",
        "#   values = yaml.safe_load(open(PATH))['PreintegrationCombinedParams']",
        "#   params = gtsam.PreintegrationCombinedParams.MakeSharedU(9.81)",
        "#   params.setGyroscopeCovariance(np.array(values['gyroscopeCovariance']))",
        "#   params.setAccelerometerCovariance(np.array(values['accelerometerCovariance']))",
        "#   params.setBiasOmegaCovariance(np.array(values['biasOmegaCovariance']))",
        "#   params.setBiasAccCovariance(np.array(values['biasAccCovariance']))",
        "",
        *_missing(noise, "#"),
        "PreintegrationCombinedParams:",
    ]
    for key, entry in noise.values.items():
        value = _number(entry["value"])
        rows = ", ".join(
            "[" + ", ".join(value if i == j else "0.0" for j in range(3)) + "]" for i in range(3)
        )
        lines.append(f"  {key}: [{rows}]  # [{entry['unit']}]")
    return "\n".join(lines)


def _px4(noise: FilterNoise, topic: str | None) -> str:
    lines = [
        "# Onboard parameters for Vehicle 1",
        *_explained(noise, "#"),
    ]
    for key, entry in noise.values.items():
        low, high = PX4_RANGES[key]
        if not low <= entry["value"] <= high:
            lines.append(
                f"# WARNING: {key} = {entry['value']:.4g} lies outside PX4's range [{low:g}, "
                f"{high:g}]: PX4 may refuse or clamp it"
            )
    lines += [
        *_missing(noise, "#"),
        "#",
        "# Vehicle-Id\tComponent-Id\tName\tValue\tType",
        *(f"1\t1\t{key}\t{entry['value']:.9g}\t9" for key, entry in noise.values.items()),
    ]
    return "\n".join(lines)


_WRITERS = {
    "kalibr": _kalibr,
    "openvins": _openvins,
    "orbslam3": _orbslam3,
    "vins": _vins,
    "gtsam": _gtsam,
    "px4": _px4,
}


def filter_file(noise: FilterNoise, topic: str | None = None) -> str:
    """The text of ``noise``'s estimator's file (module docstring); ``topic`` the IMU topic
    where the file names one (a placeholder otherwise)."""
    return _WRITERS[noise.estimator.name](noise, topic) + "\n"


def filter_document(noise: FilterNoise, path: str | None = None) -> dict:
    """The JSON document: the estimator, horizon, quantile and rate; ``values`` as written to
    the file; per channel its ``values`` and ``items`` (:attr:`FilterNoise.summary`)."""
    return {
        "schema": SCHEMA,
        "schema_version": 1,
        "estimator": noise.estimator.name,
        "title": noise.estimator.title,
        "convention": noise.estimator.reference,
        "file": path,
        "horizon_s": noise.horizon_s,
        "aiding": None
        if noise.aiding is None
        else {
            "kind": noise.aiding.kind,
            "sd": noise.aiding.sd,
            "unit": noise.aiding.unit,
            "interval_s": noise.aiding.interval_s,
        },
        "quantile": noise.quantile,
        "filter_rate_hz": noise.filter_rate_hz,
        "values": noise.values,
        "channels": noise.summary,
        "passed": noise.passed,
        "failures": list(noise.failures),
        "notes": list(noise.notes),
    }


def filter_text(noise: FilterNoise, path: str) -> str:
    """What the command prints: each value written and where it comes from."""
    lines = [f"bayescal export-filter: {noise.estimator.title} noise written to {path}"]
    for key, entry in noise.values.items():
        lines.append(f"  {key} = {entry['value']:.4e} {entry['unit']} (from {entry['channel']})")
    return "\n".join(lines)


@dataclass(frozen=True)
class ReportFilterNoise:
    """What the report tells a navigation filter (:func:`report_filter_noise`)."""

    noise: FilterNoise | None
    """The continuous-time densities of the channels exported (None: none could be)."""
    withheld: dict
    """channel -> why it is not exported."""


def report_filter_noise(analyses) -> ReportFilterNoise:
    """The noise a navigation filter should be told from a report's channels (its
    :class:`~bayescal.report._html.ChannelAnalysis` objects): Kalibr's continuous densities
    with each channel's horizon from the default aiding. A channel is withheld when it has no
    posterior, is neither a gyro nor an accelerometer, or when discovery found effects its
    noise model lacks: its noise model's numbers are then not the ones that hold them."""
    fits, withheld = [], {}
    for analysis in analyses:
        fit = analysis.noise.noise
        if fit is None:
            withheld[analysis.channel] = "classical only: no posterior to export"
            continue
        try:
            sensor_of_unit(fit.unit, analysis.channel, fit.source)
        except InputError:
            withheld[analysis.channel] = f"its unit, {fit.unit}, is no angular rate or acceleration"
            continue
        if analysis.effects is not None:
            withheld[analysis.channel] = (
                f"discovery found {' and '.join(analysis.effects.effects)}, which the noise "
                "model lacks: its N and K are not a filter's until the effect is removed or "
                "compensated"
            )
            continue
        fits.append(fit)
    return ReportFilterNoise(filter_noise(fits, estimator="kalibr") if fits else None, withheld)


def filter_section(exported: ReportFilterNoise, source: str) -> str:
    """The report's section "For your navigation filter": per channel N and K (continuous
    densities, SI) with their items, the values per sensor, what was withheld and the
    command that writes an estimator's own file."""
    noise = exported.noise
    parts = ["<h2>For your navigation filter</h2>"]
    if noise is not None:
        parts.append(
            "<p class='note'>The white noise N and the bias's random walk K a navigation "
            "filter should be told, as continuous-time densities (what Kalibr, OpenVINS, "
            "ORB-SLAM3 and GTSAM take), each the root-sum-square of its items: the "
            f"posterior's {100 * noise.quantile:g} % quantile, and each bias term as the "
            "random walk that bounds it over the horizon, here the span over which "
            f"{esc(noise.aiding.describe())} reveal the channel's bias (an assumption: give "
            "your filter's aiding or window).</p>"
        )
        rows = []
        summary = noise.summary
        for channel in noise.channels.values():
            for p in ("N", "K"):
                items = "; ".join(
                    f"{esc(item)} {num(part.value, 3)}"
                    for item in ITEMS
                    for part in channel.items[item]
                    if part.parameter == p
                )
                rows.append(
                    f"<tr><td>{esc(channel.channel)}</td><td>{p}</td>"
                    f"<td>{num(channel.density[p], 4)} "
                    f"{esc(summary[channel.channel]['density'][p]['unit'])}"
                    f"</td><td>{items}</td><td>{num(channel.horizon_s, 3)} s</td></tr>"
                )
        parts.append(
            "<table><tr><th>channel</th><th></th><th>density</th><th>items</th>"
            "<th>horizon</th></tr>" + "".join(rows) + "</table>"
        )
        parts.append(
            "<p>One value per sensor covers its three axes (the largest of its channels): "
            + "; ".join(
                f"<code>{esc(key)}</code> = {num(entry['value'], 4)} {esc(entry['unit'])} "
                f"({esc(entry['channel'])})"
                for key, entry in noise.values.items()
            )
            + ".</p>"
        )
        for note in noise.notes:
            parts.append(f"<p class='note'>{esc(note)}</p>")
    if exported.withheld:
        parts.append(
            "<p class='bad'>Not exported: "
            + "; ".join(f"<b>{esc(c)}</b>: {esc(why)}" for c, why in exported.withheld.items())
            + ".</p>"
        )
    parts.append(
        "<p class='note'>Another estimator's file (its own names, units and per-sample "
        "convention), another aiding or a sliding window's horizon: <code>bayescal "
        f"export-filter {esc(source)} --estimator vins --aiding position:1@1 --out "
        "vins_imu.yaml</code> (estimators: kalibr, openvins, orbslam3, vins, gtsam, px4).</p>"
    )
    return "\n".join(parts)


def report_filter_document(exported: ReportFilterNoise) -> dict:
    """The report JSON's ``navigation_filter``: the export's document and what was
    withheld."""
    return {
        **(filter_document(exported.noise) if exported.noise is not None else {}),
        "withheld": dict(exported.withheld),
    }
