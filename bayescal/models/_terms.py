"""The noise terms a user names (``--terms``, ``terms=``): canonical names, aliases, the
default and the full set. No JAX here: the command line checks a user's terms before it loads
anything heavy."""

from .._errors import InputError

PARAMETER_OF_TERM = {
    "output_filter": "F",
    "quantization": "Q",
    "white": "N",
    "bias_instability": "B",
    "rate_random_walk": "K",
    "rate_ramp": "R",
}
TERM_OF_PARAMETER = {parameter: term for term, parameter in PARAMETER_OF_TERM.items()}
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
    "rate_ramp": "rate_ramp",
    "ramp": "rate_ramp",
    "r": "rate_ramp",
    "output_filter": "output_filter",
    "filter": "output_filter",
    "f": "output_filter",
}
DEFAULT_TERMS = ("white", "bias_instability", "rate_random_walk")
ALL_TERMS = (
    "quantization",
    "white",
    "output_filter",
    "bias_instability",
    "rate_random_walk",
    "rate_ramp",
)


def parse_terms(spec: str) -> tuple[str, ...]:
    """Noise terms from ``--terms`` (comma-separated names or aliases, or ``all``), in the
    canonical order; the bias is always part of the model."""
    if spec.strip().lower() == "all":
        return ALL_TERMS
    terms = set()
    for word in spec.split(","):
        name = word.strip().lower()
        if not name or name == "bias":
            continue
        if name not in TERM_ALIASES:
            raise InputError(
                f"--terms: unknown term '{word.strip()}'",
                fix="choose from white, bias_instability, rate_random_walk, "
                "quantization, rate_ramp (or rrw, flicker, ramp, all)",
            )
        terms.add(TERM_ALIASES[name])
    if not terms & {"white", "bias_instability", "rate_random_walk", "quantization"}:
        raise InputError("--terms: the model needs at least one noise term (e.g. white)")
    if "output_filter" in terms and "white" not in terms:
        raise InputError("--terms: output_filter shapes the white noise; add white")
    return tuple(term for term in ALL_TERMS if term in terms)


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
