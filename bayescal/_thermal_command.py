"""``bayescal thermal fit | update | compensate``, and the calibration file they share.

Calibration file (JSON, ``schema: bayescal.thermal_calibration``, ``schema_version: 1``):
the channel and its unit, the temperature unit, the reference temperature T0, the degree,
the coefficients c_0..c_d of bias(T) = sum_j c_j (T - T0)^j with their units and covariance
(a multivariate normal: what ``update`` takes as its prior), the temperature range the data
covered, the noise model, the Earth rate taken off (if any), and the provenance of every
step. ``fit`` writes it, ``update`` reads it and writes the same schema, ``compensate`` reads
it. A file of another schema version, or for another unit, is refused.

``update`` takes the calibration as the prior of the coefficients *plus a drift since then*
(:mod:`bayescal._thermal`): ``--drift auto`` (default) learns its scale from the alignment
data, ``--drift S`` fixes it (S in the channel's unit: about how far the bias may have moved
at T0), ``--drift 0`` assumes nothing has changed. An updated file adds ``drift`` (the scale
used or learned, with its 90 % interval) and ``offsets`` (the period offsets); both are
optional keys of schema version 1.
"""

import csv
import datetime
import json
import math
import os
import sys
import tempfile
from importlib.metadata import version
from pathlib import Path

import numpy as np
from scipy import stats

from ._errors import InputError

SCHEMA = "bayescal.thermal_calibration"
SCHEMA_VERSION = 1
NOISE_TERMS = ("white", "bias_instability", "rate_random_walk")
_TEMPERATURE_NAMES = (
    "temperature",
    "temp",
    "temp_c",
    "temperature_c",
    "gyro_temperature",
    "imu_temperature",
)


def add_parser(commands) -> None:
    from ._cli import _confidence, _positive_float

    thermal = commands.add_parser("thermal", help="thermal bias of a gyro: fit, update, compensate")
    steps = thermal.add_subparsers(dest="step", required=True, parser_class=type(thermal))

    def recording(parser):
        parser.add_argument("file", help="recording: .csv, .parquet or .npz")
        parser.add_argument("--channel", required=True, help="gyro column, e.g. gyro_z")
        parser.add_argument(
            "--temperature", metavar="COL", help="temperature column (default: found by name)"
        )
        parser.add_argument("--unit", help="unit of the channel (default: from the header)")
        parser.add_argument("--rate", type=_positive_float, metavar="HZ")
        parser.add_argument("--time-column", metavar="NAME")
        parser.add_argument("--time-unit", metavar="UNIT")
        parser.add_argument("--gaps", choices=("error", "split"), default="error")

    fit = steps.add_parser("fit", help="fit a thermal bias polynomial")
    recording(fit)
    fit.add_argument("--degree", default="auto", help="polynomial degree, or auto (default)")
    fit.add_argument(
        "--reference",
        type=float,
        metavar="T0",
        help="reference temperature (default: the middle of the range)",
    )
    fit.add_argument(
        "--terms",
        default=",".join(NOISE_TERMS),
        help="noise terms beside the thermal bias (as for noise; no ramp)",
    )
    fit.add_argument(
        "--latitude", type=float, metavar="DEG", help="take the Earth rate off (with --axis)"
    )
    fit.add_argument(
        "--axis",
        default="up",
        help="direction of the gyro axis: up, down, north, "
        "south, east, west or east,north,up components (default up)",
    )
    fit.add_argument("--confidence", type=_confidence, default=0.95)
    fit.add_argument("--seed", type=int, default=0)
    fit.add_argument("--quiet", action="store_true")
    fit.add_argument("--json", metavar="PATH", required=True, help="calibration file to write")
    fit.set_defaults(run=run_fit)

    update = steps.add_parser("update", help="update a calibration with alignment data")
    recording(update)
    update.add_argument("--calibration", required=True, metavar="PATH")
    update.add_argument(
        "--offset-measurement",
        metavar="M±U[,M±U...]",
        help="the common offset of each alignment period, measured separately, "
        "in the channel's unit",
    )
    update.add_argument(
        "--periods",
        metavar="T0:T1,...",
        help="alignment periods in seconds (default: the record's gap-free runs)",
    )
    update.add_argument(
        "--drift",
        default="auto",
        metavar="S|auto",
        help="how far the bias may have moved since the calibration, in the channel's unit "
        "(about that much at T0, each polynomial term about that much at the edge of the "
        "calibrated range); auto (default) learns it from the data, 0 assumes no change",
    )
    update.add_argument("--latitude", type=float, metavar="DEG")
    update.add_argument("--axis", default="up")
    update.add_argument("--seed", type=int, default=0)
    update.add_argument("--quiet", action="store_true")
    update.add_argument("--json", metavar="PATH", required=True, help="updated calibration file")
    update.set_defaults(run=run_update)

    compensate = steps.add_parser("compensate", help="subtract the thermal bias from the output")
    recording(compensate)
    compensate.add_argument("--calibration", required=True, metavar="PATH")
    compensate.add_argument("--out", required=True, metavar="CSV", help="compensated recording")
    compensate.set_defaults(run=run_compensate)


def find_temperature_column(table, given: str | None) -> str:
    if given:
        table.require(given, "temperature column")
        return given
    for name in table.columns:
        base = name.lower()
        if base in _TEMPERATURE_NAMES or base.startswith("temp"):
            return name
    raise InputError(
        "no temperature column",
        source=table.source,
        fix="pass --temperature COL (found by name: temperature, temp, temp_C ...)",
    )


def _read(args):
    from ._recording import load_table, prepare_channel

    table = load_table(args.file)
    temperature = find_temperature_column(table, args.temperature)
    data = prepare_channel(
        table,
        args.channel,
        unit=args.unit,
        rate=args.rate,
        time_column=args.time_column,
        time_unit=args.time_unit,
        gaps=args.gaps,
        temperature=temperature,
    )
    return table, data, temperature


def _earth_rate(args, unit: str) -> dict | None:
    from ._thermal import earth_rate_on_axis

    if args.latitude is None:
        return None
    value = earth_rate_on_axis(args.latitude, args.axis, unit)
    return {"latitude_deg": args.latitude, "axis": args.axis, "value": value, "unit": unit}


def _coefficient_units(unit: str, temperature_unit: str, degree: int) -> list[str]:
    return [unit] + [
        f"{unit}/{temperature_unit}" + (f"^{j}" if j > 1 else "") for j in range(1, degree + 1)
    ]


def classical_thermal(
    values, temperature, degree: int, reference: float, confidence: float
) -> dict:
    """Bin by temperature, mean per bin with its Student-t interval, then a weighted
    least-squares polynomial through the bin means with its covariance."""
    present = ~np.isnan(values) & ~np.isnan(temperature)
    values, temperature = values[present], temperature[present]
    span = np.ptp(temperature)
    count = int(min(20, max(degree + 2, round(span / 0.25))))
    edges = np.linspace(temperature.min(), temperature.max(), count + 1)
    index = np.clip(np.digitize(temperature, edges) - 1, 0, count - 1)
    bins = []
    for b in range(count):
        member = values[index == b]
        if member.size < 3:
            continue
        half = (
            stats.t.ppf(0.5 + confidence / 2, member.size - 1)
            * member.std(ddof=1)
            / math.sqrt(member.size)
        )
        bins.append(
            (
                float(temperature[index == b].mean()),
                float(member.mean()),
                float(half),
                int(member.size),
            )
        )
    bins = np.array(bins)
    if bins.shape[0] < degree + 1:
        raise InputError(
            f"the temperature range ({span:.3g}) fills only {bins.shape[0]} bins, "
            f"too few for degree {degree}",
            fix="lower --degree",
        )
    z = stats.norm.ppf(0.5 + confidence / 2)
    weight = 1 / (bins[:, 2] / z) ** 2
    design = (bins[:, 0:1] - reference) ** np.arange(degree + 1)
    covariance = np.linalg.inv(design.T @ (weight[:, None] * design))
    coefficients = covariance @ design.T @ (weight * bins[:, 1])
    return {
        "bins": [
            {"temperature": t, "mean": m, "half_width": h, "n_samples": n} for t, m, h, n in bins
        ],
        "coefficients": coefficients,
        "covariance": covariance,
        "confidence": confidence,
        "method": "bin means (independent samples) and weighted least squares",
    }


def _document(
    channel,
    unit,
    temperature_unit,
    fit,
    temperature_range,
    noise_terms,
    earth,
    provenance,
    extra=None,
) -> dict:
    from ._units import noise_parameter_unit

    degree = fit.degree
    document = {
        "schema": SCHEMA,
        "schema_version": SCHEMA_VERSION,
        "channel": channel,
        "unit": unit,
        "temperature_unit": temperature_unit,
        "reference_temperature": fit.reference,
        "degree": degree,
        "coefficients": fit.coefficient_mean,
        "coefficient_units": _coefficient_units(unit, temperature_unit, degree),
        "covariance": fit.coefficient_covariance,
        "temperature_range": list(temperature_range),
        "noise": {
            "terms": list(noise_terms),
            **{
                name: {"mean": m, "q05": lo, "q95": hi, "unit": noise_parameter_unit(name, unit)}
                for name, (m, lo, hi) in fit.noise.items()
            },
        },
        "earth_rate": earth,
        "provenance": provenance,
        "bayesian": {
            "map_coefficients": fit.map_coefficients,
            "map_covariance": fit.map_covariance,
            "coefficient_q05": np.quantile(fit.coefficient_draws, 0.05, axis=0),
            "coefficient_q95": np.quantile(fit.coefficient_draws, 0.95, axis=0),
            "degree_scores": {
                str(d): {"elpd": e, "se_difference": se} for d, (e, se) in fit.degree_scores.items()
            },
            "diagnostics": fit.diagnostics.as_dict(),
        },
    }
    document.update(extra or {})
    return document


def read_calibration(path: str, unit: str) -> dict:
    source = str(path)
    try:
        document = json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError("no such calibration file", source=source, fix="check the path") from None
    except json.JSONDecodeError as error:
        raise InputError(f"not a JSON calibration file: {error}", source=source) from None
    if document.get("schema") != SCHEMA:
        raise InputError(
            f"not a bayescal thermal calibration (schema {document.get('schema')!r})",
            source=source,
            fix="give a file written by bayescal thermal fit",
        )
    if document.get("schema_version") != SCHEMA_VERSION:
        raise InputError(
            f"calibration schema version {document.get('schema_version')!r}; this "
            f"bayescal reads version {SCHEMA_VERSION}",
            source=source,
            fix="refit with this version (bayescal thermal fit)",
        )
    if document["unit"] != unit:
        raise InputError(
            f"the calibration is in {document['unit']} but the channel is in {unit}",
            source=source,
            fix="pass --unit to match, or refit in this unit",
        )
    return document


def _provenance(step: str, args, data, extra: dict) -> dict:
    return {
        "step": step,
        "source": data.source,
        "channel": data.channel,
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "bayescal_version": version("bayescal"),
        "n_samples": data.n_samples,
        "seed": getattr(args, "seed", None),
        **extra,
    }


def run_fit(args) -> int:
    from ._allan import allan_deviation
    from ._noise_fit import parse_terms
    from ._output import check_writable, write_json
    from ._thermal import (
        ThermalRecord,
        check_temperature,
        choose_degree,
        sample_thermal,
        thermal_problem,
    )

    check_writable(args.json, "--json")
    noise_terms = parse_terms(args.terms)
    if "rate_ramp" in noise_terms:
        raise InputError("--terms: a ramp cannot be told from a thermal drift; leave it out")
    _, data, temperature_column = _read(args)
    check_temperature(data.temperature, data.source, temperature_column)
    earth = _earth_rate(args, data.unit)
    values = data.values - (earth["value"] if earth else 0.0)
    present = data.temperature[~np.isnan(data.temperature)]
    reference = (
        args.reference
        if args.reference is not None
        else float(round((present.min() + present.max()) / 2, 1))
    )
    record = ThermalRecord(values, data.temperature, data.rate_hz, ((0, values.size),))
    allan = allan_deviation(values, data.rate_hz)
    if args.degree == "auto":
        degree, scores = choose_degree(record, reference, noise_terms=noise_terms, allan=allan)
    else:
        degree, scores = _degree(args.degree), {}
    problem = thermal_problem(record, degree, reference, noise_terms=noise_terms, allan=allan)
    fit = sample_thermal(
        problem,
        degree,
        reference,
        seed=args.seed,
        progress=not args.quiet and sys.stderr.isatty(),
        degree_scores=scores,
    )
    classical = classical_thermal(values, data.temperature, degree, reference, args.confidence)
    temperature_unit = "degC"
    document = _document(
        data.channel,
        data.unit,
        temperature_unit,
        fit,
        (float(present.min()), float(present.max())),
        noise_terms,
        earth,
        [_provenance("fit", args, data, {"degree_chosen": args.degree == "auto"})],
        {"classical": classical},
    )
    write_json(args.json, document)
    print(_fit_text(document))
    return _health(fit, "thermal fit")


def _degree(text: str) -> int:
    from ._thermal import MAX_DEGREE

    try:
        degree = int(text)
    except ValueError:
        degree = -1
    if not 0 <= degree <= MAX_DEGREE:
        raise InputError(f"--degree {text!r}", fix=f"give auto or a whole number 0..{MAX_DEGREE}")
    return degree


def _health(fit, command: str) -> int:
    if fit.diagnostics.passed:
        return 0
    print(
        f"bayescal {command}: HEALTH CHECK FAILED: " + "; ".join(fit.diagnostics.failures),
        file=sys.stderr,
    )
    return 1


def _parse_measurements(text: str | None, count: int) -> list:
    from ._units import parse_measurement

    if not text:
        return [None] * count
    parsed = []
    for part in text.split(","):
        try:
            value, uncertainty = parse_measurement(part)
        except ValueError:
            value, uncertainty = math.nan, None
        if not (math.isfinite(value) and uncertainty and uncertainty > 0):
            raise InputError(
                f"--offset-measurement {part!r}",
                fix="write it like 0.002±0.001 (a value and a positive uncertainty)",
            )
        parsed.append((value, uncertainty))
    if len(parsed) == 1:
        parsed = parsed * count
    if len(parsed) != count:
        raise InputError(
            f"--offset-measurement gives {len(parsed)} values for {count} periods",
            fix="give one for all periods or one per period",
        )
    return parsed


def _periods(data, given: str | None) -> tuple[tuple[int, int], ...]:
    time = data.time_s
    if given:
        periods = []
        for part in given.split(","):
            try:
                start, stop = (float(x) for x in part.split(":"))
            except ValueError:
                raise InputError(
                    f"--periods {given!r}", fix="write T0:T1,T0:T1 in seconds"
                ) from None
            keep = np.flatnonzero((time >= start) & (time < stop))
            if keep.size < 16:
                raise InputError(f"--periods: {part} holds {keep.size} samples", fix="widen it")
            periods.append((int(keep[0]), int(keep[-1]) + 1))
        return tuple(periods)
    present = ~np.isnan(data.values)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], present.astype(np.int8), [0]))))
    return tuple(
        (int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a >= 16
    )


def _parse_drift(text: str) -> float | str | None:
    if text.strip().lower() == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise InputError(
            f"--drift {text!r}",
            fix="give auto, 0 (no change since the calibration) or a positive scale in the "
            "channel's unit",
        )
    return value or None


def run_update(args) -> int:
    from ._noise_fit import NoisePrior
    from ._output import check_writable, write_json
    from ._thermal import ThermalRecord, sample_thermal, thermal_problem

    check_writable(args.json, "--json")
    drift = _parse_drift(args.drift)
    _, data, _ = _read(args)
    calibration = read_calibration(args.calibration, data.unit)
    earth = _earth_rate(args, data.unit)
    values = data.values - (earth["value"] if earth else 0.0)
    periods = _periods(data, args.periods)
    measurements = _parse_measurements(args.offset_measurement, len(periods))
    record = ThermalRecord(values, data.temperature, data.rate_hz, periods)
    degree = calibration["degree"]
    noise = calibration["noise"]
    parameters = tuple(name for name in ("Q", "N", "F", "B", "K") if name in noise)
    # The noise as the calibration measured it: log-normal around its posterior mean with
    # the spread of its 90 % interval (F: normal on atanh).
    location, scale = [], []
    for name in parameters:
        mean, low, high = noise[name]["mean"], noise[name]["q05"], noise[name]["q95"]
        if name == "F":
            location.append(math.atanh(mean))
            scale.append(max((math.atanh(high) - math.atanh(low)) / 3.29, 0.01))
        else:
            location.append(math.log(mean))
            scale.append(max(math.log(high / low) / 3.29, 0.01))
    noise_prior = NoisePrior(
        np.array(location),
        np.array(scale),
        np.asarray(1.0),
        parameters,
        # A fixed text: it is a static field of the problem, and a path in it would make every
        # calibration file compile its own likelihood (the provenance names the file).
        "the noise of the prior calibration",
    )
    problem = thermal_problem(
        record,
        degree,
        calibration["reference_temperature"],
        noise_terms=(),
        allan=None,
        coefficient_prior=(
            np.asarray(calibration["coefficients"]),
            np.asarray(calibration["covariance"]),
        ),
        offset_prior=measurements,
        noise_prior=noise_prior,
        drift=drift,
        calibrated_range=tuple(calibration["temperature_range"]),
    )
    fit = sample_thermal(
        problem,
        degree,
        calibration["reference_temperature"],
        seed=args.seed,
        progress=not args.quiet and sys.stderr.isatty(),
    )
    present = data.temperature[~np.isnan(data.temperature)]
    old_low, old_high = calibration["temperature_range"]
    document = _document(
        data.channel,
        data.unit,
        calibration["temperature_unit"],
        fit,
        (min(old_low, float(present.min())), max(old_high, float(present.max()))),
        calibration["noise"]["terms"],
        calibration.get("earth_rate"),
        [
            *calibration["provenance"],
            _provenance(
                "update",
                args,
                data,
                {
                    "prior": str(args.calibration),
                    "periods": [list(p) for p in periods],
                    "offset_measurements": measurements,
                    "drift": args.drift,
                },
            ),
        ],
        {
            "offsets": {"mean": fit.offset_mean, "sd": fit.offset_sd, "unit": data.unit},
            "drift": _drift_entry(drift, fit, data.unit),
        },
    )
    write_json(args.json, document)
    print(_fit_text(document))
    return _health(fit, "thermal update")


def _drift_entry(drift, fit, unit: str) -> dict:
    """The drift since the prior calibration that the update allowed for."""
    if drift == "auto":
        mean, low, high = fit.drift
        return {"scale": mean, "q05": low, "q95": high, "unit": unit, "learned": True}
    value = drift or 0.0
    return {"scale": value, "q05": value, "q95": value, "unit": unit, "learned": False}


def run_compensate(args) -> int:
    from ._recording import load_table

    table = load_table(args.file)
    temperature_column = find_temperature_column(table, args.temperature)
    out = Path(args.out)
    if not out.parent.is_dir():
        raise InputError(f"--out {out}: folder '{out.parent}' does not exist")
    from ._recording import resolve_unit

    values = table.require(args.channel, "channel")
    unit, note = resolve_unit(table, args.channel, args.unit)
    calibration = read_calibration(args.calibration, unit)
    temperature = table.require(temperature_column, "temperature column")
    degree, reference = calibration["degree"], calibration["reference_temperature"]
    powers = (temperature[:, None] - reference) ** np.arange(degree + 1)
    coefficients = np.asarray(calibration["coefficients"])
    covariance = np.asarray(calibration["covariance"])
    bias = powers @ coefficients
    spread = np.sqrt(np.einsum("ij,jk,ik->i", powers, covariance, powers))
    earth = calibration.get("earth_rate")
    compensated = values - bias - (earth["value"] if earth else 0.0)
    low, high = calibration["temperature_range"]
    outside = (temperature < low) | (temperature > high)
    if outside.any():
        distance = float(np.max(np.maximum(low - temperature, temperature - high)[outside]))
        print(
            f"bayescal thermal compensate: warning: {int(outside.sum())} samples "
            f"({100 * outside.mean():.3g}%) lie outside the calibrated range [{low:.4g}, "
            f"{high:.4g}] {calibration['temperature_unit']}, by up to {distance:.3g}: the "
            "polynomial is extrapolated there",
            file=sys.stderr,
        )
    columns = dict(table.columns)
    columns[f"{args.channel}_compensated"] = compensated
    columns[f"{args.channel}_compensated_sd"] = spread
    descriptor, temporary = tempfile.mkstemp(dir=out.parent, prefix=f".{out.name}.")
    try:
        with os.fdopen(descriptor, "w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle)
            writer.writerow(columns)
            writer.writerows(zip(*(column.tolist() for column in columns.values()), strict=True))
        os.replace(temporary, out)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    if note:
        print(f"bayescal thermal compensate: note: {note}", file=sys.stderr)
    print(
        f"bayescal thermal compensate: wrote {out} ({values.size} rows; {args.channel} minus "
        f"the thermal bias of {args.calibration}, with its sd)"
    )
    return 0


def _fit_text(document: dict) -> str:
    lines = [
        f"bayescal thermal: channel {document['channel']} [{document['unit']}], degree "
        f"{document['degree']}, T0 = {document['reference_temperature']:g} "
        f"{document['temperature_unit']}, range {document['temperature_range'][0]:.4g}-"
        f"{document['temperature_range'][1]:.4g}"
    ]
    sd = np.sqrt(np.diag(np.asarray(document["covariance"])))
    bayes = document["bayesian"]
    for j, (value, spread, unit) in enumerate(
        zip(document["coefficients"], sd, document["coefficient_units"], strict=True)
    ):
        row = (
            f"  c{j} {value:.6g} +- {spread:.3g} {unit}  [90%: {bayes['coefficient_q05'][j]:.6g},"
            f" {bayes['coefficient_q95'][j]:.6g}]"
        )
        if "classical" in document:
            classical = document["classical"]
            row += (
                f"   classical WLS {classical['coefficients'][j]:.6g} +- "
                f"{math.sqrt(classical['covariance'][j][j]):.3g}"
            )
        lines.append(row)
    if bayes["degree_scores"]:
        lines.append(
            "  degree chosen by one-block-ahead ELPD: "
            + ", ".join(
                f"{d}: {s['elpd']:.1f} (se {s['se_difference']:.1f})"
                for d, s in bayes["degree_scores"].items()
            )
        )
    if "drift" in document:
        drift = document["drift"]
        lines.append(
            f"  drift since the prior calibration: {drift['scale']:.3g} {drift['unit']}"
            + (
                f" (learned, 90%: {drift['q05']:.3g}-{drift['q95']:.3g})"
                if drift["learned"]
                else " (given)"
            )
        )
    if "offsets" in document:
        lines.append(
            "  period offsets: "
            + ", ".join(
                f"{m:.4g} +- {s:.2g}"
                for m, s in zip(document["offsets"]["mean"], document["offsets"]["sd"], strict=True)
            )
        )
    lines.append(
        "  noise: "
        + ", ".join(
            f"{k} {v['mean']:.3g} {v['unit']}" for k, v in document["noise"].items() if k != "terms"
        )
    )
    diagnostics = bayes["diagnostics"]
    lines.append(
        "  posterior checks "
        + ("passed" if diagnostics["passed"] else "FAILED: " + "; ".join(diagnostics["failures"]))
    )
    return "\n".join(lines)
