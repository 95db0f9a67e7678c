"""Is one unit within its datasheet? P(N < limit), P(B < limit), P(K < limit) (and P(|bias| <
limit)) from one unit's noise posterior, with the datasheet's density convention stated, beside
the fleet's fraction in spec when a fleet was fitted against the same limits.

Limits are parsed as a fleet's are (:mod:`._fleet_spec`: ``"N<0.3 deg/sqrt(h)"``, a mapping,
or a sensor card's figures). Densities: bayescal's N is IEEE Std 952's (the two-sided PSD of the
rate's white noise is N^2; a sample averaged over 1/f has variance N^2 f). A datasheet whose
"noise density" is the root of a one-sided PSD G = 2 N^2 quotes sqrt(2) N: with
``psd="one_sided"`` the limit on N is the datasheet's value over sqrt(2). Random-walk figures
(deg/sqrt(h)) are N itself in either convention (their definition is the angle's growth).
"""

import math
from dataclasses import dataclass

import numpy as np

from .._errors import InputError
from ._fleet_spec import assessed_limits, requested_limits
from ._noise import NoiseFit

PSD_CONVENTIONS = ("two_sided", "one_sided")
"""How a datasheet's noise density relates to N: equal (IEEE Std 952), or sqrt(2) N."""


@dataclass(frozen=True)
class SpecCheck:
    """One unit against its limits (:func:`within_spec`)."""

    channel: str
    """The unit's channel."""
    psd: str
    """The datasheet's density convention the limits on N were read in."""
    limits: tuple
    """Each limit: {parameter, label, limit, unit, probability, convention, fleet}."""
    notes: tuple[str, ...] = ()
    """Limits that could not be assessed, and why."""

    @property
    def summary(self) -> dict:
        """label -> {parameter, limit, unit, probability, convention, fleet}."""
        return {entry["label"]: dict(entry) for entry in self.limits}


def _density_limit(limit, psd: str, density_unit: str) -> tuple[float, str]:
    """The limit on N in bayescal's convention, and what was done."""
    if limit.parameter != "N":
        return limit.value, ""
    if psd == "one_sided" and "sqrt(Hz)" in density_unit.replace("√Hz", "sqrt(Hz)"):
        return limit.value / math.sqrt(2), (
            "the datasheet's density is the root of a one-sided PSD: N < limit / sqrt(2)"
        )
    return limit.value, "the datasheet's density is N (IEEE Std 952, two-sided PSD N^2)"


def within_spec(fit: NoiseFit, spec, *, psd: str = "two_sided", fleet=None) -> SpecCheck:
    """The probability that one unit meets each limit of ``spec``, from its noise posterior.

    Parameters
    ----------
    fit : NoiseFit
        The unit's noise fit (:func:`~bayescal.fit_noise`).
    spec : str, SensorCard, mapping or sequence
        Limits as :func:`~bayescal.fit_fleet` takes them (``"N<0.3 deg/sqrt(h)"``, a sensor
        card's name for its datasheet figures ...).
    psd : str
        The datasheet's density convention: ``"two_sided"`` (its noise density is N, IEEE Std
        952) or ``"one_sided"`` (the root of a one-sided PSD, sqrt(2) N).
    fleet : FleetFit, optional
        A fleet fitted against the same limits: its probability that a unit drawn from the
        population meets each, and the mean of its units', beside this unit's.

    Returns
    -------
    SpecCheck
        Per limit the posterior probability P(parameter < limit), the convention used, and
        the fleet's figures where given.

    Raises
    ------
    InputError
        A limit that cannot be read, a parameter the fit does not hold, an unknown ``psd``.

    Examples
    --------
    >>> import bayescal as bc
    >>> y = bc.NoiseModel(rate_hz=100.0, N=0.0035, K=4e-5).simulate(2**14, seed=3)
    >>> fit = bc.fit_noise(y, 100.0, terms="white,rrw", unit="deg/s")
    >>> check = bc.within_spec(fit, "N<0.3 deg/sqrt(h)")
    >>> check.summary["N < 0.3 deg/sqrt(h)"]["probability"] > 0.99  # N = 0.21 deg/sqrt(h)
    True
    """
    if psd not in PSD_CONVENTIONS:
        raise InputError(f"psd={psd!r}", fix=f"choose one of {', '.join(PSD_CONVENTIONS)}")
    requested, card = requested_limits(spec)
    parameters = [p for p in fit.draws if p != "bias"]
    limits, notes = assessed_limits(requested, card, fit.unit, parameters)
    fleet_spec = {}
    if fleet is not None:
        summary = fleet.summary.get("spec") or {}
        fleet_spec = {entry["label"]: entry for entry in summary.get("limits", [])}
    entries = []
    for limit in limits:
        value, convention = _density_limit(limit, psd, limit.unit)
        draws = np.ravel(fit.draws[limit.parameter])
        meets = np.abs(draws) <= value if limit.parameter == "bias" else draws <= value
        matched = fleet_spec.get(limit.label)
        entries.append(
            {
                "parameter": limit.parameter,
                "label": limit.label,
                "limit": limit.value,
                "limit_used": value,
                "unit": limit.unit,
                "source": limit.source,
                "probability": float(np.mean(meets)),
                "convention": convention,
                "fleet": None
                if matched is None
                else {
                    "next_unit": matched["next_unit"],
                    "units_mean": float(np.mean(list(matched["units"].values())))
                    if matched["units"]
                    else None,
                },
            }
        )
    if fleet is not None and not fleet_spec:
        notes.append("the fleet was fitted without these limits: no fleet figures")
    return SpecCheck(fit.channel, psd, tuple(entries), tuple(notes))
