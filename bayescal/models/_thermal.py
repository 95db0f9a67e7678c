"""Thermal gyro bias: a polynomial in temperature, fitted beside the stationary noise, updated
in the field, and used to compensate the gyro output.

Model: y(t) = sum_j c_j (T(t) - T0)^j + o_p + e(t), where e is the stationary noise of
:mod:`bayescal._noise_model` (white, output filter, flicker, rate random walk, quantization),
o_p a common offset of period p (in-field updates only; the heading-error equivalent an
alignment cannot see) and T the measured temperature. An optional known Earth rate
(15.041 deg/h projected on the axis) is taken off y first, so that it does not pass for bias.

Likelihood. Temperature changes slowly, so the record is cut into blocks short enough that the
temperature barely moves within one (at most 96 blocks per record); the block means have an
exact Gaussian covariance given the noise parameters (:func:`bayescal._level.
block_covariance_basis`), in which a random walk is a random walk — it cannot pass for a
thermal slope, whose signature is that it follows the temperature. Above the blocks'
frequencies the Whittle likelihood of the increments adds what the fast noise says. The
coefficients (and offsets) enter linearly with a Gaussian (or flat) prior, so they are
integrated out exactly for each value of the noise parameters: the noise parameters are
sampled (emcee), the coefficients drawn from their Gaussian conditional. With white noise
only, fixed, the posterior is Gaussian in closed form.

Drift since the calibration. An in-field update takes an earlier calibration as its prior.
That calibration's covariance says how well the bias curve was known *then*; the sensor has
aged since (the reason for updating at all), so taken as it is, the prior is over-confident
and the update inherits its errors with bands that miss them. The update therefore adds a
drift of the coefficients since the calibration, independent per term,
delta_j ~ N(0, (s / h^j)^2), with h the largest distance of the calibrated temperature range
from T0: the bias has moved by about s at T0 and each term by about s at the edge of the
range. s (in the channel's unit) is either given (0: no aging) or learned with the noise
(``drift="auto"``): log-normal prior with its median at the calibration's own standard
deviation of c_0 and sd DRIFT_PRIOR_LOG_SD in the log; where the field data show the old
calibration to be off, s grows and the coefficients the field data cannot see (the curvature
when they cover a few degrees) keep bands as wide as that drift allows.

Degree. With ``degree="auto"`` each degree 0..4 is scored by its expected log predictive
density computed one block ahead (the prequential score p(z_k | z_1..k-1): leave-future-out,
valid for correlated noise, where leave-one-out is not), at its MAP noise; the lowest degree
within max(4, 2 standard errors) of the best is chosen.
"""

import math
from dataclasses import dataclass

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._errors import InputError
from ._components import Components
from ._noise_problem import NoisePrior
from ._terms import PARAMETERS
from ._whittle import spectral_summary, whittle_log_likelihood
from .effects._parameter import Context

MAX_BLOCKS = 96
MAX_DEGREE = 4
DRIFT_PRIOR_LOG_SD = 3.0


@dataclass(frozen=True)
class ThermalRecord:
    """A rate channel and its temperature on one sample grid, cut into stationary periods."""

    values: np.ndarray
    temperature: np.ndarray
    rate_hz: float
    periods: tuple[tuple[int, int], ...]
    """[start, stop) sample ranges; one period unless the record holds several alignments."""


def check_temperature(temperature: np.ndarray, source: str, column: str) -> None:
    present = temperature[~np.isnan(temperature)]
    if present.size == 0 or np.ptp(present) == 0:
        value = f" at {present[0]:g}" if present.size else ""
        raise InputError(
            f"the temperature is constant{value}: a thermal model needs the temperature to change",
            source=source,
            column=column,
            fix="record while the sensor warms up or cools down",
        )


def _blocks(record: ThermalRecord) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Even blocks within each period, none spanning a missing sample: start, stop, period."""
    total = sum(stop - start for start, stop in record.periods)
    size = max(8, math.ceil(total / MAX_BLOCKS))
    starts, stops, owners = [], [], []
    present = ~np.isnan(record.values) & ~np.isnan(record.temperature)
    for index, (start, stop) in enumerate(record.periods):
        edges = np.flatnonzero(
            np.diff(np.concatenate(([0], present[start:stop].astype(np.int8), [0])))
        )
        for run_start, run_stop in zip(edges[::2] + start, edges[1::2] + start, strict=True):
            cuts = np.arange(run_start, run_stop, size)
            for first in cuts:
                last = min(first + size, run_stop)
                if last - first >= size // 2:
                    starts.append(first)
                    stops.append(last)
                    owners.append(index)
    return np.array(starts), np.array(stops), np.array(owners)


class ThermalProblem(eqx.Module):
    """Log marginal posterior of the noise parameters with the regression integrated out."""

    block_mean: np.ndarray
    design: np.ndarray
    """(blocks, regressors): block means of (T - T0)^j, then one indicator per period offset."""
    basis: np.ndarray
    """(components, blocks, blocks) covariance per unit component weight (per period)."""
    spectral: object
    prior_mean: np.ndarray
    prior_precision: np.ndarray
    noise_prior: NoisePrior
    high_bins: np.ndarray
    """Weights that keep only the Whittle bins above the blocks' frequencies."""
    drift_base: np.ndarray | None = None
    """Learned drift only: the calibration's covariance of c, to which the drift is added."""
    drift_shape: np.ndarray | None = None
    """Learned drift only: sd of each coefficient's drift per unit s (1 / h^j)."""
    drift_prior: np.ndarray | None = None
    """Learned drift only: location and scale of the normal prior on log s."""

    @property
    def learns_drift(self) -> bool:
        return self.drift_base is not None

    @property
    def parameters(self) -> tuple[str, ...]:
        """Names of the sampled coordinates: the noise parameters, then the drift s."""
        return self.noise_prior.parameters + (("drift",) if self.learns_drift else ())

    @property
    def location(self):
        """Prior location of every sampled coordinate (a normal prior on each)."""
        if not self.learns_drift:
            return jnp.asarray(self.noise_prior.location)
        return jnp.append(self.noise_prior.location, self.drift_prior[0])

    @property
    def scale(self):
        if not self.learns_drift:
            return jnp.asarray(self.noise_prior.scale)
        return jnp.append(self.noise_prior.scale, self.drift_prior[1])

    def drift(self, theta):
        """The drift scale s of a draw (learned drift only)."""
        return jnp.exp(theta[..., len(self.noise_prior.parameters)])

    def prior(self, theta):
        """Mean and precision of the regression's prior (zero precision: flat), and the log
        determinant of its proper part where that depends on theta (else 0)."""
        if not self.learns_drift:
            return self.prior_mean, self.prior_precision, 0.0
        size = self.drift_base.shape[0]
        covariance = self.drift_base + jnp.diag((self.drift(theta) * self.drift_shape) ** 2)
        factor = jnp.linalg.cholesky(covariance)
        inverse = jax.scipy.linalg.cho_solve((factor, True), jnp.eye(size))
        precision = jnp.asarray(self.prior_precision).at[:size, :size].set(inverse)
        return self.prior_mean, precision, -2 * jnp.sum(jnp.log(jnp.diag(factor)))

    def natural(self, theta):
        """The noise parameters at ``theta``, each from its term's coordinate."""
        context = Context(self.spectral.rate_hz, self.spectral.duration_s)
        return {
            name: PARAMETERS[name].natural(theta[..., index], context)
            for index, name in enumerate(self.noise_prior.parameters)
        }

    def weights(self, theta):
        return self.spectral.components.weights(self.natural(theta))

    def conditional(self, theta):
        """Precision and mean of the regression given the noise (and drift), and the pieces
        of the log marginal likelihood: log det of the block covariance less that of the prior
        precision where it varies, and the quadratic form."""
        prior_mean, prior_precision, prior_log_det = self.prior(theta)
        covariance = jnp.einsum("t,tij->ij", self.weights(theta), self.basis)
        factor = jnp.linalg.cholesky(covariance)
        whitened_design = jax.scipy.linalg.solve_triangular(factor, self.design, lower=True)
        whitened_data = jax.scipy.linalg.solve_triangular(factor, self.block_mean, lower=True)
        precision = prior_precision + whitened_design.T @ whitened_design
        linear = whitened_design.T @ whitened_data + prior_precision @ prior_mean
        mean = jnp.linalg.solve(precision, linear)
        log_det = 2 * jnp.sum(jnp.log(jnp.diag(factor))) - prior_log_det
        quadratic = (
            whitened_data @ whitened_data
            + prior_mean @ prior_precision @ prior_mean
            - linear @ mean
        )
        return precision, mean, log_det, quadratic

    def log_posterior(self, theta):
        precision, _, log_det, quadratic = self.conditional(theta)
        _, log_det_precision = jnp.linalg.slogdet(precision)
        levels = -0.5 * (log_det + log_det_precision + quadratic)
        pointwise = whittle_log_likelihood(self.spectral, self.weights(theta))
        fast = jnp.sum(pointwise[: self.high_bins.size] * self.high_bins)
        prior = -0.5 * jnp.sum(((theta - self.location) / self.scale) ** 2)
        value = levels + fast + prior
        return jnp.where(jnp.isfinite(value), value, -jnp.inf)


def thermal_problem(
    record: ThermalRecord,
    degree: int,
    reference: float,
    *,
    noise_prior: NoisePrior,
    coefficient_prior: tuple[np.ndarray, np.ndarray] | None = None,
    offset_prior: list[tuple[float, float] | None] | None = None,
    spectral=None,
    drift: float | str | None = None,
    calibrated_range: tuple[float, float] | None = None,
) -> ThermalProblem:
    """Set up the likelihood. ``noise_prior`` is the prior of the noise parameters (it names
    the terms); ``coefficient_prior`` is (mean, covariance) of c (flat when
    None); ``offset_prior`` adds one offset per period, each N(m, u^2) when measured and flat
    otherwise (then only the coefficient prior fixes the level); ``spectral`` reuses a
    :func:`record_spectrum`.

    When ``coefficient_prior`` is an earlier calibration, ``drift`` is how far its bias may
    have moved since (module docstring): a scale s in the channel's unit, ``"auto"`` to learn
    s from the data, or None / 0 to take the prior as it stands (right only when nothing has
    changed since). ``calibrated_range`` is that calibration's temperature range (h)."""
    start, stop, owner = _blocks(record)
    if start.size < degree + 3:
        raise InputError(
            f"{start.size} blocks of data are too few for degree {degree}",
            fix="record longer or lower --degree",
        )
    block_mean = np.array(
        [np.nanmean(record.values[a:b]) for a, b in zip(start, stop, strict=True)]
    )
    powers = np.array(
        [
            [np.nanmean((record.temperature[a:b] - reference) ** j) for j in range(degree + 1)]
            for a, b in zip(start, stop, strict=True)
        ]
    )
    if spectral is None:
        spectral = record_spectrum(record, noise_prior.terms)
    # Periods are independent; the slow noise of each starts afresh at its first sample.
    components = spectral.components
    basis = np.zeros((len(components.shapes), start.size, start.size))
    for period in np.unique(owner):
        rows = np.flatnonzero(owner == period)
        first = record.periods[period][0]
        basis[:, rows[:, None], rows[None, :]] = components.block_covariances(
            start[rows] - first, stop[rows] - first, record.rate_hz
        )
    mean = np.zeros(degree + 1)
    precision = np.zeros((degree + 1, degree + 1))
    drift_fields = {}
    if coefficient_prior is not None:
        mean, covariance = (np.asarray(x, dtype=float) for x in coefficient_prior)
        if drift is not None and drift != 0:
            shape = _drift_shape(degree, reference, calibrated_range)
            if drift == "auto":
                drift_fields = {
                    "drift_base": covariance,
                    "drift_shape": shape,
                    "drift_prior": np.array(
                        [math.log(math.sqrt(covariance[0, 0])), DRIFT_PRIOR_LOG_SD]
                    ),
                }
            elif isinstance(drift, (int, float)) and drift > 0:
                covariance = covariance + np.diag((drift * shape) ** 2)
            else:
                raise InputError(
                    f"drift {drift!r}", fix="give a positive scale in the channel's unit or auto"
                )
        precision = np.linalg.inv(covariance)
    design = powers
    if offset_prior is not None:
        indicators = np.equal.outer(owner, np.arange(len(record.periods))).astype(float)
        design = np.hstack([powers, indicators])
        offset_mean = np.array([p[0] if p else 0.0 for p in offset_prior])
        offset_precision = np.array([1 / p[1] ** 2 if p else 0.0 for p in offset_prior])
        mean = np.concatenate([mean, offset_mean])
        precision = np.block(
            [
                [precision, np.zeros((degree + 1, offset_mean.size))],
                [np.zeros((offset_mean.size, degree + 1)), np.diag(offset_precision)],
            ]
        )
    block_seconds = float(np.median(stop - start)) / record.rate_hz
    high = (spectral.frequency_hz > 1.0 / block_seconds).astype(float)
    return ThermalProblem(
        block_mean=block_mean,
        design=design,
        basis=basis,
        spectral=spectral,
        prior_mean=mean,
        prior_precision=precision,
        noise_prior=noise_prior,
        high_bins=high,
        **drift_fields,
    )


def _drift_shape(degree: int, reference: float, calibrated_range) -> np.ndarray:
    """sd of the drift of c_j per unit s: 1 / h^j, h the calibrated range's farthest point
    from T0."""
    if calibrated_range is None:
        raise ValueError("a drift needs the calibrated temperature range")
    low, high = calibrated_range
    half = max(abs(reference - low), abs(high - reference))
    if not half > 0:
        raise InputError(
            f"the calibrated temperature range [{low:g}, {high:g}] has no width about "
            f"T0 = {reference:g}"
        )
    return half ** -np.arange(degree + 1.0)


def record_spectrum(record: ThermalRecord, terms) -> object:
    """The Whittle summary of a record's periods (no increment bridges two periods), with the
    components of the noise ``terms``."""
    joined = np.concatenate([np.append(record.values[a:b], np.nan) for a, b in record.periods])
    components = Components.of(terms, Context(record.rate_hz, joined.size / record.rate_hz))
    return spectral_summary(joined, record.rate_hz, components=components)


def prequential_score(problem: ThermalProblem, theta, skip: int) -> np.ndarray:
    """log p(z_k | z_1..k-1) for k > ``skip``, the regression integrated under its prior
    (flat parts included: their improper constants cancel between k - 1 and k)."""
    weights = np.asarray(problem.weights(jnp.asarray(theta)))
    covariance = np.einsum("t,tij->ij", weights, problem.basis)
    prior_mean, prior_precision, _ = (np.asarray(x) for x in problem.prior(jnp.asarray(theta)))
    flat = int(np.sum(np.diag(prior_precision) == 0))

    def log_marginal(k):
        sigma = covariance[:k, :k]
        factor = np.linalg.cholesky(sigma)
        design = np.linalg.solve(factor, problem.design[:k])
        data = np.linalg.solve(factor, problem.block_mean[:k])
        precision = prior_precision + design.T @ design
        linear = design.T @ data + prior_precision @ prior_mean
        mean = np.linalg.solve(precision, linear)
        _, log_det_precision = np.linalg.slogdet(precision)
        quadratic = data @ data + prior_mean @ prior_precision @ prior_mean - linear @ mean
        return -0.5 * (
            (k - flat) * math.log(2 * math.pi)
            + 2 * np.sum(np.log(np.diag(factor)))
            + log_det_precision
            + quadratic
        )

    totals = np.array([log_marginal(k) for k in range(skip, problem.block_mean.size + 1)])
    return np.diff(totals)


def _identified_from(design: np.ndarray) -> int:
    """How many leading blocks it takes for the columns of ``design`` to be identified (full
    column rank, singular values above 1e-6 of the largest, columns scaled to 1); one more
    than the blocks if never. A quantized temperature that sits on a few values at first
    leaves the higher powers unidentified for a while."""
    scaled = design / np.maximum(np.max(np.abs(design), axis=0), np.finfo(float).tiny)
    for k in range(design.shape[1], design.shape[0] + 1):
        singular = np.linalg.svd(scaled[:k], compute_uv=False)
        if singular[-1] > 1e-6 * singular[0]:
            return k
    return design.shape[0] + 1
