"""Finding columns by name: gyros, accelerometers (an x, y, z triple), temperature."""

import re

from .._errors import InputError
from ._units import parse_unit, unit_from_column_suffix

_ACCEL_NAME = re.compile(r"^(?P<prefix>acc|accel|accelerometer|a)[_ \-]?(?P<axis>[xyz])$")
_TEMPERATURE_NAMES = (
    "temperature",
    "temp",
    "temp_c",
    "temperature_c",
    "gyro_temperature",
    "imu_temperature",
)


def is_gyro_name(name: str) -> bool:
    return bool(re.match(r"(gyr|gyro|g[xyz]\b|omega|rate|w[xyz]\b)", name.lower()))


def is_accel_name(name: str) -> bool:
    return bool(re.match(r"(acc|a[xyz]\b|f[xyz]\b|specific)", name.lower()))


def find_accelerometer_columns(table) -> tuple[str, str, str] | None:
    """The first x, y, z triple named like an accelerometer (acc_x, ax, accel_x_mps2 ...)."""
    triples: dict[str, dict[str, str]] = {}
    for name in table.columns:
        base = name.rpartition("_")[0] if unit_from_column_suffix(name) else name
        match = _ACCEL_NAME.match(base.lower())
        if match:
            triples.setdefault(match["prefix"], {})[match["axis"]] = name
    for axes in triples.values():
        if len(axes) == 3:
            return axes["x"], axes["y"], axes["z"]
    return None


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
        fix='pass temperature="COLUMN" (found by name: temperature, temp, temp_C ...)',
    )


def default_channels(table) -> list[str]:
    return [
        name
        for name in table.columns
        if name not in ("time", "t", "timestamp") and (is_gyro_name(name) or is_accel_name(name))
    ]


def temperature_unit(recording, column: str) -> tuple[str, bool]:
    """The unit of the temperature column (from its header or name; degC when neither says)
    and whether the file declares it."""
    declared = recording.header_units.get(column) or unit_from_column_suffix(column)
    if declared is None:
        return "degC", False
    parsed = parse_unit(declared)
    if parsed.quantity != "temperature":
        raise InputError(
            f"the temperature column's unit '{declared}' is not a temperature unit",
            source=recording.source,
            column=column,
            fix="write degC, degF or K in its header, e.g. temperature[degC]",
        )
    return parsed.name, True
