"""The patent's own pipeline, classically: tilt rates from the velocity error's curvature,
block by block, turned into gyro biases (US 5,527,003, claim 1 steps e-j).

The vehicle is still, so the computed velocity is the velocity error. Within each block a
quadratic fitted by least squares to each horizontal component gives its slope (the level tilt
with the accelerometer bias: dv_N/dt = g phi_E + nabla_N, dv_E/dt = -g phi_N + nabla_E) and
its curvature (the tilt rate). With the tilts read from the slopes (the accelerometer biases
taken as zero, as the classical reading does) the error model at rest
(:mod:`._error_model`) gives, per block,

    eps_N             = -dphi_N/dt - Omega sin L phi_E + delta v_E / R_E
    eps_E - Omega cos L phi_D = -dphi_E/dt + Omega sin L phi_N - delta v_N / R_N

— the north bias, and the east bias hidden behind the heading error (one constant over the
park: the claim's steps k-n take it off with the taxi's heading). The vertical gyro's bias is
not seen (taken as zero). The interval of each point treats the residuals of the fit as
independent, as the classical thermal fit does (:mod:`bayescal.classical._thermal`).
"""

import math

import numpy as np

from ._earth import EARTH_RATE, radii

BLOCK_S = 120.0
"""Length of a block, s: ten points over a 20-minute park."""


def blocks(times, block_s: float = BLOCK_S) -> list[np.ndarray]:
    """The indices of ``times`` in each whole block (a last part shorter than half a block is
    left out)."""
    edges = np.arange(times[0], times[-1] + 1e-9, block_s)
    found = []
    for start in edges:
        inside = np.flatnonzero((times >= start) & (times < start + block_s))
        if inside.size >= 4 and times[inside[-1]] - times[inside[0]] >= 0.5 * block_s:
            found.append(inside)
    return found


def tilt_rate_points(times, velocity, latitude: float, gravity: float) -> list[dict]:
    """Per block: its middle time, the north bias and the east bias less the heading term
    (rad/s), each with its standard error, from the computed
    north and east velocity (m/s) at ``times`` (s); ``latitude`` in rad."""
    meridian, transverse = (float(r) for r in radii(latitude))
    sin_l = math.sin(latitude)
    rows = []
    for index in blocks(times):
        t = times[index]
        middle = 0.5 * (t[0] + t[-1])
        design = np.stack([np.ones_like(t), t - middle, (t - middle) ** 2], axis=1)
        fit = {}
        for axis in (0, 1):
            coefficients, residual, _, _ = np.linalg.lstsq(design, velocity[index, axis])
            dof = t.size - 3
            variance = float(residual[0]) / dof if residual.size else 0.0
            covariance = variance * np.linalg.inv(design.T @ design)
            fit[axis] = (coefficients, covariance)
        (north, north_cov), (east, east_cov) = fit[0], fit[1]
        phi_east, phi_north = north[1] / gravity, -east[1] / gravity
        rate_east, rate_north = 2 * north[2] / gravity, -2 * east[2] / gravity
        eps_north = -rate_north - EARTH_RATE * sin_l * phi_east + east[0] / transverse
        eps_east = -rate_east + EARTH_RATE * sin_l * phi_north - north[0] / meridian
        sd_north = 2 * math.sqrt(east_cov[2, 2]) / gravity
        sd_east = 2 * math.sqrt(north_cov[2, 2]) / gravity
        rows.append(
            {
                "time_s": float(middle),
                "north": float(eps_north),
                "north_sd": sd_north,
                "east_less_heading": float(eps_east),
                "east_sd": sd_east,
            }
        )
    return rows


def heading_corrected(rows: list[dict], heading: float, latitude: float) -> list[dict]:
    """The claim's steps m-n: each block's east point with the heading error's Earth-rate
    equivalent taken off, eps_E = (eps_E - Omega cos L phi_D) - Omega cos L psi with psi =
    -phi_D the computed minus true heading (rad, one constant over the park: the taxi's),
    ``latitude`` in rad; the heading's own uncertainty is not carried (the patent takes it as
    known)."""
    shift = EARTH_RATE * math.cos(latitude) * heading
    return [{**row, "east": row["east_less_heading"] - shift} for row in rows]


def interpolate_calibration(
    temperature, bias, sd, coefficients, covariance, reference: float
) -> tuple[np.ndarray, np.ndarray]:
    """The claim's step o, classically: the points (``temperature``, ``bias`` with its ``sd``)
    fitted by weighted least squares with the old polynomial's degree about its ``reference``,
    and the fit and the old ``coefficients`` (``covariance``) weighted by their inverse
    covariances (the interpolation of old and new: the Gaussian product, no aging since the
    old one, each point's sd as independent). Returns the new coefficients and covariance, in
    the points' unit."""
    temperature, bias, sd = (np.asarray(x, dtype=float) for x in (temperature, bias, sd))
    degree = len(coefficients) - 1
    design = (temperature[:, None] - reference) ** np.arange(degree + 1)
    weighted = design / sd[:, None]
    precision = weighted.T @ weighted + np.linalg.inv(covariance)
    information = weighted.T @ (bias / sd) + np.linalg.solve(covariance, coefficients)
    new_covariance = np.linalg.inv(precision)
    return new_covariance @ information, new_covariance
