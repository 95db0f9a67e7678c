"""A fleet's manifest: the CSV that lists its recordings (../shared/DESIGN.md, "Fleets").

One header row, then one row per recording:

========  ========  ===============================================================
column    required  value
========  ========  ===============================================================
path      yes       the recording, relative to the manifest's folder (or absolute)
unit      yes       the unit's serial or id
run       no        the power-up or session within the unit; numbered 1, 2 ... in
                    manifest order when the column is absent
rate      no        the sample rate, Hz, for a recording without a time column
                    (empty: the command's ``--rate``, else the time stamps)
temperature no      the temperature the run was recorded at, degC (reported beside
                    it; the population model does not use it)
========  ========  ===============================================================

Column names are read without regard to case or surrounding spaces; blank lines are skipped.
Each field is checked, and a bad one raises :class:`~bayescal.InputError` naming the manifest,
the column, the data row (1 = the first row under the header) and its line, and what to do:
a missing file, a path or a (unit, run) given twice, an empty unit, a rate that is not a
positive number, a temperature below absolute zero, an unknown column (a misspelt ``rate``
would otherwise be ignored).
"""

import csv
import math
from dataclasses import dataclass
from pathlib import Path

from .._errors import InputError, MissingFileError

REQUIRED_COLUMNS = ("path", "unit")
OPTIONAL_COLUMNS = ("run", "rate", "temperature")
ABSOLUTE_ZERO_C = -273.15


@dataclass(frozen=True)
class ManifestRow:
    """One recording of a fleet."""

    row: int
    """Data row (1 = the first row under the header)."""
    line: int
    """Line of the manifest file."""
    path: Path
    """The recording, resolved against the manifest's folder."""
    written: str
    """The path as the manifest writes it."""
    unit: str
    run: str
    rate_hz: float | None = None
    temperature_c: float | None = None


@dataclass(frozen=True)
class Manifest:
    """A fleet's recordings, in manifest order (:func:`read_manifest`)."""

    source: str
    """The manifest file."""
    rows: tuple[ManifestRow, ...]
    """One per recording: its path (resolved against the manifest's folder), the unit it
    belongs to, its run, and the rate and temperature the manifest gives, if any."""

    @property
    def units(self) -> tuple[str, ...]:
        """The units' ids, in order of first appearance."""
        return tuple(dict.fromkeys(row.unit for row in self.rows))


def _number(text: str, *, where: str, source: str, column: str, fix: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(
            f"{where}: '{text}' is not a number", source=source, column=column, fix=fix
        ) from None
    if not math.isfinite(value):
        raise InputError(f"{where}: '{text}' is not finite", source=source, column=column, fix=fix)
    return value


def read_manifest(path: str | Path) -> Manifest:
    """Read and check a fleet's manifest.

    Parameters
    ----------
    path : str or Path
        The CSV file (module docstring for its columns).

    Returns
    -------
    Manifest
        Its rows, each path resolved against the manifest's folder.

    Raises
    ------
    InputError
        The file cannot be read, a column is missing or unknown, or a field is bad (the
        message names the file, column, row and line).

    Examples
    --------
    >>> import bayescal as bc
    >>> manifest = bc.read_manifest("fleet.csv")  # doctest: +SKIP
    >>> manifest.units, manifest.rows[0].path  # doctest: +SKIP
    """
    source = str(path)
    manifest_path = Path(path)
    if not manifest_path.exists():
        raise MissingFileError(
            "no such manifest file",
            source=source,
            fix="give the CSV that lists the fleet's recordings",
        )
    if not manifest_path.is_file():
        raise InputError(
            "is not a file", source=source, fix="give the CSV that lists the fleet's recordings"
        )
    try:
        text = manifest_path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"cannot be read as UTF-8 text ({error})", source=source) from None
    reader = csv.reader(text.splitlines())
    header = next((fields for fields in reader if any(f.strip() for f in fields)), None)
    if header is None:
        raise InputError(
            "the manifest is empty",
            source=source,
            fix="write a header row (path,unit[,run,rate,temperature]) and one row per recording",
        )
    names = [name.strip().lower() for name in header]
    allowed = (*REQUIRED_COLUMNS, *OPTIONAL_COLUMNS)
    for name in names:
        if name not in allowed:
            raise InputError(
                f"unknown column '{name}'",
                source=source,
                fix=f"a manifest's columns are {', '.join(allowed)}",
            )
        if names.count(name) > 1:
            raise InputError(f"column '{name}' appears twice in the header", source=source)
    for name in REQUIRED_COLUMNS:
        if name not in names:
            raise InputError(
                f"no column '{name}'",
                source=source,
                fix="the header needs path and unit (and may have run, rate, temperature)",
            )
    folder = manifest_path.resolve().parent
    rows, paths, runs, counts = [], {}, {}, {}
    for fields in reader:
        if not any(field.strip() for field in fields):
            continue
        number, line = len(rows) + 1, reader.line_num
        where = f"data row {number} (line {line})"
        if len(fields) != len(names):
            raise InputError(
                f"{where} has {len(fields)} fields, the header {len(names)}",
                source=source,
                fix="give every row the header's columns (leave an optional one empty)",
            )
        values = {name: field.strip() for name, field in zip(names, fields, strict=True)}
        if not values["path"]:
            raise InputError(f"{where}: empty path", source=source, column="path")
        resolved = (folder / values["path"]).resolve()
        if not resolved.exists():
            raise MissingFileError(
                f"{where}: no such file '{values['path']}' (looked for {resolved})",
                source=source,
                column="path",
                fix="paths are relative to the manifest's folder",
                filename=str(resolved),
            )
        if resolved in paths:
            raise InputError(
                f"{where}: '{values['path']}' is already listed on data row {paths[resolved]}",
                source=source,
                column="path",
                fix="list each recording once",
            )
        paths[resolved] = number
        unit = values["unit"]
        if not unit:
            raise InputError(
                f"{where}: empty unit", source=source, column="unit", fix="give the unit's id"
            )
        if "run" in values:
            run = values["run"]
            if not run:
                raise InputError(
                    f"{where}: empty run",
                    source=source,
                    column="run",
                    fix="name every run, or leave the column out to number them in order",
                )
        else:
            counts[unit] = counts.get(unit, 0) + 1
            run = str(counts[unit])
        if (unit, run) in runs:
            raise InputError(
                f"{where}: unit '{unit}' run '{run}' is already listed on data row "
                f"{runs[unit, run]}",
                source=source,
                column="run",
                fix="give each run of a unit its own id",
            )
        runs[unit, run] = number
        rate = None
        if values.get("rate"):
            rate = _number(
                values["rate"],
                where=where,
                source=source,
                column="rate",
                fix="write the sample rate in Hz, or leave it empty",
            )
            if not rate > 0:
                raise InputError(
                    f"{where}: rate {values['rate']} must be a positive sample rate in Hz",
                    source=source,
                    column="rate",
                )
        temperature = None
        if values.get("temperature"):
            temperature = _number(
                values["temperature"],
                where=where,
                source=source,
                column="temperature",
                fix="write the temperature in degC, or leave it empty",
            )
            if temperature < ABSOLUTE_ZERO_C:
                raise InputError(
                    f"{where}: temperature {values['temperature']} degC is below absolute zero",
                    source=source,
                    column="temperature",
                    fix="write it in degC",
                )
        rows.append(
            ManifestRow(number, line, resolved, values["path"], unit, run, rate, temperature)
        )
    if not rows:
        raise InputError(
            "the manifest lists no recording", source=source, fix="add one row per recording"
        )
    return Manifest(source, tuple(rows))
