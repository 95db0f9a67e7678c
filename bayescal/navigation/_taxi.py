"""The taxi as a measurement of the heading (claim 1 of US 5,527,003, steps k-l;
../shared/NAVIGATION.md): the vehicle's wander about a taxiway's centre line, and which filter
steps lie on a straight leg of known heading.

With a constant heading error psi the computed velocity is the true one turned by psi, so across
the known track the computed velocity is V psi plus the vehicle's own cross-track velocity, the
wander's; the cross-track offset drifts by psi times the distance run while the wander's stays
bounded. The wander is therefore a state, not white noise: white, it would let the filter
average V psi out of each second's cross-track velocity as if every second were independent,
and claim a heading far tighter than the offset's bounded excursions allow.

The wander's model (one home: the simulator draws from it, the filter holds it as two states):
the cross-track offset w is a second-order Gauss-Markov process,

    d2w/dt2 = -2 zeta omega dw/dt - omega^2 w + u,   E[u(t) u(s)] = q delta(t - s),

with zeta = 1/sqrt(2) and omega = 1 / time constant; stationary, var(w) = sigma^2 when
q = 4 zeta omega^3 sigma^2, and var(dw/dt) = omega^2 sigma^2 (Gelb 1974, *Applied Optimal
Estimation*, table 3.8-1). Below WANDER_SPEED it fades in with a smooth step of the speed.
"""

import math
from dataclasses import dataclass

import numpy as np

WANDER_SD = 0.5
"""sd of the cross-track offset about a taxiway's centre line, m."""
WANDER_TIME_S = 20.0
"""The wander's time constant 1 / omega, s: a driver's corrections take tens of seconds."""
WANDER_DAMPING = 1 / math.sqrt(2)
"""zeta of the wander's second-order process."""
WANDER_SPEED = 3.0
"""Below this speed (m/s) the wander fades out (a standing vehicle does not wander); at it and
above the cross-track velocity is the process's own."""
MIN_TRACK_SPEED = WANDER_SPEED + 0.1
"""A filter step is on a leg only at this computed speed or more (m/s): below it the wander's
fade (and the track's direction) make the cross-track velocity another quantity."""
LEG_TOLERANCE_DEG = 1.0
"""A step is on a leg when its computed track lies within this of the leg's heading (deg) ..."""
LEG_MARGIN_S = 5.0
"""... at it and at every step within this many seconds of it (the end of a turn is not a
leg)."""


def wander_model(sd: float = WANDER_SD, time_constant_s: float = WANDER_TIME_S):
    """The wander's continuous model for the states (w, dw/dt): F (2 x 2), the noise's spectral
    density matrix (2 x 2) and the stationary covariance (2 x 2) (module docstring)."""
    omega = 1.0 / time_constant_s
    dynamics = np.array([[0.0, 1.0], [-(omega**2), -2 * WANDER_DAMPING * omega]])
    density = 4 * WANDER_DAMPING * omega**3 * sd**2
    noise = np.array([[0.0, 0.0], [0.0, density]])
    stationary = np.diag([sd**2, (omega * sd) ** 2])
    return dynamics, noise, stationary


def wander_fade(speed):
    """The smooth step r(V) that fades the wander in with the speed, and dr/dV (1/(m/s)):
    3 x^2 - 2 x^3 with x = V / WANDER_SPEED clipped to [0, 1]."""
    x = np.clip(np.asarray(speed, dtype=float) / WANDER_SPEED, 0.0, 1.0)
    return 3 * x**2 - 2 * x**3, 6 * x * (1 - x) / WANDER_SPEED


def wrap_deg(angle):
    """An angle, or an array of them, wrapped into (-180, 180] deg."""
    return -((-(np.asarray(angle, dtype=float) + 180.0)) % 360.0) + 180.0


def leg_steps(times, velocity, headings_deg, tolerance_deg=LEG_TOLERANCE_DEG) -> np.ndarray:
    """Which leg each filter step lies on: the index into ``headings_deg`` (the known track
    headings, deg), or -1. ``times`` (s) and ``velocity`` (K, 2 or 3: the computed north and
    east velocity, m/s) at the steps. A step is on leg i when the computed speed is at least
    MIN_TRACK_SPEED and the computed track is within ``tolerance_deg`` (deg; one, or one per
    step) of heading i at it and at every step within LEG_MARGIN_S of it."""
    times = np.asarray(times, dtype=float)
    velocity = np.asarray(velocity, dtype=float)
    speed = np.hypot(velocity[:, 0], velocity[:, 1])
    track = np.degrees(np.arctan2(velocity[:, 1], velocity[:, 0]))
    found = np.full(times.size, -1)
    for leg, heading in enumerate(headings_deg):
        close = (np.abs(wrap_deg(track - heading)) <= tolerance_deg) & (speed >= MIN_TRACK_SPEED)
        for k in np.flatnonzero(close & (found < 0)):
            near = np.abs(times - times[k]) <= LEG_MARGIN_S
            if close[near].all():
                found[k] = leg
    return found


@dataclass(frozen=True)
class TaxiReference:
    """What the fine alignment is told about a taxi that follows the park: where it starts in
    the record and the taxiway's known track headings."""

    start_sample: int
    """The taxi's first sample, counted from the window's start."""
    headings_deg: tuple[float, ...]
    """The known track heading of each straight leg, deg from north."""
    wander_sd: float = WANDER_SD
    wander_time_s: float = WANDER_TIME_S


def cross_track_row(heading_deg: float, velocity) -> tuple[np.ndarray, np.ndarray]:
    """The cross-track velocity's sensitivity to the velocity errors (north, east) and to the
    tilts (north, east, down) at computed ``velocity`` (north, east, down, m/s), across a track
    of ``heading_deg``: with the modified phi-angle model (:mod:`._error_model`) the computed
    velocity is the true one plus delta v + v x phi, and n . (v x phi) = -(v . t) phi_D, t and n
    the along- and cross-track unit vectors (so V psi, psi = -phi_D, as NAVIGATION.md says)."""
    chi = math.radians(heading_deg)
    across = np.array([-math.sin(chi), math.cos(chi)])
    along = np.array([math.cos(chi), math.sin(chi)])
    tilt = np.array([0.0, 0.0, -float(along @ np.asarray(velocity)[:2])])
    return across, tilt
