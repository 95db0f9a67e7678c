"""Priors of the noise parameters.

Weakly informative by default: each noise scale (a parameter sampled in the log without a
prior of its own) is log-normal with its median at the level the classical Allan curve allows
for that term (:func:`~bayescal.models._terms.reference_scales`) and a standard deviation of
``PRIOR_LOG_SD`` in the logarithm (a factor 55); every other parameter takes the normal prior
its term gives its coordinate (:class:`~bayescal.models.effects._parameter.Parameter`): the
ramp normal around zero with ten times the drift that would explain the whole Allan deviation
at the longest tau, the one-tap output filter's logit F normal around F = 0.2 (sd 1.5), a
low-pass shape's coordinates within a wide range around a typical filter, a Gauss-Markov
correlation time near flat in its logarithm over the record; the bias is flat. Where a
biquad's poles and zeros coincide the filter is flat whatever they are: there the prior alone
places them, and N is unaffected.

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
from ..models._terms import PARAMETERS, card_values, reference_scales, term_parameters
from ..recording._sensor_cards import SensorCard

CARD_LOG_SD = math.log(3.0)


def default_prior(terms: tuple[str, ...], allan: DeviationResult) -> NoisePrior:
    """The weakly informative prior of a model of ``terms`` (module docstring), centred by
    the Allan deviation ``allan`` of the record.

    Parameters
    ----------
    terms : tuple of str
        The model's terms.
    allan : DeviationResult
        The record's Allan deviation.

    Returns
    -------
    NoisePrior
        The prior of every parameter of ``terms``.
    """
    scales = reference_scales(allan)
    parameters = term_parameters(terms)
    location, scale = [], []
    for name in parameters:
        fixed = PARAMETERS[name].prior
        location.append(fixed[0] if fixed else math.log(scales[name]))
        scale.append(fixed[1] if fixed else PRIOR_LOG_SD)
    return NoisePrior(
        np.array(location),
        np.array(scale),
        np.asarray(scales["R"]),
        parameters,
        "weakly informative: log-normal noise scales, median at the Allan-curve "
        f"bound of each term, sd {PRIOR_LOG_SD:g} in the log; normal ramp around 0; "
        "logit of the one-tap output filter coefficient normal around F = 0.2 (sd 1.5); a "
        "low-pass filter's coordinates normal around 3 samples and one stage (decimation), "
        "fs/4 and order 2 (Butterworth) or a flat biquad; a Gauss-Markov correlation time "
        "near flat in its log over the record",
    )


def card_prior(
    card: SensorCard, terms: tuple[str, ...], unit: str, allan, *, require: bool = True
) -> NoisePrior:
    """The default prior with the card's figures in place of the terms it gives; with
    ``require``, an :class:`InputError` when it gives none of them."""
    base = default_prior(terms, allan)
    values = card_values(card, unit)
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
    return NoisePrior(location, scale, base.linear_scale, base.parameters, description)
