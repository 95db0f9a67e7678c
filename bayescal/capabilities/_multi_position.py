"""Multi-position accelerometer calibration: the classical least squares with g fixed
(:mod:`bayescal.classical._multi_position`) and the posterior of the Bayesian model
(:mod:`bayescal.models._multi_position`), g_local drawn from its prior for each draw."""

import math
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._errors import HealthCheckError, InputError
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
from ..inference._mcmc import (
    Diagnostics,
    batch_log_density,
    diagnose,
    sample_ensemble,
    walker_count,
)
from ..inference._optimize import maximum_a_posteriori
from ..models._multi_position import MultiPositionProblem, multi_position_problem
from ..recording._sections import MIN_DURATION_S


@dataclass(frozen=True)
class BayesianCalibration:
    names: tuple[str, ...]
    """The calibration parameters, then pose_scatter and g_local."""
    draws: dict
    """name -> (walkers, draws) posterior draws."""
    map_values: dict
    map_sd: dict
    """Laplace (Hessian) standard deviations at the MAP, by the delta method, gravity's
    uncertainty included in the scales and the pose scatter."""
    diagnostics: Diagnostics


def bayesian_multi_position(
    poses: Poses,
    classical: ClassicalCalibration,
    *,
    seed: int = 0,
    n_walkers: int = 32,
    max_steps: int = 40_000,
    progress: bool = False,
) -> BayesianCalibration:
    """Posterior of the calibration parameters, the pose scatter sigma_p (m/s^2) and g_local,
    with its MAP and health checks. The same inputs and ``seed`` give the same result."""
    problem = multi_position_problem(poses, classical)
    gravity = classical.gravity
    names = (*classical.names, "pose_scatter")
    n_calibration = len(classical.names)
    rng = np.random.default_rng(seed)
    mode = maximum_a_posteriori(
        MultiPositionProblem.log_posterior, problem, jnp.zeros_like(problem.location)
    )
    best, map_converged, covariance = mode.theta, mode.converged, mode.covariance
    sampler, converged = sample_ensemble(
        batch_log_density(MultiPositionProblem.log_posterior, problem),
        np.asarray(best),
        covariance,
        rng,
        walker_count(len(names), n_walkers),
        max_steps,
        progress,
    )
    diagnostics, kept = diagnose(sampler, names, converged, bool(map_converged))
    u = np.asarray(problem.location) + np.asarray(problem.step) * kept
    g = gravity.value + gravity.uncertainty * rng.standard_normal(u.shape[:-1])

    def physical(u, g):
        """Calibration parameters, pose scatter and g from coordinates u in units of g."""
        values = np.concatenate(
            [g[..., None] * np.exp(u[..., :3]), u[..., 3:n_calibration]], axis=-1
        )
        scatter = g * np.exp(u[..., n_calibration])
        return {
            **{name: values[..., i] for i, name in enumerate(classical.names)},
            "pose_scatter": scatter,
            "g_local": g,
        }

    draws = physical(u, g)
    u_map = np.asarray(problem.location) + np.asarray(problem.step) * np.asarray(best)
    map_values = {
        name: float(value) for name, value in physical(u_map, np.asarray(gravity.value)).items()
    }
    u_sd = np.asarray(problem.step) * np.sqrt(np.maximum(np.diag(covariance), 0.0))
    relative_g = gravity.uncertainty / gravity.value
    map_sd = {"g_local": gravity.uncertainty}
    for i, name in enumerate(names):
        if i < 3 or name == "pose_scatter":
            map_sd[name] = map_values[name] * math.hypot(u_sd[i], relative_g)
        else:
            map_sd[name] = float(u_sd[i])
    return BayesianCalibration((*names, "g_local"), draws, map_values, map_sd, diagnostics)


@dataclass(frozen=True)
class MultiPositionCalibration:
    """A multi-position calibration of a three-axis accelerometer
    (:func:`calibrate_multi_position`): the poses, the classical least squares and the
    posterior."""

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
    def passed(self) -> bool:
        """Whether the posterior passed its sampler checks (True when none was sampled)."""
        return self.bayesian is None or bool(self.bayesian.diagnostics.passed)

    def check(self) -> "MultiPositionCalibration":
        """Raise :class:`~bayescal.HealthCheckError` when the posterior failed its checks.

        Returns
        -------
        MultiPositionCalibration
            This result, unchanged, when every check passed, so that the call chains
            (``result = capability(...).check()``).

        Raises
        ------
        HealthCheckError
            A check failed; the message names each.
        """
        if not self.passed:
            raise HealthCheckError(
                "multi-position: posterior checks failed: "
                + "; ".join(self.bayesian.diagnostics.failures)
            )
        return self


def calibrate_multi_position(
    values,
    rate_hz: float | None = None,
    *,
    gravity: LocalGravity,
    unit: str = "m/s^2",
    orientations: str = "free",
    sections: list[tuple[float, float]] | None = None,
    min_still_s: float = MIN_DURATION_S,
    start_s: float = 0.0,
    confidence: float = 0.95,
    bayesian: bool = True,
    seed: int = 0,
    progress: bool = False,
) -> MultiPositionCalibration:
    """Scale, offset and misalignment of a three-axis accelerometer from still poses.

    Parameters
    ----------
    values : array_like (samples, 3), or Poses
        The x, y and z readings on one grid (``unit``: m/s^2, g, or counts such as LSB), or
        the still poses already found (:class:`~bayescal.Poses`, e.g. from
        :meth:`Poses.from_samples`).
    rate_hz : float
        Sample rate, Hz (readings only).
    gravity : LocalGravity
        Local gravity.
    orientations : "free" or "six-face"
        Any orientations, gravity's magnitude only (imu_tk; 10 or more poses in 9 or more
        orientations), or each pose on a face of a cube (Ferraris; every face at least once).
    sections : list of (start, stop), optional
        The still poses in seconds from ``start_s`` (default: found, each still for at least
        ``min_still_s``).
    min_still_s : float
        The shortest stillness (s) that counts as a pose when the poses are found; too few
        found poses are listed in the error, with a shorter minimum that finds enough.
    confidence : float
        Confidence of the classical half-widths.
    bayesian : bool
        Also the posterior (else the classical answer only).
    seed : int
        The same inputs and seed give the same posterior.

    Returns
    -------
    MultiPositionCalibration

    Raises
    ------
    InputError
        Too few poses or orientations, a moving section, a unit that does not fit gravity,
        poses that do not determine the calibration.
    """
    if orientations not in ORIENTATIONS:
        raise InputError(
            f"--orientations {orientations!r} is not known", fix="choose free or six-face"
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
        bayesian_multi_position(poses, classical, seed=seed, progress=progress)
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
                f"--min-still {shorter:g} finds {found.n} poses in "
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
            fix="give the poses with --sections",
        )
    return find_poses(
        values, rate_hz, sections=sections, start_s=start_s, unit=unit, min_duration_s=min_still_s
    )
