"""Priors of the noise parameters.

Weakly informative by default: each noise scale is log-normal with its median at the level the
classical Allan curve allows for that term (:func:`allan_reference_scales`) and a standard
deviation of ``PRIOR_LOG_SD`` in the logarithm (a factor 55); R is normal around zero with
``RAMP_PRIOR_FACTOR`` times the drift that would explain the whole Allan deviation at the
longest tau; the one-tap output filter's logit F is normal around F = 0.2 (sd 1.5); a
low-pass output filter's coordinates are normal (:data:`FILTER_PRIORS`: a decimation filter
of 3 samples and one stage, a Butterworth filter of order 2 at a quarter of the sample rate,
a biquad flat at the centre with its reflection coefficients free over (-1, 1), each within a
wide range); the bias is flat. Where a biquad's poles and zeros coincide the filter is flat
whatever they are: there the prior alone places them, and N is unaffected.

From a sensor card (:mod:`bayescal.recording._sensor_cards`), each datasheet figure becomes a
log-normal centred on it with a standard deviation of log 3 in the logarithm: datasheets quote
typical units, and a unit three times better or worse than typical is not surprising. Terms
the card says nothing of keep the weakly informative default.
"""

import math

import numpy as np

from .._errors import InputError
from ..classical._allan import DeviationResult
from ..models._noise_problem import PRIOR_LOG_SD, NoisePrior
from ..models._terms import term_parameters
from ..models.effects.output_filter import reflection_coordinate
from ..recording._sensor_cards import SensorCard

RAMP_PRIOR_FACTOR = 10.0
CARD_LOG_SD = math.log(3.0)
FILTER_PRIORS = {
    # log(M - 1): M = 3 samples, 95 % within 1.2 to 60 samples.
    "filter_length": (math.log(2.0), 1.5),
    # log p: one stage, 95 % within 0.14 to 7.
    "filter_stages": (0.0, 1.0),
    # logit(2 f_c / fs): a quarter of the sample rate, 95 % within fs / 100 and 0.49 fs.
    "filter_cutoff": (0.0, 2.0),
    # log(n - 1): second order, 95 % within 1.1 and 8.
    "filter_order": (0.0, 1.0),
    # logit kappa: between a filter at the output rate (1) and one far faster (0).
    "filter_warping": (0.0, 2.0),
    # A biquad's reflection coefficients (coordinates: atanh k, output_filter.reflection): a
    # flat section (k = 0) at the centre, 95 % within |k| < 0.994, near enough the radius
    # bound for a pair of poles or zeros on it.
    **dict.fromkeys(
        ("filter_pole_k1", "filter_pole_k2", "filter_zero_k1", "filter_zero_k2"),
        (reflection_coordinate(0.0), 1.5),
    ),
}
"""(location, sd) of the normal prior of each low-pass coordinate
(:func:`bayescal.models.effects.output_filter.lowpass_natural`)."""
FIXED_PRIORS = {"R": (0.0, 1.0), "F": (math.log(0.2 / 0.8), 1.5), **FILTER_PRIORS}
"""The coordinates whose prior does not scale with the Allan curve."""


def allan_reference_scales(allan: DeviationResult) -> dict[str, float]:
    """The level of each term the classical Allan curve allows (its upper bound, DESIGN.md
    table): the centres of the weakly informative priors."""
    usable = np.isfinite(allan.deviation)
    tau, sigma = allan.tau[usable], allan.deviation[usable]
    return {
        "Q": float(np.min(sigma * tau / math.sqrt(3.0))),
        "N": float(np.min(sigma * np.sqrt(tau))),
        "B": float(np.min(sigma) / math.sqrt(2 * math.log(2) / math.pi)),
        "K": float(np.min(sigma * np.sqrt(3.0 / tau))),
        "R": float(np.min(sigma * math.sqrt(2.0) / tau)),
    }


def default_prior(terms: tuple[str, ...], allan: DeviationResult) -> NoisePrior:
    scales = allan_reference_scales(allan)
    parameters = term_parameters(terms)
    location = [
        FIXED_PRIORS[p][0] if p in FIXED_PRIORS else math.log(scales[p]) for p in parameters
    ]
    scale = [FIXED_PRIORS[p][1] if p in FIXED_PRIORS else PRIOR_LOG_SD for p in parameters]
    return NoisePrior(
        np.array(location),
        np.array(scale),
        np.asarray(RAMP_PRIOR_FACTOR * scales["R"]),
        parameters,
        "weakly informative: log-normal noise scales, median at the Allan-curve "
        f"bound of each term, sd {PRIOR_LOG_SD:g} in the log; normal ramp around 0; "
        "logit of the one-tap output filter coefficient normal around F = 0.2 (sd 1.5); a "
        "low-pass filter's "
        "coordinates normal around 3 samples and one stage (decimation) or fs/4 and order 2 "
        "(Butterworth)",
    )


def card_prior(
    card: SensorCard, terms: tuple[str, ...], unit: str, allan, *, require: bool = True
) -> NoisePrior:
    """The default prior with the card's figures in place of the terms it gives; with
    ``require``, an :class:`InputError` when it gives none of them."""
    base = default_prior(terms, allan)
    try:
        values = card.datasheet_values(unit)
    except ValueError as error:
        raise InputError(f"--sensor {card.name}: {error}", source=str(card.path)) from None
    location, scale = np.array(base.location), np.array(base.scale)
    used = []
    for index, parameter in enumerate(base.parameters):
        if parameter in values:
            location[index] = math.log(values[parameter][0])
            scale[index] = CARD_LOG_SD
            used.append(parameter)
    if not used:
        if not require:
            return base
        raise InputError(
            f"--sensor {card.name}: the card gives none of the fitted terms "
            f"({', '.join(base.parameters)})"
        )
    description = (
        f"sensor card {card.name} ({card.datasheet}): log-normal on "
        f"{', '.join(used)} with median at the datasheet value and sd log 3; "
        f"other terms: {base.description}"
    )
    return NoisePrior(location, scale, base.ramp_scale, base.parameters, description)
