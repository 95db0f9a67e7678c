"""The in-field update of a strapdown system's gyro thermal calibration from its own alignment
(claim 1 of US 5,527,003, steps a-j, at rest; ../shared/NAVIGATION.md).

It composes the layers below: the recording's gyros, accelerometers and temperatures in the
alignment window (checked still), the old calibration taken off the gyros, the mechanization
and fine-alignment filter of :mod:`bayescal.navigation._alignment`, the posterior of the aging
since the calibration (:mod:`bayescal.inference._infield`), and the patent's classical tilt
rates block by block (:mod:`bayescal.navigation._tilt_rates`) beside it.

What the alignment can tell (NAVIGATION.md): the north-projected bias and the north and east
projections of the thermal slope, and the down-projected bias through the computed heading's
turn over the park (a still vehicle does not turn: the vertical gyro); not the east bias
level, which at rest is one quantity with the heading error (its interval stays as wide as the
prior) until a taxi tells the heading. A gyro whose axis lies within 60 deg of the vertical
counts as vertical (the patent's tilt rates leave it out).
"""

import math
from dataclasses import dataclass, field

import numpy as np

from .._caches import release_compiled_code
from .._errors import InputError
from .._output import to_jsonable
from ..classical._gravity import normal_gravity
from ..inference._infield import sample_alignment
from ..inference._sampler import Sampler, sampler_of
from ..inference._thermal_posterior import central_gaussian
from ..navigation._alignment import (
    DRIFT_PRIOR_SCALE,
    POSITION_SD,
    find_motion,
    fine_alignment,
)
from ..navigation._alignment import heading_sensitivity as _heading_row
from ..navigation._earth import check_latitude
from ..navigation._error_model import TILT
from ..navigation._frames import dcm_from_euler, euler_from_dcm
from ..navigation._free_inertial import FLIGHT_S, position_error_map
from ..navigation._simulate import ACCELEROMETERS, GYROS
from ..navigation._taxi import WANDER_SD, WANDER_TIME_S, TaxiReference
from ..recording._recording import Recording, load_recording
from ..recording._units import parse_unit
from ._checked import Checked
from ._infield_inputs import (
    alignment_window,
    check_wander,
    gyro_priors,
    old_calibrations,
    position_names,
    read_alignment,
    read_positions,
    taxi_reference,
)
from ._infield_summary import (
    calibration_notes,
    calibrations,
    classical,
    computed_track,
    informed_axes,
    innovation_check,
    leg_innovation_checks,
    points,
    projection,
    projections,
    summary,
    taxi_summary,
)
from ._thermal import save_thermal_calibrations as _save

ACCEL_INSTABILITY = 1e-5
"""The accelerometers' bias instability assumed, m/s^2 (1 ug: navigation grade)."""


@dataclass(frozen=True)
class InFieldUpdate(Checked):
    """The gyro thermal calibrations updated from an alignment at rest, with what the
    alignment could and could not tell.

    Made by :func:`infield_update`; :meth:`save` writes the calibrations as one file,
    :meth:`to_document` the whole result.

    Attributes
    ----------
    calibration : dict
        Channel -> its updated :class:`~bayescal.ThermalCalibration` (its provenance saying
        how the alignment informed it).
    heading_error : dict
        The heading error at the window's end (the taxi's end when there is one), computed
        minus true: ``mean``, ``sd``, ``q05``, ``q95`` in degrees, and its posterior
        ``correlation_with_east_level``. At rest it is the east bias level in disguise
        (correlation near -1); a taxi along a known track tells it, and the two separate.
    points : dict
        Channel -> the (temperature, gyro bias) pairs of the fine alignment's smoother, one
        per block: ``time_s``, ``temperature``, ``bias``, ``sd`` and the ``unit``.
    classical : dict
        The patent's tilt rates block by block: the north bias and the east bias less the
        heading term per block, and each gyro's points (its vertical part taken as the old
        calibration's).
    checks : dict
        ``passed``, ``failures``, the sampler's checks, the velocity innovations' check and
        each taxi leg's cross-track innovations' check (``taxi_innovations``).
    axes : dict
        Channel -> whether the alignment informs it (every gyro), and how.
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
    taxi : dict
        The taxi, when one was given: its window, the track headings, how many filter steps lay
        on each leg, the position reference (``positions``: its columns, sd in m and fixes in
        the taxi), whether it told the heading (``informative``) and which reference told it
        (``reference``: ``track heading``, ``position fixes`` or both).
    notes : tuple of str
        What the run noticed (temperatures outside the calibrated range, ...).
    track : dict
        The computed (free-inertial) position at each filter step, north and east of the
        first (m), and the taxi leg each step lay on (-1: the park, or off the legs).
    old_calibration : dict
        Channel -> the old :class:`~bayescal.ThermalCalibration` (the prior).
    posterior : object
        The draws behind it (the drift scale and every state at the alignment's end).
    coefficient_draws : dict
        Channel -> the joint posterior's draws of its polynomial's coefficients (draws,
        degree + 1), the calibrations' units; the draws keep the correlations
        between the gyros that the per-gyro calibrations drop.
    """

    _check_subject = "in-field update"

    calibration: dict
    heading_error: dict
    points: dict
    classical: dict
    checks: dict
    axes: dict
    projections: dict
    drift: dict
    alignment: dict
    taxi: dict | None = None
    notes: tuple[str, ...] = ()
    track: dict = field(default_factory=dict)
    old_calibration: dict = field(default_factory=dict, compare=False, repr=False)
    posterior: object = field(default=None, compare=False, repr=False)
    coefficient_draws: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def passed(self) -> bool:
        """Whether every check passed."""
        return bool(self.checks["passed"])

    @property
    def failures(self) -> tuple[str, ...]:
        """Each failed check, in words (empty when every check passed)."""
        return tuple(self.checks["failures"])

    def position_error(
        self,
        temperature,
        *,
        speed: float = 0.0,
        duration_s: float = FLIGHT_S,
        calibration: dict | None = None,
    ) -> dict:
        """The horizontal position error the updated calibrations (or ``calibration``) leave
        after free inertial navigation (steps p-q of the claim: the gyros compensated at their
        temperature), as the posterior predicts it.

        The next mission aligns where this one parked (gyrocompassed and levelled), then
        navigates for ``duration_s``, parked or at ``speed`` turning 90 deg every 15 min
        (:func:`~bayescal.navigation._free_inertial.position_error_map`, the phi-angle error
        model of Titterton & Weston 2004 ch. 12). The error is linear in the gyros' residual
        biases (calibration minus truth), so each joint posterior draw of the three
        polynomials gives one draw of it; its Gaussian is the draws' bulk
        (:func:`~bayescal.inference._thermal_posterior.central_gaussian`).

        Parameters
        ----------
        temperature : float or sequence of float
            The gyros' temperature in flight, the calibrations' temperature unit: one for all
            three or one each.
        speed : float
            Ground speed, m/s (0: parked).
        duration_s : float
            How long it navigates, s.
        calibration : dict, optional
            Channel -> the :class:`~bayescal.ThermalCalibration` the next mission compensates
            with (default: the updated ones); ``update.old_calibration`` gives the error that
            keeping the old calibration leaves, as the posterior sees it.

        Returns
        -------
        dict
            ``mean`` and ``covariance`` of the (north, east) error (m, m^2), ``sd`` (the root
            of the covariance's trace, m: the horizontal error's rms spread) and ``map`` (the
            (2, 3) matrix from the body gyros' residuals, m per calibration unit).

        Examples
        --------
        >>> update.position_error(38.6, speed=250.0)["sd"]  # m  # doctest: +SKIP
        310.0
        """
        temperature = np.broadcast_to(np.asarray(temperature, dtype=float), (3,))
        first = next(iter(self.calibration.values()))
        si = parse_unit(first.unit).to_si
        attitude = dcm_from_euler(*np.radians(list(self.alignment["park_attitude_deg"].values())))
        mapping = position_error_map(
            self.alignment["latitude_deg"],
            np.asarray(attitude),
            speed=speed,
            duration_s=duration_s,
            height=self.alignment["height_m"],
        )
        used = self.calibration if calibration is None else calibration
        residuals = []
        for axis, (name, updated) in enumerate(self.calibration.items()):
            powers = (temperature[axis] - updated.reference) ** np.arange(updated.degree + 1)
            bias = used[name].bias(temperature[axis])[0]
            residuals.append(bias - self.coefficient_draws[name] @ powers)
        errors = si * np.stack(residuals, axis=1) @ mapping.T
        mean, covariance = central_gaussian(errors)
        return {
            "mean": mean,
            "covariance": covariance,
            "sd": float(np.sqrt(np.trace(covariance))),
            "unit": "m",
            "map": mapping * si,
            "speed_m_s": speed,
            "duration_s": duration_s,
        }

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
            ``checks``, ``alignment``, ``taxi``, ``track`` and ``notes``.
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
                "taxi": self.taxi,
                "track": self.track,
                "notes": list(self.notes),
            }
        )


def infield_update(
    recording,
    calibration,
    *,
    latitude: float,
    align: tuple[float, float],
    taxi: tuple[float, float] | None = None,
    track_heading=None,
    positions=None,
    position_sd: float = POSITION_SD,
    wander: tuple[float, float] = (WANDER_SD, WANDER_TIME_S),
    seed: int = 0,
    drift: float | str = "auto",
    gyro_columns=GYROS,
    accel_columns=ACCELEROMETERS,
    temperature=None,
    unit: str | None = None,
    accel_unit: str | None = None,
    rate_hz: float | None = None,
    time_column: str | None = None,
    time_unit: str | None = None,
    height: float = 0.0,
    accel_instability: float = ACCEL_INSTABILITY,
    sampler: Sampler = Sampler(),
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
    taxi : (float, float), optional
        The taxi after the park, seconds from the first sample (starting at or after the
        park's end): mechanized on from the alignment, its steps on a straight leg of known
        heading measure the computed cross-track velocity, which tells the heading error and
        so separates it from the east bias level (steps k-l of the claim).
    track_heading : float or sequence of float or str, optional
        The taxiway's known track heading, deg from north: one, or one per straight leg
        (``"120,210"`` as a string too). Without it or ``positions`` the taxi tells nothing
        about the heading (a note says so) and the east level stays at its prior.
    positions : (str, str) or str, optional
        A position reference (GNSS): the recording's north and east position columns
        (``"gnss_latitude,gnss_longitude"`` as a string too), latitude and longitude in an
        angle unit (deg, rad) or north and east in m, as the header declares; NaN or empty
        where there is no fix. The value at each filter step's sample (once a second) is taken
        as the position then, and the first such fix lies in the park. The computed position
        less each fix measures the position error; the heading error turns the computed
        track away from the fixes by psi times the distance run, so the taxi tells the heading
        without a known track (both may be given).
    position_sd : float
        sd of a fix's north and east error, m (white).
    wander : (float, float)
        The vehicle's wander about the taxiway's centre line: its sd (m) and time constant
        (s) (a second-order Gauss-Markov process, :mod:`bayescal.navigation._taxi`). It sets
        how well the taxi tells the heading: over simulated 10-minute taxis at 10 m/s the east
        level's sd is about 0.0065 deg/h at 0.5 m (the default), 0.004 deg/h at 0.05 m.
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
    rate_hz, time_column, time_unit
        The time base, as for every recording (:meth:`~bayescal.Recording.channel`).
    height : float
        Height above the ellipsoid, m.
    accel_instability : float
        The accelerometers' bias instability, m/s^2.
    sampler : Sampler
        The sampler's settings (:class:`~bayescal.Sampler`), used when the aging scale is
        learned.

    Returns
    -------
    InFieldUpdate
        The updated calibrations, heading error, points, classical points and checks.

    Raises
    ------
    InputError
        Motion in the alignment window (where), a missing temperature, a latitude out of
        range, a window too short, a calibration of other channels or units, a taxi window
        before the park's end or past the record, a track heading or positions without a taxi,
        position columns that are missing, of no declared unit, or with no fix in the park, a
        wander whose sd or time constant is not positive.

    Examples
    --------
    >>> import bayescal as bc
    >>> update = bc.infield_update(
    ...     "park.csv", "old.json", latitude=45.2, align=(0, 1200)
    ... ).check()  # doctest: +SKIP
    >>> update.projections["north"]["level"]["sd"]  # deg/h  # doctest: +SKIP
    0.0037
    >>> update.axes["gyro_z"]["informed_by_alignment"]  # doctest: +SKIP
    True
    >>> update.save("new.json")  # doctest: +SKIP
    """
    release_compiled_code()
    latitude = check_latitude(latitude)
    window = alignment_window(align)
    taxi_window, headings = taxi_reference(taxi, track_heading, window)
    position_columns, position_sd = position_names(positions, position_sd, taxi_window)
    wander_sd, wander_time_s = check_wander(wander)
    if drift != "auto" and not (isinstance(drift, (int, float)) and 0 <= drift < math.inf):
        raise InputError(
            f"drift {drift!r}", fix="give auto, 0 (no aging) or a positive scale in the gyros' unit"
        )
    if not isinstance(recording, Recording):
        recording = load_recording(recording)
    columns = {"gyro": gyro_columns, "accel": accel_columns, "temperature": temperature}
    columns |= {"unit": unit, "accel_unit": accel_unit}
    options = {"rate_hz": rate_hz, "time_column": time_column, "time_unit": time_unit}
    read = window if taxi_window is None else (window[0], taxi_window[1])
    gyro, accel, heat, first, heat_unit, notes = read_alignment(recording, read, columns, options)
    old = old_calibrations(calibration, gyro_columns, first.unit, heat_unit)
    fixes = None
    if position_columns is not None:
        fixes = read_positions(recording, position_columns, first, options, height)
    si = parse_unit(first.unit).to_si
    park = min(gyro.shape[0], round((window[1] - window[0]) * first.rate_hz))
    moved = find_motion(gyro[:park] * si, accel[:park], first.rate_hz)
    if moved is not None:
        raise InputError(
            f"the vehicle moves during the alignment window: at t = {first.start_s + moved[0]:.1f}"
            f" s {moved[1]}",
            source=recording.source,
            fix="give a still window for the alignment (its start and stop, s)",
        )
    compensated = si * np.stack(
        [gyro[:, axis] - cal.bias(heat[:, axis])[0] for axis, cal in enumerate(old.values())], 1
    )
    priors = gyro_priors(old, heat, first.rate_hz, si)
    sd_c0 = float(np.exp(np.mean([0.5 * math.log(p.covariance[0, 0]) for p in priors])))
    location = math.log(DRIFT_PRIOR_SCALE * sd_c0)
    reference = None
    if taxi_window is not None and headings:
        start = round((taxi_window[0] - window[0]) * first.rate_hz)
        reference = TaxiReference(
            start_sample=start,
            headings_deg=headings,
            wander_sd=wander_sd,
            wander_time_s=wander_time_s,
        )
    alignment = fine_alignment(
        compensated,
        accel,
        first.rate_hz,
        priors,
        latitude=math.radians(latitude),
        height=height,
        reference_drift=math.exp(location),
        accel_instability=accel_instability,
        park_samples=park,
        taxi=reference,
        positions=fixes,
        position_sd=position_sd,
    )
    posterior = sample_alignment(
        alignment,
        location=location,
        seed=seed,
        drift=drift if drift == "auto" else drift * si,
        sampler=sampler_of(sampler),
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
        "taxi": taxi_window,
        "headings": headings,
        "positions": position_columns,
        "position_sd": position_sd,
        "park_samples": park,
    }
    return _result(alignment, posterior, old, heat, priors, context)


def _result(alignment, posterior, old: dict, heat, priors, context: dict) -> InFieldUpdate:
    """Every part of the :class:`InFieldUpdate` from the alignment and its posterior."""
    si, unit = context["si"], context["unit"]
    final_attitude = alignment.trajectory.attitude[-1]
    attitude = alignment.trajectory.attitude[alignment.park_steps - 1]
    park_heat = heat[: context["park_samples"]]
    heading = np.degrees(posterior.states[:, TILT] @ _heading_row(final_attitude))
    taxi = taxi_summary(alignment, context)
    told = bool(taxi and taxi["informative"])
    if posterior.diagnostics is None:
        sampler = {
            "passed": True,
            "failures": [],
            "method": "the aging scale was given: one Gaussian posterior, nothing sampled",
        }
    else:
        sampler = posterior.diagnostics.as_dict()
    drift = {**summary(posterior.drift / si, unit), "learned": posterior.diagnostics is not None}
    drift["scale"] = drift.pop("mean")
    axes = informed_axes(attitude, list(old), taxi=told)
    new = calibrations(alignment, posterior, old, heat, axes, sampler, drift, context)
    latitude = math.radians(context["latitude"])
    gravity = normal_gravity(context["latitude"], context["height"])
    innovations = innovation_check(posterior.filtered)
    failures = list(sampler["failures"])
    if not innovations["passed"]:
        failures.append(
            f"the velocity innovations (sum of NIS {innovations['sum_nis']:.4g}) exceed the "
            f"99.9 % chi^2 limit {innovations['upper_limit']:.4g}: the vehicle swayed or moved, "
            "or the noise is larger than the model holds"
            + (
                " (the position fixes' residuals included: their errors may be larger than "
                "position_sd or not white)"
                if context["positions"] is not None
                else ""
            )
        )
    legs = leg_innovation_checks(posterior.filtered, alignment.legs, context["headings"])
    failures += [
        f"the cross-track innovations on the {leg['track_heading_deg']:g} deg leg (sum of NIS "
        f"{leg['sum_nis']:.4g} over {leg['dof']} steps) exceed the 99.9 % chi^2 limit "
        f"{leg['upper_limit']:.4g}: the taxi holds more than its model (wander, track, "
        "linearization), and the heading it tells would be overconfident"
        for leg in legs
        if not leg["passed"]
    ]
    coarse, final, park_attitude = (
        dict(
            zip(
                ("roll", "pitch", "heading"),
                np.degrees(np.asarray(euler_from_dcm(c))).tolist(),
                strict=True,
            )
        )
        for c in (alignment.coarse_attitude, final_attitude, attitude)
    )
    notes = calibration_notes(old, heat, context)
    if taxi is not None and not told:
        notes.append(taxi["why"])
    east, east_old = projection(alignment.layout, priors, old, park_heat, attitude, 1, "level")
    park_heading = None
    if told:
        # The patent's heading error: the smoother's at the park's end, one constant for the
        # park's points (steps m-n).
        means, _ = alignment.model.smooth(posterior.filtered)
        state = np.asarray(means[alignment.park_steps - 1]) * np.asarray(alignment.model.scale)
        park_heading = float(state[TILT] @ _heading_row(attitude))
    correlation = float(np.corrcoef(heading, posterior.states @ east + east_old)[0, 1])
    return InFieldUpdate(
        calibration=new,
        heading_error={
            **summary(heading, "deg"),
            "correlation_with_east_level": correlation,
            "definition": "computed minus true heading at the window's end (the taxi's end "
            "when there is one)",
        },
        points=points(alignment, old, park_heat, posterior, si),
        classical=classical(
            alignment, old, park_heat, attitude, latitude, gravity, si, park_heading
        ),
        checks={
            "passed": not failures,
            "failures": failures,
            "sampler": sampler,
            "innovations": innovations,
            "taxi_innovations": legs,
        },
        axes=axes,
        projections=projections(alignment, priors, old, park_heat, posterior, attitude, told),
        drift=drift,
        alignment={
            "start_s": context["window"][0],
            "stop_s": context["window"][1],
            "latitude_deg": context["latitude"],
            "height_m": context["height"],
            "coarse_attitude_deg": coarse,
            "final_attitude_deg": final,
            "park_attitude_deg": park_attitude,
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
        taxi=taxi,
        notes=tuple(notes),
        track=computed_track(alignment),
        old_calibration=dict(old),
        posterior=posterior,
        coefficient_draws={
            name: calibration.coefficients
            + posterior.states[:, alignment.layout.coefficients[axis]] / si
            for axis, (name, calibration) in enumerate(old.items())
        },
    )
