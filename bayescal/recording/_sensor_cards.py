"""Sensor cards: datasheet noise figures of common IMU parts, read from TOML.

A card is a TOML file in the repository's ``models/`` folder, which a wheel installs as the
package data ``bayescal/_cards`` (or in the folder named by ``BAYESCAL_MODELS``), with a
``[gyro]`` and/or ``[accelerometer]`` section; every number carries its unit and where in the
datasheet it comes from (the schema is in models/README.md). For a channel, the section is
chosen by the channel's unit (an angular rate or an acceleration).

The "in-run bias stability" of datasheets is the minimum of the Allan deviation, so
B = that / 0.664 (IEEE 952); noise densities and random walks are the same quantity N in
different units. How the figures become priors: :mod:`bayescal.inference._priors`.
"""

import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

from .._errors import InputError
from ._units import BIAS_INSTABILITY_FACTOR, card_value_in, parse_unit

SCHEMA_VERSION = 1
_SECTION_OF_QUANTITY = {"angular_rate": "gyro", "acceleration": "accelerometer"}
_WHITE_ENTRIES = ("noise_density", "angle_random_walk", "velocity_random_walk")


@dataclass(frozen=True)
class SensorCard:
    """The datasheet figures of one IMU part (a TOML file in ``models/``; schema in
    ``models/README.md``): its gyro and accelerometer noise, each number with its unit and
    the place in the datasheet it comes from.

    Attributes
    ----------
    name : str
        The part's name (``MPU-6050``), as ``--sensor`` takes it.
    path : Path
        The card's file.
    content : dict
        The parsed TOML: ``[gyro]`` and ``[accelerometer]`` sections of entries
        ``{value, unit, source}``.
    """

    name: str
    path: Path
    content: dict

    @property
    def datasheet(self) -> str:
        """The datasheet the figures come from (title and revision), or ""."""
        return self.content.get("datasheet", "")

    def section(self, unit: str) -> dict:
        """The card's section for a channel of this unit: ``gyro`` for an angular rate,
        ``accelerometer`` for an acceleration.

        Parameters
        ----------
        unit : str
            The channel's unit (deg/s, m/s^2 ...).

        Returns
        -------
        dict
            The section's entries, each ``{value, unit, source}``.

        Raises
        ------
        InputError
            The unit is neither an angular rate nor an acceleration, or the card has no
            section for that kind of sensor.
        """
        quantity = parse_unit(unit).quantity
        section = _SECTION_OF_QUANTITY.get(quantity)
        if section is None:
            raise InputError(
                f"--sensor {self.name}: the channel's unit '{unit}' is neither an "
                "angular rate nor an acceleration",
                fix="pass --unit",
            )
        if section not in self.content:
            raise InputError(
                f"--sensor {self.name}: the card has no [{section}] section",
                fix="choose a card for this kind of sensor (bayescal sensors)",
            )
        return self.content[section]

    def datasheet_values(self, unit: str) -> dict[str, tuple[float, str]]:
        """N, B and K from the card, in the channel's parameter units, each with its source.

        The datasheet's "in-run bias stability" is the minimum of the Allan deviation, so
        B = that / 0.664 (IEEE Std 952) unless the card defines it otherwise.

        Parameters
        ----------
        unit : str
            The channel's unit; N is returned in unit/√Hz, B in unit, K in unit·√Hz.

        Returns
        -------
        dict
            Parameter name (``N``, ``B``, ``K``; those the card gives) -> (value, where in
            the datasheet it comes from).

        Raises
        ------
        InputError
            As :meth:`section`.
        """
        section = self.section(unit)
        values = {}
        for entry in _WHITE_ENTRIES:
            if entry in section:
                item = section[entry]
                values["N"] = (
                    card_value_in("N", item["value"], item["unit"], unit),
                    item["source"],
                )
                break
        if "bias_instability" in section:
            item = section["bias_instability"]
            value = card_value_in("B", item["value"], item["unit"], unit)
            if item.get("definition", "allan_minimum") == "allan_minimum":
                value /= BIAS_INSTABILITY_FACTOR
            values["B"] = (value, item["source"])
        if "rate_random_walk" in section:
            item = section["rate_random_walk"]
            values["K"] = (card_value_in("K", item["value"], item["unit"], unit), item["source"])
        return values


def models_folder() -> Path:
    """The folder the sensor cards are read from: ``BAYESCAL_MODELS`` when set, else the
    cards installed with the package (a wheel carries the repository's ``models/`` folder as
    ``bayescal/_cards``), else ``models/`` beside the package (a source checkout)."""
    if os.environ.get("BAYESCAL_MODELS"):
        return Path(os.environ["BAYESCAL_MODELS"])
    package = Path(__file__).resolve().parents[1]
    installed = package / "_cards"
    return installed if installed.is_dir() else package.parent / "models"


def sensor_cards() -> list[SensorCard]:
    """The sensor cards there are (``bayescal sensors`` lists them).

    Read from the cards installed with the package (the repository's ``models/`` folder), or
    from the folder ``BAYESCAL_MODELS`` names.

    Returns
    -------
    list of SensorCard
        Every card, in the order of their file names.

    Raises
    ------
    InputError
        A card that is not valid TOML, or of another schema version.

    Examples
    --------
    >>> import bayescal as bc
    >>> "MPU-6050" in [card.name for card in bc.sensor_cards()]
    True
    """
    cards = []
    for path in sorted(models_folder().glob("*.toml")):
        try:
            content = tomllib.loads(path.read_text(encoding="utf-8"))
        except tomllib.TOMLDecodeError as error:
            raise InputError(f"sensor card is not valid TOML: {error}", source=str(path)) from None
        if content.get("schema_version") != SCHEMA_VERSION:
            raise InputError(
                f"sensor card schema_version {content.get('schema_version')!r} is "
                f"not {SCHEMA_VERSION}",
                source=str(path),
            )
        cards.append(SensorCard(content.get("name", path.stem), path, content))
    return cards


def find_card(name: str) -> SensorCard:
    """The sensor card of a part, by name (case, ``_`` and ``-`` do not matter) or file stem.

    Parameters
    ----------
    name : str
        The part, as ``--sensor`` takes it (``MPU-6050``, ``adis16405``).

    Returns
    -------
    SensorCard
        Its card.

    Raises
    ------
    InputError
        No card of that name (the message lists those there are).

    Examples
    --------
    >>> import bayescal as bc
    >>> card = bc.find_card("mpu_6050")
    >>> card.name, sorted(card.datasheet_values("deg/s"))
    ('MPU-6050', ['N'])
    """
    wanted = name.strip().lower().replace("_", "-")
    cards = sensor_cards()
    for card in cards:
        if wanted in (card.name.lower().replace("_", "-"), card.path.stem.lower()):
            return card
    raise InputError(
        f"--sensor {name}: no such sensor card",
        fix=f"choose one of {', '.join(card.name for card in cards) or '(none)'}",
    )
