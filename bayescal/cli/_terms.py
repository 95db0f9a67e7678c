"""``bayescal terms``: the noise terms a model may hold (the registry,
:data:`bayescal.models._terms.NOISE_TERMS`), with the names ``--terms`` takes and each
parameter's unit for a channel."""


def add_parser(commands) -> None:
    parser = commands.add_parser(
        "terms", help="list the noise terms (the names --terms takes) and their parameters"
    )
    parser.add_argument(
        "--unit", default="deg/s", help="the channel's unit the parameters' units derive from"
    )
    parser.set_defaults(run=run)


def run(args) -> int:
    from ..models._terms import NOISE_TERMS

    for term in NOISE_TERMS:
        names = ", ".join(term.aliases)
        auto = "" if term.candidate else "  (always in the model)"
        print(f"{term.name}{f' ({names})' if names else ''}{auto}")
        for parameter in term.parameters:
            print(
                f"    {parameter.name:<16} {parameter.unit_for(args.unit):<20} {parameter.meaning}"
            )
    return 0
