"""Discovery: find the physics a model of a static channel left out, add it, show the fit
improve.

First, two effects of single samples are scanned for on the samples' distribution, each
accepted on a decisive Bayes factor: clipping at a rail (``saturation``,
:mod:`bayescal._saturation`; the clipped samples are imputed for what follows) and isolated
glitches (``outliers``, replaced by their neighbours' mean). Then the loop (documented for
users in the README, section "Discovery"):

1. fit the current model — bias, noise terms and deterministic terms — by its Whittle
   likelihood (:mod:`bayescal._whittle`): the periodogram of the increments of the data minus
   the deterministic terms, with the noise terms' exact expected periodogram. Deterministic
   coefficients are profiled out exactly (the likelihood is quadratic in them); the slow ones
   are then taken from the block means (:func:`level_coefficients`). The model's score counts
   each frequency once: the exact Gaussian likelihood of 128 block means up to their Nyquist
   frequency, the Whittle bins above it;
2. run the checks (:func:`run_checks`): Allan deviation against the model, the spectrum in
   octave bands and its largest line, residual block means over time, against the temperature
   and against the accelerometers, tails, a rail, discrete levels, time stamps. Each gives a
   statistic, a p-value (Bonferroni-corrected over the places it looked) and where it looked;
3. fit every catalogue term not yet in the model (../shared/DESIGN.md names), and compare each
   with the current model by the Schwarz (BIC) approximation of the log Bayes factor. A
   nonlinear parameter found by search (a sinusoid's frequency among the Fourier
   frequencies, a transient's or a Gauss-Markov time constant on a log grid) has a uniform
   prior over the values searched: it pays the log of their number, a lower bound of the
   Bayes factor's cost. The term with the largest log Bayes factor is accepted when that exceeds
   log(100) — "decisive" on Jeffreys' scale; its expected log predictive density gain
   (pointwise over independent frequency bins and one-block-ahead predictions of the block
   means, AIC-penalised) and the standard error of that gain are reported beside it;
4. repeat until every check passes (nothing is left to explain) or no term is decisive, and
   report which located mismatches are gone.

Because the candidates compete on the same data, the signatures decide between effects that
raise the same statistic: a thermal polynomial only explains what follows the temperature, a
warm-up only what decays from power-on, a random walk what is spread over the spectrum as
1/f^2, a Gauss-Markov term what flattens below its corner frequency.
"""

import math
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from scipy import fft, stats
from scipy.signal import windows

from ._allan import allan_deviation
from ._edf import equivalent_degrees_of_freedom
from ._level import block_covariance_basis
from ._mcmc import batch_log_density, diagnose, sample_ensemble, summarize, walker_count
from ._noise_fit import allan_reference_scales
from ._noise_model import SPECTRAL_COMPONENTS, NoiseModel, component_weights
from ._saturation import impute_clipped, rail_check, saturation_scan
from ._units import noise_parameter_unit
from ._whittle import regression_coefficients, spectral_summary, whittle_log_likelihood

EXPLANATIONS = {
    "bias_instability": "The bias wanders with a 1/f (flicker) spectrum, so averaging longer "
    "stops helping: the Allan deviation flattens into a floor.",
    "rate_random_walk": "The bias performs a random walk (integrated white noise), so long "
    "averages drift apart: the Allan deviation rises as the square root of tau.",
    "gauss_markov": "The bias is exponentially correlated with a time constant: it wanders "
    "but returns, which leaves a bump in the Allan deviation and a Lorentzian spectrum.",
    "quantization": "The output is rounded to the converter's resolution (LSB): the samples "
    "sit on discrete levels and the Allan deviation falls as 1/tau at short tau.",
    "rate_ramp": "The bias drifts steadily in time, at a constant rate, independent of the "
    "temperature.",
    "sinusoid": "A periodic disturbance (vibration, a rotor, mains pickup) adds a line to the "
    "spectrum at a fixed frequency.",
    "thermal_bias": "The bias depends on the temperature: the residual follows the "
    "temperature column, not time.",
    "warmup_transient": "After power-on the bias settles exponentially: the start of the "
    "recording departs from the rest, and the departure decays.",
    "outliers": "Isolated glitches far outside the noise: the residual has heavier tails than "
    "a Gaussian.",
    "saturation": "The output is clipped at the end of the sensor's range: samples that would "
    "lie beyond it are stuck on one value (the rail), which pulls the mean in and shrinks the "
    "spread.",
    "g_sensitivity": "The gyro bias moves with the specific force: the residual follows an "
    "accelerometer channel.",
}
NOISE_SLOTS = ("N", "B", "K", "Q", "G", "R", "F")
"""Sampled coordinates: log N, log B, log K, log Q, log sigma of a Gauss-Markov term, the
ramp R / scale, atanh of the output filter F."""
TERM_SLOT = {
    "white": "N",
    "bias_instability": "B",
    "rate_random_walk": "K",
    "quantization": "Q",
    "gauss_markov": "G",
    "rate_ramp": "R",
    "output_filter": "F",
}
NOISE_EFFECTS = ("bias_instability", "rate_random_walk", "gauss_markov", "rate_ramp")
MAX_SINUSOIDS = 2
MAX_COVARIATES = 3
MAX_THERMAL_DEGREE = 3
MAX_REGRESSORS = MAX_THERMAL_DEGREE + 1 + 2 * MAX_SINUSOIDS + MAX_COVARIATES
DECISIVE_LOG_BAYES_FACTOR = math.log(100.0)
"""Jeffreys' "decisive": odds of 100 to 1."""
AMBIGUOUS_LOG_BAYES_FACTOR = math.log(10.0)
"""A runner-up closer than this to the accepted term explains the mismatch about as well:
the two are reported as indistinguishable on this recording."""
UNMODELLED_CHECKS = ("timestamps", "rail")
"""Checks no term of the search answers — the time stamps, and a rail, which the saturation
scan decides before the search: they are reported, but do not start a search."""
CHECK_LEVEL = 0.01
"""A check fails when its (Bonferroni-corrected) p-value is below this."""
TIME_BLOCKS = 32
GRID_POINTS = 6
PARABOLIC_STEPS = 3
"""Refinements of a searched time constant by a parabola through the best score and its two
neighbours (in log time constant), after the grid and its midpoints."""
SEARCHED_VALUES = 2 * GRID_POINTS - 1 + PARABOLIC_STEPS
PROFILE_DROP = 0.5 * stats.chi2.ppf(0.90, 1)
"""Fall of a profile log-likelihood from its peak at the ends of a 90 % interval."""
PRIOR_LOG_SD = 4.0
LEVEL_BLOCKS = 128
"""Block means for the coefficients of slow deterministic terms (see :func:`fit_model`)."""


class DiscoveryData(eqx.Module):
    """One static channel on a regular grid and the series it may depend on."""

    values: np.ndarray
    rate_hz: float = eqx.field(static=True)
    channel: str = eqx.field(static=True)
    unit: str = eqx.field(static=True)
    temperature: np.ndarray | None = None
    temperature_unit: str = eqx.field(static=True, default="degC")
    covariates: dict = eqx.field(default_factory=dict)
    """name -> samples of accelerometer channels (for g-sensitivity)."""
    covariate_units: dict = eqx.field(static=True, default_factory=dict)
    notes: tuple[str, ...] = eqx.field(static=True, default=())

    def __check_init__(self):
        if np.asarray(self.values).ndim != 1:
            raise ValueError("values: one channel, a 1-D array")
        if np.count_nonzero(np.isfinite(self.values)) < 256:
            raise ValueError("values: at least 256 finite samples are needed for discovery")

    @property
    def time_s(self) -> np.ndarray:
        return np.arange(self.values.size) / self.rate_hz

    @property
    def duration_s(self) -> float:
        return self.values.size / self.rate_hz


class ModelSpec(eqx.Module):
    """Which terms a model holds, with the nonlinear parameters fixed where it has them."""

    noise: tuple[str, ...] = eqx.field(static=True, default=("white",))
    gauss_markov_s: float = eqx.field(static=True, default=0.0)
    thermal_degree: int = eqx.field(static=True, default=0)
    warmup_s: float = eqx.field(static=True, default=0.0)
    sinusoid_hz: tuple[float, ...] = eqx.field(static=True, default=())
    g_sensitivity: tuple[str, ...] = eqx.field(static=True, default=())
    saturation: bool = eqx.field(static=True, default=False)
    outliers: bool = eqx.field(static=True, default=False)

    def terms(self) -> list[str]:
        """The model's terms as catalogue names, the bias first."""
        names = ["bias", *self.noise]
        names += ["thermal_bias"] * (self.thermal_degree > 0)
        names += ["warmup_transient"] * (self.warmup_s > 0)
        names += ["sinusoid"] * len(self.sinusoid_hz)
        names += ["g_sensitivity"] * len(self.g_sensitivity)
        names += ["saturation"] * self.saturation
        names += ["outliers"] * self.outliers
        return names

    def regressor_names(self) -> list[str]:
        names = [f"c{k}" for k in range(1, self.thermal_degree + 1)]
        names += ["warmup_amplitude"] * (self.warmup_s > 0)
        for index in range(len(self.sinusoid_hz)):
            names += [f"sinusoid{index}_sin", f"sinusoid{index}_cos"]
        names += [f"g_{name}" for name in self.g_sensitivity]
        return names

    def searched(self) -> int:
        """Nonlinear parameters fixed by a search: time constants and frequencies."""
        return (self.gauss_markov_s > 0) + (self.warmup_s > 0) + len(self.sinusoid_hz)

    def search_penalty(self, n_frequencies: int) -> float:
        """log of the number of values each search chose among: with a uniform prior over
        them, the marginal likelihood is at least the best one's divided by that number, so
        the log Bayes factor is at least the best fit's minus this."""
        time_constants = (self.gauss_markov_s > 0) + (self.warmup_s > 0)
        return time_constants * math.log(SEARCHED_VALUES) + len(self.sinusoid_hz) * math.log(
            n_frequencies
        )


def _gauss_markov_rate_autocovariance(lags, rate_hz: float, time_constant_s: float):
    """Autocovariance of period averages of an Ornstein-Uhlenbeck rate of unit variance."""
    a = 1.0 / (rate_hz * time_constant_s)
    lags = np.abs(np.asarray(lags, dtype=float))
    scale = 1.0 / (a * a)
    same = 2.0 * scale * (a - 1.0 + math.exp(-a))
    apart = scale * (-math.expm1(-a)) ** 2 * np.exp(-a * np.maximum(lags - 1.0, 0.0))
    return np.where(lags == 0, same, apart)


def gauss_markov_increment_autocovariance(rate_hz: float, time_constant_s: float) -> Callable:
    """Increment autocovariance of a unit-variance Gauss-Markov rate, as a function of lag."""

    def autocovariance(lags):
        lags = np.asarray(lags, dtype=float)
        gamma = lambda k: _gauss_markov_rate_autocovariance(k, rate_hz, time_constant_s)  # noqa: E731
        return 2.0 * gamma(lags) - gamma(lags - 1.0) - gamma(lags + 1.0)

    return autocovariance


def gauss_markov_allan_variance(tau, sigma, time_constant_s):
    """Allan variance of a first-order Gauss-Markov rate of variance sigma^2 (IEEE Std 952,
    annex C): (2 sigma^2 T / tau) [1 - T / (2 tau) (3 - 4 e^{-tau/T} + e^{-2 tau/T})]."""
    ratio = np.asarray(tau, dtype=float) / time_constant_s
    return (2 * sigma**2 / ratio) * (
        1 - (3 - 4 * np.exp(-ratio) + np.exp(-2 * ratio)) / (2 * ratio)
    )


def _gauss_markov_block_covariance(start, stop, rate_hz, time_constant_s):
    """Covariance of block means of a unit-variance Gauss-Markov rate (continuous time):
    T^2 (1 - e^{-La/T}) (1 - e^{-Lb/T}) e^{-gap/T} / (La Lb) between blocks, and
    2 T^2 (L/T - 1 + e^{-L/T}) / L^2 for a block with itself."""
    a, b = start / rate_hz, stop / rate_hz
    length = b - a
    t = time_constant_s
    decay = -np.expm1(-length / t)
    before = np.subtract.outer(a, b)  # a_i - b_j
    gap = np.maximum(np.maximum(before, before.T), 0.0)
    apart = t * t * np.outer(decay, decay) * np.exp(-gap / t) / np.outer(length, length)
    same = 2 * t * t * (length / t - decay) / length**2
    return np.where(np.equal.outer(start, start), np.diag(same), apart)


class _Design(eqx.Module):
    """The data of one model, ready for the compiled functions."""

    summary: object
    location: np.ndarray
    scale: np.ndarray
    mask: np.ndarray
    regressor_mask: np.ndarray
    ramp_scale: np.ndarray


def _variances(theta, mask, ramp_scale):
    on = mask.astype(theta.dtype)
    value = lambda slot: on[slot] * jnp.exp(theta[..., slot])  # noqa: E731
    filter_coefficient = on[6] * jnp.tanh(theta[..., 6])
    weights = component_weights(value(0), value(1), value(2), value(3), filter_coefficient)
    gauss_markov = value(4) ** 2
    variances = jnp.concatenate((weights, gauss_markov[..., None]), axis=-1)
    return variances, on[5] * theta[..., 5] * ramp_scale


def _profile(design: _Design, theta):
    """Log-likelihood at the best regression coefficients given the noise, the coefficients
    and their precision."""
    variances, ramp = _variances(theta, design.mask, design.ramp_scale)
    # Absent regressors are zero columns: a unit ridge pins their coefficients at zero.
    beta, precision = regression_coefficients(
        design.summary, variances, ramp, ridge=1.0 - design.regressor_mask
    )
    pointwise = whittle_log_likelihood(design.summary, variances, ramp, beta)
    return pointwise, beta, precision


def _log_prior(design: _Design, theta):
    return -0.5 * jnp.sum(((theta - design.location) / design.scale) ** 2)


def _marginal_log_posterior(design: _Design, theta):
    """Log posterior of the noise coordinates with the regression coefficients integrated
    out under a flat prior (exact: the likelihood is Gaussian in them)."""
    pointwise, _, precision = _profile(design, theta)
    active = design.regressor_mask
    sign, log_det = jnp.linalg.slogdet(precision)
    value = (
        jnp.sum(pointwise)
        + _log_prior(design, theta)
        + 0.5 * jnp.sum(active) * jnp.log(2 * jnp.pi)
        - 0.5 * log_det
    )
    return jnp.where(jnp.isfinite(value) & (sign > 0), value, -jnp.inf)


@eqx.filter_jit
def _maximum(design: _Design):
    """MAP of the noise coordinates (regression profiled), from the prior centre and from a
    start well below it; the better optimum, the pointwise log-likelihood there, the
    coefficients, their precision and the Hessian of the negative log posterior."""

    def objective(theta, _):
        value = -(jnp.sum(_profile(design, theta)[0]) + _log_prior(design, theta))
        return jnp.where(jnp.isfinite(value), value, 1e30)

    solver = optx.BFGS(rtol=1e-9, atol=1e-9)
    lowered = design.location - 3.0 * design.mask * jnp.array([1, 1, 1, 1, 1, 0, 0])
    solutions = [
        optx.minimise(objective, solver, start, max_steps=2000, throw=False)
        for start in (design.location, lowered)
    ]
    values = jnp.stack([objective(solution.value, None) for solution in solutions])
    pick = jnp.argmin(values)
    best = jnp.where(pick == 0, solutions[0].value, solutions[1].value)
    converged = jnp.where(
        pick == 0,
        solutions[0].result == optx.RESULTS.successful,
        solutions[1].result == optx.RESULTS.successful,
    )
    pointwise, beta, precision = _profile(design, best)
    hessian = jax.hessian(lambda theta: objective(theta, None))(best)
    return best, pointwise, beta, precision, hessian, converged


@eqx.filter_jit
def _batch_profile(design: _Design, theta):
    return jax.vmap(lambda t: _profile(design, t)[1:])(theta)


class ModelFit(eqx.Module):
    """The MAP fit of one model to one recording."""

    spec: ModelSpec
    theta: np.ndarray
    beta: np.ndarray
    beta_covariance: np.ndarray
    pointwise: np.ndarray
    """Log-likelihood at the MAP, pointwise: the Whittle bins above the block means' band,
    then the one-block-ahead predictive density of each block mean."""
    log_likelihood: float
    n_parameters: int
    schwarz: float
    """log-likelihood - (continuous parameters / 2) log(frequencies) - log(values searched):
    differences of it approximate log Bayes factors."""
    converged: bool
    residual: np.ndarray
    """The data minus the fitted deterministic terms (bias and noise left)."""
    clean: np.ndarray
    """The data the model was fitted to (clipped samples imputed and outliers replaced when
    the model has those terms)."""
    design: _Design
    hessian: np.ndarray

    @property
    def noise(self) -> dict:
        """Noise parameters at the MAP in the channel's units (absent terms: 0)."""
        mask, theta = np.asarray(self.design.mask), self.theta
        values = {
            slot: float(mask[i] * math.exp(theta[i])) for i, slot in enumerate(NOISE_SLOTS[:5])
        }
        values["R"] = float(mask[5] * theta[5] * self.design.ramp_scale)
        values["F"] = float(mask[6] * math.tanh(theta[6]))
        return values


def _standardized(column: np.ndarray) -> np.ndarray:
    column = column - np.nanmean(column)
    scale = np.nanstd(column)
    return column / scale if scale > 0 else column


def regressor_columns(spec: ModelSpec, data: DiscoveryData) -> tuple[np.ndarray, np.ndarray]:
    """(samples, MAX_REGRESSORS) columns of the deterministic terms (zero columns where
    absent) and the scale that turns each coefficient back into the channel's units."""
    time = data.time_s
    columns, scales = [], []
    if spec.thermal_degree:
        centred = data.temperature - np.nanmean(data.temperature)
        spread = float(np.nanstd(centred))
        for power in range(1, spec.thermal_degree + 1):
            columns.append((centred / spread) ** power)
            scales.append(spread**power)
    if spec.warmup_s:
        columns.append(np.exp(-time / spec.warmup_s))
        scales.append(1.0)
    for frequency in spec.sinusoid_hz:
        columns += [np.sin(2 * np.pi * frequency * time), np.cos(2 * np.pi * frequency * time)]
        scales += [1.0, 1.0]
    for name in spec.g_sensitivity:
        covariate = data.covariates[name]
        spread = float(np.nanstd(covariate))
        columns.append(_standardized(covariate))
        scales.append(spread)
    matrix = np.zeros((data.values.size, MAX_REGRESSORS))
    if columns:
        matrix[:, : len(columns)] = np.stack(columns, axis=1)
    return matrix, np.array(scales)


def _prior(spec: ModelSpec, scales: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    location = np.array(
        [
            math.log(scales["N"]),
            math.log(scales["B"]),
            math.log(scales["K"]),
            math.log(scales["Q"]),
            math.log(scales["G"]),
            0.0,
            0.0,
        ]
    )
    scale = np.array([PRIOR_LOG_SD] * 5 + [1.0, 1.0])
    mask = np.zeros(len(NOISE_SLOTS))
    for term in spec.noise:
        mask[NOISE_SLOTS.index(TERM_SLOT[term])] = 1.0
    return location, scale, mask


class _Context(eqx.Module):
    """What every fit of one recording shares."""

    data: DiscoveryData
    prior_scales: dict
    n_frequencies: int
    unclipped: np.ndarray
    """The data with clipped samples imputed (the data itself when nothing is clipped)."""
    clean: np.ndarray
    """``unclipped`` with the outliers replaced (itself when there are none)."""
    summaries: dict
    """Spectral summaries already computed, by the parts of a spec they depend on, and the
    time constants found by earlier searches."""


def _context(data: DiscoveryData, unclipped: np.ndarray, clean: np.ndarray) -> _Context:
    allan = allan_deviation(clean, data.rate_hz, "octave")
    scales = allan_reference_scales(allan)
    scales["G"] = float(np.nanmax(allan.deviation)) * 2.0
    half = np.count_nonzero(np.isfinite(clean)) // 2
    return _Context(data, scales, half, unclipped, clean, {})


def _slow_columns(spec: ModelSpec) -> np.ndarray:
    """Indices of the regressors estimated from block means: all but the sinusoids."""
    names = spec.regressor_names()
    return np.array(
        [i for i, name in enumerate(names) if not name.startswith("sinusoid")], dtype=int
    )


def _padded(summary):
    """The summary with its regression moments padded by zero columns to MAX_REGRESSORS, so
    that every model of a recording shares one compiled likelihood."""
    extra = MAX_REGRESSORS - summary.cross.shape[1]
    return eqx.tree_at(
        lambda s: (s.cross, s.gram, s.mean_regressor),
        summary,
        (
            np.pad(summary.cross, ((0, 0), (0, extra), (0, 0))),
            np.pad(summary.gram, ((0, 0), (0, extra), (0, extra), (0, 0))),
            np.pad(summary.mean_regressor, ((0, 0), (0, extra))),
        ),
    )


def _level_design(values, regressors, rate_hz: float):
    """Block means of the data and of the regressors, and the blocks' covariance bases."""
    edges = np.linspace(0, values.size, LEVEL_BLOCKS + 1).round().astype(np.int64)
    start, stop = edges[:-1], edges[1:]
    means = _block_means(values, start, stop)
    columns = np.array([_block_means(column, start, stop) for column in regressors.T]).T.reshape(
        LEVEL_BLOCKS, regressors.shape[1]
    )
    return means, columns, start, stop


def level_coefficients(fit_like, values, regressors, rate_hz, theta):
    """GLS coefficients of ``regressors`` from the block means of the data under the noise at
    ``theta`` (one set of coordinates, or a batch), the bias taken out and the ramp removed;
    their covariance; and the one-block-ahead log predictive density of each block mean.

    The increments' likelihood discards the ends of the record with its taper, where a
    warm-up or a temperature step hold most of their information, and it cannot see the
    level of the signal, which is what tells a Gauss-Markov term (bounded) from a random walk
    (not); the block means keep both. With the coefficients at their GLS values the
    Cholesky-whitened residuals are the standardised one-step-ahead prediction errors, so the
    exact Gaussian log-likelihood of the block means splits into one predictive density per
    block."""
    means, columns, start, stop = _level_design(values, regressors, rate_hz)
    time = (start + stop) / 2 / rate_hz
    theta = np.atleast_2d(theta)
    variances, ramp = _variances(jnp.asarray(theta), fit_like.mask, fit_like.ramp_scale)
    variances, ramp = np.asarray(variances), np.asarray(ramp)
    basis = block_covariance_basis(start, stop, rate_hz)
    covariance = np.einsum("dt,tij->dij", variances[:, : len(SPECTRAL_COMPONENTS)], basis)
    if fit_like.gauss_markov_s > 0:
        shape = _gauss_markov_block_covariance(start, stop, rate_hz, fit_like.gauss_markov_s)
        covariance = covariance + variances[:, -1, None, None] * shape
    design = np.concatenate((np.ones((columns.shape[0], 1)), columns), axis=1)
    factor = np.linalg.cholesky(covariance)
    white_design = np.linalg.solve(factor, np.broadcast_to(design, (theta.shape[0], *design.shape)))
    target = means[None, :] - ramp[:, None] * time[None, :]
    white_target = np.linalg.solve(factor, target[..., None])[..., 0]
    normal = np.einsum("dip,diq->dpq", white_design, white_design)
    right = np.einsum("dip,di->dp", white_design, white_target)
    coefficient_covariance = np.linalg.inv(normal)
    coefficients = np.einsum("dpq,dq->dp", coefficient_covariance, right)
    errors = white_target - np.einsum("dip,dp->di", white_design, coefficients)
    log_scale = np.log(np.diagonal(factor, axis1=-2, axis2=-1))
    predictive = -0.5 * (errors**2 + math.log(2 * math.pi)) - log_scale
    return coefficients[:, 1:], coefficient_covariance[:, 1:, 1:], predictive


def _above_level_band(summary, duration_s: float) -> np.ndarray:
    """The Whittle bins above the band the block means already cover (up to their Nyquist
    frequency), so that no frequency is counted twice in a model's likelihood."""
    return summary.frequency_hz > LEVEL_BLOCKS / (2 * duration_s)


class _LevelNoise(eqx.Module):
    mask: np.ndarray
    ramp_scale: np.ndarray
    gauss_markov_s: float = eqx.field(static=True)


def fit_model(context: _Context, spec: ModelSpec) -> ModelFit:
    """MAP fit of ``spec``: the noise by the Whittle likelihood of the increments with the
    regression profiled exactly; then the coefficients of the slow deterministic terms (all
    but sinusoids) by GLS on block means under that noise (:func:`level_coefficients`). The
    score (log-likelihood, Schwarz) takes the block means' exact likelihood for the band they
    cover and the Whittle bins above it, so that no frequency is counted twice."""
    data = context.data
    values = (
        context.clean if spec.outliers else context.unclipped if spec.saturation else data.values
    )
    regressors, _ = regressor_columns(spec, data)
    time_constant = spec.gauss_markov_s or 1.0
    n_regressors = len(spec.regressor_names())
    key = (
        spec.saturation,
        spec.outliers,
        spec.thermal_degree,
        spec.warmup_s,
        spec.sinusoid_hz,
        spec.g_sensitivity,
        time_constant,
    )
    if key not in context.summaries:
        context.summaries[key] = _padded(
            spectral_summary(
                values,
                data.rate_hz,
                regressors=regressors[:, : max(n_regressors, 1)],
                extra_components=(
                    gauss_markov_increment_autocovariance(data.rate_hz, time_constant),
                ),
            )
        )
    summary = context.summaries[key]
    location, scale, mask = _prior(spec, context.prior_scales)
    regressor_mask = (np.arange(MAX_REGRESSORS) < n_regressors).astype(float)
    design = _Design(
        summary,
        location,
        scale,
        mask,
        regressor_mask,
        np.asarray(10.0 * context.prior_scales["R"]),
    )
    theta, pointwise, beta, precision, hessian, converged = _maximum(design)
    beta = np.array(beta)
    covariance = np.linalg.inv(np.asarray(precision))
    slow = _slow_columns(spec)
    fast = np.setdiff1d(np.arange(n_regressors), slow)
    level_beta, level_covariance, level_pointwise = level_coefficients(
        _LevelNoise(mask, design.ramp_scale, spec.gauss_markov_s),
        values - regressors[:, fast] @ beta[fast],
        regressors[:, slow],
        data.rate_hz,
        np.asarray(theta),
    )
    if slow.size:
        beta[slow] = level_beta[0]
        covariance[np.ix_(slow, slow)] = level_covariance[0]
        pointwise = whittle_log_likelihood(
            summary, *_variances(jnp.asarray(theta), mask, design.ramp_scale), beta
        )
    pointwise = np.concatenate(
        (
            np.asarray(pointwise)[: summary.n_bins][_above_level_band(summary, data.duration_s)],
            level_pointwise[0],
        )
    )
    n_parameters = int(mask.sum()) + n_regressors + spec.searched()
    log_likelihood = float(np.sum(pointwise))
    # Schwarz for the continuous parameters; the searched ones pay log(number searched).
    continuous = n_parameters - spec.searched()
    schwarz = (
        log_likelihood
        - 0.5 * continuous * math.log(context.n_frequencies)
        - spec.search_penalty(context.n_frequencies)
    )
    fitted = regressors @ beta
    return ModelFit(
        spec=spec,
        theta=np.asarray(theta),
        beta=beta[:n_regressors],
        beta_covariance=covariance[:n_regressors, :n_regressors],
        pointwise=np.asarray(pointwise),
        log_likelihood=log_likelihood,
        n_parameters=n_parameters,
        schwarz=schwarz,
        converged=bool(converged),
        residual=values - fitted,
        clean=values,
        design=design,
        hessian=np.asarray(hessian),
    )


# --- checks ---------------------------------------------------------------------------


def _bonferroni(p_values) -> tuple[float, int]:
    p_values = np.asarray(p_values, dtype=float)
    worst = int(np.nanargmin(p_values))
    return float(min(1.0, p_values[worst] * np.count_nonzero(np.isfinite(p_values)))), worst


def model_allan_variance(fit: ModelFit, tau, rate_hz: float):
    noise = fit.noise
    model = NoiseModel(
        rate_hz, N=noise["N"], B=noise["B"], K=noise["K"], Q=noise["Q"], R=noise["R"], F=noise["F"]
    )
    variance = np.asarray(model.allan_variance(tau))
    if noise["G"] > 0:
        variance = variance + gauss_markov_allan_variance(tau, noise["G"], fit.spec.gauss_markov_s)
    return variance


def _dominant_exponent(fit: ModelFit, tau, rate_hz: float) -> list[int]:
    """Power-law exponent alpha of S_y(f) of the model term with the largest Allan variance at
    each tau (a Gauss-Markov term counts as a random walk below its time constant, as white
    noise above it)."""
    noise = fit.noise
    terms = [
        (2, 3 * noise["Q"] ** 2 / tau**2),
        (0, noise["N"] ** 2 / tau),
        (-1, 2 * math.log(2) / math.pi * noise["B"] ** 2 + 0 * tau),
        (-2, noise["K"] ** 2 * tau / 3 + noise["R"] ** 2 * tau**2 / 2),
    ]
    if noise["G"] > 0:
        variance = gauss_markov_allan_variance(tau, noise["G"], fit.spec.gauss_markov_s)
        below = tau < fit.spec.gauss_markov_s
        terms.append((-2, np.where(below, variance, 0.0)))
        terms.append((0, np.where(below, 0.0, variance)))
    exponents = np.array([alpha for alpha, _ in terms])
    values = np.stack([np.broadcast_to(value, np.shape(tau)) for _, value in terms])
    return exponents[np.argmax(values, axis=0)].tolist()


def _allan_check(fit: ModelFit, rate_hz: float, unit: str) -> dict:
    allan = allan_deviation(fit.residual, rate_hz, "octave")
    usable = np.isfinite(allan.deviation)
    tau, deviation = allan.tau[usable], allan.deviation[usable]
    predicted = model_allan_variance(fit, tau, rate_hz)
    # The band is the model's: its EDF for the noise type the model says dominates at each
    # tau, not for a type identified from the data (unreliable from a few long averages).
    n_phase = int(np.count_nonzero(np.isfinite(fit.residual))) + 1
    edf = np.array(
        [
            equivalent_degrees_of_freedom(
                alpha, 2, int(m), n_phase, overlapping=True, modified=False
            )
            for alpha, m in zip(_dominant_exponent(fit, tau, rate_hz), allan.m[usable], strict=True)
        ]
    )
    ratio = deviation**2 / predicted
    lower = stats.chi2.cdf(edf * ratio, edf)
    p_each = 2 * np.minimum(lower, 1 - lower)
    p_value, worst = _bonferroni(p_each)
    flagged = p_each * usable.sum() < CHECK_LEVEL
    location = {"tau_s": float(tau[worst]), "adev_over_model": float(math.sqrt(ratio[worst]))}
    if flagged.any():
        location["tau_range_s"] = [float(tau[flagged].min()), float(tau[flagged].max())]
        if flagged.sum() >= 2:
            excess = np.sqrt(np.maximum(deviation[flagged] ** 2 - predicted[flagged], 1e-300))
            slope = np.polyfit(np.log(tau[flagged]), np.log(excess), 1)[0]
            location["excess_slope"] = float(slope)
    return {
        "name": "allan_deviation",
        "statistic": float(np.max(np.abs(np.log(ratio)))),
        "p_value": p_value,
        "location": location,
        "unit": unit,
        "curve": {
            "tau_s": tau.tolist(),
            "adev": deviation.tolist(),
            "model_low": np.sqrt(predicted * stats.chi2.ppf(0.05, edf) / edf).tolist(),
            "model_high": np.sqrt(predicted * stats.chi2.ppf(0.95, edf) / edf).tolist(),
        },
    }


def _bin_ratios(fit: ModelFit) -> tuple[np.ndarray, np.ndarray]:
    """sum I / S in each frequency bin at the MAP, and the model's expected periodogram."""
    summary = fit.design.summary
    variances, _ = _variances(jnp.asarray(fit.theta), fit.design.mask, fit.design.ramp_scale)
    s0 = np.einsum("t,tb->b", np.asarray(variances), summary.basis[:, 0, :])
    beta = np.zeros(MAX_REGRESSORS)
    beta[: fit.beta.size] = fit.beta
    moment0 = (
        summary.moment0
        - 2 * np.einsum("p,pb->b", beta, summary.cross[0])
        + np.einsum("p,q,pqb->b", beta, beta, summary.gram[0])
    )
    return moment0 / s0, s0


def _spectrum_check(fit: ModelFit) -> dict:
    summary = fit.design.summary
    ratio, _ = _bin_ratios(fit)
    weight = summary.weight
    frequency = summary.frequency_hz
    octave = np.floor(np.log2(frequency / frequency.min())).astype(int)
    p_each, bands = [], []
    for band in np.unique(octave):
        members = octave == band
        shape = float(np.sum(summary.count[members] * weight[members]))
        observed = float(np.sum(ratio[members] * weight[members]))
        lower = stats.gamma.cdf(observed, shape)
        p_each.append(2 * min(lower, 1 - lower))
        bands.append(
            (float(frequency[members].min()), float(frequency[members].max()), observed / shape)
        )
    p_value, worst = _bonferroni(p_each)
    low, high, power_ratio = bands[worst]
    return {
        "name": "spectrum_bands",
        "statistic": float(abs(math.log(power_ratio))),
        "p_value": p_value,
        "location": {"frequency_hz": [low, high], "power_over_model": power_ratio},
    }


def _line_search(fit: ModelFit, rate_hz: float) -> tuple[float, float, int]:
    """The largest ratio of the tapered periodogram of the residual's increments to the
    model's, its frequency (refined between Fourier frequencies) and how many were searched."""
    residual = fit.residual
    finite = np.isfinite(residual)
    increments = np.diff(np.where(finite, residual, np.nanmean(residual)))
    length = increments.size
    taper = windows.tukey(length, 0.1)
    power = np.abs(fft.rfft(taper * (increments - increments.mean()))) ** 2 / np.sum(taper**2)
    _, s0 = _bin_ratios(fit)
    summary = fit.design.summary
    frequency = np.arange(power.size) * rate_hz / length
    expected = np.interp(np.log(np.maximum(frequency, 1e-300)), np.log(summary.frequency_hz), s0)
    lowest = 10  # below ten cycles per record a line cannot be told from a drift
    ratio = power[lowest:-1] / expected[lowest:-1]
    peak = int(np.argmax(ratio))
    index = peak + lowest
    # Refine between Fourier frequencies: the DFT of the tapered increments on ever finer
    # grids, then the vertex of a parabola through the best three (the estimate's own scatter,
    # about 1 / (record length * sqrt(SNR)), is far below a Fourier bin).
    time = np.arange(length)
    tapered = taper * (increments - increments.mean())
    centre, half_width = float(index), 1.0
    for _ in range(3):
        fine = centre + np.linspace(-half_width, half_width, 21)
        strength = np.array(
            [abs(np.dot(tapered, np.exp(-2j * np.pi * nu / length * time))) for nu in fine]
        )
        best = int(np.clip(np.argmax(strength), 1, fine.size - 2))
        centre, half_width = float(fine[best]), half_width / 10
    low, middle, high = np.log(strength[best - 1 : best + 2])
    step = half_width  # the last grid's spacing
    curvature = low - 2 * middle + high
    if curvature < 0:
        centre += step * 0.5 * (low - high) / curvature
    return float(ratio[peak]), float(centre / length * rate_hz), ratio.size


def _line_check(fit: ModelFit, rate_hz: float) -> dict:
    ratio, frequency, searched = _line_search(fit, rate_hz)
    # The largest of `searched` unit exponentials exceeds x with probability 1 - (1-e^-x)^M.
    p_value = float(-np.expm1(searched * np.log1p(-math.exp(-ratio))))
    return {
        "name": "spectral_line",
        "statistic": ratio,
        "p_value": p_value,
        "location": {"frequency_hz": frequency, "power_over_model": ratio},
    }


def _block_edges(size: int) -> tuple[np.ndarray, np.ndarray]:
    edges = np.linspace(0, size, TIME_BLOCKS + 1).round().astype(np.int64)
    return edges[:-1], edges[1:]


def _block_covariance(fit: ModelFit, start, stop, rate_hz):
    variances, _ = _variances(jnp.asarray(fit.theta), fit.design.mask, fit.design.ramp_scale)
    variances = np.asarray(variances)
    basis = block_covariance_basis(start, stop, rate_hz)
    covariance = np.einsum("t,tij->ij", variances[: len(SPECTRAL_COMPONENTS)], basis)
    if variances[-1] > 0:
        covariance += variances[-1] * _gauss_markov_block_covariance(
            start, stop, rate_hz, fit.spec.gauss_markov_s
        )
    return covariance


def _block_means(values, start, stop):
    return np.array([np.nanmean(values[a:b]) for a, b in zip(start, stop, strict=True)])


def _whitened_blocks(fit: ModelFit, rate_hz: float):
    """GLS residual of the block means around the bias, Cholesky-whitened."""
    start, stop = _block_edges(fit.residual.size)
    time = (start + stop) / 2 / rate_hz
    means = _block_means(fit.residual, start, stop) - fit.noise["R"] * time
    factor = np.linalg.cholesky(_block_covariance(fit, start, stop, rate_hz))
    white_means = np.linalg.solve(factor, means)
    white_ones = np.linalg.solve(factor, np.ones_like(means))
    bias = np.dot(white_ones, white_means) / np.dot(white_ones, white_ones)
    return white_means - bias * white_ones, white_ones, factor, start, stop


def _time_check(fit: ModelFit, rate_hz: float, unit: str) -> dict:
    whitened, _, _, start, stop = _whitened_blocks(fit, rate_hz)
    statistic = float(np.dot(whitened, whitened))
    p_value = float(stats.chi2.sf(statistic, whitened.size - 1))
    worst = int(np.argmax(np.abs(whitened)))
    means = _block_means(fit.residual, start, stop)
    return {
        "name": "residual_time",
        "statistic": statistic,
        "p_value": p_value,
        "location": {
            "window_s": [float(start[worst] / rate_hz), float(stop[worst] / rate_hz)],
            "largest_departure": float(means[worst] - np.nanmean(fit.residual)),
            "unit": unit,
            "start_versus_rest": float(means[0] - np.nanmean(means[1:])),
        },
        "curve": {
            "time_s": ((start + stop) / 2 / rate_hz).tolist(),
            "residual": (means - np.nanmean(fit.residual)).tolist(),
        },
    }


def _covariate_check(fit: ModelFit, rate_hz, covariate, name, unit, covariate_unit) -> dict:
    """GLS slope of the residual block means on the covariate's block means."""
    whitened, white_ones, factor, start, stop = _whitened_blocks(fit, rate_hz)
    regressor = _block_means(covariate, start, stop)
    white_regressor = np.linalg.solve(factor, regressor)
    white_regressor = white_regressor - (
        np.dot(white_ones, white_regressor) / np.dot(white_ones, white_ones) * white_ones
    )
    information = float(np.dot(white_regressor, white_regressor))
    if not information > 0:
        slope, z = 0.0, 0.0
    else:
        slope = float(np.dot(white_regressor, whitened) / information)
        z = slope * math.sqrt(information)
    means = _block_means(fit.residual, start, stop)
    return {
        "name": f"residual_vs_{name}",
        "statistic": abs(z),
        "p_value": float(2 * stats.norm.sf(abs(z))),
        "location": {
            "range": [float(np.nanmin(regressor)), float(np.nanmax(regressor))],
            "range_unit": covariate_unit,
            "slope": slope,
            "slope_unit": f"{unit}/{covariate_unit}",
        },
        "curve": {"covariate": regressor.tolist(), "residual": (means - means.mean()).tolist()},
    }


def robust_scores(values: np.ndarray) -> np.ndarray:
    """Each sample's departure from the mean of its two neighbours, in units of the robust
    spread of that departure: Gaussian for any noise that is smooth or white at the sample
    scale, and a glitch of one sample stands out at its own index."""
    filled = np.where(np.isfinite(values), values, np.nanmedian(values))
    detail = np.zeros_like(filled)
    detail[1:-1] = filled[1:-1] - 0.5 * (filled[:-2] + filled[2:])
    detail[0], detail[-1] = filled[0] - filled[1], filled[-1] - filled[-2]
    spread = 1.4826 * np.median(np.abs(detail - np.median(detail)))
    return detail / spread if spread > 0 else np.zeros_like(detail)


def _tail_threshold(n: int) -> float:
    """|z| exceeded by 0.01 samples on average among n Gaussian ones."""
    return float(stats.norm.isf(0.005 / n))


def _tail_check(values: np.ndarray, rate_hz: float) -> dict:
    scores = robust_scores(values)
    threshold = _tail_threshold(scores.size)
    beyond = np.flatnonzero(np.abs(scores) > threshold)
    return {
        "name": "tails",
        "statistic": int(beyond.size),
        "p_value": float(stats.poisson.sf(beyond.size - 1, 0.01)) if beyond.size else 1.0,
        "location": {
            "threshold_sigma": threshold,
            "times_s": (beyond[:10] / rate_hz).tolist(),
        },
    }


def discrete_step(values: np.ndarray) -> float:
    """The spacing of the levels the samples sit on, or 0 when they are not on a grid."""
    finite = values[np.isfinite(values)]
    levels = np.unique(finite)
    if levels.size > finite.size / 4 or levels.size < 3:
        return 0.0
    steps = np.diff(levels)
    step = float(np.min(steps))
    on_grid = np.abs(steps / step - np.round(steps / step)) < 1e-3
    return step if np.mean(on_grid) > 0.99 else 0.0


def _levels_check(fit: ModelFit, rate_hz: float, unit: str) -> dict:
    step = discrete_step(fit.clean)
    white_sd = fit.noise["N"] * math.sqrt(rate_hz)
    material = step > 0 and step > 0.5 * white_sd
    return {
        "name": "discrete_levels",
        "statistic": step / white_sd if white_sd > 0 else 0.0,
        "p_value": 0.0 if material else 1.0,
        "location": {"lsb": step, "unit": unit},
    }


def _timestamp_check(data: DiscoveryData) -> dict:
    issues = [note for note in data.notes if "gap" in note or "missing" in note]
    return {
        "name": "timestamps",
        "statistic": len(issues),
        "p_value": 1.0 if not issues else 0.0,
        "location": {"notes": list(issues)},
    }


def run_checks(fit: ModelFit, data: DiscoveryData) -> list[dict]:
    """Every check of the model ``fit`` against the data; each dict has name, statistic,
    p_value, location and passed."""
    rate, unit = data.rate_hz, data.unit
    checks = [
        _allan_check(fit, rate, unit),
        _spectrum_check(fit),
        _line_check(fit, rate),
        _time_check(fit, rate, unit),
    ]
    if data.temperature is not None:
        checks.append(
            _covariate_check(
                fit, rate, data.temperature, "temperature", unit, data.temperature_unit
            )
        )
    for name, covariate in data.covariates.items():
        checks.append(
            _covariate_check(fit, rate, covariate, name, unit, data.covariate_units.get(name, ""))
        )
    checks += [
        _tail_check(fit.clean, rate),
        rail_check(fit.clean, rate, unit),
        _levels_check(fit, rate, unit),
        _timestamp_check(data),
    ]
    for check in checks:
        check["passed"] = bool(check["p_value"] >= CHECK_LEVEL)
    return checks


# --- candidates -----------------------------------------------------------------------


def _replace(spec: ModelSpec, **changes) -> ModelSpec:
    fields = {
        name: getattr(spec, name)
        for name in (
            "noise",
            "gauss_markov_s",
            "thermal_degree",
            "warmup_s",
            "sinusoid_hz",
            "g_sensitivity",
            "saturation",
            "outliers",
        )
    }
    fields.update(changes)
    return ModelSpec(**fields)


def _time_grid(data: DiscoveryData) -> np.ndarray:
    return np.geomspace(max(5.0, 20.0 / data.rate_hz), data.duration_s / 3.0, GRID_POINTS)


def _search_time(context, make_spec, key: str) -> tuple[ModelFit, dict]:
    """The best fit over a log grid of time constants, refined around the best point by the
    midpoints to its neighbours and then by parabolic steps in log time constant (a
    deterministic term with a time constant off by a third leaves a residual that a noise
    term would take up); the profile (time constant, Schwarz score) is returned for the
    interval, sampled also where the parabola puts the ends of the 90 % interval (the profile
    is skewed, and the grid's neighbours of the peak can sit far out on it). A later step
    searches only around the time constant the previous step found for the same term. Where
    the best is the grid's longest time constant, the grid is extended by its own step until
    the score falls, up to the record's length (beyond it a decay is a ramp): a true value
    just past the grid's end would otherwise be located at the end with a zero-width
    interval."""
    previous = context.summaries.get(("best time", key))
    if previous is None:
        grid = list(_time_grid(context.data))
    else:
        grid = [previous / 1.6, previous, previous * 1.6]
    fits = {t: fit_model(context, make_spec(float(t))) for t in grid}
    best = max(fits, key=lambda t: fits[t].schwarz)
    step = grid[1] / grid[0]
    while best == grid[-1] and best * step <= context.data.duration_s:
        grid.append(best * step)
        fits[grid[-1]] = fit_model(context, make_spec(float(grid[-1])))
        best = max(fits, key=lambda t: fits[t].schwarz)
    position = grid.index(best)
    for neighbour in (position - 1, position + 1):
        if 0 <= neighbour < len(grid):
            middle = math.sqrt(best * grid[neighbour])
            fits[middle] = fit_model(context, make_spec(float(middle)))
    for _ in range(PARABOLIC_STEPS):
        times = sorted(fits)
        log_times = np.log(times)
        peak = _peak_parabola(log_times, [fits[t].schwarz for t in times])
        if peak is None or np.min(np.abs(peak[0] - log_times)) < 0.02:
            break
        vertex = float(np.exp(peak[0]))
        fits[vertex] = fit_model(context, make_spec(vertex))
    times = sorted(fits)
    peak = _peak_parabola(np.log(times), [fits[t].schwarz for t in times])
    if peak is not None:
        half = math.sqrt(PROFILE_DROP / -peak[1])
        for end in (math.exp(peak[0] - half), math.exp(peak[0] + half)):
            fits[end] = fit_model(context, make_spec(end))
    times = sorted(fits)
    winner = max(times, key=lambda t: fits[t].schwarz)
    context.summaries[("best time", key)] = winner
    return fits[winner], {
        "time_constant_s": times,
        "score": [fits[t].schwarz for t in times],
        "estimates": [
            {
                **dict(zip(fits[t].spec.regressor_names(), fits[t].beta, strict=True)),
                "sigma_gm": fits[t].noise["G"],
            }
            for t in times
        ],
    }


def _peak_parabola(x, y) -> tuple[float, float, float] | None:
    """Vertex, curvature and height of the parabola through the highest of the points (x
    sorted) and its two neighbours; None where the highest is at an end or the parabola opens
    upward."""
    x, y = np.asarray(x), np.asarray(y)
    best = int(np.argmax(y))
    if not 0 < best < x.size - 1:
        return None
    curvature, slope, value = np.polyfit(
        x[best - 1 : best + 2] - x[best], y[best - 1 : best + 2], 2
    )
    if not curvature < 0:
        return None
    return (
        float(x[best] - slope / (2 * curvature)),
        float(curvature),
        float(value - slope**2 / (4 * curvature)),
    )


def candidate_fits(context: _Context, current: ModelFit) -> dict[str, tuple[ModelFit, dict]]:
    """Each catalogue term not yet in the model, added and fitted: name -> (fit, search)."""
    data, spec = context.data, current.spec
    candidates = {}
    for term in NOISE_EFFECTS:
        if term in spec.noise:
            continue
        if term == "gauss_markov":
            candidates[term] = _search_time(
                context,
                lambda t: _replace(spec, noise=(*spec.noise, "gauss_markov"), gauss_markov_s=t),
                "gauss_markov",
            )
        else:
            candidates[term] = (fit_model(context, _replace(spec, noise=(*spec.noise, term))), {})
    if "quantization" not in spec.noise and discrete_step(data.values) > 0:
        candidates["quantization"] = (
            fit_model(context, _replace(spec, noise=(*spec.noise, "quantization"))),
            {},
        )
    if data.temperature is not None and spec.thermal_degree == 0 and _varies(data.temperature):
        fits = [
            fit_model(context, _replace(spec, thermal_degree=degree))
            for degree in range(1, MAX_THERMAL_DEGREE + 1)
        ]
        best = max(fits, key=lambda fit: fit.schwarz)
        candidates["thermal_bias"] = (best, {"degree_scores": [fit.schwarz for fit in fits]})
    if not spec.warmup_s:
        candidates["warmup_transient"] = _search_time(
            context, lambda t: _replace(spec, warmup_s=t), "warmup_transient"
        )
    if len(spec.sinusoid_hz) < MAX_SINUSOIDS:
        _, frequency, _ = _line_search(current, data.rate_hz)
        fit = fit_model(context, _replace(spec, sinusoid_hz=(*spec.sinusoid_hz, frequency)))
        candidates["sinusoid"] = (fit, {"frequency_hz": frequency})
    unused = [name for name in data.covariates if name not in spec.g_sensitivity]
    if unused and len(spec.g_sensitivity) < MAX_COVARIATES:
        fits = [
            fit_model(context, _replace(spec, g_sensitivity=(*spec.g_sensitivity, name)))
            for name in unused
            if _varies(data.covariates[name])
        ]
        if fits:
            candidates["g_sensitivity"] = (max(fits, key=lambda fit: fit.schwarz), {})
    return candidates


def _varies(series: np.ndarray) -> bool:
    finite = series[np.isfinite(series)]
    return finite.size > 0 and np.unique(finite).size >= 3 and np.ptp(finite) > 0


def outlier_scan(values: np.ndarray) -> dict:
    """Contaminated-normal against normal on the robust scores: the log Bayes factor (Schwarz,
    two parameters), the ELPD gain with its standard error (per sample: the scores are nearly
    independent), the fraction and scale of the glitches and which samples they are."""
    scores = robust_scores(values)
    n = scores.size
    normal = stats.norm.logpdf(scores)
    best = None
    for fraction in np.geomspace(1.0 / n, 0.05, 12):
        for scale in (5.0, 10.0, 20.0, 50.0, 100.0):
            mixture = np.logaddexp(
                np.log1p(-fraction) + normal,
                math.log(fraction) + stats.norm.logpdf(scores, scale=scale),
            )
            total = float(mixture.sum())
            if best is None or total > best[0]:
                best = (total, fraction, scale, mixture)
    total, fraction, scale, mixture = best
    difference = mixture - normal
    outlier_probability = np.exp(
        math.log(fraction) + stats.norm.logpdf(scores, scale=scale) - mixture
    )
    # A glitch also shifts its neighbours' scores by half its own: flag only the peak.
    magnitude = np.abs(scores)
    peak = magnitude >= np.maximum(np.roll(magnitude, 1), np.roll(magnitude, -1))
    flagged = (outlier_probability > 0.5) & peak
    return {
        "log_bayes_factor": float(difference.sum() - math.log(n)),
        "delta_elpd": float(difference.sum() - 2.0),
        "delta_elpd_se": float(math.sqrt(n) * np.std(difference)),
        "fraction": fraction,
        "scale": scale,
        "flagged": flagged,
    }


def _without_outliers(values: np.ndarray, flagged: np.ndarray) -> np.ndarray:
    """The flagged samples replaced by the mean of their nearest unflagged neighbours."""
    index = np.arange(values.size)
    keep = ~flagged & np.isfinite(values)
    return np.where(flagged, np.interp(index, index[keep], values[keep]), values)


def _elpd_difference(new: ModelFit, old: ModelFit) -> tuple[float, float]:
    """AIC-penalised ELPD gain and its standard error, pointwise over frequency bins and
    block predictions."""
    difference = new.pointwise - old.pointwise
    gain = float(difference.sum()) - (new.n_parameters - old.n_parameters)
    return gain, float(math.sqrt(difference.size) * np.std(difference))


class Finding(eqx.Module):
    """One accepted effect: its name, the fit with it, and the evidence."""

    name: str = eqx.field(static=True)
    fit: ModelFit
    log_bayes_factor: float
    delta_elpd: float
    delta_elpd_se: float
    runner_up: tuple
    search: dict


class Discovery(eqx.Module):
    """The result of :func:`discover`."""

    data: DiscoveryData
    baseline: ModelFit
    final: ModelFit
    findings: tuple
    baseline_checks: list
    final_checks: list
    outliers: dict | None
    undecided: tuple = ()
    """(name, log Bayes factor) of the best candidate when the search stopped with a check
    still failing because no term was decisive; empty otherwise."""
    saturation: dict | None = None


def discover(
    data: DiscoveryData,
    *,
    baseline: tuple[str, ...] = ("white",),
    max_effects: int = 4,
    progress: Callable[[str], None] | None = None,
    seed: int = 0,
) -> Discovery:
    """Find, name and model what the ``baseline`` noise terms leave out of ``data``.

    Two sample-level effects are scanned for first, on the samples' distribution: clipped
    samples (``saturation``, imputed with ``seed`` for the fits that follow) and isolated
    glitches (``outliers``, replaced by their neighbours' mean)."""
    report = progress or (lambda message: None)
    unknown = [term for term in baseline if term not in TERM_SLOT]
    if unknown:
        raise ValueError(f"baseline: unknown term(s) {unknown}; known: {sorted(TERM_SLOT)}")
    if "white" not in baseline:
        baseline = ("white", *baseline)

    def decisive(scan):
        return scan if scan and scan["log_bayes_factor"] > DECISIVE_LOG_BAYES_FACTOR else None

    saturation = decisive(saturation_scan(data.values))
    unclipped = (
        impute_clipped(data.values, saturation, np.random.default_rng(seed))
        if saturation
        else data.values
    )
    outliers = decisive(outlier_scan(unclipped))
    clean = _without_outliers(unclipped, outliers["flagged"]) if outliers else unclipped
    context = _context(data, unclipped, clean)
    report("fitting the baseline")
    current = fit_model(context, ModelSpec(noise=tuple(baseline)))
    baseline_fit = current
    baseline_checks = run_checks(current, data)
    findings = []
    for name, scan in (("saturation", saturation), ("outliers", outliers)):
        if scan:
            current = fit_model(context, _replace(current.spec, **{name: True}))
            findings.append(
                Finding(
                    name,
                    current,
                    scan["log_bayes_factor"],
                    scan["delta_elpd"],
                    scan["delta_elpd_se"],
                    (),
                    {},
                )
            )
    checks = baseline_checks if not findings else run_checks(current, data)
    undecided = ()
    for _ in range(max_effects):
        if not any(
            not check["passed"] for check in checks if check["name"] not in UNMODELLED_CHECKS
        ):
            break  # nothing located: nothing left to explain
        report(f"trying terms beyond {', '.join(current.spec.terms())}")
        candidates = candidate_fits(context, current)
        if not candidates:
            break
        ranked = sorted(candidates.items(), key=lambda item: item[1][0].schwarz, reverse=True)
        name, (fit, search) = ranked[0]
        log_bayes_factor = fit.schwarz - current.schwarz
        if not log_bayes_factor > DECISIVE_LOG_BAYES_FACTOR:
            undecided = (name, float(log_bayes_factor))
            break
        gain, gain_se = _elpd_difference(fit, current)
        runner_up = (
            (ranked[1][0], float(ranked[1][1][0].schwarz - current.schwarz))
            if len(ranked) > 1
            else ()
        )
        findings.append(Finding(name, fit, log_bayes_factor, gain, gain_se, runner_up, search))
        current = fit
        checks = run_checks(current, data)
    report("checking the final model")
    return Discovery(
        data=data,
        baseline=baseline_fit,
        final=current,
        findings=tuple(findings),
        baseline_checks=baseline_checks,
        final_checks=checks,
        outliers=outliers,
        undecided=undecided,
        saturation=saturation,
    )


# --- posterior of the final model ------------------------------------------------------


class FinalPosterior(eqx.Module):
    draws: dict
    """name -> (walkers, draws) in the channel's units."""
    units: dict = eqx.field(static=True)
    diagnostics: object


def _active_noise(spec: ModelSpec) -> list[int]:
    return [NOISE_SLOTS.index(TERM_SLOT[term]) for term in spec.noise]


def sample_final(fit: ModelFit, data: DiscoveryData, *, seed: int = 0) -> FinalPosterior:
    """emcee posterior of the final model's noise coordinates (regression integrated out),
    then the regression coefficients from their exact conditional normal. Nonlinear
    parameters found by search (time constants, frequencies) are held at their values."""
    rng = np.random.default_rng(seed)
    active = _active_noise(fit.spec)
    full = np.asarray(fit.theta)

    def embed(sub):
        theta = np.broadcast_to(full, (*sub.shape[:-1], full.size)).copy()
        theta[..., active] = sub
        return theta

    hessian = fit.hessian[np.ix_(active, active)]
    covariance = np.linalg.pinv(hessian)
    names = [NOISE_SLOTS[i] for i in active]
    log_posterior = batch_log_density(_marginal_log_posterior, fit.design)
    sampler, converged = sample_ensemble(
        lambda sub: log_posterior(embed(sub)),
        full[active],
        covariance,
        rng,
        walker_count(len(active)),
        40_000,
    )
    diagnostics, kept = diagnose(sampler, names, converged, fit.converged)
    theta = embed(kept)
    flat = theta.reshape(-1, theta.shape[-1])
    beta, precision = _batch_profile(fit.design, jnp.asarray(flat))
    beta, precision = np.array(beta), np.asarray(precision)
    n_regressors = fit.beta.size
    noise_draw = rng.standard_normal((flat.shape[0], MAX_REGRESSORS))
    factor = np.linalg.cholesky(np.linalg.inv(precision))
    beta = beta + np.einsum("dij,dj->di", factor, noise_draw)
    slow = _slow_columns(fit.spec)
    if slow.size:
        regressors, _ = regressor_columns(fit.spec, data)
        level_beta, level_covariance, _ = level_coefficients(
            _LevelNoise(fit.design.mask, fit.design.ramp_scale, fit.spec.gauss_markov_s),
            fit.clean,
            regressors[:, slow],
            data.rate_hz,
            flat,
        )
        level_factor = np.linalg.cholesky(level_covariance)
        beta[:, slow] = level_beta + np.einsum(
            "dij,dj->di", level_factor, rng.standard_normal(level_beta.shape)
        )
    shape = theta.shape[:-1]
    draws, units = {}, {}
    ramp_scale = float(fit.design.ramp_scale)
    for index in active:
        slot = NOISE_SLOTS[index]
        if slot == "R":
            value = theta[..., index] * ramp_scale
        elif slot == "F":
            value = np.tanh(theta[..., index])
        else:
            value = np.exp(theta[..., index])
        name = "sigma_gm" if slot == "G" else slot
        draws[name] = value
        units[name] = data.unit if slot == "G" else noise_parameter_unit(slot, data.unit)
    _, scales = regressor_columns(fit.spec, data)
    coefficient_names = fit.spec.regressor_names()
    coefficients = beta[:, :n_regressors] / np.where(scales > 0, scales, 1.0)
    thermal_unit = data.temperature_unit
    for position, name in enumerate(coefficient_names):
        draws[name] = coefficients[:, position].reshape(shape)
        if name.startswith("c"):
            power = int(name[1:])
            units[name] = f"{data.unit}/{thermal_unit}" + (f"^{power}" if power > 1 else "")
        elif name.startswith("g_"):
            units[name] = f"{data.unit}/({data.covariate_units.get(name[2:], '1')})"
        else:
            units[name] = data.unit
    for index in range(len(fit.spec.sinusoid_hz)):
        sine = draws.pop(f"sinusoid{index}_sin")
        cosine = draws.pop(f"sinusoid{index}_cos")
        units.pop(f"sinusoid{index}_sin")
        units.pop(f"sinusoid{index}_cos")
        draws[f"sinusoid{index}_amplitude"] = np.hypot(sine, cosine)
        units[f"sinusoid{index}_amplitude"] = data.unit
    return FinalPosterior(draws, units, diagnostics)


def _profile_interval(search: dict, key: str) -> dict:
    """Value and 90 % profile-likelihood interval of a searched time constant, in log(time
    constant): the peak from the parabola through the best point and its neighbours; each
    end where the profile has fallen by PROFILE_DROP, by a parabola from the peak through the
    point on that side whose fall is nearest to it (the search samples the profile near both
    ends, and a profile is seldom symmetric). Where the best point sits at the end of the
    search, the interval runs to the search's end on that side."""
    grid, score = np.log(np.asarray(search[key])), np.asarray(search["score"])
    best = int(np.argmax(score))
    centre, low, high = grid[best], grid[0], grid[-1]
    peak = _peak_parabola(grid, score)
    if peak is not None:
        centre, curvature, height = peak
        ends = []
        for side in (-1.0, 1.0):
            offset, fall = side * (grid - centre), height - score
            usable = (offset > 1e-3) & (fall > 0)
            if np.any(usable):
                nearest = np.argmin(np.abs(np.log(fall[usable] / PROFILE_DROP)))
                half = offset[usable][nearest] * math.sqrt(PROFILE_DROP / fall[usable][nearest])
            else:
                half = math.sqrt(PROFILE_DROP / -curvature)
            ends.append(centre + side * half)
        low, high = ends
    elif best in (0, grid.size - 1):
        inside = grid[score >= score[best] - PROFILE_DROP]
        low, high = min(inside.min(), centre), max(inside.max(), centre)
        low = grid[0] if best == 0 else low
        high = grid[-1] if best == grid.size - 1 else high
    return {
        "mean": float(math.exp(centre)),
        "q05": float(math.exp(low)),
        "q95": float(math.exp(high)),
        "unit": "s",
        "method": "profile likelihood in log time constant over a search of "
        f"{grid.size} values ({math.exp(grid[0]):.3g} to {math.exp(grid[-1]):.3g} s)",
    }


def _widened_for_time_constant(
    summary: dict, search: dict, name: str, time_constant: dict, *, log_scale: bool
) -> dict:
    """The posterior of a parameter tied to a searched time constant (a warm-up's amplitude,
    a Gauss-Markov sigma) is conditional on the located value, and the two trade against each
    other (a longer warm-up with a smaller amplitude; a longer correlation time with a larger
    sigma). Marginalised to first order (delta method): the sd grows by the parameter's slope
    in log time constant (from the search's fits around the best) times the profile sd of log
    time constant (``time_constant``, its :func:`_profile_interval`). With ``log_scale`` (a
    scale such as sigma) it is widened in its logarithm, so the interval stays positive."""
    log_time = np.log(np.asarray(search["time_constant_s"]))
    estimate = np.array([values[name] for values in search["estimates"]])
    best = int(np.argmax(search["score"]))
    around = slice(max(best - 1, 0), best + 2)
    transformed = np.log(estimate[around]) if log_scale else estimate[around]
    slope = np.polyfit(log_time[around], transformed, 1)[0]
    z = stats.norm.ppf(0.95)
    log_sd = (math.log(time_constant["q95"]) - math.log(time_constant["q05"])) / (2 * z)
    centre = summary["mean"]
    conditional_sd = summary["sd"] / centre if log_scale else summary["sd"]
    sd = math.hypot(conditional_sd, slope * log_sd)
    low, high = (
        (centre * math.exp(-z * sd), centre * math.exp(z * sd))
        if log_scale
        else (centre - z * sd, centre + z * sd)
    )
    return {
        **summary,
        "sd": centre * sd if log_scale else sd,
        "q05": low,
        "q95": high,
        "method": "posterior at the located time constant, widened by the time constant's "
        "profile-likelihood spread (delta method)",
    }


def _frequency_interval(fit: ModelFit, index: int, amplitude: float, rate_hz: float) -> dict:
    """Cramér-Rao sd of a sinusoid's frequency in locally white noise: var f =
    6 sigma^2 / (pi^2 A^2 n^3 dt^2), sigma^2 the rate-noise level at the line."""
    frequency = fit.spec.sinusoid_hz[index]
    _, s0 = _bin_ratios(fit)
    summary = fit.design.summary
    at_line = float(np.interp(math.log(frequency), np.log(summary.frequency_hz), s0))
    level = at_line / (4 * math.sin(math.pi * frequency / rate_hz) ** 2)
    n = np.count_nonzero(np.isfinite(fit.residual))
    sd = math.sqrt(6 * level / (math.pi**2 * amplitude**2 * n**3)) * rate_hz
    z = stats.norm.ppf(0.95)
    return {
        "mean": frequency,
        "sd": sd,
        "q05": frequency - z * sd,
        "q95": frequency + z * sd,
        "unit": "Hz",
        "method": "Cramér-Rao bound at the located frequency",
    }


def effect_parameters(name: str, finding: Finding, posterior: FinalPosterior, data) -> dict:
    """The parameters of one accepted effect, from the final posterior."""
    spec = finding.fit.spec
    draws, units = posterior.draws, posterior.units
    pick = lambda *names: {n: summarize(draws[n], units[n]) for n in names if n in draws}  # noqa: E731
    match name:
        case "thermal_bias":
            out = pick(*[f"c{k}" for k in range(1, spec.thermal_degree + 1)])
            out["T0"] = {"mean": float(np.nanmean(data.temperature)), "unit": data.temperature_unit}
            return out
        case "warmup_transient":
            out = pick("warmup_amplitude")
            out["time_constant"] = _profile_interval(finding.search, "time_constant_s")
            out["warmup_amplitude"] = _widened_for_time_constant(
                out["warmup_amplitude"],
                finding.search,
                "warmup_amplitude",
                out["time_constant"],
                log_scale=False,
            )
            return out
        case "sinusoid":
            index = len(spec.sinusoid_hz) - 1
            out = {"amplitude": summarize(draws[f"sinusoid{index}_amplitude"], data.unit)}
            out["frequency"] = _frequency_interval(
                finding.fit, index, out["amplitude"]["mean"], data.rate_hz
            )
            return out
        case "gauss_markov":
            out = pick("sigma_gm")
            out["time_constant"] = _profile_interval(finding.search, "time_constant_s")
            out["sigma_gm"] = _widened_for_time_constant(
                out["sigma_gm"], finding.search, "sigma_gm", out["time_constant"], log_scale=True
            )
            return out
        case "g_sensitivity":
            return pick(f"g_{spec.g_sensitivity[-1]}")
        case "outliers" | "saturation":
            return {}
    slot = TERM_SLOT[name]
    return pick(slot)
