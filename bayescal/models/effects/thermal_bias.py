"""Thermal bias: the bias depends on the temperature, as a polynomial."""

from typing import ClassVar

import numpy as np

from ._base import RegressionTerm, varies

MAX_DEGREE = 3
"""The highest degree discovery tries (the thermal calibration goes to 4)."""


class ThermalBias(RegressionTerm):
    """bias(T) = sum_{k=1..d} c_k (T - T0)^k beside the constant bias, T0 the record's mean
    temperature: the residual follows the temperature column, not time. The columns are the
    powers of the standardized temperature (``degree`` of them); coefficients come back in
    unit / (temperature unit)^k."""

    name: ClassVar[str] = "thermal_bias"
    explanation: ClassVar[str] = (
        "The bias depends on the temperature: the residual follows the temperature column, "
        "not time."
    )
    located_by: ClassVar[str] = "residual_vs_temperature"
    band: ClassVar[str] = "low"
    rank: ClassVar[int] = 1
    max_columns: ClassVar[int] = MAX_DEGREE
    degree: int = 1

    def column_names(self, index):
        return [f"c{power}" for power in range(1, self.degree + 1)]

    def columns(self, data, time_s):
        centred = data.temperature - np.nanmean(data.temperature)
        spread = float(np.nanstd(centred))
        powers = range(1, self.degree + 1)
        columns = [(centred / spread) ** power for power in powers]
        scales = [spread**power for power in powers]
        units = [
            f"{data.unit}/{data.temperature_unit}" + (f"^{power}" if power > 1 else "")
            for power in powers
        ]
        return columns, scales, units

    @classmethod
    def propose(cls, search, current):
        """Degrees 1 to MAX_DEGREE, the best by its score."""
        data = search.data
        if data.temperature is None or current.spec.has(cls.name) or not varies(data.temperature):
            return None
        fits = [
            search.fit(current.spec.with_effect(cls(degree))) for degree in range(1, MAX_DEGREE + 1)
        ]
        best = max(fits, key=lambda fit: fit.schwarz)
        return best, {"degree_scores": [fit.schwarz for fit in fits]}

    def describe(self, finding, posterior, search) -> dict:
        out = {
            name: search.summarize(posterior.draws[name], posterior.units[name])
            for name in (f"c{k}" for k in range(1, self.degree + 1))
        }
        data = search.data
        out["T0"] = {"mean": float(np.nanmean(data.temperature)), "unit": data.temperature_unit}
        return out

    def simulate(self, temperature: np.ndarray, c1: float) -> np.ndarray:
        """A linear thermal bias c1 (T - mean T) (degree one, as the benchmarks conceal)."""
        return c1 * (temperature - temperature.mean())
