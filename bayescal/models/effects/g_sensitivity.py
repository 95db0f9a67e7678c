"""g-sensitivity: the gyro bias moves with the specific force on it."""

from typing import ClassVar

import numpy as np

from ._base import RegressionTerm, standardized, varies

MAX_COUNT = 3
"""The most accelerometer axes discovery adds to one model."""


class GSensitivity(RegressionTerm):
    """g * a(t) for an accelerometer channel a (``covariate``, by name): the residual follows
    that accelerometer. The coefficient is in (channel unit) / (accelerometer unit)."""

    name: ClassVar[str] = "g_sensitivity"
    explanation: ClassVar[str] = (
        "The gyro bias moves with the specific force: the residual follows an accelerometer "
        "channel."
    )
    located_by: ClassVar[str] = "residual_vs_accelerometer"
    band: ClassVar[str] = "low"
    rank: ClassVar[int] = 4
    max_columns: ClassVar[int] = MAX_COUNT
    covariate: str

    def column_names(self, index):
        return [f"g_{self.covariate}"]

    def columns(self, data, time_s):
        covariate = data.covariates[self.covariate]
        unit = f"{data.unit}/({data.covariate_units.get(self.covariate, '1')})"
        return [standardized(covariate)], [float(np.nanstd(covariate))], [unit]

    @classmethod
    def propose(cls, search, current):
        """Each accelerometer axis not yet in the model, the best by its score."""
        data, spec = search.data, current.spec
        unused = [name for name in data.covariates if not spec.has_instance(cls(name))]
        if not unused or spec.count(cls.name) >= MAX_COUNT:
            return None
        fits = [
            search.fit(spec.with_effect(cls(name)))
            for name in unused
            if varies(data.covariates[name])
        ]
        return (max(fits, key=lambda fit: fit.schwarz), {}) if fits else None

    def describe(self, finding, posterior, search) -> dict:
        name = f"g_{self.covariate}"
        return {name: search.summarize(posterior.draws[name], posterior.units[name])}

    def location(self, finding, checks: dict) -> dict:
        pointer = f"residual_vs_{self.covariate}"
        location = dict(checks[pointer]["location"]) if pointer in checks else {}
        location["check"] = pointer
        return location

    def simulate(self, specific_force: np.ndarray, sensitivity: float) -> np.ndarray:
        return sensitivity * (specific_force - np.mean(specific_force))
