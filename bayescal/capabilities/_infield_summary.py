"""The parts of an in-field update's result (:mod:`._infield`): the projected biases, each gyro's
points, the patent's classical points, the updated calibrations, which gyros the alignment
informs, and the velocity innovations' check — each read off the fine alignment
(:mod:`bayescal.navigation._alignment`) and its posterior (:mod:`bayescal.inference._infield`).
"""

import math
from dataclasses import replace

import numpy as np

from .._output import to_jsonable
from ..inference._thermal_posterior import central_gaussian
from ..navigation._alignment import mixture_moments
from ..navigation._earth import north_east
from ..navigation._tilt_rates import (
    blocks,
    heading_corrected,
    interpolate_calibration,
    tilt_rate_points,
)
from ..recording._units import parse_unit
from ._thermal import provenance_step

INFORMED_HORIZONTAL = 0.5
"""A gyro axis whose horizontal part (sin of its angle from the vertical) is below this is the
vertical gyro: the park's heading change, not its tilt rates, tells it, and the patent's
block-by-block tilt rates leave it out."""
DEG_PER_HOUR = math.radians(1) / 3600
"""rad/s per deg/h."""


def summary(draws, unit: str) -> dict:
    draws = np.ravel(draws)
    return {
        "mean": float(draws.mean()),
        "sd": float(draws.std(ddof=1)),
        "q05": float(np.quantile(draws, 0.05)),
        "q95": float(np.quantile(draws, 0.95)),
        "unit": unit,
    }


def _slope_weights(degree: int, temperature: float, reference: float) -> np.ndarray:
    """d/dT of (T - T0)^j at ``temperature``, j = 0..degree."""
    power = np.arange(degree + 1)
    return power * (temperature - reference) ** np.maximum(power - 1, 0)


def projection(layout, priors, old, heat, attitude, row: int, kind: str):
    """The vector that turns the coefficients' changes (the state, SI) into one projection of
    the gyro biases (row 0, 1, 2 of C_b^n ``attitude``: north, east, down; ``kind`` "level",
    "level_at_reference" or "slope", over the still samples ``heat``), and the old
    calibration's part of it (rad/s or rad/s/degC)."""
    vector, old_part = np.zeros(len(layout.names)), 0.0
    park = heat.shape[0]
    for axis, (prior, calibration) in enumerate(zip(priors, old.values(), strict=True)):
        degree, reference = calibration.degree, calibration.reference
        if kind == "level":
            weights = prior.powers[:park].mean(axis=0)
        elif kind == "slope":
            weights = _slope_weights(degree, float(heat[:, axis].mean()), reference)
        else:
            weights = np.eye(degree + 1)[0]
        vector[layout.coefficients[axis]] = attitude[row, axis] * weights
        old_value = float(weights @ calibration.coefficients)
        old_part += attitude[row, axis] * old_value * parse_unit(calibration.unit).to_si
    return vector, old_part


def projections(alignment, priors, old, heat, posterior, attitude, east_informed=False) -> dict:
    """The north, east and down projections of the gyro biases, old calibration plus change:
    their mean over the park ("level", what the tilt rates measure), their value at each
    gyro's reference temperature ("level_at_reference", the polynomials' constant: east, the
    one the heading error hides) and their slope at each gyro's mean temperature; posterior
    summary and prior sd (given s, averaged over its posterior), deg/h and deg/h/degC.
    ``heat`` and ``attitude`` are the park's; ``east_informed``: whether a taxi told the
    heading, and so the east level."""
    layout, model = alignment.layout, alignment.model
    scale = np.asarray(model.scale)
    drifts = np.quantile(posterior.drift, np.linspace(0.01, 0.99, 50))
    priors_s = [np.asarray(model.prior(s)) for s in drifts]
    informed = {
        "north": {"level": True, "level_at_reference": True, "slope": True},
        "east": {"level": east_informed, "level_at_reference": east_informed, "slope": True},
        "down": {"level": True, "level_at_reference": True, "slope": True},
    }
    found = {}
    for row, direction in enumerate(informed):
        for kind in informed[direction]:
            vector, old_part = projection(layout, priors, old, heat, attitude, row, kind)
            scaled = vector * scale
            variance = np.mean([scaled @ prior_s @ scaled for prior_s in priors_s])
            entry = summary(
                (posterior.states @ vector + old_part) / DEG_PER_HOUR,
                "deg/h/degC" if kind == "slope" else "deg/h",
            )
            entry["prior_sd"] = math.sqrt(variance) / DEG_PER_HOUR
            entry["informed"] = informed[direction][kind]
            found.setdefault(direction, {})[kind] = entry
    return found


def points(alignment, old, heat, posterior, si: float) -> dict:
    """Each gyro's bias at each block's middle from the smoother: the old calibration plus the
    change of its coefficients and its instability, under the posterior mixture over s."""
    layout, scale = alignment.layout, np.asarray(alignment.model.scale)
    means, covariances = (np.asarray(x) for x in alignment.model.smooth(posterior.filtered))
    block = layout.all_coefficients
    draws = posterior.states[:, block] / scale[block]
    park = alignment.times[: alignment.park_steps]
    steps = [int(index[index.size // 2]) for index in blocks(park)]
    found = {}
    for axis, (name, calibration) in enumerate(old.items()):
        samples = [min(k * alignment.step_samples, heat.shape[0] - 1) for k in steps]
        temperature = heat[samples, axis]
        vectors = np.zeros((len(steps), len(layout.names)))
        powers = np.arange(calibration.degree + 1)
        vectors[:, layout.coefficients[axis]] = (
            temperature[:, None] - calibration.reference
        ) ** powers
        if layout.walks[axis] is not None:
            vectors[:, layout.walks[axis]] = 1.0
        mean, sd = mixture_moments(means[steps], covariances[steps], vectors * scale, block, draws)
        found[name] = {
            "time_s": alignment.times[steps],
            "temperature": temperature,
            "bias": calibration.bias(temperature)[0] + mean / si,
            "sd": sd / si,
            "unit": calibration.unit,
        }
    return found


def classical(alignment, old, heat, attitude, latitude, gravity: float, si: float, heading):
    """The patent's pipeline, classically: the tilt rates block by block
    (:mod:`bayescal.navigation._tilt_rates`) as north and east points, the east ones with the
    heading error's Earth-rate equivalent taken off (steps m-n: ``heading``, computed minus true
    at the park's end, rad, the taxi's estimate; None when no taxi told it, and nothing is taken
    off), as each gyro's points (its vertical part from the old calibration), and each
    horizontal gyro's old and new calibration interpolated by their weights (step o; the
    vertical gyro, INFORMED_HORIZONTAL, has no tilt rate of its own)."""
    park = alignment.park_steps
    rows = tilt_rate_points(
        alignment.times[:park], alignment.trajectory.velocity[:park, :2], latitude, gravity
    )
    rows = heading_corrected(rows, 0.0 if heading is None else heading, latitude)
    found = {}
    for axis, (name, calibration) in enumerate(old.items()):
        points = []
        for row in rows:
            k = int(np.argmin(np.abs(alignment.times - row["time_s"])))
            temperature = float(heat[min(k * alignment.step_samples, heat.shape[0] - 1), axis])
            north = attitude[0, axis] * row["north"]
            sd = math.hypot(attitude[0, axis] * row["north_sd"], attitude[1, axis] * row["east_sd"])
            points.append(
                {
                    "time_s": row["time_s"],
                    "temperature": temperature,
                    "bias_before_heading": float(calibration.bias(temperature)[0])
                    + (north + attitude[1, axis] * row["east_less_heading"]) / si,
                    "bias": float(calibration.bias(temperature)[0])
                    + (north + attitude[1, axis] * row["east"]) / si,
                    "sd": sd / si,
                }
            )
        found[name] = {"points": points, "unit": calibration.unit}
        if math.hypot(attitude[0, axis], attitude[1, axis]) >= INFORMED_HORIZONTAL:
            coefficients, covariance = interpolate_calibration(
                [p["temperature"] for p in points],
                [p["bias"] for p in points],
                [p["sd"] for p in points],
                calibration.coefficients,
                calibration.covariance,
                calibration.reference,
            )
            found[name] |= {"coefficients": coefficients, "covariance": covariance}
    blocks_deg_h = [
        {
            key: value / DEG_PER_HOUR if key not in ("time_s",) else value
            for key, value in row.items()
        }
        for row in rows
    ]
    return {
        "method": "tilt rates from the curvature of the velocity error, block by block "
        "(quadratic least squares, residuals taken as independent); the east points less the "
        "heading error's Earth-rate equivalent (the taxi's heading, taken as exact"
        + ("" if heading is not None else "; no taxi told it: nothing taken off")
        + "), the vertical part the old calibration's; each horizontal gyro's points fitted by "
        "weighted least squares and interpolated with the old calibration by their inverse "
        "covariances, with no aging allowed since it",
        "heading_error_deg": None if heading is None else math.degrees(heading),
        "blocks": blocks_deg_h,
        "block_unit": "deg/h",
        "axes": found,
    }


def updated(calibration, draws, si: float, heat, step: dict, sampler: dict, drift: dict):
    """``calibration`` with its coefficients' posterior from the alignment: the draws' mean and
    covariance when the aging scale was given (one Gaussian), the Gaussian of their bulk
    (:func:`~bayescal.inference._thermal_posterior.central_gaussian`) when it was learned (a
    scale mixture over s whose tail is the drift prior's), as the thermal update does."""
    coefficients = calibration.coefficients + draws / si
    if drift["learned"]:
        mean, covariance = central_gaussian(coefficients)
    else:
        mean, covariance = coefficients.mean(axis=0), np.cov(coefficients.T)
    low, high = calibration.temperature_range
    return replace(
        calibration,
        coefficients=mean,
        covariance=np.reshape(covariance, (calibration.degree + 1, -1)),
        temperature_range=(min(low, float(heat.min())), max(high, float(heat.max()))),
        provenance=(*calibration.provenance, step),
        bayesian=to_jsonable(
            {
                "coefficient_q05": np.quantile(coefficients, 0.05, axis=0),
                "coefficient_q95": np.quantile(coefficients, 0.95, axis=0),
                "degree_scores": {},
                "diagnostics": sampler,
            }
        ),
        classical=None,
        offsets=None,
        drift=drift,
        posterior=None,
        origin=None,
    )


def informed_axes(attitude, names, taxi: bool = False) -> dict:
    """Per gyro (``names`` in x, y, z order), how the alignment informs it: through the tilt
    rates where its axis's horizontal part at C_b^n ``attitude`` reaches INFORMED_HORIZONTAL,
    through the park's heading change where it does not (the vertical gyro); and why. Every
    gyro is updated."""
    axes = {}
    for axis, name in enumerate(names):
        horizontal = math.hypot(attitude[0, axis], attitude[1, axis])
        tilt = math.degrees(math.asin(min(1.0, horizontal)))
        why = (
            f"{tilt:.0f} deg from the vertical: its bias projects on north and east, so the "
            "north projection and the thermal slopes are informed; "
            + (
                "the east level through the heading the taxi told"
                if taxi
                else "the east level is one quantity with the heading error (kept at its prior "
                "until a taxi or a heading reference)"
            )
            if horizontal >= INFORMED_HORIZONTAL
            else f"{tilt:.0f} deg from the vertical: a still vehicle does not turn, so the "
            "computed heading's turn over the park is its bias (level and thermal slope, to "
            "about ARW / sqrt(park))"
        )
        axes[name] = {"informed_by_alignment": True, "updated": True, "why": why}
    return axes


def taxi_summary(alignment, context) -> dict | None:
    """The taxi as the filter used it: its window, the track headings and the steps on each
    leg, the position reference and its fixes in the taxi, whether it told the heading, which
    reference told it (``reference``), and why (not)."""
    if context["taxi"] is None:
        return None
    headings = context["headings"]
    legs = alignment.legs
    counts = [int(np.sum(legs == i)) for i in range(len(headings))] if legs is not None else []
    fixes = 0
    if alignment.fixes is not None:
        moving = np.arange(alignment.fixes.shape[0]) >= alignment.park_steps
        fixes = int(np.sum(np.isfinite(alignment.fixes[:, 0]) & moving))
    told = [
        name
        for name, used in (("track heading", sum(counts) > 0), ("position fixes", fixes > 0))
        if used
    ]
    if not headings and context["positions"] is None:
        why = (
            "the taxi gave no heading information: no track heading or position reference was "
            "given (a taxi without a known track or a position reference cannot tell the "
            "heading error from the east bias level); the east level stays at its prior"
        )
    elif not told:
        reasons = [
            "no filter step lay on a leg of the given track headings (computed track within 1 "
            "deg of one for 5 s either side, at 3.1 m/s or more)"
        ] * bool(headings)
        reasons += ["no position fix lay in the taxi"] * (context["positions"] is not None)
        why = (
            f"the taxi gave no heading information: {' and '.join(reasons)}; the east level "
            "stays at its prior"
        )
    else:
        why = (
            " and ".join(
                {
                    "track heading": "the cross-track velocity on the legs",
                    "position fixes": "the computed track's drift from the position fixes",
                }[name]
                for name in told
            )
            + " told the heading error"
        )
    positions = None
    if context["positions"] is not None:
        positions = {
            "columns": list(context["positions"]),
            "sd_m": context["position_sd"],
            "fixes_in_taxi": fixes,
        }
    return {
        "start_s": context["taxi"][0],
        "stop_s": context["taxi"][1],
        "track_heading_deg": list(headings),
        "steps_on_legs": counts,
        "positions": positions,
        "informative": bool(told),
        "reference": " and ".join(told) or None,
        "why": why,
    }


def computed_track(alignment) -> dict:
    """The mechanization's position at each filter step as north and east of the first, m: the
    changes of latitude and longitude times the ellipsoid's meridian and transverse radii there
    (:func:`~bayescal.navigation._earth.north_east`; flat over the few km of a taxi); and the taxi
    leg each step lay on (an index into the track headings, -1 for the park's steps and those
    off the legs). The free-inertial track, not corrected by the filter: it carries the heading
    error the taxi tells. With a position reference, ``fixes``: the fixes the filter measured
    (``time_s``, ``north``, ``east``, m north and east of the first fix, which lies in the park
    where the track starts: :func:`~bayescal.navigation._alignment.fine_alignment`); else
    None."""
    trajectory = alignment.trajectory
    track = north_east(trajectory.latitude, trajectory.longitude, float(trajectory.height))
    legs = alignment.legs if alignment.legs is not None else np.full(track.shape[0], -1)
    fixes = None
    if alignment.fixes is not None:
        measured = np.flatnonzero(np.isfinite(alignment.fixes).all(axis=1))
        fixes = {
            "time_s": alignment.times[measured],
            "north": alignment.fixes[measured, 0],
            "east": alignment.fixes[measured, 1],
        }
    return {
        "time_s": alignment.times,
        "north": track[:, 0],
        "east": track[:, 1],
        "unit": "m",
        "leg": np.asarray(legs, dtype=int),
        "park_steps": int(alignment.park_steps),
        "fixes": fixes,
    }


def innovation_check(filtered) -> dict:
    """The velocity innovations against the chi^2 their model gives them: larger ones mean
    motion or noise the model does not hold."""
    from scipy import stats

    total = float(np.sum(filtered.normalized_innovation))
    dof = int(np.sum(filtered.observed))
    limit = float(stats.chi2.ppf(0.999, dof))
    return {"sum_nis": total, "dof": dof, "upper_limit": limit, "passed": total <= limit}


def leg_innovation_checks(filtered, legs, headings) -> list[dict]:
    """The cross-track innovations of each taxi leg against the chi^2 their model gives them
    (the sum of the normalized innovations over the leg's steps, its 99.9 % point): a leg
    whose residuals exceed their predicted spread holds more than the model (a wander larger
    or slower than assumed, a track off the given heading, a linearization that does not
    hold), and the heading it tells is then narrower than the data allow."""
    from scipy import stats

    if legs is None:
        return []
    nis = np.asarray(filtered.normalized_innovation)
    observed = np.asarray(filtered.observed)
    found = []
    for index, heading in enumerate(headings):
        on = np.asarray(legs) == index
        dof = int(np.sum(observed[on]))
        if dof == 0:
            continue
        total = float(np.sum(nis[on]))
        limit = float(stats.chi2.ppf(0.999, dof))
        found.append(
            {
                "track_heading_deg": heading,
                "sum_nis": total,
                "dof": dof,
                "upper_limit": limit,
                "passed": total <= limit,
            }
        )
    return found


def calibrations(alignment, posterior, old, heat, axes, sampler, drift, context) -> dict:
    """Each gyro's calibration after the alignment, its provenance saying how the alignment
    informed it."""
    new = {}
    for axis, (name, calibration) in enumerate(old.items()):
        step = provenance_step(
            "infield",
            source=context["source"],
            channel=name,
            n_samples=heat.shape[0],
            seed=context["seed"],
            extra={
                "prior": calibration.origin or "a calibration in memory",
                "latitude_deg": context["latitude"],
                "align": list(context["window"]),
                "drift": context["drift"],
                "updated": axes[name]["updated"],
                "why": axes[name]["why"],
            },
        )
        draws = posterior.states[:, alignment.layout.coefficients[axis]]
        new[name] = updated(calibration, draws, context["si"], heat[:, axis], step, sampler, drift)
    return new


def calibration_notes(old, heat, context) -> list[str]:
    """Where the old polynomials are extrapolated."""
    notes = list(context["notes"])
    for axis, (name, calibration) in enumerate(old.items()):
        outside = calibration.outside_range(heat[:, axis])
        if outside.any():
            notes.append(
                f"{name}: {100 * outside.mean():.3g} % of the alignment lies outside the "
                f"calibrated range {calibration.temperature_range}: the old polynomial is "
                "extrapolated there"
            )
    return notes
