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
"""

import math

import numpy as np
from scipy import optimize, special, stats

SIDES = ("upper", "lower")
MIN_LEVELS = 5
"""Fewer distinct values than this: the converter's step hides any rail (and the spread)."""
_END = {"upper": -1, "lower": 0}
"""Index of each side's extreme among the sorted levels."""


def _log_bin(low, high):
    """log(Phi(high) - Phi(low)) for standard scores low < high, accurate in either tail and
    for bins far narrower than the spread."""
    upper_tail = low > 0
    a = np.where(upper_tail, -high, low)
    b = np.where(upper_tail, -low, high)
    log_b = special.log_ndtr(b)
    with np.errstate(divide="ignore", invalid="ignore"):
        exact = log_b + np.log1p(-np.exp(special.log_ndtr(a) - log_b))
    narrow = stats.norm.logpdf(0.5 * (low + high)) + np.log(high - low)
    return np.where(high - low < 1e-3, narrow, exact)


def _rails(levels: np.ndarray, counts: np.ndarray) -> dict:
    """side -> (rail value, samples on it) for each extreme that at least two samples share."""
    out = {}
    for side in SIDES:
        if counts[_END[side]] >= 2:
            out[side] = (float(levels[_END[side]]), int(counts[_END[side]]))
    return out


def _rail_log_probability(side: str, rail, mean, sd, half_step):
    """log probability of the whole tail beyond the inner edge of the rail's bin."""
    if side == "upper":
        return special.log_ndtr((mean - rail + half_step) / sd)
    return special.log_ndtr((rail + half_step - mean) / sd)


def _pointwise(levels, mean, sd, half_step, rails: dict) -> np.ndarray:
    """log probability of each level's bin under N(mean, sd), censored at ``rails``."""
    out = _log_bin((levels - half_step - mean) / sd, (levels + half_step - mean) / sd)
    for side in rails:
        out[_END[side]] = _rail_log_probability(side, levels[_END[side]], mean, sd, half_step)
    return out


def _fit(levels, counts, half_step, rails: dict) -> tuple[float, float, np.ndarray]:
    """Maximum-likelihood mean and sd of the (censored) normal, and the log probability of
    each level at them."""
    inside = np.ones(levels.size, bool)
    inside[[_END[side] for side in rails]] = False
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
            return np.dot(weights, _pointwise(levels, mean, sd, half_step, {}))

    def objective(x):
        mean, sd = mean0 + x[0] * sd0, sd0 * math.exp(x[1])
        at_rails = sum(
            counts[_END[side]]
            * _rail_log_probability(side, levels[_END[side]], mean, sd, half_step)
            for side in rails
        )
        return -(inside_rails(mean, sd) + at_rails)

    found = optimize.minimize(
        objective, np.zeros(2), method="Nelder-Mead", options={"xatol": 1e-7, "fatol": 1e-7}
    )
    mean, sd = mean0 + found.x[0] * sd0, sd0 * math.exp(found.x[1])
    return float(mean), float(sd), _pointwise(levels, mean, sd, half_step, rails)


def saturation_scan(values: np.ndarray, *, decisive: float) -> dict | None:
    """Censored normal against normal on the samples' marginal distribution: the log Bayes
    factor (each rail paying the log of the number of levels it could have sat on), the ELPD
    gain (AIC: one parameter per rail) with its standard error, the rails (those whose log
    Bayes factor alone exceeds ``decisive``, else every candidate: together they may), and
    the unclipped mean and sd. ``None`` when no extreme value is shared by two samples."""
    finite = values[np.isfinite(values)]
    levels, inverse, counts = np.unique(finite, return_inverse=True, return_counts=True)
    candidates = _rails(levels, counts) if levels.size >= MIN_LEVELS else {}
    if not candidates:
        return None
    step = float(np.min(np.diff(levels)))
    half_step = 0.5 * step
    rail_cost = math.log(np.ptp(levels) / step + 1)
    normal = _fit(levels, counts, half_step, {})[2]

    def log_bayes_factor(rails):
        return (
            np.dot(counts, _fit(levels, counts, half_step, rails)[2] - normal)
            - len(rails) * rail_cost
        )

    kept = {
        side: rail for side, rail in candidates.items() if log_bayes_factor({side: rail}) > decisive
    }
    rails = kept or candidates
    mean, sd, censored = _fit(levels, counts, half_step, rails)
    difference = (censored - normal)[inverse]
    return {
        "log_bayes_factor": float(difference.sum() - len(rails) * rail_cost),
        "delta_elpd": float(difference.sum() - len(rails)),
        "delta_elpd_se": float(math.sqrt(difference.size) * np.std(difference)),
        "rails": {side: {"value": rail, "samples": count} for side, (rail, count) in rails.items()},
        "mean": mean,
        "sd": sd,
    }


def impute_clipped(values: np.ndarray, scan: dict, rng: np.random.Generator) -> np.ndarray:
    """The clipped samples replaced by draws from the fitted normal beyond their rail (one
    imputation, seeded): what the sensor would have read with a wider range, as far as the
    record can tell."""
    out = values.copy()
    for side, rail in scan["rails"].items():
        at_rail = values == rail["value"]
        edge = (rail["value"] - scan["mean"]) / scan["sd"]
        low, high = (edge, np.inf) if side == "upper" else (-np.inf, edge)
        out[at_rail] = stats.truncnorm.rvs(
            low,
            high,
            loc=scan["mean"],
            scale=scan["sd"],
            size=int(at_rail.sum()),
            random_state=rng,
        )
    return out


def rail_check(values: np.ndarray, rate_hz: float, unit: str) -> dict:
    """Samples stuck on an extreme value against the normal with the record's mean and sd:
    the chance that as many others share the extreme's resolution bin, for either side
    (Bonferroni). With fine resolution, two samples on the extreme are already improbable; on
    a coarse converter step the top level holds a few anyway."""
    finite = values[np.isfinite(values)]
    levels, counts = np.unique(finite, return_counts=True)
    candidates = _rails(levels, counts) if levels.size >= MIN_LEVELS else {}
    worst = {"name": "rail", "statistic": 1, "p_value": 1.0, "location": {}}
    if not candidates:
        return worst
    step = float(np.min(np.diff(levels)))
    mean, sd = float(np.mean(finite)), float(np.std(finite))
    for side, (rail, count) in candidates.items():
        low, high = (rail - 0.5 * step - mean) / sd, (rail + 0.5 * step - mean) / sd
        in_bin = float(np.exp(_log_bin(np.array(low), np.array(high))))
        p_value = min(1.0, len(SIDES) * stats.binom.sf(count - 2, finite.size - 1, in_bin))
        if p_value <= worst["p_value"]:
            where = np.flatnonzero(values == rail)
            worst["statistic"], worst["p_value"] = count, float(p_value)
            worst["location"] = {
                "side": side,
                "rail": rail,
                "unit": unit,
                "samples": count,
                "fraction": count / finite.size,
                "first_s": float(where[0] / rate_hz),
                "last_s": float(where[-1] / rate_hz),
            }
    return worst
