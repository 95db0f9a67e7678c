"""How long to record (``bayescal plan``): from a pilot record's noise posterior, the record
length each noise parameter needs for a stated precision, and what a given length will give.

The prediction is :func:`bayescal.inference._plan.predicted_widths`: the Laplace width a record
of each length would give, the median over draws of the pilot's posterior, on a grid of lengths
from a quarter of the pilot's to a year; the length a target needs is where the predicted width
crosses it (interpolated in log width against log length, where widths fall as a power of the
length). A parameter the record only bounds at every length of the grid (its predicted variance
above half its prior's) gets no length, and says so.
"""

import math
from dataclasses import dataclass

import numpy as np

from .._caches import release_compiled_code
from .._errors import InputError
from ..inference._plan import PredictedWidths, predicted_widths
from ..models._terms import PARAMETERS, parameter_unit
from ._noise import NoiseFit

LONGEST_S = 365.25 * 86400.0
"""The longest record a plan considers, s (a year)."""
GRID_POINTS = 25
"""Lengths of the grid, log-spaced from a quarter of the pilot's to :data:`LONGEST_S`."""


@dataclass(frozen=True)
class TermPlan:
    """What one parameter needs, and what the pilot already gives."""

    parameter: str
    target: float | None
    """The relative half-width asked for (0.2: +-20 %), or None (only predicted)."""
    length_s: float | None
    """The record length that reaches the target, s; None when none of the grid does."""
    reason: str
    """Why there is no length (empty where there is one)."""
    width_now: float
    """The predicted relative half-width at the pilot's own length."""
    width_measured: float
    """The pilot posterior's own relative half-width (q95 - q05) / 2 over its median's."""
    bounded_below_s: float
    """The length below which the record only bounds the parameter (0: pinned at every
    length of the grid; inf: bounded at every one)."""


@dataclass(frozen=True)
class RecordingPlan:
    """The record lengths a pilot's posterior asks for (:func:`plan_recording`)."""

    channel: str
    """The pilot's channel name."""
    unit: str
    """The pilot's rate unit (deg/s, m/s^2 ...)."""
    duration_s: float
    """The pilot record's length, s."""
    confidence: float
    """The interval's probability the widths are of (0.9: 90 % intervals)."""
    terms: dict
    """parameter -> :class:`TermPlan`."""
    curve: PredictedWidths
    """The predicted widths on the grid of lengths."""
    at_length: dict
    """parameter -> predicted relative half-width at the length asked about (empty when none
    was)."""
    length_asked_s: float | None = None
    """The length asked about, s (None when none was)."""

    @property
    def summary(self) -> dict:
        """parameter -> {length_s, reason, width_now, width_measured, target, unit}, the
        relative widths as fractions (0.2: +-20 %)."""
        return {
            name: {
                "target": plan.target,
                "length_s": plan.length_s,
                "reason": plan.reason,
                "width_now": plan.width_now,
                "width_measured": plan.width_measured,
                "bounded_below_s": plan.bounded_below_s,
                "unit": parameter_unit(name, self.unit),
                **({"width_at_length": self.at_length[name]} if name in self.at_length else {}),
            }
            for name, plan in self.terms.items()
        }


def _crossing(lengths: np.ndarray, widths: np.ndarray, target: float) -> float | None:
    """The length where ``widths`` first falls to ``target`` (log-log interpolation), or
    None."""
    below = np.flatnonzero(widths <= target)
    if below.size == 0:
        return None
    first = int(below[0])
    if first == 0:
        return float(lengths[0])
    x = np.log(lengths[first - 1 : first + 1])
    y = np.log(widths[first - 1 : first + 1])
    return float(np.exp(np.interp(math.log(target), y[::-1], x[::-1])))


def _measured_width(fit: NoiseFit, name: str) -> float:
    summary = fit.parameters[name]
    median = float(np.median(np.ravel(fit.draws[name])))
    return (summary.q95 - summary.q05) / 2 / median if median > 0 else math.nan


def plan_recording(
    fit: NoiseFit,
    target: dict | None = None,
    *,
    confidence: float = 0.9,
    length_s: float | None = None,
    draws: int = 16,
    seed: int = 0,
) -> RecordingPlan:
    """The record length each noise parameter needs for a stated precision, predicted from a
    pilot record's posterior (module docstring).

    Parameters
    ----------
    fit : NoiseFit
        The pilot record's noise fit (:func:`~bayescal.fit_noise`); its terms are the model
        the plan predicts for.
    target : dict, optional
        Parameter -> the relative half-width wanted at ``confidence`` (``{"K": 0.2}``: K to
        +-20 %). Only noise scales (sampled in their logarithm: N, B, K, Q ...) take one.
    confidence : float
        Confidence of the intervals, in (0, 1).
    length_s : float, optional
        A length to predict the widths at ("what will 2 h give me?"), s.
    draws : int
        Posterior draws the prediction is the median over.
    seed : int
        Chooses the draws; the same inputs and seed give the same plan.

    Returns
    -------
    RecordingPlan
        Per parameter the length its target needs (or None with the reason), its predicted
        and measured widths now, and the curve of predicted width against length.

    Raises
    ------
    InputError
        A target for a parameter the fit does not hold, or one that is not a noise scale, or
        not a positive fraction; a confidence or length out of range.

    Examples
    --------
    >>> import bayescal as bc
    >>> y = bc.NoiseModel(rate_hz=10.0, N=0.005, K=1e-4).simulate(2**13, seed=1)
    >>> fit = bc.fit_noise(y, 10.0, terms="white,rrw", seed=1)
    >>> plan = bc.plan_recording(fit, {"K": 0.2})
    >>> plan.terms["K"].length_s > plan.duration_s  # K to +-20 % needs a longer record
    True
    """
    release_compiled_code()
    target = dict(target or {})
    if not 0 < confidence < 1:
        raise InputError(f"confidence={confidence!r} must lie in (0, 1)")
    if length_s is not None and not length_s > 0:
        raise InputError(f"length_s={length_s!r} must be a positive length in seconds")
    for name, value in target.items():
        if name not in fit.fit.problem.parameters:
            raise InputError(
                f"target: {name} is not a parameter of the fitted model ({', '.join(fit.terms)})",
                fix="fit the term first (terms=...), or leave it out of the target",
            )
        scales = [p for p in fit.fit.problem.parameters if PARAMETERS[p].link == "log"]
        if name not in scales:
            raise InputError(
                f"target: {name} is not a noise scale; a relative width applies to scales",
                fix=f"choose among {', '.join(scales)}",
            )
        if not (isinstance(value, (int, float)) and value > 0):
            raise InputError(f"target: {name}={value!r} must be a positive fraction (0.2: +-20 %)")
    duration = fit.classical.duration_s
    lengths = np.geomspace(duration / 4, LONGEST_S, GRID_POINTS)
    asked = [duration] + ([length_s] if length_s is not None else [])
    curve = predicted_widths(
        fit.fit, np.concatenate((asked, lengths)), confidence=confidence, draws=draws, seed=seed
    )
    extra = len(asked)
    grid = PredictedWidths(
        lengths,
        {n: w[extra:] for n, w in curve.widths.items()},
        {n: d[extra:] for n, d in curve.prior_dominated.items()},
        confidence,
    )
    terms = {}
    for name in (p for p in fit.fit.problem.parameters if PARAMETERS[p].link == "log"):
        widths, dominated = grid.widths[name], grid.prior_dominated[name]
        pinned = np.flatnonzero(~dominated)
        bounded_below = float(lengths[pinned[0]]) if pinned.size else math.inf
        wanted = target.get(name)
        length, reason = None, ""
        if wanted is not None:
            usable = np.where(dominated, np.inf, widths)
            length = _crossing(lengths, usable, wanted)
            if length is None and not pinned.size:
                reason = (
                    f"the record only bounds {name} at every length up to a year: its "
                    "interval stays as wide as the prior allows"
                )
            elif length is None:
                reason = (
                    f"{name} reaches +-{100 * widths[-1]:.0f} % at a year of recording, "
                    f"not +-{100 * wanted:.0f} %"
                )
            else:
                length = max(length, bounded_below)
        terms[name] = TermPlan(
            name,
            wanted,
            length,
            reason,
            float(curve.widths[name][0]),
            _measured_width(fit, name),
            0.0 if bounded_below <= lengths[0] else bounded_below,
        )
    at_length = (
        {name: float(curve.widths[name][1]) for name in terms} if length_s is not None else {}
    )
    return RecordingPlan(
        fit.channel, fit.unit, duration, confidence, terms, grid, at_length, length_s
    )
