"""Saturation: samples clipped at a rail, the end of the sensor's output range.

A clipped channel piles samples up on one value — the largest (or smallest) it can output —
where an unclipped one would have spread them over the tail beyond it. The model for this is
the censored (Tobit) normal: a sample below the rail has the normal's probability, a sample
at the rail the whole tail beyond it. It is compared with the unclipped normal on the
probability of each sample's resolution bin (the file's least step between values), so that a
pile of identical values counts for what it is: with fine resolution two samples can share the
extreme value only by clipping; with a coarse converter step the top level holds a few samples
anyway, and the two models nearly agree there.

The rail is not known beforehand: its prior is uniform over as many levels above the
record's extreme as the record spans. A rail above the extreme clips nothing and explains the
data as the normal does, so the Bayes factor is the likelihood ratio at the extreme divided by
that number of levels (the log of which each rail pays).

The censored normal describes the samples around one level, as in a static record: a rail
reached only during a drift excursion is imputed from the record's level, not the local one.
"""

import math
from typing import ClassVar

import numpy as np
from scipy import optimize, special, stats

from ...recording._levels import END, Levels, log_bin
from ._base import Effect


def _rail_log_probability(side: str, rail, mean, sd, half_step):
    """log probability of the whole tail beyond the inner edge of the rail's bin."""
    if side == "upper":
        return special.log_ndtr((mean - rail + half_step) / sd)
    return special.log_ndtr((rail + half_step - mean) / sd)


def _pointwise(levels, mean, sd, half_step, rails) -> np.ndarray:
    """log probability of each level's bin under N(mean, sd), censored at ``rails``."""
    out = log_bin((levels - half_step - mean) / sd, 2 * half_step / sd)
    for side in rails:
        out[END[side]] = _rail_log_probability(side, levels[END[side]], mean, sd, half_step)
    return out


def _fit(record: Levels, rails) -> tuple[float, float, np.ndarray]:
    """Maximum-likelihood mean and sd of the normal censored at ``rails`` (sides), and the
    log probability of each level at them."""
    levels, counts, half_step = record.levels, record.counts, 0.5 * record.step
    inside = np.ones(levels.size, bool)
    inside[[END[side] for side in rails]] = False
    weights = counts * inside
    mean0 = np.average(levels, weights=weights)
    sd0 = math.sqrt(np.average((levels - mean0) ** 2, weights=weights))
    if 2 * half_step < 1e-3 * sd0:
        # Continuous data: the bins inside the rails are densities, summed through moments.
        total = weights.sum()
        centred = levels - mean0
        first, second = np.dot(weights, centred), np.dot(weights, centred**2)

        def inside_rails(mean, sd):
            shift = mean - mean0
            squares = second - 2 * shift * first + total * shift**2
            log_width = math.log(2 * half_step / sd) - 0.5 * math.log(2 * math.pi)
            return total * log_width - squares / (2 * sd**2)
    else:

        def inside_rails(mean, sd):
            return np.dot(weights, _pointwise(levels, mean, sd, half_step, ()))

    def objective(x):
        mean, sd = mean0 + x[0] * sd0, sd0 * math.exp(x[1])
        at_rails = sum(
            counts[END[side]] * _rail_log_probability(side, levels[END[side]], mean, sd, half_step)
            for side in rails
        )
        return -(inside_rails(mean, sd) + at_rails)

    found = optimize.minimize(
        objective, np.zeros(2), method="Nelder-Mead", options={"xatol": 1e-7, "fatol": 1e-7}
    )
    mean, sd = mean0 + found.x[0] * sd0, sd0 * math.exp(found.x[1])
    return float(mean), float(sd), _pointwise(levels, mean, sd, half_step, rails)


def saturation_scan(values: np.ndarray) -> dict | None:
    """Censored normal against normal on the samples' marginal distribution, with a rail on
    each side whose own log Bayes factor is positive (else the better side alone): the log
    Bayes factor (each rail paying the log of the number of levels it could have sat on),
    the ELPD gain (AIC: one parameter per rail) with its standard error, the rails, the
    unclipped mean and sd, and the resolution. ``None`` when no extreme within the noise is
    shared by two samples."""
    record = Levels(values)
    if not record.rails:
        return None
    rail_cost = math.log(np.ptp(record.levels) / record.step + 1)
    normal = _fit(record, ())[2]

    def log_bayes_factor(sides):
        return np.dot(record.counts, _fit(record, sides)[2] - normal) - len(sides) * rail_cost

    own = {side: log_bayes_factor((side,)) for side in record.rails}
    sides = tuple(side for side in own if own[side] > 0) or (max(own, key=own.get),)
    mean, sd, censored = _fit(record, sides)
    gain = np.dot(record.counts, censored - normal)
    difference = (censored - normal)[record.inverse]
    return {
        "log_bayes_factor": float(gain - len(sides) * rail_cost),
        "delta_elpd": float(gain - len(sides)),
        "delta_elpd_se": float(math.sqrt(record.n) * np.std(difference)),
        "rails": {
            side: {"value": record.rails[side][0], "samples": record.rails[side][1]}
            for side in sides
        },
        "mean": mean,
        "sd": sd,
        "step": record.step,
    }


def impute_clipped(values: np.ndarray, scan: dict, rng: np.random.Generator) -> np.ndarray:
    """The clipped samples replaced by draws from the fitted normal beyond their rail's bin
    (one imputation, seeded), put on the record's grid of levels: what the sensor would have
    read with a wider range, as far as the record can tell."""
    out = values.copy()
    step = scan["step"]
    for side, rail in scan["rails"].items():
        at_rail = values == rail["value"]
        sign = 1 if side == "upper" else -1
        edge = (rail["value"] - sign * 0.5 * step - scan["mean"]) / scan["sd"]
        low, high = (edge, np.inf) if side == "upper" else (-np.inf, edge)
        draws = stats.truncnorm.rvs(
            low,
            high,
            loc=scan["mean"],
            scale=scan["sd"],
            size=int(at_rail.sum()),
            random_state=rng,
        )
        out[at_rail] = rail["value"] + np.round((draws - rail["value"]) / step) * step
    return out


class Saturation(Effect):
    """Samples clipped at the end of the sensor's range: decided before the search, on the
    samples' distribution (:func:`saturation_scan`); the clipped samples are imputed
    (:func:`impute_clipped`) for every fit that follows."""

    name: ClassVar[str] = "saturation"
    explanation: ClassVar[str] = (
        "The output is clipped at the end of the sensor's range: samples that would lie beyond "
        "it are stuck on one value (the rail), which pulls the mean in and shrinks the spread."
    )
    located_by: ClassVar[str] = "rail"
    band: ClassVar[str] = "samples"
    rank: ClassVar[int] = 5

    def simulate(self, values: np.ndarray, rail: float, bias: float) -> np.ndarray:
        """``values`` clipped at ``rail`` (above the bias: an upper rail, else a lower one)."""
        return np.minimum(values, rail) if rail > bias else np.maximum(values, rail)
