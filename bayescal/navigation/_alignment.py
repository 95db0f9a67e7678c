"""Alignment at rest: the coarse attitude from the mean readings, then the fine-alignment
filter and smoother whose states hold the tilts, the velocity errors, the accelerometer biases
and each gyro's thermal bias, and the marginal likelihood of the aging since the calibration.

Coarse alignment (Titterton & Weston 2004, sec. 10.2; Groves 2013, sec. 5.6.2): a still body
reads f^b = -C_n^b g^n and w^b = C_n^b Omega^n; roll and pitch level the mean specific force,
and the heading turns the levelled mean rate onto north (gyrocompassing).

Fine alignment (the PSINS ``alignvn`` filter's states, Jiang & Lin 1992, extended by the gyros'
thermal polynomials): the recording is mechanized at its own rate from the coarse attitude
(:mod:`._strapdown`); the vehicle being still, the computed horizontal velocity *is* the
velocity error, measured every ``step_s`` seconds. States, in this order:

- the navigation errors of :mod:`._error_model` (position, velocity, tilt);
- the accelerometer biases nabla^b (m/s^2; constant, or a random walk of the stated
  instability);
- per gyro i, the change delta c_i of its thermal coefficients since the calibration: its gyro
  bias error is eps_i(t) = sum_j delta c_ij (T_i(t) - T0_i)^j (the compensated output keeps
  it), entering the error model through C_b^n; constant;
- the computed heading's change since the window's start, h . (phi - phi_0) (h:
  :func:`heading_sensitivity` at the park's attitude): a still vehicle does not turn, so over the
  park the computed heading's change is measured as zero to HEADING_SWAY (a zero-rate update on
  the heading, Groves 2013 sec. 15.3.3). It is how the park sees the vertical gyro: that gyro
  reads Omega sin L plus its bias, and the mechanization, which takes Omega sin L off, turns the
  computed heading at the bias's rate; the velocities alone see that turn only through the
  heading's slow effect on the east tilt, where the east bias hides it. Over a park of T
  seconds the vertical bias's level is then known to about ARW / sqrt(T), as the north one is;
- per gyro, w_i for the bias's instability (present when the calibration's noise has one). A
  flicker started at zero settles within seconds on an offset the polynomial's level cannot be
  told from (its variance grows as log t), then wanders: w_i starts at that offset (variance
  ``offset_variance``) and walks with K^2 + 9 (2 ln 2 / pi) B^2 / T, the random walk whose Allan
  variance equals the flicker floor at a third of the alignment's length T; the two together
  give the flicker's mean over the alignment its exact variance (4.0 B^2 for 20 minutes at
  100 Hz). A walk alone, from zero, gave it a third of that, and the north level's intervals
  covered 85 % over 100 parks.

The white noise of gyros and accelerometers drives the tilts and velocities (their densities
read from the record); each interval's transition and process noise are exact for the model
frozen at the interval's middle (Van Loan), the powers of the temperature averaged over it.
Over a park the velocity error is a smooth function plus the accelerometers' random walk, so a
measurement per second loses nothing the states could use (the test compares 1 s and 0.1 s).

The prior of delta c_i is N(0, Sigma_i + diag((s / h_i^j)^2)): the calibration's covariance
plus the drift of :mod:`bayescal.models._thermal` (aging), with one drift scale s for the
three gyros. The prior of s is half-Cauchy with scale DRIFT_PRIOR_SCALE times the calibrations'
sd of c_0 (a weakly informative prior for a scale, Gelman 2006, as the fleet population's): the
alignment informs s in a few directions only (the north level, the slopes), so the prior
matters, and one concentrated near the calibration's own sd (the thermal update's log-normal,
whose field data are richer) learned s at half its truth in benchmarks/infield_alignment.py and
left the east level's and heading's intervals covering two thirds of the time. The coefficients
are constant, so the filter's last estimate is their posterior
given every measurement, and changing their prior changes the evidence in closed form:
:class:`DriftProblem` gives log p(y | s) from one filter run at a reference s, so s can be
sampled at the cost of a 9 x 9 determinant per draw.
"""

import math
from dataclasses import dataclass

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._errors import InputError
from ..classical._gravity import normal_gravity
from ..models._terms import bounding_walk_variance
from ._earth import north_east
from ._error_model import (
    NAVIGATION_STATES,
    POSITION,
    TILT,
    VELOCITY,
    discretize,
    error_dynamics,
)
from ._frames import dcm_from_euler, euler_from_dcm, skew
from ._kalman import StateSpace, kalman_filter, rts_smoother
from ._strapdown import Trajectory, mechanize
from ._taxi import (
    LEG_TOLERANCE_DEG,
    TaxiReference,
    cross_track_row,
    leg_steps,
    wander_model,
)

STEP_S = 1.0
"""Seconds between the velocity measurements of the fine alignment."""
MIN_ALIGNMENT_S = 300.0
"""The shortest alignment the fine filter is offered: under five minutes the tilt rates that
carry the gyro biases are lost in the accelerometers' and gyros' noise (a tenth of a
navigation-grade bias's effect), and the patent's block-by-block tilt rates have too few
blocks."""
VELOCITY_NOISE = 1e-3
"""sd of a velocity measurement, m/s: the still vehicle's sway (wind, people aboard) that the
mechanization sees as velocity, which a perfectly still simulation lacks; 1 mm/s costs the
estimates under 1 % against 0.1 mm/s (benchmarks/infield_alignment.py)."""
TILT_PRIOR = 1e-3
"""sd of the coarse alignment's level tilt, rad (it is pinned at once by the data with the
accelerometer bias)."""
HEADING_PRIOR = 0.1
"""sd of the coarse alignment's heading error, rad. At rest the east bias level and the heading
are one quantity, and gyrocompassing leaves the heading off by the east bias over the Earth
rate's horizontal part: a few mrad at navigation grade, but 1 deg/h (a tactical gyro aged by a
few of its calibration's sd) leaves 5 deg at 45 deg latitude. The coarse heading is where the
filter is linearized, not information: this prior is wide enough that the east level's prior,
not it, bounds the heading at rest (at 0.01 rad the tactical park's heading intervals covered
38 %, benchmarks/infield_taxi.py --tactical), and small enough for the small-angle model."""
HEADING_SWAY = 2e-5
"""sd of a parked vehicle's heading about its mean over one STEP_S, rad (4 arcsec: wind and
people aboard), the noise of the zero-rate update on the heading; a step of another length
scales its variance by STEP_S / step (a white sway averaged over the step), so that measuring
more often tells no more. Over a 20-minute park it limits the vertical bias to 3e-4 deg/h, a
tenth of a navigation-grade gyro's ARW limit."""
HEADING_CHANGE_SCALE = 1e-4
"""The heading change's scale, rad (its size at navigation grade over a park)."""
LEG_SIGMAS = 3.0
"""The first search for the taxi's legs allows the park's heading error this many of its sd
beyond LEG_TOLERANCE_DEG while no leg has been found (:func:`fine_alignment`)."""
RELINEARIZATIONS = 4
"""At most this many smoother runs find the taxi's legs and linearize the next model, the first
without the taxi's cross-track measurements (:func:`fine_alignment`)."""
POSITION_SD = 2.0
"""sd of a position fix's north and east error, m (a single GNSS receiver's: 1-3 m); the fixes
are taken as white."""
DRIFT_PRIOR_SCALE = 10.0
"""The scale of the half-Cauchy prior of the aging scale s, in the calibrations' sd of c_0."""
DRIFT_PRIOR_CUT = 1000.0
"""The prior of s ends at this many times its scale."""
ACCEL_BIAS_PRIOR = 1e-3
"""sd of the accelerometer biases, m/s^2 (100 ug)."""
MOTION_RATE = math.radians(0.05)
"""A one-second mean rate that differs from the window's median by more than this (rad/s) is
motion (12 times the Earth rate; far beyond a parked vehicle's sway)."""
MOTION_FORCE = 0.05
"""A one-second mean specific force that differs from the window's median by more than this
(m/s^2, 5 mg) is motion."""
MOTION_SIGMAS = 8.0
"""Or by more than this many sd of a one-second mean's noise, whichever is larger."""


def find_motion(gyro, accel, rate_hz: float) -> tuple[float, str] | None:
    """Where a record stops being still: the start (s from its first sample) of the first
    one-second block whose mean rate (rad/s) or specific force (m/s^2) leaves the record's
    median by more than a parked vehicle can (MOTION_RATE, MOTION_FORCE, or MOTION_SIGMAS sd of
    a block mean's noise), with what moved; None when it is still throughout."""
    size = max(1, round(rate_hz))
    count = gyro.shape[0] // size
    found = []
    for values, floor, what, unit, factor in (
        (gyro, MOTION_RATE, "rate", "deg/s", 180 / math.pi),
        (accel, MOTION_FORCE, "specific force", "m/s^2", 1.0),
    ):
        means = values[: count * size].reshape(count, size, 3).mean(axis=1)
        steps = np.diff(values, axis=0)
        spread = np.median(np.abs(steps - np.median(steps, axis=0)), axis=0)
        noise = 1.4826 * spread / math.sqrt(2)
        limit = np.maximum(floor, MOTION_SIGMAS * noise / math.sqrt(size))
        deviation = np.abs(means - np.median(means, axis=0))
        far = np.flatnonzero((deviation > limit).any(axis=1))
        if far.size:
            block = int(far[0])
            axis = int(np.argmax(deviation[block] / limit))
            found.append(
                (
                    block * size / rate_hz,
                    f"the {what} of axis {'xyz'[axis]} moved by "
                    f"{deviation[block, axis] * factor:.3g} {unit} from its median",
                )
            )
    return min(found) if found else None


def coarse_alignment(gyro_mean, accel_mean) -> np.ndarray:
    """C_b^n of a still body from its mean rate (rad/s) and specific force (m/s^2): roll and
    pitch from the specific force, the heading by gyrocompassing."""
    fx, fy, fz = accel_mean
    roll = math.atan2(-fy, -fz)
    pitch = math.atan2(fx, math.hypot(fy, fz))
    levelled = np.asarray(dcm_from_euler(roll, pitch, 0.0)) @ np.asarray(gyro_mean)
    heading = math.atan2(-levelled[1], levelled[0])
    return np.asarray(dcm_from_euler(roll, pitch, heading))


def heading_sensitivity(attitude) -> np.ndarray:
    """d(computed - true heading) / d phi at C_b^n ``attitude`` (the row that turns the tilt
    into the heading error; -1 on phi_D for a level body)."""

    def heading(phi):
        computed = (jnp.eye(3) - skew(phi)) @ jnp.asarray(attitude)
        return euler_from_dcm(computed)[2]

    return np.asarray(jax.grad(heading)(jnp.zeros(3)))


@dataclass(frozen=True)
class GyroPrior:
    """One gyro's thermal polynomial as the fine alignment sees it (SI units)."""

    powers: np.ndarray
    """(n,) x (d + 1): (T(t) - T0)^j at every sample."""
    covariance: np.ndarray
    """The calibration's covariance of c, (rad/s / degC^j)^2."""
    drift_shape: np.ndarray
    """sd of each coefficient's drift per unit s: 1 / h^j."""
    instability: float
    """Power spectral density of the bias's random walk, rad^2/s^3 (0: none)."""
    offset_variance: float = 0.0
    """Variance of the offset the bias instability settles on at the start, (rad/s)^2."""


@dataclass(frozen=True)
class Layout:
    """Where each group of states sits in the fine alignment's state vector."""

    names: tuple[str, ...]
    navigation: slice
    accel: slice
    coefficients: tuple[slice, ...]
    """One per gyro."""
    walks: tuple[int | None, ...]
    """The index of each gyro's random walk, None where it has none."""
    heading_change: int = 0
    """The index of the computed heading's change since the start (module docstring)."""
    wander: slice | None = None
    """The taxi's cross-track wander and its rate (:mod:`._taxi`), None without a taxi."""

    @property
    def all_coefficients(self) -> slice:
        return slice(self.coefficients[0].start, self.coefficients[-1].stop)


def _layout(priors, wander: bool = False) -> Layout:
    names = [*NAVIGATION_STATES, "nabla_x", "nabla_y", "nabla_z"]
    coefficients = []
    for axis, prior in enumerate(priors):
        start = len(names)
        names += [f"dc{j}_{'xyz'[axis]}" for j in range(prior.covariance.shape[0])]
        coefficients.append(slice(start, len(names)))
    walks = []
    for axis, prior in enumerate(priors):
        if prior.instability > 0:
            walks.append(len(names))
            names.append(f"walk_{'xyz'[axis]}")
        else:
            walks.append(None)
    heading_change = len(names)
    names.append("heading_change")
    lateral = None
    if wander:
        lateral = slice(len(names), len(names) + 2)
        names += ["wander", "wander_rate"]
    return Layout(
        tuple(names),
        slice(0, 7),
        slice(7, 10),
        tuple(coefficients),
        tuple(walks),
        heading_change,
        lateral,
    )


def _interval_means(values, size: int, count: int):
    """Means of ``values`` over each interval between filter steps (count - 1 of them)."""
    body = values[: (count - 1) * size]
    return body.reshape(count - 1, size, *values.shape[1:]).mean(axis=1)


class AlignmentModel(eqx.Module):
    """The fine alignment's state-space model in scaled units (each state divided by
    ``scale``), its measurements, and its prior as a function of the drift scale s."""

    space: StateSpace
    observations: jax.Array
    """(K, 2) the computed north and east velocity at each step, m/s (NaN at the first)."""
    scale: jax.Array
    prior_fixed: jax.Array
    """The prior covariance (scaled) with no drift."""
    drift_shape: jax.Array
    """(n,) sd of each state's drift per unit s (scaled; zero off the coefficients)."""

    def prior(self, drift_scale):
        """The prior covariance of x_0 (scaled) at drift scale s (rad/s)."""
        return self.prior_fixed + jnp.diag((drift_scale * self.drift_shape) ** 2)

    def filter(self, drift_scale):
        """The Kalman filter at drift scale s (:func:`~._kalman.kalman_filter`)."""
        size = self.scale.size
        return kalman_filter(
            self.space, self.observations, jnp.zeros(size), self.prior(drift_scale)
        )

    def smooth(self, filtered):
        """The smoothed means and covariances (scaled) of a filter run of this model."""
        return rts_smoother(self.space, filtered)


@dataclass(frozen=True)
class FineAlignment:
    """The mechanized park and its fine-alignment model."""

    model: AlignmentModel
    layout: Layout
    times: np.ndarray
    """s from the window's start, of each filter step."""
    trajectory: Trajectory
    """The mechanization at the filter steps."""
    coarse_attitude: np.ndarray
    noise: dict
    """The white-noise densities used: gyro (rad/s/sqrt(Hz)) and accel (m/s^2/sqrt(Hz))."""
    step_samples: int
    park_steps: int = 0
    """How many filter steps lie in the park (the still part): the first ones."""
    legs: np.ndarray | None = None
    """(K,) the taxi leg each step lies on (an index into the track headings), -1 off the
    legs; None without a taxi."""
    fixes: np.ndarray | None = None
    """(K, 2) the position fix at each step, north and east of the first fix, m (NaN where
    none, and at the first: :func:`_fixes`); None without a position reference."""


def _measurements(
    layout: Layout, velocity, attitude, correction, park_steps: int, legs, taxi, track, fixes
):
    """The measurement rows and values at every step: the computed north and east velocity and
    the computed heading's change since the first step (from C_b^n ``attitude``) at the park's
    steps (the vehicle is still), the computed cross-track velocity at the taxi's
    steps on a leg (:func:`~._taxi.cross_track_row`, linearized at the velocity less
    ``correction``), and where ``fixes`` (K, 2; None: no position reference) hold a position
    fix, the computed position ``track`` (K, 2, north and east of the first step, m) less the
    fix: the position error plus the fix's own error (:func:`_fixes`); NaN where nothing is
    measured."""
    count, n = velocity.shape[0], len(layout.names)
    rows = 3 + (taxi is not None) + 2 * (fixes is not None)
    observation = np.zeros((count, rows, n))
    measured = np.full((count, rows), np.nan)
    observation[:park_steps, 0, VELOCITY.start] = 1.0
    observation[:park_steps, 1, VELOCITY.start + 1] = 1.0
    observation[:park_steps, 2, layout.heading_change] = 1.0
    measured[1:park_steps, :2] = velocity[1:park_steps, :2]
    heading = np.arctan2(attitude[:park_steps, 1, 0], attitude[:park_steps, 0, 0])
    measured[1:park_steps, 2] = np.angle(np.exp(1j * (heading[1:] - heading[0])))
    if legs is not None:
        for k in np.flatnonzero(legs >= 0):
            across, tilt = cross_track_row(taxi.headings_deg[legs[k]], velocity[k] - correction[k])
            observation[k, 3, VELOCITY] = across
            observation[k, 3, TILT] = tilt
            observation[k, 3, layout.wander.start + 1] = 1.0
            measured[k, 3] = across @ velocity[k, :2]
    if fixes is not None:
        observation[:, -2:, POSITION] = np.eye(2)
        measured[:, -2:] = track - fixes
    return observation, measured


def _fixes(positions, steps, park_steps: int) -> np.ndarray:
    """The position fixes at the filter steps, north and east of the first fix (m; NaN where
    none, and at the first itself).

    ``positions`` (n, 2) are per sample, north and east of any origin, m, NaN where no fix.
    The first fix at a step lies in the park, where the vehicle stands where the computed
    track starts: the computed position less a later fix taken from the first is then the
    position error plus the later fix's error less the first's. The position states start
    with the first fix's error as their prior (sd ``position_sd``), and the first fix is not
    measured again."""
    positions = np.asarray(positions, dtype=float)
    at = np.full((steps.size, 2), np.nan)
    inside = steps < positions.shape[0]
    at[inside] = positions[steps[inside]]
    present = np.flatnonzero(np.isfinite(at).all(axis=1))
    if not present.size or present[0] >= park_steps:
        raise InputError(
            "the position reference (positions=) has no fix in the park at a filter step "
            f"(every {steps[1] - steps[0]} samples)",
            fix="give fixes from the park on: the vehicle's position at rest ties them to the "
            "computed track",
        )
    first = present[0]
    relative = at - at[first]
    relative[first] = np.nan
    return relative


def _velocity_error(model: "AlignmentModel", drift: float, velocity):
    """The smoothed velocity error, computed minus true (north, east, down; m/s), at every
    step: delta v + v x phi of the modified phi-angle model (:mod:`._error_model`); and the
    smoothed sd of phi_D (the heading error's, deg) at every step."""
    means, covariances = model.smooth(model.filter(drift))
    scale = np.asarray(model.scale)
    states = np.asarray(means) * scale
    error = np.zeros((states.shape[0], 3))
    error[:, :2] = states[:, VELOCITY]
    down = TILT.start + 2
    heading_sd = np.degrees(np.sqrt(np.asarray(covariances)[:, down, down]) * scale[down])
    return error + np.cross(velocity, states[:, TILT]), heading_sd


def white_noise_density(values, rate_hz: float) -> np.ndarray:
    """Each column's white noise density (its unit/sqrt(Hz)) from its sample-to-sample steps
    (median absolute deviation: a few outliers or a slow drift do not move it)."""
    steps = np.diff(values, axis=0)
    spread = 1.4826 * np.median(np.abs(steps - np.median(steps, axis=0)), axis=0)
    return spread / math.sqrt(2) / math.sqrt(rate_hz)


def _dynamics(
    trajectory,
    priors,
    layout: Layout,
    size: int,
    count: int,
    height,
    gravity,
    wander,
    correction,
    heading_row,
):
    """F of the whole state per interval (the error model at the interval's middle, the
    temperature powers averaged over it, the velocity less ``correction``, the estimated
    velocity error at each step; the heading change's row ``heading_row`` times the tilt's),
    and the sensors' input matrices there."""
    middle = np.arange(count - 1) * size + size // 2
    velocity = trajectory.velocity[middle] - 0.5 * (correction[:-1] + correction[1:])
    dynamics, gyro_input, accel_input = (
        np.asarray(x)
        for x in error_dynamics(
            trajectory.latitude[middle],
            height,
            velocity,
            trajectory.attitude[middle],
            np.full(middle.size, gravity),
        )
    )
    n, nav = len(layout.names), layout.navigation
    full = np.zeros((count - 1, n, n))
    full[:, nav, nav] = dynamics
    full[:, nav, layout.accel] = accel_input
    for axis, prior in enumerate(priors):
        powers = _interval_means(prior.powers, size, count)
        full[:, nav, layout.coefficients[axis]] = gyro_input[:, :, axis, None] * powers[:, None, :]
        if layout.walks[axis] is not None:
            full[:, nav, layout.walks[axis]] = gyro_input[:, :, axis]
    full[:, layout.heading_change] = np.einsum("i,kij->kj", heading_row, full[:, TILT])
    if layout.wander is not None:
        full[:, layout.wander, layout.wander] = wander_model(*wander)[0]
    return full, gyro_input, accel_input


def _noise(layout: Layout, priors, inputs, densities, accel_walk: float, wander, heading_row):
    """The white noise's power spectral density matrix per interval: the gyros' and
    accelerometers' white noise through their input matrices, the random walks'; the heading
    change's, the tilt's through ``heading_row``."""
    gyro_input, accel_input = inputs
    gyro_density, accel_density = densities
    nav = layout.navigation
    noise = np.zeros((gyro_input.shape[0], len(layout.names), len(layout.names)))
    noise[:, nav, nav] = np.einsum("kia,a,kja->kij", gyro_input, gyro_density**2, gyro_input)
    noise[:, nav, nav] += np.einsum("kia,a,kja->kij", accel_input, accel_density**2, accel_input)
    noise[:, layout.accel, layout.accel] = accel_walk * np.eye(3)
    for axis, prior in enumerate(priors):
        if layout.walks[axis] is not None:
            noise[:, layout.walks[axis], layout.walks[axis]] = prior.instability
    change = layout.heading_change
    noise[:, change] = np.einsum("i,kij->kj", heading_row, noise[:, TILT])
    noise[:, :, change] = np.einsum("kji,i->kj", noise[:, :, TILT], heading_row)
    if layout.wander is not None:
        noise[:, layout.wander, layout.wander] = wander_model(*wander)[1]
    return noise


def _prior(
    layout: Layout, priors, reference_drift: float, duration: float, wander, position_sd=None
):
    """The prior covariance of x_0 without drift (the coarse alignment's tilts, the
    accelerometer biases, the calibrations' coefficients; with a position reference, the
    first fix's error ``position_sd``, m, as the position's: :func:`_fixes`), each state's
    drift per unit s, and the states' scales (their prior sd at the reference s)."""
    n = len(layout.names)
    prior = np.zeros((n, n))
    if position_sd is not None:
        prior[POSITION, POSITION] = position_sd**2 * np.eye(2)
    tilt = np.arange(TILT.start, TILT.stop)
    prior[tilt, tilt] = np.array([TILT_PRIOR, TILT_PRIOR, HEADING_PRIOR]) ** 2
    prior[layout.accel, layout.accel] = ACCEL_BIAS_PRIOR**2 * np.eye(3)
    shape = np.zeros(n)
    for axis, gyro in enumerate(priors):
        block = layout.coefficients[axis]
        prior[block, block] = gyro.covariance
        shape[block] = gyro.drift_shape
        if layout.walks[axis] is not None:
            prior[layout.walks[axis], layout.walks[axis]] = gyro.offset_variance
    if layout.wander is not None:
        prior[layout.wander, layout.wander] = wander_model(*wander)[2]
    scale = np.sqrt(np.diag(prior) + (reference_drift * shape) ** 2)
    # Position and velocity start known (the vehicle is still where it is; but for the first
    # fix's error): scaled by sizes their errors reach, 1 m and 1 cm/s.
    scale[POSITION] = 1.0
    scale[VELOCITY] = 0.01
    scale[layout.heading_change] = HEADING_CHANGE_SCALE
    for axis, gyro in enumerate(priors):
        if layout.walks[axis] is not None:
            scale[layout.walks[axis]] = math.sqrt(
                gyro.offset_variance + gyro.instability * duration
            )
    return prior, shape, scale


def fine_alignment(
    gyro,
    accel,
    rate_hz: float,
    priors: tuple[GyroPrior, GyroPrior, GyroPrior],
    *,
    latitude: float,
    height: float,
    reference_drift: float,
    accel_instability: float,
    velocity_noise: float = VELOCITY_NOISE,
    step_s: float = STEP_S,
    park_samples: int | None = None,
    taxi: TaxiReference | None = None,
    positions=None,
    position_sd: float = POSITION_SD,
) -> FineAlignment:
    """Mechanize a record from its coarse alignment and set up the fine-alignment model.

    ``gyro`` (rad/s, the old calibration's thermal bias taken off) and ``accel`` (m/s^2) are
    (n, 3); ``latitude`` in rad, ``height`` in m; ``reference_drift`` the drift scale s (rad/s)
    of the filter's reference run (:class:`DriftProblem` moves it); ``accel_instability`` the
    accelerometers' bias instability B (m/s^2), turned into a random walk as the gyros' is.

    The first ``park_samples`` (default: all) are still: the coarse alignment and the white
    noise are read from them, and the computed velocity at each of their steps is measured as
    zero. A ``taxi`` after them (:class:`~._taxi.TaxiReference`) adds the wander's two states
    and, at each step on a leg of known heading (:func:`~._taxi.leg_steps`), the computed
    cross-track velocity as a measurement of (delta v, phi, the wander's rate)
    (:func:`~._taxi.cross_track_row`); the steps between (the start, the turns) are
    mechanized and measure nothing.

    ``positions`` (n, 2; north and east of any origin, m, NaN where no fix), a position
    reference (GNSS) per sample, adds at each step with a fix the computed position less the
    fix as a measurement of the position error with the fix's sd ``position_sd`` (m, white):
    the heading error turns the computed track away from the fixes by psi times the distance
    run (../shared/NAVIGATION.md), so the fixes tell the heading without a known track
    (:func:`_fixes`: the first fix lies in the park).
    """
    gyro = np.asarray(gyro, dtype=float)
    accel = np.asarray(accel, dtype=float)
    park_samples = gyro.shape[0] if park_samples is None else int(park_samples)
    size = max(1, round(step_s * rate_hz))
    count = gyro.shape[0] // size + 1
    if count < 3:
        raise InputError(f"{gyro.shape[0]} samples make fewer than three filter steps")
    duration = gyro.shape[0] / rate_hz
    still_gyro, still_accel = gyro[:park_samples], accel[:park_samples]
    attitude = coarse_alignment(still_gyro.mean(axis=0), still_accel.mean(axis=0))
    trajectory = mechanize(
        gyro, accel, rate_hz, latitude=latitude, height=height, attitude=attitude
    )
    gravity = normal_gravity(math.degrees(latitude), height)
    layout = _layout(priors, wander=taxi is not None)
    wander = None if taxi is None else (taxi.wander_sd, taxi.wander_time_s)
    densities = (
        white_noise_density(still_gyro, rate_hz),
        white_noise_density(still_accel, rate_hz),
    )
    accel_walk = bounding_walk_variance(
        "bias_instability", {"B": accel_instability}, duration, rate_hz
    )
    steps = np.arange(count) * size
    times = steps / rate_hz
    park_steps = int(np.sum(steps <= park_samples))
    fixes = None if positions is None else _fixes(positions, steps, park_steps)
    prior, shape, scale = _prior(
        layout,
        priors,
        reference_drift,
        duration,
        wander,
        None if fixes is None else position_sd,
    )
    track = north_east(trajectory.latitude[steps], trajectory.longitude[steps], height)

    heading_row = heading_sensitivity(attitude)

    def assemble(correction, legs):
        full, *inputs = _dynamics(
            trajectory,
            priors,
            layout,
            size,
            count,
            height,
            gravity,
            wander,
            correction,
            heading_row,
        )
        noise = _noise(layout, priors, inputs, densities, accel_walk, wander, heading_row)
        transition, process = discretize(jnp.asarray(full), jnp.asarray(noise), step_s)
        observation, measured = _measurements(
            layout,
            trajectory.velocity[steps],
            trajectory.attitude[steps],
            correction,
            park_steps,
            legs,
            taxi,
            track,
            fixes,
        )
        n = len(layout.names)
        variances = np.full(measured.shape[1], velocity_noise**2)
        variances[2] = HEADING_SWAY**2 * STEP_S / step_s
        if fixes is not None:
            variances[-2:] = position_sd**2
        space = StateSpace(
            jnp.concatenate([jnp.eye(n)[None], transition]),
            jnp.concatenate([jnp.zeros((1, n, n)), process]),
            jnp.asarray(observation),
            jnp.broadcast_to(jnp.diag(variances), (count, *variances.shape * 2)),
        ).scaled(scale)
        return AlignmentModel(
            space=space,
            observations=jnp.asarray(measured),
            scale=jnp.asarray(scale),
            prior_fixed=jnp.asarray(prior / np.outer(scale, scale)),
            drift_shape=jnp.asarray(shape / scale),
        )

    correction = np.zeros((count, 3))
    legs = None if taxi is None else np.full(count, -1)
    model = assemble(correction, legs)
    if taxi is not None or fixes is not None:
        # Mechanized freely from the coarse alignment, the computed velocity carries the park's
        # errors (the Schuler loop's, up to m/s) into the taxi: the legs are found, and the
        # cross-track rows and the error model linearized, on the velocity less its error as
        # the smoother predicts it. The park alone predicts the heading error no better than
        # the east bias level's prior allows (degrees at tactical grade): the first legs are
        # found within LEG_SIGMAS of its sd beyond LEG_TOLERANCE_DEG, else a track that is off
        # by the heading error itself would lie off every leg, or on a leg only where the
        # wander happens to cancel it (the steps chosen by their own cross-track velocity, the
        # heading pulled towards zero). The taxi's smoother then relinearizes, and the legs are
        # found again within LEG_TOLERANCE_DEG, until they no longer change. Position fixes are
        # measured from the first model on (linear in the position error), and the model is
        # relinearized at least once on the velocity they correct.
        velocity = trajectory.velocity[steps]
        for iteration in range(RELINEARIZATIONS):
            correction, heading_sd = _velocity_error(model, reference_drift, velocity)
            found = legs
            if taxi is not None:
                widen = LEG_SIGMAS * heading_sd if (legs < 0).all() else 0.0
                found = leg_steps(
                    times, velocity - correction, taxi.headings_deg, LEG_TOLERANCE_DEG + widen
                )
                found[steps < taxi.start_sample] = -1
            unchanged = legs is None or np.array_equal(found, legs)
            if unchanged and (iteration > 0 or fixes is None):
                break
            legs = found
            model = assemble(correction, legs)
    return FineAlignment(
        model=model,
        layout=layout,
        times=times,
        trajectory=Trajectory(
            time=trajectory.time[steps],
            latitude=trajectory.latitude[steps],
            longitude=trajectory.longitude[steps],
            height=trajectory.height,
            velocity=trajectory.velocity[steps],
            attitude=trajectory.attitude[steps],
        ),
        coarse_attitude=attitude,
        noise=dict(zip(("gyro", "accel"), densities, strict=True)),
        step_samples=size,
        park_steps=park_steps,
        legs=legs,
        fixes=fixes,
    )


class DriftProblem(eqx.Module):
    """The log posterior of the drift scale s given the alignment, and the coefficients'
    Gaussian posterior at each s (all in the scaled units of :class:`AlignmentModel`).

    At the reference s the filter ends with the coefficients' posterior N(mu, S) (prior
    N(0, P_ref)). The data's information about them is J = S^-1 - P_ref^-1 and eta = S^-1 mu;
    at any s with prior P_s, the posterior is N(L^-1 eta, L^-1) with L = J + P_s^-1, and
    log p(y | s) = const - log|I + P_s J| / 2 + eta^T L^-1 eta / 2 (the Gaussian integral of
    the likelihood J, eta against the prior). The prior of s is half-Cauchy with scale
    DRIFT_PRIOR_SCALE times the calibrations' sd of c_0 (module docstring), written for log s.
    """

    information: jax.Array
    linear: jax.Array
    fixed: jax.Array
    """The prior covariance of the coefficients without drift."""
    shape: jax.Array
    location: jax.Array
    """(1,) log of the half-Cauchy prior's scale (s in rad/s), where the sampler starts."""

    @property
    def parameters(self) -> tuple[str, ...]:
        return ("log_drift",)

    def conditional(self, theta):
        """Mean and covariance of the coefficients (scaled) at log s = theta[0]."""
        prior = self.fixed + jnp.diag((jnp.exp(theta[0]) * self.shape) ** 2)
        precision = self.information + jnp.linalg.inv(prior)
        covariance = jnp.linalg.inv(precision)
        covariance = 0.5 * (covariance + covariance.T)
        return covariance @ self.linear, covariance

    def log_posterior(self, theta):
        prior = self.fixed + jnp.diag((jnp.exp(theta[0]) * self.shape) ** 2)
        factor = jnp.linalg.cholesky(prior)
        size = self.linear.size
        # |I + P J| = |I + F^T J F| with P = F F^T (symmetric, positive definite).
        inner = jnp.eye(size) + factor.T @ self.information @ factor
        inner_factor = jnp.linalg.cholesky(inner)
        log_det = 2 * jnp.sum(jnp.log(jnp.diag(inner_factor)))
        # L^-1 = F (I + F^T J F)^-1 F^T
        projected = jax.scipy.linalg.cho_solve((inner_factor, True), factor.T @ self.linear)
        quadratic = (factor.T @ self.linear) @ projected
        # Half-Cauchy in s, with the Jacobian of s = exp(theta), cut at DRIFT_PRIOR_CUT times
        # its scale (the mass beyond, 2 / (pi 1000), is below what the draws resolve; there the
        # determinants' rounding, not the data, would shape the density).
        excess = theta - self.location
        log_prior = jnp.sum(theta - jnp.log1p(jnp.exp(2 * excess)))
        value = -0.5 * log_det + 0.5 * quadratic + log_prior
        inside = jnp.isfinite(value) & jnp.all(excess < math.log(DRIFT_PRIOR_CUT))
        return jnp.where(inside, value, -jnp.inf)


def drift_problem(alignment: FineAlignment, filtered, reference_drift: float, location: float):
    """The :class:`DriftProblem` of a filter run at ``reference_drift`` (rad/s); ``location``
    is the log of the prior's scale."""
    block = alignment.layout.all_coefficients
    mean = np.asarray(filtered.mean[-1])[block]
    covariance = np.asarray(filtered.covariance[-1])[block, block]
    model = alignment.model
    reference = np.asarray(model.prior(reference_drift))[block, block]
    precision = np.linalg.inv(covariance)
    information = precision - np.linalg.inv(reference)
    # J is positive semi-definite; its rounding (1e-10 of its largest eigenvalue, either sign, in
    # the directions the data do not see) is set to zero: a negative one makes |I + P_s J| vanish
    # at some large s, a spurious peak of the evidence there.
    values, vectors = np.linalg.eigh(0.5 * (information + information.T))
    values = np.where(values > 1e-8 * values.max(), values, 0.0)
    return DriftProblem(
        information=jnp.asarray((vectors * values) @ vectors.T),
        linear=jnp.asarray(precision @ mean),
        fixed=jnp.asarray(np.asarray(model.prior_fixed)[block, block]),
        shape=jnp.asarray(np.asarray(model.drift_shape)[block]),
        location=jnp.array([location]),
    )


@jax.jit
def draw_final_states(problem: DriftProblem, mean, covariance, start: int, theta, key):
    """Draws of every state at the alignment's end (scaled), one per draw of log s in
    ``theta`` (draws, 1): the coefficients from their posterior at that s, the other states
    from their conditional given the coefficients, which the drift does not change.
    ``mean``/``covariance`` are the filter's last estimate at the reference s; the
    coefficients occupy ``start`` .. ``start`` + k."""
    size = problem.linear.size
    index = jnp.arange(mean.size)
    inside = (index >= start) & (index < start + size)
    order = jnp.argsort(~inside, stable=True)  # the coefficients first, then the rest
    mean_o = mean[order]
    covariance_o = covariance[order][:, order]
    c_mean, c_cov = mean_o[:size], covariance_o[:size, :size]
    cross = covariance_o[size:, :size]
    regression = jnp.linalg.solve(c_cov, cross.T).T
    rest_cov = covariance_o[size:, size:] - regression @ cross.T
    # A floor a million times below the scaled states' unit variance keeps the factor real.
    rest_cov = 0.5 * (rest_cov + rest_cov.T) + 1e-12 * jnp.eye(mean.size - size)
    rest_factor = jnp.linalg.cholesky(rest_cov)

    def one(theta_one, key_one):
        first, second = jax.random.split(key_one)
        m, v = problem.conditional(theta_one)
        c = m + jnp.linalg.cholesky(v) @ jax.random.normal(first, (size,))
        rest = mean_o[size:] + regression @ (c - c_mean)
        rest = rest + rest_factor @ jax.random.normal(second, (mean.size - size,))
        return jnp.concatenate([c, rest])[jnp.argsort(order)]

    keys = jax.random.split(key, theta.shape[0])
    return jax.vmap(one)(theta, keys)


def mixture_moments(means, covariances, vectors, block: slice, coefficients):
    """Mean and sd of ``vectors[k] @ x_k`` at each step k under the posterior mixture over the
    drift scale (scaled units): ``means``/``covariances`` (K, n) and (K, n, n) are smoothed at
    the reference s, ``coefficients`` (draws, k) are draws of the coefficients (block ``block``)
    from the mixture. Given the coefficients the other states do not depend on s
    (:class:`DriftProblem`), so each functional is a mixture of Gaussians whose components are
    its regression on the coefficients."""
    mean = np.empty(len(vectors))
    sd = np.empty(len(vectors))
    for k, vector in enumerate(vectors):
        cross = vector @ covariances[k][:, block]
        weights = np.linalg.solve(covariances[k][block, block], cross)
        conditional = vector @ means[k] + (coefficients - means[k][block]) @ weights
        variance = vector @ covariances[k] @ vector - cross @ weights
        mean[k] = conditional.mean()
        sd[k] = math.sqrt(max(variance, 0.0) + conditional.var())
    return mean, sd
