"""Thermal bias of a gyro, classically: bin the record by temperature, take each bin's mean
with its Student-t interval, and fit a polynomial through the bin means by weighted least
squares. It treats the samples as independent, which a random walk or flicker makes them not:
the Bayesian calibration (:mod:`bayescal.capabilities._thermal`) says by how much that
matters.
"""

import math

import numpy as np
from scipy import stats

from .._errors import InputError


def classical_thermal(
    values, temperature, degree: int, reference: float, confidence: float
) -> dict:
    """Bin by temperature, mean per bin with its Student-t interval, then a weighted
    least-squares polynomial through the bin means with its covariance."""
    present = ~np.isnan(values) & ~np.isnan(temperature)
    values, temperature = values[present], temperature[present]
    span = np.ptp(temperature)
    # Bins of 0.25 degrees, at most 20, and no more than the samples fill three at a time.
    count = int(max(1, min(20, max(degree + 2, round(span / 0.25)), values.size // 3)))
    edges = np.linspace(temperature.min(), temperature.max(), count + 1)
    index = np.clip(np.digitize(temperature, edges) - 1, 0, count - 1)
    bins = []
    for b in range(count):
        member = values[index == b]
        if member.size < 3:
            continue
        half = (
            stats.t.ppf(0.5 + confidence / 2, member.size - 1)
            * member.std(ddof=1)
            / math.sqrt(member.size)
        )
        bins.append(
            (
                float(temperature[index == b].mean()),
                float(member.mean()),
                float(half),
                int(member.size),
            )
        )
    bins = np.array(bins)
    if bins.shape[0] < degree + 1:
        raise InputError(
            f"{values.size} samples fill {bins.shape[0]} temperature bin(s) of 3 samples or "
            f"more, too few for degree {degree}",
            fix="lower degree=" if degree > 0 else "record more samples",
        )
    z = stats.norm.ppf(0.5 + confidence / 2)
    weight = 1 / (bins[:, 2] / z) ** 2
    design = (bins[:, 0:1] - reference) ** np.arange(degree + 1)
    covariance = np.linalg.inv(design.T @ (weight[:, None] * design))
    coefficients = covariance @ design.T @ (weight * bins[:, 1])
    return {
        "bins": [
            {"temperature": t, "mean": m, "half_width": h, "n_samples": n} for t, m, h, n in bins
        ],
        "coefficients": coefficients,
        "covariance": covariance,
        "confidence": confidence,
        "method": "bin means (independent samples) and weighted least squares",
    }
