"""The in-field update of a strapdown system's gyro thermal calibration from its own alignment
(claim 1 of US 5,527,003, steps a-j, at rest; ../shared/NAVIGATION.md).

It composes the layers below: the recording's gyros, accelerometers and temperatures in the
alignment window (checked still), the old calibration taken off the gyros, the mechanization
and fine-alignment filter of :mod:`bayescal.navigation._alignment`, the posterior of the aging
since the calibration (:mod:`bayescal.inference._infield`), and the patent's classical tilt
rates block by block (:mod:`bayescal.navigation._tilt_rates`) beside it.

What the alignment can tell (NAVIGATION.md): the north-projected bias and the north and east
projections of the thermal slope; not the east bias level, which at rest is one quantity with
the heading error (its interval stays as wide as the prior), nor the vertical gyro, which is
reported "not informed" and keeps its old calibration. A gyro whose axis lies within 60 deg of
the vertical counts as vertical.
"""

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from os import PathLike

import numpy as np

from .._errors import HealthCheckError, InputError
from .._output import to_jsonable
from ..classical._gravity import normal_gravity
from ..inference._infield import sample_alignment
from ..models._thermal import _drift_shape
from ..navigation._alignment import (
    DRIFT_PRIOR_SCALE,
    MIN_ALIGNMENT_S,
    GyroPrior,
    find_motion,
    fine_alignment,
    mixture_moments,
)
from ..navigation._alignment import heading_sensitivity as _heading_row
from ..navigation._earth import check_latitude
from ..navigation._error_model import TILT
from ..navigation._frames import euler_from_dcm
from ..navigation._tilt_rates import blocks, tilt_rate_points
from ..recording._columns import find_temperature_column, temperature_unit
from ..recording._recording import Recording, load_recording
from ..recording._units import FLICKER_ALLAN_FACTOR, parse_unit
from ._thermal import ThermalCalibration, _provenance, load_thermal_calibration
from ._thermal import save_thermal_calibrations as _save

GYROS = ("gyro_x", "gyro_y", "gyro_z")
ACCELEROMETERS = ("acc_x", "acc_y", "acc_z")
ACCEL_INSTABILITY = 1e-5
"""The accelerometers' bias instability assumed, m/s^2 (1 ug: navigation grade)."""
INFORMED_HORIZONTAL = 0.5
"""A gyro axis whose horizontal part (sin of its angle from the vertical) is below this is the
vertical gyro: the alignment does not inform it."""
DEG_PER_HOUR = math.radians(1) / 3600
"""rad/s per deg/h."""
TAXI_LATER = (
    "the taxi's heading measurement (--taxi, --track-heading) is not yet supported (issue 36)"
)


@dataclass(frozen=True)
class InFieldUpdate:
    """The gyro thermal calibrations updated from an alignment at rest, with what the
    alignment could and could not tell.

    Made by :func:`infield_update`; :meth:`save` writes the calibrations as one file,
    :meth:`to_document` the whole result.

    Attributes
    ----------
    calibration : dict
        Channel -> its :class:`~bayescal.ThermalCalibration`: updated for the gyros the
        alignment informs, the old one (its provenance noting why) for the vertical gyro.
    heading_error : dict
        The heading error at the alignment's end, computed minus true: ``mean``, ``sd``,
        ``q05``, ``q95`` in degrees. At rest it is the east bias level in disguise.
    points : dict
        Channel -> the (temperature, gyro bias) pairs of the fine alignment's smoother, one
        per block: ``time_s``, ``temperature``, ``bias``, ``sd`` and the ``unit``.
    classical : dict
        The patent's tilt rates block by block: the north bias and the east bias less the
        heading term per block, and each gyro's points (its vertical part taken as the old
        calibration's).
    checks : dict
        ``passed``, ``failures``, the sampler's checks and the velocity innovations' check.
    axes : dict
        Channel -> whether the alignment informs it, and why.
    projections : dict
        The north, east and down projections of the gyro biases: ``level`` (mean over the
        alignment), ``level_at_reference`` (at each gyro's T0: the polynomials' constant) and
        ``slope`` (at the mean temperature), deg/h and deg/h/degC: posterior summary, prior
        sd, and whether the alignment informs it.
    drift : dict
        The learned aging scale s, in the calibrations' unit.
    alignment : dict
        The window, the place, the coarse attitude and the computed attitude at the end
        (deg), and the white-noise densities read from the record.
    notes : tuple of str
        What the run noticed (temperatures outside the calibrated range, ...).
    posterior : object
        The draws behind it (the drift scale and every state at the alignment's end).
    """

    calibration: dict
    heading_error: dict
    points: dict
    classical: dict
    checks: dict
    axes: dict
    projections: dict
    drift: dict
    alignment: dict
    notes: tuple[str, ...] = ()
    posterior: object = field(default=None, compare=False, repr=False)

    @property
    def passed(self) -> bool:
        """Whether every check passed."""
        return bool(self.checks["passed"])

    def check(self) -> "InFieldUpdate":
        """Raise :class:`~bayescal.HealthCheckError` naming the failed checks, if any.

        Returns
        -------
        InFieldUpdate
            This result, unchanged, when every check passed.

        Raises
        ------
        HealthCheckError
            A check failed; the message names each.
        """
        if not self.passed:
            raise HealthCheckError("in-field update: " + "; ".join(self.checks["failures"]))
        return self

    def save(self, path):
        """Write the calibrations (every gyro's, updated or not) as one file.

        Parameters
        ----------
        path : str or Path
            The JSON file to write; :func:`~bayescal.load_thermal_calibration` reads each
            channel of it.

        Returns
        -------
        Path
            ``path``.
        """
        return _save(self.calibration, path)

    def to_document(self) -> dict:
        """The result as JSON-ready content (what ``bayescal thermal infield --json`` writes).

        Returns
        -------
        dict
            ``heading_error``, ``axes`` (per channel: ``informed_by_alignment`` and the
            updated coefficients), ``projections``, ``drift``, ``points``, ``classical``,
            ``checks``, ``alignment`` and ``notes``.
        """
        axes = {}
        for name, entry in self.axes.items():
            new = self.calibration[name]
            axes[name] = {
                **entry,
                "coefficients": new.coefficients,
                "coefficient_units": new.coefficient_units,
                "sd": np.sqrt(np.diag(new.covariance)),
                "covariance": new.covariance,
                "reference_temperature": new.reference,
            }
        return to_jsonable(
            {
                "schema": "bayescal.infield_update",
                "schema_version": 1,
                "heading_error": self.heading_error,
                "axes": axes,
                "projections": self.projections,
                "drift": self.drift,
                "points": self.points,
                "classical": self.classical,
                "checks": self.checks,
                "alignment": self.alignment,
                "notes": list(self.notes),
            }
        )


def _window(align) -> tuple[float, float]:
    try:
        start, stop = (float(value) for value in align)
    except (TypeError, ValueError):
        start = stop = math.nan
    if not (math.isfinite(start) and math.isfinite(stop) and stop > start >= 0):
        raise InputError(
            f"align {align!r}",
            fix="give the alignment window as (t0, t1), seconds from the first sample, t1 > t0",
        )
    if stop - start < MIN_ALIGNMENT_S:
        raise InputError(
            f"the alignment window {start:g}:{stop:g} lasts {stop - start:g} s, shorter than "
            f"the {MIN_ALIGNMENT_S:g} s the fine alignment can use",
            fix="give a longer still window (the patent's extended alignment: 10-20 minutes)",
        )
    return start, stop


def _temperature_columns(recording: Recording, temperature) -> list[str]:
    if temperature is None or (isinstance(temperature, str) and "," not in temperature):
        return [find_temperature_column(recording, temperature)] * 3
    names = temperature.split(",") if isinstance(temperature, str) else list(temperature)
    names = [name.strip() for name in names]
    if len(names) != 3:
        raise InputError(
            f"temperature {temperature!r}", fix="give one column, or one per gyro (x, y, z)"
        )
    return [find_temperature_column(recording, name) for name in names]


def _read(recording: Recording, window, columns: dict, options: dict):
    """The gyros (their unit), accelerometers (m/s^2) and per-gyro temperatures in the window,
    on one grid; the gyro unit, the temperature unit and the channels' notes."""
    temperatures = _temperature_columns(recording, columns["temperature"])
    grid = {**options, "start": window[0], "stop": window[1], "at_rest": False}
    gyros = [
        recording.channel(name, unit=columns["unit"], temperature=temperatures[axis], **grid)
        for axis, name in enumerate(columns["gyro"])
    ]
    accels = [
        recording.channel(name, unit=columns["accel_unit"], **grid) for name in columns["accel"]
    ]
    kinds = [
        *(("angular_rate", "an angular rate"),) * 3,
        *(("acceleration", "an acceleration"),) * 3,
    ]
    for channel, (quantity, kind) in zip((*gyros, *accels), kinds, strict=True):
        if parse_unit(channel.unit).quantity != quantity:
            raise InputError(
                f"unit {channel.unit} is not {kind}",
                source=recording.source,
                column=channel.channel,
                fix="pass --unit deg/s for the gyros (--accel-unit m/s^2 for the accelerometers)",
            )
    units = {g.unit for g in gyros}
    if len(units) > 1 or len({c.values.size for c in (*gyros, *accels)}) > 1:
        raise InputError(
            "the gyros and accelerometers do not share one unit and sample grid",
            source=recording.source,
            fix="give the gyros one unit (--unit) and the same time column",
        )
    if gyros[0].duration_s < window[1] - window[0] - 1.5 / gyros[0].rate_hz:
        raise InputError(
            f"the recording ends at {gyros[0].stop_s:.6g} s, inside the alignment window "
            f"{window[0]:g}:{window[1]:g}",
            source=recording.source,
            fix="give a window inside the recording",
        )
    heat_units = {temperature_unit(recording, name)[0] for name in temperatures}
    if len(heat_units) > 1:
        raise InputError("the temperature columns use different units", source=recording.source)
    gyro = np.stack([g.values for g in gyros], axis=1)
    accel = np.stack([a.values * parse_unit(a.unit).to_si for a in accels], axis=1)
    heat = np.stack([g.temperature for g in gyros], axis=1)
    notes = tuple(dict.fromkeys(note for c in (*gyros, *accels) for note in c.notes))
    return gyro, accel, heat, gyros[0], heat_units.pop(), notes


def _old_calibrations(calibration, names, unit: str, heat_unit: str) -> dict:
    if isinstance(calibration, (str, PathLike)):
        return {
            name: load_thermal_calibration(
                calibration, channel=name, unit=unit, temperature_unit=heat_unit
            )
            for name in names
        }
    given = list(calibration.values() if isinstance(calibration, Mapping) else calibration)
    if not all(isinstance(item, ThermalCalibration) for item in given):
        raise InputError(
            "calibration: give a calibration file, or ThermalCalibration objects (a mapping or "
            "a list)"
        )
    found = {item.channel: item for item in given}
    for name in names:
        if name not in found:
            raise InputError(
                f"the calibration holds {', '.join(found) or 'no channel'}, not '{name}'",
                fix="give one thermal calibration per gyro, named as its column",
            )
        old = found[name]
        if old.unit != unit or old.temperature_unit != heat_unit:
            raise InputError(
                f"the calibration of '{name}' is in {old.unit} per {old.temperature_unit}, the "
                f"recording in {unit} per {heat_unit}",
                fix="pass --unit to match, or give a calibration in the recording's units",
            )
    return {name: found[name] for name in names}


def _priors(old: dict, heat, duration_s: float, si: float) -> tuple[GyroPrior, ...]:
    priors = []
    for axis, calibration in enumerate(old.values()):
        noise = calibration.noise
        flicker = noise.get("B", {}).get("mean", 0.0) * si
        walk = noise.get("K", {}).get("mean", 0.0) * si
        powers = (heat[:, axis, None] - calibration.reference) ** np.arange(calibration.degree + 1)
        priors.append(
            GyroPrior(
                powers=powers,
                covariance=np.asarray(calibration.covariance) * si**2,
                drift_shape=_drift_shape(
                    calibration.degree, calibration.reference, calibration.temperature_range
                ),
                instability=walk**2 + 9 * FLICKER_ALLAN_FACTOR * flicker**2 / duration_s,
            )
        )
    return tuple(priors)


def _summary(draws, unit: str) -> dict:
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


def _projections(alignment, priors, old, heat, posterior, attitude) -> dict:
    """The north, east and down projections of the gyro biases, old calibration plus change:
    their mean over the alignment ("level", what the tilt rates measure), their value at each
    gyro's reference temperature ("level_at_reference", the polynomials' constant: east, the
    one the heading error hides) and their slope at each gyro's mean temperature; posterior
    summary and prior sd (given s, averaged over its posterior), deg/h and deg/h/degC."""
    layout, model = alignment.layout, alignment.model
    scale = np.asarray(model.scale)
    drifts = np.quantile(posterior.drift, np.linspace(0.01, 0.99, 50))
    priors_s = [np.asarray(model.prior(s)) for s in drifts]
    informed = {
        "north": {"level": True, "level_at_reference": True, "slope": True},
        "east": {"level": False, "level_at_reference": False, "slope": True},
        "down": {"level": False, "level_at_reference": False, "slope": False},
    }
    found = {}
    for row, direction in enumerate(informed):
        for kind in informed[direction]:
            vector, old_part = np.zeros(len(layout.names)), 0.0
            for axis, (prior, calibration) in enumerate(zip(priors, old.values(), strict=True)):
                degree, reference = calibration.degree, calibration.reference
                if kind == "level":
                    weights = prior.powers.mean(axis=0)
                elif kind == "slope":
                    weights = _slope_weights(degree, float(heat[:, axis].mean()), reference)
                else:
                    weights = np.eye(degree + 1)[0]
                vector[layout.coefficients[axis]] = attitude[row, axis] * weights
                old_value = float(weights @ calibration.coefficients)
                old_part += attitude[row, axis] * old_value * parse_unit(calibration.unit).to_si
            scaled = vector * scale
            variance = np.mean([scaled @ prior_s @ scaled for prior_s in priors_s])
            entry = _summary(
                (posterior.states @ vector + old_part) / DEG_PER_HOUR,
                "deg/h/degC" if kind == "slope" else "deg/h",
            )
            entry["prior_sd"] = math.sqrt(variance) / DEG_PER_HOUR
            entry["informed"] = informed[direction][kind]
            found.setdefault(direction, {})[kind] = entry
    return found


def _points(alignment, old, heat, posterior, si: float) -> dict:
    """Each gyro's bias at each block's middle from the smoother: the old calibration plus the
    change of its coefficients and its instability, under the posterior mixture over s."""
    layout, scale = alignment.layout, np.asarray(alignment.model.scale)
    means, covariances = (np.asarray(x) for x in alignment.model.smooth(posterior.filtered))
    block = layout.all_coefficients
    draws = posterior.states[:, block] / scale[block]
    steps = [int(index[index.size // 2]) for index in blocks(alignment.times)]
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


def _classical(alignment, old, heat, attitude, latitude, gravity: float, si: float) -> dict:
    """The patent's tilt rates block by block (:mod:`bayescal.navigation._tilt_rates`), as
    north and east points and as each gyro's points (its vertical part from the old
    calibration)."""
    rows = tilt_rate_points(
        alignment.times, alignment.trajectory.velocity[:, :2], latitude, gravity
    )
    axes = {}
    for axis, (name, calibration) in enumerate(old.items()):
        points = []
        for row in rows:
            k = int(np.argmin(np.abs(alignment.times - row["time_s"])))
            temperature = float(heat[min(k * alignment.step_samples, heat.shape[0] - 1), axis])
            change = attitude[0, axis] * row["north"] + attitude[1, axis] * row["east_less_heading"]
            sd = math.hypot(attitude[0, axis] * row["north_sd"], attitude[1, axis] * row["east_sd"])
            points.append(
                {
                    "time_s": row["time_s"],
                    "temperature": temperature,
                    "bias": float(calibration.bias(temperature)[0]) + change / si,
                    "sd": sd / si,
                }
            )
        axes[name] = {"points": points, "unit": calibration.unit}
    blocks_deg_h = [
        {
            key: value / DEG_PER_HOUR if key not in ("time_s",) else value
            for key, value in row.items()
        }
        for row in rows
    ]
    return {
        "method": "tilt rates from the curvature of the velocity error, block by block "
        "(quadratic least squares, residuals taken as independent); the east points include "
        "the heading error's Earth-rate equivalent, the vertical part is the old calibration's",
        "blocks": blocks_deg_h,
        "block_unit": "deg/h",
        "axes": axes,
    }


def _updated(calibration, draws, si: float, heat, step: dict, sampler: dict, drift: dict):
    """``calibration`` with its coefficients' posterior from the alignment."""
    coefficients = calibration.coefficients + draws / si
    low, high = calibration.temperature_range
    return replace(
        calibration,
        coefficients=coefficients.mean(axis=0),
        covariance=np.cov(coefficients.T).reshape(calibration.degree + 1, -1),
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


def _axes(attitude) -> dict:
    axes = {}
    for axis, name in enumerate(GYROS):
        horizontal = math.hypot(attitude[0, axis], attitude[1, axis])
        tilt = math.degrees(math.asin(min(1.0, horizontal)))
        informed = horizontal >= INFORMED_HORIZONTAL
        why = (
            f"{tilt:.0f} deg from the vertical: its bias projects on north and east, so the "
            "north projection and the thermal slopes are informed; the east level is one "
            "quantity with the heading error (kept at its prior until a taxi or a heading "
            "reference)"
            if informed
            else f"{tilt:.0f} deg from the vertical: the alignment sees a vertical gyro's bias "
            "only through the heading's slow drift, which the east bias hides; not updated"
        )
        axes[name] = {"informed_by_alignment": informed, "updated": informed, "why": why}
    return axes


def _innovation_check(filtered) -> dict:
    """The velocity innovations against the chi^2 their model gives them: larger ones mean
    motion or noise the model does not hold."""
    from scipy import stats

    total = float(np.sum(filtered.normalized_innovation))
    dof = int(np.sum(filtered.observed))
    limit = float(stats.chi2.ppf(0.999, dof))
    return {"sum_nis": total, "dof": dof, "upper_limit": limit, "passed": total <= limit}


def infield_update(
    recording,
    calibration,
    *,
    latitude: float,
    align: tuple[float, float],
    taxi: tuple[float, float] | None = None,
    track_heading=None,
    seed: int = 0,
    drift: float | str = "auto",
    gyro_columns=GYROS,
    accel_columns=ACCELEROMETERS,
    temperature=None,
    unit: str | None = None,
    accel_unit: str | None = None,
    rate: float | None = None,
    time_column: str | None = None,
    time_unit: str | None = None,
    height: float = 0.0,
    accel_instability: float = ACCEL_INSTABILITY,
    progress: bool = False,
) -> InFieldUpdate:
    """Update the gyros' thermal calibrations from the system's own extended alignment.

    Parameters
    ----------
    recording : Recording or str or Path
        The strapdown system's record (:func:`~bayescal.load_recording`): time, body rates,
        specific forces and gyro temperatures.
    calibration : str or Path, mapping or list of ThermalCalibration
        The old calibration of each gyro (one file of several channels, see
        :func:`~bayescal.save_thermal_calibrations`).
    latitude : float
        Geodetic latitude, degrees (within +-85).
    align : (float, float)
        The still alignment window, seconds from the first sample (at least 300 s).
    taxi, track_heading : optional
        The taxi and its known heading (not yet supported: the east level then stays at its
        prior).
    seed : int
        Seed of the sampler: the same inputs and seed give the same result.
    drift : float or "auto"
        How far each gyro's bias may have aged since the calibration (the drift scale s of
        :meth:`~bayescal.ThermalCalibration.update`, in the calibrations' unit, e.g. a
        datasheet's bias repeatability): ``"auto"`` learns it from the alignment, which
        informs it in only a few directions (see the guide), 0 assumes no aging.
    gyro_columns, accel_columns : tuple of str
        The gyro (x, y, z) and accelerometer columns.
    temperature : str or tuple of str, optional
        The temperature column, or one per gyro (default: found by name).
    unit, accel_unit : str, optional
        The gyros' unit (deg/s, rad/s ...) and the accelerometers' (m/s^2, g); default from
        the header.
    rate, time_column, time_unit
        The time base, as for every recording (:meth:`~bayescal.Recording.channel`).
    height : float
        Height above the ellipsoid, m.
    accel_instability : float
        The accelerometers' bias instability, m/s^2.
    progress : bool
        A progress bar for the sampler.

    Returns
    -------
    InFieldUpdate
        The updated calibrations, heading error, points, classical points and checks.

    Raises
    ------
    InputError
        Motion in the alignment window (where), a missing temperature, a latitude out of
        range, a window too short, a calibration of other channels or units, a taxi.
    """
    if taxi is not None or track_heading is not None:
        raise InputError(
            TAXI_LATER,
            fix="leave them out: the east bias level then stays at its prior, as the result says",
        )
    latitude = check_latitude(latitude)
    window = _window(align)
    if drift != "auto" and not (isinstance(drift, (int, float)) and 0 <= drift < math.inf):
        raise InputError(
            f"drift {drift!r}", fix="give auto, 0 (no aging) or a positive scale in the gyros' unit"
        )
    if not isinstance(recording, Recording):
        recording = load_recording(recording)
    columns = {"gyro": gyro_columns, "accel": accel_columns, "temperature": temperature}
    columns |= {"unit": unit, "accel_unit": accel_unit}
    options = {"rate": rate, "time_column": time_column, "time_unit": time_unit}
    gyro, accel, heat, first, heat_unit, notes = _read(recording, window, columns, options)
    old = _old_calibrations(calibration, gyro_columns, first.unit, heat_unit)
    si = parse_unit(first.unit).to_si
    moved = find_motion(gyro * si, accel, first.rate_hz)
    if moved is not None:
        raise InputError(
            f"the vehicle moves during the alignment window: at t = {first.start_s + moved[0]:.1f}"
            f" s {moved[1]}",
            source=recording.source,
            fix="give a still window (--align T0:T1)",
        )
    compensated = si * np.stack(
        [gyro[:, axis] - cal.bias(heat[:, axis])[0] for axis, cal in enumerate(old.values())], 1
    )
    priors = _priors(old, heat, gyro.shape[0] / first.rate_hz, si)
    sd_c0 = float(np.exp(np.mean([0.5 * math.log(p.covariance[0, 0]) for p in priors])))
    location = math.log(DRIFT_PRIOR_SCALE * sd_c0)
    alignment = fine_alignment(
        compensated,
        accel,
        first.rate_hz,
        priors,
        latitude=math.radians(latitude),
        height=height,
        reference_drift=math.exp(location),
        accel_instability=accel_instability,
    )
    posterior = sample_alignment(
        alignment,
        location=location,
        seed=seed,
        drift=drift if drift == "auto" else drift * si,
        progress=progress,
    )
    context = {
        "si": si,
        "unit": first.unit,
        "source": recording.source,
        "seed": seed,
        "latitude": latitude,
        "height": height,
        "window": window,
        "notes": notes,
        "drift": drift,
    }
    return _result(alignment, posterior, old, heat, priors, context)


def _result(alignment, posterior, old: dict, heat, priors, context: dict) -> InFieldUpdate:
    """Every part of the :class:`InFieldUpdate` from the alignment and its posterior."""
    si, unit = context["si"], context["unit"]
    attitude = alignment.trajectory.attitude[-1]
    heading = np.degrees(posterior.states[:, TILT] @ _heading_row(attitude))
    if posterior.diagnostics is None:
        sampler = {
            "passed": True,
            "failures": [],
            "method": "the aging scale was given: one Gaussian posterior, nothing sampled",
        }
    else:
        sampler = posterior.diagnostics.as_dict()
    drift = {**_summary(posterior.drift / si, unit), "learned": posterior.diagnostics is not None}
    drift["scale"] = drift.pop("mean")
    axes = _axes(attitude)
    new = {}
    for axis, (name, calibration) in enumerate(old.items()):
        step = _provenance(
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
        if axes[name]["updated"]:
            draws = posterior.states[:, alignment.layout.coefficients[axis]]
            new[name] = _updated(calibration, draws, si, heat[:, axis], step, sampler, drift)
        else:
            new[name] = replace(
                calibration, provenance=(*calibration.provenance, step), origin=None
            )
    latitude = math.radians(context["latitude"])
    gravity = normal_gravity(context["latitude"], context["height"])
    innovations = _innovation_check(posterior.filtered)
    failures = list(sampler["failures"])
    if not innovations["passed"]:
        failures.append(
            f"the velocity innovations (sum of NIS {innovations['sum_nis']:.4g}) exceed the "
            f"99.9 % chi^2 limit {innovations['upper_limit']:.4g}: the vehicle swayed or moved, "
            "or the noise is larger than the model holds"
        )
    coarse, final = (
        dict(
            zip(
                ("roll", "pitch", "heading"),
                np.degrees(np.asarray(euler_from_dcm(c))).tolist(),
                strict=True,
            )
        )
        for c in (alignment.coarse_attitude, attitude)
    )
    notes = list(context["notes"])
    for name, calibration in old.items():
        outside = calibration.outside_range(heat[:, list(old).index(name)])
        if outside.any():
            notes.append(
                f"{name}: {100 * outside.mean():.3g} % of the alignment lies outside the "
                f"calibrated range {calibration.temperature_range}: the old polynomial is "
                "extrapolated there"
            )
    return InFieldUpdate(
        calibration=new,
        heading_error={
            **_summary(heading, "deg"),
            "definition": "computed minus true heading at the alignment's end",
        },
        points=_points(alignment, old, heat, posterior, si),
        classical=_classical(alignment, old, heat, attitude, latitude, gravity, si),
        checks={
            "passed": not failures,
            "failures": failures,
            "sampler": sampler,
            "innovations": innovations,
        },
        axes=axes,
        projections=_projections(alignment, priors, old, heat, posterior, attitude),
        drift=drift,
        alignment={
            "start_s": context["window"][0],
            "stop_s": context["window"][1],
            "latitude_deg": context["latitude"],
            "height_m": context["height"],
            "coarse_attitude_deg": coarse,
            "final_attitude_deg": final,
            "gyro_white_noise": {
                "value": (alignment.noise["gyro"] / math.radians(1) * 60).tolist(),
                "unit": "deg/sqrt(h)",
            },
            "accel_white_noise": {
                "value": alignment.noise["accel"].tolist(),
                "unit": "m/s^2/sqrt(Hz)",
            },
            "filter_step_s": float(alignment.times[1] - alignment.times[0]),
        },
        notes=tuple(notes),
        posterior=posterior,
    )
