"""The located alternative a catalogue name must beat (issue 33 item 2): the departure of the
level the level scan located (:func:`~bayescal.inference._scans.level_scan`), taken out as
it is — a drift that starts late, or a stretch — with no name and no physics.

A slow term of the catalogue (a random walk, bias instability, a Gauss-Markov term, a warm-up)
can absorb one located departure — the kink of a scale factor that changed under a slow input,
a stretch where something acted on the sensor — with decisive evidence against the model
without it, and then leave every check passing, because its predictive distribution allows
such a departure anywhere. Its name is then the nearest catalogue entry, not the physics:
the name must also beat the departure itself, located where the scan put it (paying the log
of the number of shapes the scan tried, as any searched parameter does): decisively, or, where
the evidence does not decide between them, by explaining it — with both in the model the
departure gains nothing decisive beside the term, and the term still improves the predictions
beside the departure (a walk's wandering is spread over the record; a kink is one event, and
beside it a term that absorbed the kink gains nothing: ``_discovery_search._named_against``). A
step has a catalogue name of its own (``bias_step``), and so have a drift from the record's
start (``rate_ramp``) and levels that switch (``random_telegraph``): none is an alternative.
The findings are then judged (withdrawn or kept) on the model with the located departure taken
out, which is reported unexplained.
"""

import math
from typing import ClassVar

import numpy as np

from ..models._composite import ModelFit
from ..models.effects._base import RegressionTerm
from ._checks import CHECK_LEVEL
from ._scans import level_scan

UNNAMED_SHAPES = ("drift", "stretch")
"""The level scan's shapes no catalogue effect is (a step is ``bias_step``)."""
SHAPE_EFFECTS = ("bias_step", "rate_ramp", "random_telegraph")
"""Catalogue effects that are themselves shapes of the level scan (a step; a drift from the
record's start; levels that switch): never held against a located departure."""


class LocatedDeparture(RegressionTerm):
    """A drift that starts at ``start_s`` (slope, the channel's unit per second) or a stretch
    from ``start_s`` to ``stop_s`` (its offset, the channel's unit), as the level scan located
    it: never named, only the alternative a slow catalogue term must beat decisively."""

    name: ClassVar[str] = "located_departure"
    explanation: ClassVar[str] = (
        "A departure of the level the level scan located in time, taken out as it is: not a "
        "catalogue effect."
    )
    located_by: ClassVar[str] = "level_scan"
    band: ClassVar[str] = "low"
    rank: ClassVar[int] = 2
    max_columns: ClassVar[int] = 1
    shape: str
    start_s: float
    stop_s: float
    places: int

    @property
    def searched(self) -> int:
        return 1

    def search_penalty(self, n_frequencies: int) -> float:
        """Located among the shapes the level scan tried: log of their number."""
        return math.log(self.places)

    def column_names(self, index):
        return [f"located_departure{index}"]

    def columns(self, data, time_s):
        if self.shape == "drift":
            return [np.maximum(time_s - self.start_s, 0.0)], [1.0], [f"{data.unit}/s"]
        inside = (time_s >= self.start_s) & (time_s < self.stop_s)
        return [inside.astype(float)], [1.0], [data.unit]


def located_alternative(search, current: ModelFit, candidate) -> ModelFit | None:
    """``current`` with the strongest departure its level scan locates, when that is a drift
    that starts late or a stretch (:data:`UNNAMED_SHAPES`), taken out as it is: what the
    slow catalogue effect ``candidate`` must beat (module docstring). None when the scan
    passes, its strongest departure is a step or a drift from the start, or ``candidate``
    is not a slow effect or is itself a shape of the scan (:data:`SHAPE_EFFECTS`)."""
    if candidate.band != "low" or candidate.name in SHAPE_EFFECTS:
        return None
    data = search.data
    scan = level_scan(current, data.rate_hz, data.unit)
    if scan["p_value"] >= CHECK_LEVEL or not scan["location"].get("events"):
        return None
    strongest = scan["location"]["events"][0]
    if strongest["kind"] not in UNNAMED_SHAPES:
        return None
    if strongest["kind"] == "drift" and strongest["time_s"] < 1.5 * scan["location"]["block_s"]:
        return None  # a drift from the record's start is the catalogue's ramp (rate_ramp)
    time_s = strongest["time_s"]
    start, stop = (time_s, math.inf) if strongest["kind"] == "drift" else time_s
    effect = LocatedDeparture(strongest["kind"], float(start), float(stop), scan["places"])
    return search.fit(current.spec.with_effect(effect))
