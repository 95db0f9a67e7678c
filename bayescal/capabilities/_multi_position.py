"""Multi-position accelerometer calibration: the classical least squares with g fixed
(:mod:`bayescal.classical._multi_position`) and the posterior of the Bayesian model
(:mod:`bayescal.models._multi_position`; sampled by
:mod:`bayescal.inference._multi_position_posterior`), g_local drawn from its prior for each
draw."""

from dataclasses import dataclass

import numpy as np

from .._caches import release_compiled_code
from .._errors import InputError
from ..classical._gravity import LocalGravity
from ..classical._multi_position import (
    ORIENTATIONS,
    ClassicalCalibration,
    Poses,
    check_unit,
    classical_multi_position,
    describe_poses,
    distinct_orientations,
    find_poses,
    pose_shortfall,
)
from ..inference._mcmc import summarize
from ..inference._multi_position_posterior import BayesianCalibration, bayesian_multi_position
from ..inference._sampler import Sampler, sampler_of
from ..recording._inputs import channel_input
from ..recording._recording import Channel
from ..recording._sections import MIN_DURATION_S
from ..recording._units import parse_unit
from ._checked import Checked


def scale_unit(unit: str) -> str:
    """The unit of a scale for readings in ``unit``: m/s^2 per it (1 when it is m/s^2)."""
    if parse_unit(unit).name == "m/s^2":
        return "1"
    return f"m/s^2/({unit})" if "/" in unit else f"m/s^2/{unit}"


@dataclass(frozen=True)
class MultiPositionCalibration(Checked):
    """A multi-position calibration of a three-axis accelerometer
    (:func:`calibrate_multi_position`): the poses, the classical least squares and the
    posterior."""

    _check_subject = "multi-position: posterior checks failed"

    unit: str
    """The readings' unit (counts welcome); offsets are in it, scales in m/s^2 per it."""
    rate_hz: float | None
    """Sample rate, Hz (None for poses given as means)."""
    poses: Poses
    """The still poses used: mean, sd, count and times of each."""
    found_by: str
    """How the poses were found (still sections of the recording, or given)."""
    classical: ClassicalCalibration
    """Least squares at g = g_local: scales K, offsets b, misalignment angles (rad) with
    covariance s^2 (J^T J)^-1 and Student-t half-widths; the calibration matrices."""
    bayesian: BayesianCalibration | None
    """The posterior (draws, MAP with Laplace sd, sampler checks); None with
    ``bayesian=False``."""

    @property
    def units(self) -> dict:
        """parameter -> its unit: scales in m/s^2 per reading unit (1 for readings in
        m/s^2), offsets in the readings' unit, angles in rad, the pose scatter and g_local
        in m/s^2."""
        units = {"pose_scatter": "m/s^2", "g_local": "m/s^2"}
        for name in self.classical.names:
            if name.startswith("scale_"):
                units[name] = scale_unit(self.unit)
            elif name.startswith("offset_"):
                units[name] = self.unit
            else:
                units[name] = "rad"
        return units

    @property
    def summary(self) -> dict:
        """parameter -> ``{mean, sd, q05, q95, map, map_sd, unit}`` from the posterior (its
        90 % interval, and the MAP with its Laplace sd): the scales, misalignment angles and
        offsets, the pose scatter and g_local; with ``bayesian=False``, the classical least
        squares instead, ``{value, half_width, confidence, unit}``."""
        units = self.units
        if self.bayesian is None:
            return {
                name: {
                    "value": value,
                    "half_width": half_width,
                    "confidence": self.classical.confidence,
                    "unit": units[name],
                }
                for name, (value, half_width) in self.classical.parameters.items()
            }
        posterior = self.bayesian
        return {
            name: summarize(
                posterior.draws[name],
                units[name],
                posterior.map_values[name],
                posterior.map_sd[name],
            )
            for name in posterior.names
        }

    @property
    def passed(self) -> bool:
        """Whether the posterior passed its sampler checks (True when none was sampled)."""
        return self.bayesian is None or bool(self.bayesian.diagnostics.passed)

    @property
    def failures(self) -> tuple[str, ...]:
        """The posterior's failed sampler checks (empty when it passed or none was sampled)."""
        return () if self.bayesian is None else tuple(self.bayesian.diagnostics.failures)


def calibrate_multi_position(
    values,
    rate_hz: float | None = None,
    *,
    gravity: LocalGravity,
    unit: str | None = None,
    orientations: str = "free",
    sections: list[tuple[float, float]] | None = None,
    min_still_s: float = MIN_DURATION_S,
    start_s: float | None = None,
    confidence: float = 0.95,
    bayesian: bool = True,
    seed: int = 0,
    sampler: Sampler = Sampler(),
) -> MultiPositionCalibration:
    """Scale, offset and misalignment of a three-axis accelerometer from still poses.

    Parameters
    ----------
    values : array_like (samples, 3), three Channels, or Poses
        The x, y and z readings on one grid (``unit``: m/s^2, g, or counts such as LSB), as
        one array or as the three axes' :class:`~bayescal.Channel` (which bring their rate,
        unit and start), or the still poses already found (:class:`~bayescal.Poses`, e.g.
        from :meth:`Poses.from_samples`).
    rate_hz : float
        Sample rate, Hz (readings only; from the channels when they are Channels).
    gravity : LocalGravity
        Local gravity.
    unit : str, optional
        The readings' unit (the Channels' own, else m/s^2).
    orientations : "free" or "six-face"
        Any orientations, gravity's magnitude only (imu_tk; 10 or more poses in 9 or more
        orientations), or each pose on a face of a cube (Ferraris; every face at least once).
    sections : list of (start, stop), optional
        The still poses in seconds from ``start_s`` (default: found, each still for at least
        ``min_still_s``).
    start_s : float, optional
        Time of the first reading, s (the Channels' start, else 0).
    min_still_s : float
        The shortest stillness (s) that counts as a pose when the poses are found; too few
        found poses are listed in the error, with a shorter minimum that finds enough.
    confidence : float
        Confidence of the classical half-widths.
    bayesian : bool
        Also the posterior (else the classical answer only).
    seed : int
        The same inputs and seed give the same posterior.
    sampler : Sampler
        How the posterior is sampled (:class:`~bayescal.Sampler`).

    Returns
    -------
    MultiPositionCalibration

    Raises
    ------
    InputError
        Too few poses or orientations, a moving section, a unit that does not fit gravity,
        poses that do not determine the calibration, Channels not on one grid.
    """
    release_compiled_code()
    values, rate_hz, unit, start_s = _readings(values, rate_hz, unit, start_s)
    if orientations not in ORIENTATIONS:
        raise InputError(
            f"orientations={orientations!r} is not known", fix="choose 'free' or 'six-face'"
        )
    if isinstance(values, Poses):
        poses, found_by = values, "given as poses"
    else:
        poses = _poses(values, rate_hz, sections, start_s, unit, min_still_s)
        found_by = (
            "--sections"
            if sections
            else f"still sections of at least {min_still_s:g} s found in the record"
        )
    check_unit(poses, unit)
    if not isinstance(values, Poses) and sections is None:
        _check_found_enough(values, rate_hz, poses, start_s, unit, orientations, min_still_s)
    classical = classical_multi_position(
        poses, gravity, orientations=orientations, confidence=confidence
    )
    posterior = (
        bayesian_multi_position(poses, classical, seed=seed, sampler=sampler_of(sampler))
        if bayesian
        else None
    )
    return MultiPositionCalibration(unit, rate_hz, poses, found_by, classical, posterior)


SHORTER_STILL_S = (1.5, 1.0, 0.5)
"""The shorter minimum stillness (s) offered when too few poses are found: a pose held by
hand is often still for only a second or so."""


def _check_found_enough(values, rate_hz, poses, start_s, unit, orientations, min_still_s):
    """Too few poses found: say which were found, and the longest shorter minimum stillness
    (``--min-still``) that finds enough, when one does."""
    shortfall = pose_shortfall(poses, orientations)
    if shortfall is None:
        return
    problem, fix = shortfall
    for shorter in (s for s in SHORTER_STILL_S if s < min_still_s):
        try:
            found = _poses(values, rate_hz, None, start_s, unit, shorter)
        except InputError:
            continue
        if pose_shortfall(found, orientations) is None:
            fix = (
                f"min_still_s={shorter:g} finds {found.n} poses in "
                f"{distinct_orientations(found)} orientations; or {fix}"
            )
            break
    raise InputError(
        f"{problem}; the poses found (still for at least {min_still_s:g} s): "
        f"{describe_poses(poses)}",
        fix=fix,
    )


def _poses(values, rate_hz, sections, start_s, unit, min_still_s) -> Poses:
    values = np.asarray(values, dtype=float)
    if values.ndim != 2 or values.shape[1] != 3:
        raise InputError(f"values: (samples, 3) readings of x, y, z (shape {values.shape})")
    if rate_hz is None or not rate_hz > 0:
        raise InputError(f"rate_hz={rate_hz!r} must be a positive sample rate in Hz")
    if sections is None and np.isnan(values).any():
        raise InputError(
            "still poses cannot be found across gaps or dropped samples",
            fix="give the poses with sections=",
        )
    return find_poses(
        values, rate_hz, sections=sections, start_s=start_s, unit=unit, min_duration_s=min_still_s
    )


def _readings(values, rate_hz, unit, start_s):
    """(readings, rate, unit, start) from what was given: an array (with ``rate_hz``), Poses,
    or the three axes' Channels, which must lie on one grid in one unit."""
    channels = isinstance(values, (list, tuple)) and any(isinstance(v, Channel) for v in values)
    if not channels:
        return values, rate_hz, unit or "m/s^2", 0.0 if start_s is None else start_s
    if len(values) != 3 or not all(isinstance(v, Channel) for v in values):
        raise InputError(
            f"values: {len(values)} item(s); give the three axes' Channels (x, y, z) or one "
            "(samples, 3) array"
        )
    axes = [channel_input(v, rate_hz, unit=unit, channel=None, argument="values") for v in values]
    grids = {
        (a.rate_hz, a.unit, np.shape(a.values)[0], v.start_s)
        for a, v in zip(axes, values, strict=True)
    }
    if len(grids) > 1:
        described = "; ".join(
            f"{a.channel}: {np.shape(a.values)[0]} samples at {a.rate_hz:g} Hz in {a.unit} from "
            f"{v.start_s:g} s"
            for a, v in zip(axes, values, strict=True)
        )
        raise InputError(
            f"values: the three Channels are not on one grid ({described})",
            fix="prepare the three axes alike, from one recording",
        )
    readings = np.column_stack([np.asarray(a.values, dtype=float) for a in axes])
    first = values[0].start_s if start_s is None else start_s
    return readings, axes[0].rate_hz, axes[0].unit, first
