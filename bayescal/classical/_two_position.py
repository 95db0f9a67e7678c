"""Two-position accelerometer calibration, classically: the axis held vertical (up), then
anti-vertical (down).

The course method (../shared/DESIGN.md): the mean of each section with its Student-t
uncertainty; span = up - down with the RMS of the two uncertainties; scale factor
2 g_local / span with the uncertainty propagated to first order (gravity's included, at the
same confidence); offset = (up + down) / 2 with half the RMS of the two. The sections come from
two files or are found in one (:func:`sections_from_channel`).
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from .._errors import InputError
from ..recording._recording import Channel
from ..recording._sections import find_static_sections
from ..recording._units import STANDARD_GRAVITY, parse_unit
from ._gravity import LocalGravity

# A section whose level moves by more than this many standard errors between its halves is
# moving, not static.
MOVING_LIMIT = 8.0


@dataclass(frozen=True)
class Section:
    """One still section of a two-position calibration (sensitive axis up, or down).

    Attributes
    ----------
    values : numpy.ndarray
        The channel's samples in the section, its unit; NaN marks a missing one.
    start_s : float
        Time of the first sample, seconds from the start of its file.
    source : str
        The file it comes from (named in messages).
    """

    values: np.ndarray
    start_s: float
    source: str


def _mean_and_uncertainty(values: np.ndarray, confidence: float) -> tuple[float, float]:
    present = values[~np.isnan(values)]
    half = stats.t.ppf(0.5 + confidence / 2, present.size - 1) * present.std(ddof=1)
    return float(present.mean()), float(half / math.sqrt(present.size))


def check_sections(up: Section, down: Section, unit: str, channel: str) -> None:
    """Bad calibration data: a moving section, sections not opposite, a span far from 2 g."""
    for name, section in (("up", up), ("down", down)):
        present = section.values[~np.isnan(section.values)]
        if present.size < 16:
            raise InputError(
                f"the {name} section has only {present.size} samples",
                column=channel,
                source=section.source,
                fix="record at least a few seconds",
            )
        halves = np.array_split(present, 2)
        spread = math.hypot(*(h.std(ddof=1) / math.sqrt(h.size) for h in halves))
        change = abs(halves[1].mean() - halves[0].mean())
        if change > MOVING_LIMIT * spread and change > 0.01 * abs(present.mean()):
            raise InputError(
                f"the {name} section is not static: its level moves by {change:.4g} {unit} "
                f"between its halves ({change / spread:.0f} standard errors)",
                source=section.source,
                column=channel,
                fix="give a still stretch as the section, or hold the sensor still",
            )
    up_mean, down_mean = np.nanmean(up.values), np.nanmean(down.values)
    span = up_mean - down_mean
    if not (span > 0 and abs(up_mean + down_mean) < 0.5 * span):
        raise InputError(
            f"the sections are not opposite: up reads {up_mean:.4g} and down {down_mean:.4g} "
            f"{unit}; they should be about +g and -g around the offset",
            source=up.source,
            column=channel,
            fix="check which section is up and which down",
        )
    parsed = parse_unit(unit)
    if parsed.quantity == "acceleration":
        expected = 2 * STANDARD_GRAVITY / parsed.to_si
        if not 0.7 < span / expected < 1.3:
            raise InputError(
                f"the span is {span:.4g} {unit} but 2 g is {expected:.4g} {unit}: the unit is "
                "probably wrong",
                source=up.source,
                column=channel,
                fix="check unit=",
            )


def classical_two_position(
    up: np.ndarray, down: np.ndarray, gravity: LocalGravity, confidence: float
) -> dict:
    """The course method; every uncertainty is a half-width at ``confidence``."""
    mean_up, u_up = _mean_and_uncertainty(up, confidence)
    mean_down, u_down = _mean_and_uncertainty(down, confidence)
    span, u_span = mean_up - mean_down, math.hypot(u_up, u_down)
    g_half_width = float(stats.norm.ppf(0.5 + confidence / 2)) * gravity.uncertainty
    scale = 2 * gravity.value / span
    u_scale = scale * math.hypot(u_span / span, g_half_width / gravity.value)
    offset, u_offset = (mean_up + mean_down) / 2, u_span / 2
    return {
        "mean_up": (mean_up, u_up),
        "mean_down": (mean_down, u_down),
        "span": (span, u_span),
        "scale": (scale, u_scale),
        "offset": (offset, u_offset),
        "g_local": (gravity.value, g_half_width),
    }


def sections_from_channel(
    data: Channel, accelerometer: np.ndarray | None, given: str | None
) -> tuple[Section, Section, str]:
    """The up and down sections of one recording: from ``--sections UP_START:UP_STOP,...``
    (seconds) or found as the longest still stretches at the channel's highest and lowest
    levels (still-ness judged on the whole accelerometer when there is one)."""
    time = data.time_s
    if given:
        try:
            (up_start, up_stop), (down_start, down_stop) = (
                tuple(float(x) for x in part.split(":")) for part in given.split(",")
            )
        except ValueError:
            raise InputError(
                f"sections={given!r}",
                fix="write UP_START:UP_STOP,DOWN_START:DOWN_STOP in seconds from the first sample",
            ) from None

        def cut(start, stop):
            keep = (time >= start) & (time < stop)
            return Section(
                data.values[keep], float(time[keep][0]) if keep.any() else start, data.source
            )

        return cut(up_start, up_stop), cut(down_start, down_stop), "--sections"
    if np.isnan(data.values).any():
        raise InputError(
            "static sections cannot be found across gaps",
            source=data.source,
            column=data.channel,
            fix="give them with sections=",
        )
    still = find_static_sections(
        data.values if accelerometer is None else accelerometer, data.rate_hz
    )
    levels = np.array([data.values[s.start : s.stop].mean() for s in still])
    if levels.size < 2:
        raise InputError(
            f"found {levels.size} still section(s); two are needed (up and down)",
            source=data.source,
            column=data.channel,
            fix="hold the sensor still in each position for a few seconds, or "
            "give the sections with sections=",
        )
    middle, half = (levels.max() + levels.min()) / 2, (levels.max() - levels.min()) / 2
    chosen = {}
    for name, sign in (("up", 1), ("down", -1)):
        near = [
            s
            for s, level in zip(still, levels, strict=True)
            if sign * (level - middle) > 0.8 * half
        ]
        chosen[name] = max(near, key=lambda s: s.stop - s.start)
    up, down = (
        Section(data.values[s.start : s.stop], float(time[s.start]), data.source)
        for s in (chosen["up"], chosen["down"])
    )
    return up, down, f"{len(still)} still sections found; the longest at each extreme"
