"""The plan of ``bayescal plan`` (:class:`~bayescal.capabilities._plan.RecordingPlan`): its
JSON document, its printed table, and the figure of predicted width against record length."""

import math
from importlib.metadata import version

from ..capabilities._plan import RecordingPlan


def _duration(seconds: float | None) -> str:
    """A length in the unit that reads best (s, min, h, days)."""
    if seconds is None or not math.isfinite(seconds):
        return "-"
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= 2 * size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


def plan_document(plan: RecordingPlan, source: str) -> dict:
    """The JSON document: per parameter ``length_s`` (or null and the reason), the predicted
    relative half-width at the pilot's length ``width_now`` (and the pilot posterior's own,
    ``width_measured``), and the curve of predicted width against length."""
    return {
        "bayescal_version": version("bayescal"),
        "source": source,
        "channel": plan.channel,
        "unit": plan.unit,
        "duration_s": plan.duration_s,
        "confidence": plan.confidence,
        "width_definition": "relative half-width of the interval at the confidence: "
        "(upper - lower) / 2 over the median (0.2: +-20 %)",
        "terms": plan.summary,
        "length_asked_s": plan.length_asked_s,
        "curve": {
            "length_s": plan.curve.lengths_s.tolist(),
            "width": {name: plan.curve.widths[name].tolist() for name in plan.terms},
            "bounded": {name: plan.curve.prior_dominated[name].tolist() for name in plan.terms},
        },
    }


def plan_text(plan: RecordingPlan, source: str) -> str:
    """The printed table: per parameter its width now (predicted and measured), its target
    and the length that reaches it."""
    lines = [
        f"bayescal plan: {source}, channel {plan.channel} [{plan.unit}], a pilot of "
        f"{_duration(plan.duration_s)}; {100 * plan.confidence:g} % intervals, their "
        "relative half-widths",
        f"  {'':4}{'now (pred.)':>12}{'now (fit)':>11}{'target':>9}   length needed",
    ]
    for name, term in plan.terms.items():
        target = f"+-{100 * term.target:.3g} %" if term.target is not None else "-"
        needed = _duration(term.length_s) if term.length_s is not None else term.reason or "-"
        if term.length_s is not None and term.length_s <= plan.duration_s:
            needed += " (the pilot's length is enough)"
        lines.append(
            f"  {name:<4}{_percent(term.width_now):>12}{_percent(term.width_measured):>11}"
            f"{target:>9}   {needed}"
        )
        if term.bounded_below_s > 0:
            lines.append(
                f"        bounded, not pinned, below {_duration(term.bounded_below_s)} of record"
            )
    if plan.length_asked_s is not None:
        shown = ", ".join(f"{name} {_percent(w)}" for name, w in plan.at_length.items())
        lines.append(f"  after {_duration(plan.length_asked_s)}: {shown}")
    return "\n".join(lines)


def _percent(width: float) -> str:
    if not math.isfinite(width):
        return "-"
    return f"+-{100 * width:.3g} %" if width < 10 else f"x{math.exp(math.asinh(width)):.3g}"


def plan_figure(plan: RecordingPlan, path) -> None:
    """The predicted relative half-width of each parameter against the record's length (a
    PNG at ``path``), the pilot's length and each target marked."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(7, 4.2))
    axes = figure.subplots()
    for name, term in plan.terms.items():
        widths = plan.curve.widths[name]
        (line,) = axes.loglog(plan.curve.lengths_s / 3600.0, widths, label=name)
        if term.target is not None:
            axes.axhline(term.target, color=line.get_color(), ls=":", lw=1)
    axes.axvline(plan.duration_s / 3600.0, color="0.5", lw=1, label="pilot record")
    axes.set(
        xlabel="record length [h]",
        ylabel=f"relative half-width of the {100 * plan.confidence:g} % interval",
        title=f"{plan.channel}: what a longer record gives",
    )
    axes.legend(fontsize=8)
    figure.savefig(path, format="png", dpi=110, bbox_inches="tight")
