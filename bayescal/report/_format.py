"""Numbers and units as text and as HTML, and the pages' shared style: what every text and
page of the report writes a number with.

A number on a page carries its unit (``_q``), an interval as many significant digits as
resolve it (``interval``); units are shown as a reader writes them (``pretty_unit``: √Hz, °C,
m/s²). Text output (the command line's tables) formats its numbers where it prints them.
"""

import html
import math

STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 1.5em auto;
       max-width: 1180px; color: #222; line-height: 1.4; padding: 0 1em; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; } h2 { border-bottom: 2px solid #3182bd;
     padding-bottom: 0.15em; margin-top: 1.8em; } h3 { margin-top: 1.4em; }
table { border-collapse: collapse; margin: 0.6em 0 1em 0; font-size: 0.88em; display: block;
        overflow-x: auto; max-width: 100%; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.5em; vertical-align: top; text-align: left; }
th { background: #eef3f8; } td.num { font-variant-numeric: tabular-nums; }
.bad { color: #b00020; font-weight: bold; } .ok { color: #1b7a1b; }
.alarm { background: #fde8ea; border: 2px solid #b00020; padding: 0.6em 1em; margin: 1em 0; }
.alarm h2 { border: none; color: #b00020; margin-top: 0; }
tr.failed td { background: #fde8ea; } .note { color: #555; font-size: 0.9em; }
img.figure { display: block; max-width: 100%; margin: 0.6em 0; border: 1px solid #ddd; }
code { background: #f4f4f4; padding: 0 0.2em; }
.story { background: #fff8e1; border: 2px solid #e6a700; padding: 0.6em 1em; margin: 1em 0; }
"""
"""The style of every page (inline: a page opens offline)."""


def esc(value) -> str:
    """``value`` as text, HTML-escaped (quotes too)."""
    return html.escape(str(value), quote=True)


def page_start(title: str) -> list[str]:
    """The opening of every page: the document's head with :data:`STYLE` and ``title`` as
    its heading."""
    return [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{esc(title)}</title><style>{STYLE}</style></head><body>",
        f"<h1>{esc(title)}</h1>",
    ]


def num(value, digits: int = 4) -> str:
    """A number with ``digits`` significant digits; ``n/a`` for None or not finite."""
    if value is None:
        return "n/a"
    try:
        number = float(value)
    except (TypeError, ValueError):
        return esc(value)
    if not math.isfinite(number):
        return "n/a"
    return f"{number:.{digits}g}"


def pretty_unit(unit: str) -> str:
    """A unit as text for the page: sqrt(Hz) -> √Hz, ^2 -> ², degC -> °C, 1 -> (no unit)."""
    if unit in ("1", ""):
        return "(dimensionless)"
    text = unit.replace("sqrt(Hz)", "√Hz").replace("sqrt(h)", "√h").replace("^2", "²")
    return text.replace("^3", "³").replace("degC", "°C")


def squared(unit: str) -> str:
    """The square of a unit, for a power spectral density: (deg/s)², m²."""
    text = pretty_unit(unit)
    return f"({text})²" if any(mark in text for mark in "/*·") else f"{text}²"


def quantity(value, unit: str, digits: int = 4) -> str:
    """A number with its unit, HTML-escaped."""
    return f"{num(value, digits)}&nbsp;{esc(pretty_unit(unit))}"


def digits_of(value, low, high) -> int:
    """Significant digits that resolve an interval: a bias of 9.8 m/s^2 known to 1e-4 needs
    six, a noise density known to 1 % needs four."""
    try:
        value, width = abs(float(value)), abs(float(high) - float(low)) / 2
    except (TypeError, ValueError):
        return 4
    if not (math.isfinite(value) and math.isfinite(width)) or value == 0 or width == 0:
        return 4
    return min(10, max(4, math.ceil(math.log10(value / width)) + 2))


def interval(value, low, high, unit: str) -> str:
    """``value [low, high] unit`` with the digits that resolve the interval."""
    digits = digits_of(value, low, high)
    return (
        f"{num(value, digits)} [{num(low, digits)}, {num(high, digits)}]"
        f"&nbsp;{esc(pretty_unit(unit))}"
    )


def stacked(value, low, high, unit: str) -> str:
    """Value with its unit, the interval below it (for narrow table cells)."""
    digits = digits_of(value, low, high)
    return (
        f"{quantity(value, unit, digits)}<br><span class='note'>[{num(low, digits)}, "
        f"{num(high, digits)}]&nbsp;{esc(pretty_unit(unit))}</span>"
    )


def percent(fraction) -> str:
    """A fraction as a percentage, HTML."""
    return f"{100 * float(fraction):g}&nbsp;%"
