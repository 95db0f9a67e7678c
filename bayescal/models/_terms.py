"""The registry of noise terms: every term of the stationary noise model, one class in one
file of :mod:`.effects`, registered once in :data:`NOISE_TERMS`. Everything else that speaks
of terms reads it: the names and aliases a user may give (``--terms``, ``terms=``), each
parameter's unit, whether datasheets quote it, its coordinate and prior, the classical
readings, the sensor cards' entries, the candidates of the term search, the model and its
likelihood.

Adding a term is its file and one line in :data:`NOISE_TERMS`.

The default, ``auto``, lets the record choose its terms by evidence
(:func:`bayescal.inference.select_noise_terms`): white noise always, and each of
:data:`CANDIDATE_TERMS` when the record holds decisive evidence for it.
"""

from typing import Literal

from .._errors import InputError
from ..recording._units import datasheet_values
from .effects._base import NoiseTerm
from .effects._parameter import Parameter
from .effects.bias_instability import BiasInstability
from .effects.biquad_filter import BiquadFilter
from .effects.butterworth_filter import ButterworthFilter
from .effects.decimation_filter import DecimationFilter
from .effects.gauss_markov import GaussMarkov
from .effects.output_filter import OutputFilter
from .effects.quantization import Quantization
from .effects.rate_ramp import RateRamp
from .effects.rate_random_walk import RateRandomWalk
from .effects.spectral_lines import SpectralLines
from .effects.white import White

NOISE_TERMS: tuple[type[NoiseTerm], ...] = (
    Quantization,
    White,
    OutputFilter,
    DecimationFilter,
    ButterworthFilter,
    BiquadFilter,
    BiasInstability,
    RateRandomWalk,
    RateRamp,
    GaussMarkov,
    SpectralLines,
)
"""Every noise term, in the canonical order (by the slope of its Allan deviation, as IEEE Std
952's table: -1, -1/2 and the output filter's shapes, 0, +1/2, +1, then the bump and the
lines)."""

TERMS = {term.name: term for term in NOISE_TERMS}
"""Every noise term by its name."""
ALL_TERMS = tuple(TERMS)
"""Every noise term's name, in the canonical order."""
TERM_ALIASES = {alias: term.name for term in NOISE_TERMS for alias in (term.name, *term.aliases)}
"""Every name a user may give a term (lower case) -> the term's name."""
PARAMETERS = {p.name: p for term in NOISE_TERMS for p in term.parameters}
"""Every noise parameter by its name."""
PARAMETERS_OF_TERM = {term.name: tuple(p.name for p in term.parameters) for term in NOISE_TERMS}
TERM_OF_PARAMETER = {
    parameter: term for term, parameters in PARAMETERS_OF_TERM.items() for parameter in parameters
}
FILTER_SHAPE_OF_TERM = {
    term.name: term.filter_shape for term in NOISE_TERMS if term.filter_shape is not None
}
"""The output filter's terms, one per shape: a model holds at most one of them."""
CANDIDATE_TERMS = tuple(term.name for term in NOISE_TERMS if term.candidate)
"""The terms ``auto`` tries beside white noise (at most one output filter shape)."""
FOUND_TERMS = tuple(term.name for term in NOISE_TERMS if term.found_in_record)
"""The terms found in the record before the stochastic terms are fitted (their parameters
are estimated there, never sampled)."""
READINGS = {
    term.parameters[0].name: term.reading for term in NOISE_TERMS if term.reading is not None
}
"""Each term's classical reading off the Allan deviation, by parameter (IEEE Std 952 Annex C:
Q, N, B, K)."""
AUTO = "auto"
"""Choose the terms by evidence (the default)."""
DEFAULT_TERMS = AUTO
CLASSICAL_TERMS = ("white", "bias_instability", "rate_random_walk")
"""The three terms most datasheets quote (the default before ``auto``, and a fleet's)."""


def parse_terms(spec: str) -> tuple[str, ...] | Literal["auto"]:
    """Noise terms from ``--terms`` / ``terms=`` (comma-separated names or aliases, ``all`` for
    every term with the one-tap output filter, or ``auto``), in the canonical order; the bias
    is always part of the model.

    Raises
    ------
    InputError
        An unknown name (the message lists the names there are), or terms that make no model
        (:func:`check_terms`).
    """
    word = spec.strip().lower()
    if word == AUTO:
        return AUTO
    if word == "all":
        return tuple(t for t in ALL_TERMS if FILTER_SHAPE_OF_TERM.get(t, "one_tap") == "one_tap")
    terms = set()
    for word in spec.split(","):
        name = word.strip().lower()
        if not name or name == "bias":
            continue
        if name not in TERM_ALIASES:
            aliases = sorted({a for a in TERM_ALIASES if a not in TERMS})
            raise InputError(
                f"terms: unknown term '{word.strip()}'",
                fix=f"choose from {', '.join(ALL_TERMS)} (or {', '.join(aliases)}, all, auto)",
            )
        terms.add(TERM_ALIASES[name])
    return check_terms(tuple(t for t in ALL_TERMS if t in terms))


def check_terms(terms: tuple[str, ...]) -> tuple[str, ...]:
    """``terms`` (canonical names) in the canonical order, if they make a model.

    Raises
    ------
    InputError
        An unknown term, no stochastic term, a filter shape without white noise, or two
        filter shapes.
    """
    unknown = [t for t in terms if t not in TERMS]
    if unknown:
        raise InputError(f"terms: unknown term {unknown[0]!r}", fix=f"choose from {ALL_TERMS}")
    stochastic = [
        t
        for t in terms
        if TERMS[t].filter_shape is None
        and TERMS[t].mean_rate is None
        and not TERMS[t].found_in_record
    ]
    if not stochastic:
        raise InputError("terms: the model needs at least one noise term (e.g. white)")
    filters = [t for t in terms if t in FILTER_SHAPE_OF_TERM]
    if filters and "white" not in terms:
        raise InputError(f"terms: {filters[0]} shapes the white noise; add white")
    if len(filters) > 1:
        raise InputError(
            f"terms: one output filter shape at a time ({', '.join(filters)} given)",
            fix="keep one of them, or choose the terms by evidence (auto)",
        )
    return tuple(t for t in ALL_TERMS if t in terms)


def fleet_terms(terms) -> tuple[str, ...]:
    """The terms every recording of a fleet is fitted with: named ones, never ``auto``.

    A population of ln B across units needs B in every unit's model. Terms chosen by evidence
    record by record would put B in some models and hold it at zero in others (a record too
    short to resolve it is not a unit without it), so a fleet fits one set of terms
    everywhere: by default the classical three (white, bias instability, rate random walk),
    whose scales a record does not resolve keep a prior-wide posterior that the population
    divides out again (and a scale no recording resolves is left out of the population).
    Terms of the sensor's high frequencies (quantization, an output filter) may be added;
    they stay each recording's own.
    """
    terms = parse_terms(terms) if isinstance(terms, str) else check_terms(tuple(terms))
    if terms == AUTO:
        raise InputError(
            "terms: a fleet fits the same terms in every recording, and 'auto' would choose "
            "them recording by recording",
            fix="name the terms (default white,bias_instability,rate_random_walk), adding "
            "the high-frequency ones 'bayescal noise' chose (e.g. quantization, output_filter)",
        )
    return terms


def term_parameters(terms: tuple[str, ...]) -> tuple[str, ...]:
    """The sampled parameters of ``terms``, in order (a term found in the record has none:
    its parameters are estimated before the fit)."""
    return tuple(
        p for term in terms if not TERMS[term].found_in_record for p in PARAMETERS_OF_TERM[term]
    )


def parameter(name: str) -> Parameter:
    """The noise parameter ``name``.

    Raises
    ------
    ValueError
        An unknown parameter (the message lists those there are).
    """
    if name not in PARAMETERS:
        raise ValueError(
            f"unknown noise parameter {name!r}; expected bias or one of {tuple(PARAMETERS)}"
        )
    return PARAMETERS[name]


def parameter_unit(name: str, channel_unit: str) -> str:
    """Unit of a noise parameter (or of the bias) for a channel in ``channel_unit`` (IEEE Std
    952; ASCII, e.g. ``deg/s/sqrt(Hz)``).

    Raises
    ------
    ValueError
        An unknown parameter.
    """
    if name == "bias":
        return channel_unit
    return parameter(name).unit_for(channel_unit)


def display_values(name: str, value: float, channel_unit: str) -> dict[str, float]:
    """The value of noise parameter ``name`` (in :func:`parameter_unit`) in the units IMU
    datasheets use for a channel of that kind (deg/sqrt(h), deg/h, µg/sqrt(Hz) ...): each
    conventional unit -> the value; empty for a channel whose unit bayescal does not know."""
    if name not in PARAMETERS or not PARAMETERS[name].datasheet:
        return {}
    return datasheet_values(value, channel_unit, PARAMETERS[name].time_power)


BOUNDING_FRACTION = 3.0
"""A bias term's bounding random walk matches its Allan variance at the horizon over this."""


def bias_terms(terms) -> tuple[str, ...]:
    """The terms among ``terms`` that move the bias without being a random walk a navigation
    filter models: those with long memory (bias instability, Gauss-Markov) and the ramp."""
    return tuple(t for t in terms if TERMS[t].long_memory or TERMS[t].mean_rate is not None)


def bounding_walk_variance(term: str, values: dict, horizon_s: float, rate_hz: float) -> float:
    """The power spectral density q^2 of the random walk that stands for bias term ``term``
    over ``horizon_s`` seconds: the walk whose Allan variance, q^2 tau / 3, equals the term's
    at tau = horizon / :data:`BOUNDING_FRACTION`, so q^2 = 9 sigma_A^2(H / 3) / H (unit^2/s
    for a channel in unit; for flicker, 9 (2 ln 2 / pi) B^2 / H, IEEE Std 952 eq. C.9). Below
    that tau the walk holds less than the term, beyond it more; a third of the horizon is
    where a filter's estimate of the bias over the horizon is most sensitive to it (the fine
    alignment's 20-minute coverage, benchmarks/infield_alignment.py, and the filter
    consistency benchmark, benchmarks/filter_consistency.py)."""
    tau = horizon_s / BOUNDING_FRACTION
    variance = float(TERMS[term].allan_variance(tau, values, rate_hz))
    return 3.0 * variance / tau


def card_values(card, channel_unit: str) -> dict[str, tuple[float, str]]:
    """The noise parameters a sensor card gives for a channel in ``channel_unit`` (its
    section for that kind of sensor, :meth:`~bayescal.SensorCard.section`), each in its unit
    with where in the datasheet it comes from.

    Raises
    ------
    InputError
        The channel's unit is no angular rate or acceleration, the card has no section for
        it, or an entry's unit is of another dimension than its parameter's.
    """
    section = card.section(channel_unit)
    values = {}
    for term in NOISE_TERMS:
        try:
            values |= term.card_values(section, channel_unit)
        except ValueError as error:
            raise InputError(f"sensor card {card.name}: {error}", source=str(card.path)) from None
    return values


def reference_scales(allan) -> dict[str, float]:
    """The level of each noise parameter the classical Allan curve allows (its upper bound,
    DESIGN.md table): the centres of the weakly informative priors, and the ramp's scale."""
    return {k: v for term in NOISE_TERMS for k, v in term.reference_scales(allan).items()}


def find_in_record(terms, values, rate_hz: float, transform=None) -> dict:
    """What each term of ``terms`` found in the record before the fit (the terms
    :attr:`~bayescal.models.effects._base.NoiseTerm.found_in_record`: spectral lines), by
    name: each an object with ``found``, ``removed``, ``excluded_bands_hz``, ``verdict`` and
    ``log_bayes_factor``. ``transform``: the tapered transform of the record's longest run
    without a gap, where already taken
    (:func:`~bayescal.classical._periodogram.longest_run_transform`)."""
    return {
        term.name: term.find(values, rate_hz, transform=transform)
        for term in NOISE_TERMS
        if term.found_in_record and term.name in terms
    }


def without_found(found: dict, values):
    """``values`` less what the terms found in them (:func:`find_in_record`): what the
    stochastic terms are fitted to. ``values`` itself when nothing was found."""
    for finding in found.values():
        if finding.found:
            values = finding.removed(values)
    return values


def excluded_bands(found: dict) -> tuple[tuple[float, float], ...]:
    """The bands, Hz, the stochastic fit leaves out for what the terms found."""
    return tuple(band for finding in found.values() for band in finding.excluded_bands_hz)


def left_in(found: dict) -> dict:
    """What the terms found in the record leave in it (a broadened line), as a noise model's
    parameters: the checks of a model fitted to the record less them add it."""
    values = {}
    for finding in found.values():
        values |= finding.left_in
    return values
