"""Sensor cards: datasheet noise figures of common IMU parts, read from TOML.

A card is a TOML file in the repository's ``models/`` folder, which a wheel installs as the
package data ``bayescal/_cards`` (or in the folder named by ``BAYESCAL_MODELS``), with a
``[gyro]`` and/or ``[accelerometer]`` section; every number carries its unit and where in the
datasheet it comes from (the schema is in models/README.md). For a channel, the section is
chosen by the channel's unit (an angular rate or an acceleration).

Which entry gives which noise parameter, and in what unit, is each noise term's to say
(:meth:`~bayescal.models.effects._base.NoiseTerm.card_values`; all of them:
:func:`~bayescal.models._terms.card_values`); how the figures become priors:
:mod:`bayescal.inference._priors`.
"""

import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

from .._errors import InputError
from ._units import parse_unit

SCHEMA_VERSION = 1
_SECTION_OF_QUANTITY = {"angular_rate": "gyro", "acceleration": "accelerometer"}


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
                f"sensor={self.name!r}: the channel's unit '{unit}' is neither an "
                "angular rate nor an acceleration",
                fix="pass unit=",
            )
        if section not in self.content:
            raise InputError(
                f"sensor={self.name!r}: the card has no [{section}] section",
                fix="choose a card for this kind of sensor (bayescal sensors)",
            )
        return self.content[section]


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
    >>> card.name, card.section("deg/s")["noise_density"]["unit"]
    ('MPU-6050', 'deg/s/sqrt(Hz)')
    """
    wanted = name.strip().lower().replace("_", "-")
    cards = sensor_cards()
    for card in cards:
        if wanted in (card.name.lower().replace("_", "-"), card.path.stem.lower()):
            return card
    raise InputError(
        f"sensor={name!r}: no such sensor card",
        fix=f"choose one of {', '.join(card.name for card in cards) or '(none)'}",
    )
