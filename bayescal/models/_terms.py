"""The noise terms a user names (``--terms``, ``terms=``): canonical names, aliases, the
default and the full set. No JAX here: the command line checks a user's terms before it loads
anything heavy.

The default, ``auto``, lets the record choose its terms by evidence
(:func:`bayescal.inference.select_noise_terms`): white noise always, and each of
:data:`CANDIDATE_TERMS` when the record holds decisive evidence for it.
"""

from typing import Literal

from .._errors import InputError

LOWPASS_PARAMETERS = {
    "decimation": ("filter_length", "filter_stages"),
    "butterworth": ("filter_cutoff", "filter_order", "filter_warping"),
    "biquad": ("filter_pole_k1", "filter_pole_k2", "filter_zero_k1", "filter_zero_k2"),
}
"""The low-pass output filter's shapes and their parameters (:mod:`.effects.output_filter`)."""
FILTER_SHAPE_OF_TERM = {
    "output_filter": "one_tap",
    "decimation_filter": "decimation",
    "butterworth_filter": "butterworth",
    "biquad_filter": "biquad",
}
"""The output filter's terms, one per shape: a model holds at most one of them."""
PARAMETERS_OF_TERM = {
    "quantization": ("Q",),
    "white": ("N",),
    "output_filter": ("F",),
    "decimation_filter": LOWPASS_PARAMETERS["decimation"],
    "butterworth_filter": LOWPASS_PARAMETERS["butterworth"],
    "biquad_filter": LOWPASS_PARAMETERS["biquad"],
    "bias_instability": ("B",),
    "rate_random_walk": ("K",),
    "rate_ramp": ("R",),
}
TERM_OF_PARAMETER = {
    parameter: term for term, parameters in PARAMETERS_OF_TERM.items() for parameter in parameters
}
TERM_ALIASES = {
    "white": "white",
    "n": "white",
    "arw": "white",
    "vrw": "white",
    "bias_instability": "bias_instability",
    "flicker": "bias_instability",
    "b": "bias_instability",
    "rate_random_walk": "rate_random_walk",
    "rrw": "rate_random_walk",
    "k": "rate_random_walk",
    "quantization": "quantization",
    "q": "quantization",
    "white_angle": "quantization",
    "rate_ramp": "rate_ramp",
    "ramp": "rate_ramp",
    "r": "rate_ramp",
    "output_filter": "output_filter",
    "one_tap": "output_filter",
    "filter": "output_filter",
    "f": "output_filter",
    "decimation_filter": "decimation_filter",
    "decimation": "decimation_filter",
    "cic": "decimation_filter",
    "butterworth_filter": "butterworth_filter",
    "butterworth": "butterworth_filter",
    "lowpass": "butterworth_filter",
    "biquad_filter": "biquad_filter",
    "biquad": "biquad_filter",
    "second_order_section": "biquad_filter",
    "sos": "biquad_filter",
}
AUTO = "auto"
"""Choose the terms by evidence (the default)."""
DEFAULT_TERMS = AUTO
CLASSICAL_TERMS = ("white", "bias_instability", "rate_random_walk")
"""The three terms most datasheets quote (the default before ``auto``)."""
ALL_TERMS = (
    "quantization",
    "white",
    "output_filter",
    "decimation_filter",
    "butterworth_filter",
    "biquad_filter",
    "bias_instability",
    "rate_random_walk",
    "rate_ramp",
)
"""Every noise term, in the canonical order."""
CANDIDATE_TERMS = (
    "bias_instability",
    "rate_random_walk",
    "rate_ramp",
    "quantization",
    "output_filter",
    "decimation_filter",
    "butterworth_filter",
    "biquad_filter",
)
"""The terms ``auto`` tries beside white noise (at most one output filter shape)."""


def parse_terms(spec: str) -> tuple[str, ...] | Literal["auto"]:
    """Noise terms from ``--terms`` (comma-separated names or aliases, ``all`` for every term
    with the one-tap output filter, or ``auto``), in the canonical order; the bias is always
    part of the model."""
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
            raise InputError(
                f"--terms: unknown term '{word.strip()}'",
                fix="choose from white, bias_instability, rate_random_walk, quantization, "
                "rate_ramp, output_filter, decimation_filter, butterworth_filter, biquad_filter "
                "(or rrw, flicker, ramp, all, auto)",
            )
        terms.add(TERM_ALIASES[name])
    return check_terms(tuple(t for t in ALL_TERMS if t in terms))


def check_terms(terms: tuple[str, ...]) -> tuple[str, ...]:
    """``terms`` (canonical names) if they make a model, else :class:`InputError`."""
    unknown = [t for t in terms if t not in PARAMETERS_OF_TERM]
    if unknown:
        raise InputError(f"terms: unknown term {unknown[0]!r}", fix="see parse_terms")
    if not set(terms) & {"white", "bias_instability", "rate_random_walk", "quantization"}:
        raise InputError("--terms: the model needs at least one noise term (e.g. white)")
    filters = [t for t in terms if t in FILTER_SHAPE_OF_TERM]
    if filters and "white" not in terms:
        raise InputError(f"--terms: {filters[0]} shapes the white noise; add white")
    if len(filters) > 1:
        raise InputError(
            f"--terms: one output filter shape at a time ({', '.join(filters)} given)",
            fix="keep one of them, or use --terms auto to let the record choose",
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
    """The parameters of ``terms``, in order."""
    return tuple(p for term in terms for p in PARAMETERS_OF_TERM[term])


BASELINE_TERMS = (
    "white",
    "output_filter",
    "bias_instability",
    "rate_random_walk",
    "quantization",
    "gauss_markov",
    "rate_ramp",
)
"""The noise terms a discovery baseline may hold (the noise terms of the effect catalogue)."""
