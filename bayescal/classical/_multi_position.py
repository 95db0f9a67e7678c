"""Multi-position accelerometer calibration: scale, offset and axis misalignment of a triad
from many static poses.

**Model** (Tedaldi, Pretto & Menegatti, "A robust and easy to implement method for IMU
calibration without external equipments", ICRA 2014 — imu_tk): a raw reading r (any unit: m/s^2,
g, counts) calibrates to ``a = T K (r - b)``, with b the three offsets (raw unit), K =
diag(k_x, k_y, k_z) the scale factors (m/s^2 per raw unit) and T imu_tk's misalignment matrix in
its "body frame" form ``[[1, -a_yz, a_zy], [0, 1, -a_zx], [0, 0, 1]]``: the body frame's z axis
is the z accelerometer's sensing axis and its y axis lies in the plane of the y and z sensing
axes, so three small angles describe how far the axes are from orthogonal.

**free** orientations (imu_tk): the orientation of each pose is unknown, and only the magnitude
of gravity is used, ``||T K (m_i - b)|| = g`` for each pose mean m_i. The 9 parameters need at
least 9 distinct, well-spread orientations; bayescal asks for 10 poses (one degree of freedom
for the residual variance) in at least 9 orientations, and checks the conditioning of the
least-squares Jacobian. The first estimate is algebraic: the general quadric through the pose
means (linear least squares), whose Cholesky factor is exactly T K.

**six-face** orientations (Ferraris et al., "Procedure for effortless in-field calibration of
three-axial rate gyro and accelerometers", Sensors and Materials 7, 1995): each pose lies on a
face of a cube, so its gravity vector in the fixture frame is known, f_i = +-g e_axis (by the
dominant axis of the pose mean). The model is linear, ``m_i = M f_i + b``, M a general 3x3 matrix
(12 parameters); it is solved by linear least squares in the raw unit and reported in the same
conventions as the free model through ``M^-1 = R T K`` (a QR decomposition), where the rotation
R, written as a rotation vector, is how the sensor sits in the fixture. Several poses on one
face are allowed: they see the same gravity (the still pauses of a Ferraris rotation about the
vertical axis, for instance).

**Classical** answer: least squares with g fixed at the local value (Levenberg-Marquardt from
the algebraic or linear estimate), covariance s^2 (J^T J)^-1 with s^2 the residual variance over
N - 9 (free) or 3N - 12 (six-face) degrees of freedom, Student-t half-widths; the scales, which
are proportional to g, also carry gravity's uncertainty (as the two-position command does).

The Bayesian answer is :mod:`bayescal.models._multi_position`.
"""

import math
from dataclasses import dataclass
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from scipy import stats
from scipy.spatial.transform import Rotation

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._errors import InputError
from ..recording._inputs import check_same_length
from ..recording._sections import MIN_DURATION_S, find_static_sections
from ..recording._units import STANDARD_GRAVITY, parse_unit
from ._gravity import LocalGravity
from ._two_position import MOVING_LIMIT

ORIENTATIONS = ("free", "six-face")
AXES = "xyz"
SCALES = tuple(f"scale_{axis}" for axis in AXES)
ANGLES = ("misalignment_yz", "misalignment_zy", "misalignment_zx")
ROTATION = tuple(f"rotation_{axis}" for axis in AXES)
OFFSETS = tuple(f"offset_{axis}" for axis in AXES)
FREE_PARAMETERS = (*SCALES, *ANGLES, *OFFSETS)
SIX_FACE_PARAMETERS = (*SCALES, *ANGLES, *ROTATION, *OFFSETS)
FACES = ("+x", "-x", "+y", "-y", "+z", "-z")

MIN_FREE_POSES = 10
MIN_FREE_ORIENTATIONS = 9
# Poses whose gravity directions lie closer than this carry nearly the same magnitude
# information: they count as one orientation.
SAME_ORIENTATION_DEG = 10.0
# The least-squares Jacobian (columns in relative scale, radians and offsets in g; rows in g)
# must have its smallest singular value at least this share of its largest: below it some
# combination of the parameters is determined a thousand times worse than the best one.
MIN_CONDITIONING = 1e-3
# A six-face pose must lie within this angle of its face (the sensor may sit a little rotated
# in its fixture, and faces are rarely perfectly level).
FACE_TOLERANCE_DEG = 15.0
# Pose magnitudes must lie within this factor of g in a declared acceleration unit.
UNIT_TOLERANCE = 0.3


@dataclass(frozen=True)
class Poses:
    """Static poses: the mean, per-axis sample sd and count of each, in the raw unit."""

    mean: np.ndarray
    """(N, 3)"""
    sd: np.ndarray
    """(N, 3)"""
    count: np.ndarray
    """(N,)"""
    start_s: np.ndarray
    """(N,) seconds from the first sample of the file; NaN where unknown"""
    stop_s: np.ndarray
    """(N,) seconds from the first sample of the file; NaN where unknown"""

    @property
    def n(self) -> int:
        """The number of poses."""
        return int(self.count.size)

    @property
    def variance_of_mean(self) -> np.ndarray:
        """(N, 3) variance of each pose mean if the noise were white."""
        return self.sd**2 / self.count[:, None]

    @classmethod
    def from_samples(cls, samples, start_s=None, stop_s=None) -> "Poses":
        """Poses from a list of (samples, 3) arrays of still readings (NaN: missing).

        Parameters
        ----------
        samples : list of array_like
            One (samples, 3) array per pose, the three axes' readings in the raw unit.
        start_s, stop_s : array_like, optional
            Each pose's start and stop, s from the first sample of the file (default:
            unknown, NaN).

        Returns
        -------
        Poses
            Each pose's mean, sample sd and count.

        Raises
        ------
        InputError
            A pose with fewer than two samples, an array that is not (samples, 3), a
            ``start_s`` or ``stop_s`` without one value per pose.

        Examples
        --------
        >>> import numpy as np
        >>> import bayescal as bc
        >>> rng = np.random.default_rng(0)
        >>> up = rng.normal([0.0, 0.0, 9.81], 0.01, (200, 3))
        >>> down = rng.normal([0.0, 0.0, -9.81], 0.01, (200, 3))
        >>> poses = bc.Poses.from_samples([up, down])
        >>> poses.n, poses.mean[:, 2].round(2).tolist()
        (2, [9.81, -9.81])
        """
        blocks = [np.asarray(block, dtype=float) for block in samples]
        for index, block in enumerate(blocks):
            if block.ndim != 2 or block.shape[1] != 3:
                raise InputError(
                    f"samples[{index}] has shape {block.shape}; each pose needs a (samples, 3) "
                    "array"
                )
        check_same_length(
            ("samples", blocks),
            *((name, times) for name, times in (("start_s", start_s), ("stop_s", stop_s))),
        )
        count = np.array([np.count_nonzero(~np.isnan(block[:, 0])) for block in blocks])
        if np.any(count < 2):
            raise InputError(
                f"a pose holds {int(count.min())} sample(s)", fix="hold each pose for a few seconds"
            )
        unknown = np.full(len(blocks), np.nan)
        return cls(
            np.array([np.nanmean(block, axis=0) for block in blocks]).reshape(-1, 3),
            np.array([np.nanstd(block, axis=0, ddof=1) for block in blocks]).reshape(-1, 3),
            count,
            unknown if start_s is None else np.asarray(start_s, dtype=float),
            unknown if stop_s is None else np.asarray(stop_s, dtype=float),
        )


def find_poses(
    values: np.ndarray,
    rate_hz: float,
    *,
    sections=None,
    start_s: float = 0.0,
    min_duration_s: float = MIN_DURATION_S,
    unit: str = "",
) -> Poses:
    """Poses of a (samples, 3) recording: its still sections
    (:func:`bayescal._sections.find_static_sections` on all three channels), or the given
    ``sections``, (start, stop) pairs in seconds from the first sample, each checked to be
    still. ``start_s`` is the time of the first sample in the file; ``unit``, the readings'
    unit, goes into the messages."""
    values = np.asarray(values, dtype=float)
    if sections is None:
        still = find_static_sections(values, rate_hz, min_duration_s=min_duration_s)
        if not still:
            raise InputError(
                "no still poses found: the sensor seems to move throughout",
                fix=f"hold the sensor still for at least {min_duration_s:g} s in each "
                "orientation, or give the poses with sections=",
            )
        return Poses.from_samples(
            [values[s.start : s.stop] for s in still],
            [start_s + s.start / rate_hz for s in still],
            [start_s + s.stop / rate_hz for s in still],
        )
    time = start_s + np.arange(values.shape[0]) / rate_hz
    blocks = []
    for start, stop in sections:
        block = values[(time >= start) & (time < stop)]
        if np.count_nonzero(~np.isnan(block[:, 0])) < 16:
            raise InputError(
                f"the section {start:g}-{stop:g} s holds {block.shape[0]} sample(s)",
                fix="give sections of at least a few seconds inside the record (sections=)",
            )
        blocks.append(block)
    poses = Poses.from_samples(blocks, [s for s, _ in sections], [s for _, s in sections])
    _check_still(blocks, poses, unit)
    return poses


def _check_still(blocks, poses: Poses, unit: str) -> None:
    """A given section is not still when its mean moves between its halves by more than
    MOVING_LIMIT standard errors on some axis and by more than 1 % of the poses' radius."""
    radius = _rough_radius(poses.mean)
    for index, block in enumerate(blocks):
        present = block[~np.isnan(block[:, 0])]
        halves = np.array_split(present, 2)
        error = np.hypot(*(h.std(axis=0, ddof=1) / math.sqrt(h.shape[0]) for h in halves))
        change = np.abs(halves[1].mean(axis=0) - halves[0].mean(axis=0))
        moved = (change > MOVING_LIMIT * error) & (change > 0.01 * radius)
        if moved.any():
            # A coarsely quantized still half can have no scatter at all.
            with np.errstate(divide="ignore", invalid="ignore"):
                axis = int(np.argmax(np.where(moved, change / error, 0)))
            amount = f"{change[axis]:.4g} {unit}".strip()
            raise InputError(
                f"the section {poses.start_s[index]:g}-{poses.stop_s[index]:g} s is not still: "
                f"its {AXES[axis]} reading moves by {amount} between its halves "
                f"({change[axis] / error[axis]:.0f} standard errors)",
                fix="choose still stretches (sections=) or hold the sensor still",
            )


def _rough_centre(mean: np.ndarray) -> np.ndarray:
    """Midpoint of the extreme readings of each axis: the offset to within cross-axis and
    scale effects when the poses point both ways along each axis."""
    return (mean.max(axis=0) + mean.min(axis=0)) / 2


def _rough_radius(mean: np.ndarray) -> float:
    return float(np.median(np.linalg.norm(mean - _rough_centre(mean), axis=1)))


def check_unit(poses: Poses, unit: str) -> None:
    """In a declared acceleration unit the pose magnitudes must be near g (offsets are a small
    part of g in calibrated-ish units); a unit that fits them better is suggested. A unit of
    another quantity (deg/s ...) is refused; a count unit (LSB ...) is taken as it is."""
    parsed = parse_unit(unit)
    if parsed.known and parsed.quantity != "acceleration":
        raise InputError(
            f"the unit {unit} is a unit of {parsed.quantity.replace('_', ' ')}, not of "
            "acceleration: the three channels must be one accelerometer's",
            fix="pass unit= (m/s^2, g, mg or the sensor's count unit, LSB), and check that the "
            "three channels are one accelerometer's",
        )
    if parsed.quantity != "acceleration":
        return
    magnitude = float(np.median(np.linalg.norm(poses.mean, axis=1)))
    expected = STANDARD_GRAVITY / parsed.to_si
    if abs(magnitude / expected - 1) <= UNIT_TOLERANCE:
        return
    candidates = [
        name
        for name in ("m/s^2", "g", "mg")
        if abs(magnitude * parse_unit(name).to_si / STANDARD_GRAVITY - 1) <= UNIT_TOLERANCE
    ]
    guess = f"the unit is probably {candidates[0]}" if candidates else "the unit is probably wrong"
    raise InputError(
        f"the still poses read about {magnitude:.4g} {unit} in magnitude, but gravity is "
        f"{expected:.4g} {unit}: {guess}",
        fix=f"pass unit={candidates[0]!r}" if candidates else "check unit= and the columns",
    )


def _rough_directions(mean: np.ndarray) -> np.ndarray:
    """Each pose's rough gravity direction (unit rows): its mean about the rough centre
    (:func:`_rough_centre`), or, where that leaves nothing (a single pose is its own centre),
    its mean itself."""
    centred = mean - _rough_centre(mean)
    length = np.linalg.norm(centred, axis=1, keepdims=True)
    rough = np.where(length > 0, centred, mean)
    return rough / np.linalg.norm(rough, axis=1, keepdims=True)


def distinct_orientations(poses: Poses) -> int:
    """Orientations among the poses: poses within SAME_ORIENTATION_DEG count once."""
    limit = math.cos(math.radians(SAME_ORIENTATION_DEG))
    kept: list[np.ndarray] = []
    for direction in _rough_directions(poses.mean):
        if all(direction @ other < limit for other in kept):
            kept.append(direction)
    return len(kept)


def assign_faces(poses: Poses) -> tuple[np.ndarray, tuple[str, ...]]:
    """Unit gravity direction in the fixture frame of each pose of a six-face session, by the
    dominant axis of its mean about the rough centre, and the face names (+x ...)."""
    directions = _rough_directions(poses.mean)
    axis = np.argmax(np.abs(directions), axis=1)
    sign = np.sign(directions[np.arange(poses.n), axis])
    labels = tuple(f"{'+' if s > 0 else '-'}{AXES[a]}" for s, a in zip(sign, axis, strict=True))
    missing = [face for face in FACES if face not in labels]
    if missing:
        raise InputError(
            f"{poses.n} poses cover the faces {', '.join(sorted(set(labels)))} but not "
            f"{', '.join(missing)}: a six-face calibration needs every axis up and down",
            fix='record the missing faces, or use orientations="free" with 10 or more poses',
        )
    faces = np.zeros((poses.n, 3))
    faces[np.arange(poses.n), axis] = sign
    off = np.degrees(np.arccos(np.clip(np.sum(directions * faces, axis=1), -1, 1)))
    worst = int(np.argmax(off))
    if off[worst] > FACE_TOLERANCE_DEG:
        raise InputError(
            f"pose {worst + 1} ({_when(poses, worst)}) is {off[worst]:.0f} deg from its nearest "
            f"face ({labels[worst]}); six-face poses must each lie on a face "
            f"(within {FACE_TOLERANCE_DEG:g} deg)",
            fix='drop that pose with sections=, or use orientations="free"',
        )
    return faces, labels


def pose_shortfall(poses: Poses, orientations: str) -> tuple[str, str] | None:
    """Why ``poses`` are too few for the ``orientations`` model, and what to do: (problem,
    fix), or None when they are enough. Six-face needs six poses; free needs
    MIN_FREE_POSES poses in MIN_FREE_ORIENTATIONS distinct orientations."""
    if orientations == "six-face":
        if poses.n >= 6:
            return None
        return (
            f"found {poses.n} still pose(s); a six-face calibration needs all six",
            "hold the sensor still on each face for a few seconds, or give the poses with "
            "sections=",
        )
    if poses.n < MIN_FREE_POSES:
        return (
            f"found {poses.n} still pose(s); the free model needs at least {MIN_FREE_POSES} "
            "(9 parameters from gravity's magnitude alone)",
            "record more poses in different orientations (12 or more, spread over the "
            'sphere), or, for a six-face session, pass orientations="six-face"',
        )
    distinct = distinct_orientations(poses)
    if distinct < MIN_FREE_ORIENTATIONS:
        return (
            f"{poses.n} still poses but only {distinct} distinct orientations (poses within "
            f"{SAME_ORIENTATION_DEG:g} deg count once); the free model needs at least "
            f"{MIN_FREE_ORIENTATIONS}",
            "record more poses in different orientations, or, for a six-face session, pass "
            'orientations="six-face"',
        )
    return None


def describe_poses(poses: Poses) -> str:
    """The poses in words, one per pose: when, and which way gravity points in the sensor's
    axes (its rough direction), e.g. ``12.5-20.1 s (+z)``, or its number where the poses
    were given without times."""
    directions = _rough_directions(poses.mean)
    words = []
    for index, direction in enumerate(directions):
        axis = int(np.argmax(np.abs(direction)))
        sign = "+" if direction[axis] > 0 else "-"
        when = (
            f"{poses.start_s[index]:.1f}-{poses.stop_s[index]:.1f} s"
            if np.isfinite(poses.start_s[index])
            else f"pose {index + 1}"
        )
        words.append(f"{when} ({sign}{AXES[axis]})")
    return ", ".join(words)


def _check_enough(poses: Poses, orientations: str) -> None:
    shortfall = pose_shortfall(poses, orientations)
    if shortfall is not None:
        problem, fix = shortfall
        raise InputError(problem, fix=fix)


def _when(poses: Poses, index: int) -> str:
    if np.isnan(poses.start_s[index]):
        return "given as samples"
    return f"{poses.start_s[index]:.6g}-{poses.stop_s[index]:.6g} s"


# --- the model ------------------------------------------------------------------------------


def misalignment_matrix(angles):
    """imu_tk's T from (a_yz, a_zy, a_zx) in its body-frame (upper triangular) form."""
    a_yz, a_zy, a_zx = angles[0], angles[1], angles[2]
    one, zero = jnp.ones_like(a_yz), jnp.zeros_like(a_yz)
    return jnp.stack(
        [
            jnp.stack([one, -a_yz, a_zy]),
            jnp.stack([zero, one, -a_zx]),
            jnp.stack([zero, zero, one]),
        ]
    )


def rotation_matrix(vector):
    """Rotation by the rotation vector ``vector`` (Rodrigues), safe to differentiate at 0."""
    theta2 = vector @ vector
    small = theta2 < 1e-8
    safe = jnp.where(small, 1.0, theta2)
    theta = jnp.sqrt(safe)
    first = jnp.where(small, 1 - theta2 / 6, jnp.sin(theta) / theta)
    second = jnp.where(small, 0.5 - theta2 / 24, (1 - jnp.cos(theta)) / safe)
    x, y, z = vector[0], vector[1], vector[2]
    zero = jnp.zeros_like(x)
    cross = jnp.stack(
        [jnp.stack([zero, -z, y]), jnp.stack([z, zero, -x]), jnp.stack([-y, x, zero])]
    )
    return jnp.eye(3) + first * cross + second * cross @ cross


def _split(p, six_face: bool):
    """(scales, angles, rotation vector or None, offsets) of a parameter vector."""
    if six_face:
        return p[0:3], p[3:6], p[6:9], p[9:12]
    return p[0:3], p[3:6], None, p[6:9]


def _calibration_matrix(scales, angles):
    return misalignment_matrix(angles) * scales[None, :]


def _residuals(p, mean, faces, g, six_face: bool):
    """Free: ||T K (m_i - b)|| - g (m/s^2). Six-face: m_i - M f_i - b (raw unit), M = (R T K)^-1."""
    scales, angles, rotation, offsets = _split(p, six_face)
    matrix = _calibration_matrix(scales, angles)
    if not six_face:
        return jnp.linalg.norm((mean - offsets) @ matrix.T, axis=1) - g
    gravity = g * faces @ rotation_matrix(rotation)  # R^T f_i, row by row
    predicted = jnp.linalg.solve(matrix, gravity.T).T + offsets
    return (mean - predicted).ravel()


@partial(jax.jit, static_argnames="six_face")
def _least_squares(start, step, mean, faces, g, six_face):
    """Levenberg-Marquardt in coordinates z (p = start + step z, so that each unit of z moves
    the residuals by about g); the solution, its Jacobian and residuals, and convergence."""

    def residuals(z, _):
        return _residuals(start + step * z, mean, faces, g, six_face)

    solver = optx.LevenbergMarquardt(rtol=1e-10, atol=1e-10)
    solution = optx.least_squares(
        residuals, solver, jnp.zeros_like(start), max_steps=500, throw=False
    )
    best = start + step * solution.value
    jacobian = jax.jacfwd(_residuals)(best, mean, faces, g, six_face)
    return (
        best,
        jacobian,
        _residuals(best, mean, faces, g, six_face),
        solution.result == optx.RESULTS.successful,
    )


def _quadric_estimate(mean: np.ndarray, g: float) -> np.ndarray:
    """Free-model parameters from the general quadric through the pose means (linear least
    squares in centred, scaled coordinates): (x - c)^T Q (x - c) = 1, T K = g chol(Q) / s."""
    centre = mean.mean(axis=0)
    spread = float(np.sqrt(np.mean(np.sum((mean - centre) ** 2, axis=1))))
    x = (mean - centre) / spread
    design = np.column_stack(
        [x[:, 0] ** 2, x[:, 1] ** 2, x[:, 2] ** 2]
        + [2 * x[:, i] * x[:, j] for i, j in ((0, 1), (0, 2), (1, 2))]
        + [-2 * x[:, i] for i in range(3)]
    )
    coefficients = np.linalg.lstsq(design, np.ones(mean.shape[0]), rcond=None)[0]
    (p11, p22, p33, p12, p13, p23), linear = coefficients[:6], coefficients[6:]
    quadric = np.array([[p11, p12, p13], [p12, p22, p23], [p13, p23, p33]])
    try:
        centre_x = np.linalg.solve(quadric, linear)
        scaled = quadric / (1 + centre_x @ quadric @ centre_x)
        upper = np.linalg.cholesky(scaled).T
    except np.linalg.LinAlgError:
        raise InputError(
            "the pose means do not lie on an ellipsoid: the poses do not span enough "
            "orientations, or some are not still",
            fix="record more poses in different orientations (12 or more, spread over the sphere)",
        ) from None
    matrix = g * upper / spread
    return _from_upper(matrix, centre + spread * centre_x)


def _from_upper(matrix: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Free-model parameters of an upper-triangular T K and offsets b."""
    scales = np.diag(matrix).copy()
    t = matrix / scales[None, :]
    return np.concatenate([scales, [-t[0, 1], t[0, 2], -t[1, 2]], offsets])


def _linear_six_face(mean: np.ndarray, faces: np.ndarray, g: float) -> np.ndarray:
    """Ferraris: m_i = M f_i + b by linear least squares, then M^-1 = R (T K) by QR."""
    design = np.column_stack([g * faces, np.ones(mean.shape[0])])
    coefficients = np.linalg.lstsq(design, mean, rcond=None)[0]
    sensitivity, offsets = coefficients[:3].T, coefficients[3]
    orthogonal, upper = np.linalg.qr(np.linalg.inv(sensitivity))
    signs = np.sign(np.diag(upper))
    orthogonal, upper = orthogonal * signs[None, :], upper * signs[:, None]
    if np.linalg.det(orthogonal) < 0:
        raise InputError(
            "the three channels form a left-handed frame",
            fix="check the order (x, y, z) and the signs of the three channels",
        )
    free = _from_upper(upper, offsets)
    rotation = Rotation.from_matrix(orthogonal).as_rotvec()
    return np.concatenate([free[:6], rotation, free[6:]])


@dataclass(frozen=True)
class ClassicalCalibration:
    orientations: str
    names: tuple[str, ...]
    values: np.ndarray
    covariance: np.ndarray
    """s^2 (J^T J)^-1 at g fixed."""
    uncertainty: np.ndarray
    """Student-t half-widths at ``confidence``; the scales' include gravity's uncertainty."""
    confidence: float
    dof: int
    residual_rms: float
    """m/s^2 (free: magnitude residuals) or the raw unit (six-face: component residuals)."""
    conditioning: float
    gravity: LocalGravity
    faces: np.ndarray | None
    """(N, 3) unit gravity direction of each pose in the fixture frame (six-face)."""
    face_labels: tuple[str, ...] | None
    distinct_orientations: int

    @property
    def parameters(self) -> dict:
        return {
            name: (float(value), float(u))
            for name, value, u in zip(self.names, self.values, self.uncertainty, strict=True)
        }

    @property
    def six_face(self) -> bool:
        return self.orientations == "six-face"


def _coordinate_step(p: np.ndarray, g: float, six_face: bool) -> np.ndarray:
    """Natural size of each parameter: the scale itself, 1 rad, and 1 g in the raw unit."""
    scales = np.abs(p[:3])
    angles = np.ones(6 if six_face else 3)
    return np.concatenate([scales, angles, g / scales])


def classical_multi_position(
    poses: Poses, gravity: LocalGravity, *, orientations: str = "free", confidence: float = 0.95
) -> ClassicalCalibration:
    """Least-squares calibration with g fixed at the local value; the poses are checked first
    (count, distinct orientations or faces, conditioning)."""
    if orientations not in ORIENTATIONS:
        raise InputError(f"orientations={orientations!r} must be 'free' or 'six-face'")
    six_face = orientations == "six-face"
    g = gravity.value
    distinct = distinct_orientations(poses)
    if six_face:
        _check_enough(poses, orientations)
        faces, labels = assign_faces(poses)
        start = _linear_six_face(poses.mean, faces, g)
        names, dof = SIX_FACE_PARAMETERS, 3 * poses.n - 12
    else:
        _check_enough(poses, orientations)
        faces, labels = None, None
        start = _quadric_estimate(poses.mean, g)
        names, dof = FREE_PARAMETERS, poses.n - 9
    step = _coordinate_step(start, g, six_face)
    best, jacobian, residuals, converged = (
        np.asarray(x)
        for x in _least_squares(
            jnp.asarray(start),
            jnp.asarray(step),
            jnp.asarray(poses.mean),
            jnp.asarray(np.zeros((poses.n, 3)) if faces is None else faces),
            g,
            six_face,
        )
    )
    # Rows in g (six-face rows are raw readings: k / g per axis), columns per natural size.
    row_scale = np.tile(best[:3], poses.n) / g if six_face else np.full(poses.n, 1 / g)
    singular = np.linalg.svd(jacobian * row_scale[:, None] * step[None, :], compute_uv=False)
    conditioning = float(singular[-1] / singular[0])
    if conditioning < MIN_CONDITIONING:
        raise InputError(
            f"the {poses.n} poses do not determine the calibration (conditioning "
            f"{conditioning:.2g} < {MIN_CONDITIONING:g}): they cover too little of the sphere",
            fix="record more poses in different orientations (12 or more, spread over the sphere)",
        )
    if not converged:
        raise InputError(
            f"the least-squares fit to the {poses.n} poses did not converge",
            fix="check that every pose is still and that the three channels are one "
            "accelerometer's x, y and z",
        )
    rss = float(residuals @ residuals)
    covariance = rss / dof * np.linalg.inv(jacobian.T @ jacobian)
    t = float(stats.t.ppf(0.5 + confidence / 2, dof))
    uncertainty = t * np.sqrt(np.diag(covariance))
    z = float(stats.norm.ppf(0.5 + confidence / 2))
    uncertainty[:3] = np.hypot(uncertainty[:3], best[:3] * z * gravity.uncertainty / g)
    return ClassicalCalibration(
        orientations=orientations,
        names=names,
        values=best,
        covariance=covariance,
        uncertainty=uncertainty,
        confidence=confidence,
        dof=dof,
        residual_rms=math.sqrt(rss / residuals.size),
        conditioning=conditioning,
        gravity=gravity,
        faces=faces,
        face_labels=labels,
        distinct_orientations=distinct,
    )


def calibration_matrices(values, six_face: bool) -> dict:
    """T, K, T K, the sensitivity (T K)^-1 (raw unit per m/s^2; its rows are the sensing
    axes) and, for six faces, R and the sensitivity in the fixture frame (R T K)^-1 — the M of
    Ferraris and imucal."""
    scales, angles, rotation, offsets = _split(np.asarray(values), six_face)
    misalignment = np.asarray(misalignment_matrix(jnp.asarray(angles)))
    matrix = misalignment * scales[None, :]
    result = {
        "misalignment_T": misalignment,
        "scale_K": np.diag(scales),
        "calibration_TK": matrix,
        "sensitivity": np.linalg.inv(matrix),
        "offset_b": np.asarray(offsets),
    }
    if six_face:
        rotation_m = Rotation.from_rotvec(rotation).as_matrix()
        result["rotation_R"] = rotation_m
        result["sensitivity_fixture"] = np.linalg.inv(rotation_m @ matrix)
    return result
