"""Sensor cards: datasheet noise figures of common IMU parts, read from TOML.

A card is a TOML file in ``models/`` (or in the folder named by ``BAYESCAL_MODELS``) with a
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
    name: str
    path: Path
    content: dict

    @property
    def datasheet(self) -> str:
        return self.content.get("datasheet", "")

    def section(self, unit: str) -> dict:
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
        """N, B and K from the card, in the channel's parameter units, each with its source."""
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
    return Path(os.environ.get("BAYESCAL_MODELS") or Path(__file__).resolve().parents[2] / "models")


def sensor_cards() -> list[SensorCard]:
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
    wanted = name.strip().lower().replace("_", "-")
    cards = sensor_cards()
    for card in cards:
        if wanted in (card.name.lower().replace("_", "-"), card.path.stem.lower()):
            return card
    raise InputError(
        f"--sensor {name}: no such sensor card",
        fix=f"choose one of {', '.join(card.name for card in cards) or '(none)'}",
    )
