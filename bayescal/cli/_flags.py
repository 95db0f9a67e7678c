"""The library's messages name its arguments as Python does (``gaps="split"``,
``start=/stop=``); the command line says its own flags (``--gaps split``, ``--start/--stop``).
This is the one place that translates them: every ``name=`` of an error's text whose name is
an option of a command (its destination, or the library's name for it, :data:`ALIASES`)
becomes that option's flag, and a value after it, the value as typed on the command line."""

import argparse
import re

ALIASES = {
    "rate_hz": "rate",
    "min_still_s": "min_still",
    "latitude_deg": "latitude",
    "height_m": "height",
    "n_walkers": "walkers",
}
"""The library's name of an argument -> the command line's (argparse destination)."""

_VALUE = (
    r"""(?:"(?P<double>[^"]*)"|'(?P<single>[^']*)'"""
    r"|(?P<items>[\[(][^\])]*[\])])|(?P<mapping>\{[^}]*\})|(?P<plain>[\w.+:-]+))?"
)


def flags(parser: argparse.ArgumentParser) -> dict[str, str]:
    """destination -> long flag, over every command of ``parser``."""
    found = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for command in action.choices.values():
                found.update(flags(command))
        elif action.option_strings and action.dest not in ("help",):
            found.setdefault(action.dest, max(action.option_strings, key=len))
    return found


def in_flags(message: str, parser: argparse.ArgumentParser) -> str:
    """``message`` with each argument the library named (``name=`` and its value) written
    as the command line's flag."""
    by_name = flags(parser)
    by_name.update({name: by_name[dest] for name, dest in ALIASES.items() if dest in by_name})
    pattern = re.compile(
        r"(?<![\w.\[])(?P<name>"
        + "|".join(sorted(map(re.escape, by_name), key=len, reverse=True))
        + r")="
        + _VALUE
    )

    def flag(match: re.Match) -> str:
        value = match["double"] if match["double"] is not None else match["single"]
        if match["items"] is not None:
            value = _listed(match["items"])
        elif match["mapping"] is not None:  # {"VAR": ["a", "b"]}: the command line's VAR:a,b
            key, _, items = match["mapping"][1:-1].partition(":")
            value = f"{key.strip().strip(chr(39) + chr(34))}:{_listed(items.strip())}"
        elif value is None:
            value = match["plain"]
        return by_name[match["name"]] + (f" {value}" if value else "")

    return pattern.sub(flag, message)


def _listed(items: str) -> str:
    """``["a", "b"]`` or ``("a", "b")`` as the command line writes it: ``a,b``."""
    return ",".join(part.strip().strip("'\"") for part in items[1:-1].split(",") if part.strip())
