"""The composite model discovery grows: the stationary noise terms, deterministic terms of
the mean and sample effects (the catalogue, :mod:`.effects`) of one static channel.

Layout. The noise coordinates sit in fixed slots, one per noise term the search may add, each
in its term's coordinate (:class:`~bayescal.models.effects._parameter.Parameter`) — log N,
log B, log K, log Q, log sigma of a Gauss-Markov term, the ramp R / scale, the logit of the
one-tap output filter's F — and the regression coefficients in MAX_REGRESSORS columns; a model
switches slots and columns on or off with masks, so that every model of a recording shares one
compiled likelihood.

Likelihood. The Whittle likelihood of the increments (:mod:`._whittle`) of the data minus the
deterministic terms, with the noise terms' exact expected periodogram; the coefficients enter
as a quadratic form, profiled (for the MAP) or integrated out (for the posterior) exactly.
The slow coefficients (all but the sinusoids') are then taken from block means by generalised
least squares (:func:`level_coefficients`): the increments' likelihood discards the ends of
the record with its taper, where a warm-up or a temperature step hold most of their
information, and cannot see the level of the signal, which is what tells a Gauss-Markov term
(bounded) from a random walk (not).
"""

import math
from functools import partial

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ._components import Components
from ._noise_model import NoiseModel
from ._noise_problem import PRIOR_LOG_SD
from ._whittle import expected_power, regression_coefficients, whittle_log_likelihood
from .effects._base import Effect, RegressionTerm, SlotTerm
from .effects._catalogue import CATALOGUE, SEARCHED
from .effects._parameter import Context
from .effects.bias_instability import BiasInstability
from .effects.gauss_markov import GaussMarkov
from .effects.noise_burst import NoiseBurst
from .effects.outliers import Outliers
from .effects.output_filter import OutputFilter
from .effects.quantization import Quantization
from .effects.rate_ramp import RateRamp
from .effects.rate_random_walk import RateRandomWalk
from .effects.saturation import Saturation
from .effects.white import White

SLOT_TERMS = (
    White,
    BiasInstability,
    RateRandomWalk,
    Quantization,
    GaussMarkov,
    RateRamp,
    OutputFilter,
)
"""The noise terms a model may hold, one slot each, in slot order."""
SLOT_PARAMETERS = tuple(term.parameters[0] for term in SLOT_TERMS)
"""Each slot's parameter: the term's scale, its coordinate and prior (a Gauss-Markov term's
correlation time is searched, not sampled)."""
NOISE_SLOTS = tuple(parameter.name for parameter in SLOT_PARAMETERS)
"""The sampled noise coordinates, by parameter (module docstring)."""
BASELINE_TERMS = tuple(term.name for term in SLOT_TERMS)
"""The noise terms a discovery baseline may hold (a low-pass shape of the output filter is
decided by discovery itself, before its search)."""
SLOT_OF = {term: index for index, term in enumerate(SLOT_TERMS)}
"""The slot of each noise term."""
SLOT_COMPONENTS = Components.of(
    [term.name for term in SLOT_TERMS if term is not GaussMarkov], Context(1.0)
)
"""The fixed-shape components of the slot terms (a Gauss-Markov term's shape, at its searched
time constant, is an extra component of each summary: :func:`summary_components`)."""
SCALE_SLOTS = np.array([parameter.link == "log" for parameter in SLOT_PARAMETERS], dtype=float)
"""The slots of a term's scale, sampled in the log (lowered for a second MAP start)."""
MAX_REGRESSORS = sum(term.max_columns for term in SEARCHED if issubclass(term, RegressionTerm))
LEVEL_BLOCKS = 128
"""Block means for the coefficients of slow deterministic terms."""


class ModelSpec(eqx.Module):
    """Which effects a model holds, each with its nonlinear parameters fixed (a time
    constant, a frequency, a degree): white noise and the baseline's terms, then whatever
    discovery added, in the order it added them."""

    effects: tuple = eqx.field(static=True, default=(White(),))

    @classmethod
    def from_names(cls, names) -> "ModelSpec":
        """A model of the noise terms ``names`` (white noise always among them)."""
        names = ("white", *(name for name in names if name != "white"))
        return cls(tuple(CATALOGUE[name]() for name in names))

    def has(self, name: str) -> bool:
        return any(effect.name == name for effect in self.effects)

    def has_instance(self, effect: Effect) -> bool:
        return effect in self.effects

    def count(self, name: str) -> int:
        return sum(effect.name == name for effect in self.effects)

    def with_effect(self, effect: Effect) -> "ModelSpec":
        return ModelSpec((*self.effects, effect))

    def index_of(self, effect: Effect) -> int:
        """How many effects of its kind come before ``effect`` in this model."""
        same = [other for other in self.effects if type(other) is type(effect)]
        return same.index(effect)

    @property
    def noise(self) -> tuple[str, ...]:
        """The noise terms, in the order they were added."""
        return tuple(effect.name for effect in self.effects if isinstance(effect, SlotTerm))

    @property
    def gauss_markov_s(self) -> float:
        """The Gauss-Markov term's time constant (0 without one)."""
        found = [effect for effect in self.effects if isinstance(effect, GaussMarkov)]
        return found[0].time_constant_s if found else 0.0

    @property
    def saturation(self) -> bool:
        return any(isinstance(effect, Saturation) for effect in self.effects)

    @property
    def outliers(self) -> bool:
        """Whether the model is fitted to the cleaned samples: glitches replaced, a noise
        burst scaled down."""
        return any(isinstance(effect, (Outliers, NoiseBurst)) for effect in self.effects)

    def ranked(self) -> list[Effect]:
        """The effects beyond the noise terms, by rank (each kind in the order added)."""
        others = [effect for effect in self.effects if not isinstance(effect, SlotTerm)]
        return sorted(others, key=lambda effect: effect.rank)

    def terms(self) -> list[str]:
        """The model's terms as catalogue names, the bias first."""
        return ["bias", *self.noise, *(effect.name for effect in self.ranked())]

    def regression_terms(self) -> list[tuple[RegressionTerm, int]]:
        """The deterministic terms by rank, each with how many of its kind precede it."""
        seen: dict[type, int] = {}
        terms = []
        for effect in self.ranked():
            if isinstance(effect, RegressionTerm):
                terms.append((effect, seen.get(type(effect), 0)))
                seen[type(effect)] = seen.get(type(effect), 0) + 1
        return terms

    def regression_terms_of(self, name: str) -> list[RegressionTerm]:
        """The deterministic terms named ``name``, in the order they were added."""
        return [term for term, _ in self.regression_terms() if term.name == name]

    def regressor_names(self) -> list[str]:
        return [
            name for term, index in self.regression_terms() for name in term.column_names(index)
        ]

    def searched(self) -> int:
        """Nonlinear parameters fixed by a search: time constants and frequencies."""
        return sum(effect.searched for effect in self.effects)

    def search_penalty(self, n_frequencies: int) -> float:
        """log of the number of values each search chose among: with a uniform prior over
        them, the marginal likelihood is at least the best one's divided by that number, so
        the log Bayes factor is at least the best fit's minus this."""
        return sum(effect.search_penalty(n_frequencies) for effect in self.effects)

    def summary_key(self) -> tuple:
        """What a model's spectral summary depends on: the data it is fitted to, its
        deterministic terms and the Gauss-Markov time constant."""
        return (
            self.saturation,
            self.outliers,
            tuple(term for term, _ in self.regression_terms()),
            self.gauss_markov_s or 1.0,
        )


def regressor_columns(spec: ModelSpec, data) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(samples, MAX_REGRESSORS) columns of the deterministic terms (zero columns where
    absent), the scale that turns each coefficient back into the channel's units, and each
    coefficient's unit."""
    columns, scales, units = [], [], []
    for term, _ in spec.regression_terms():
        term_columns, term_scales, term_units = term.columns(data, data.time_s)
        columns += term_columns
        scales += term_scales
        units += term_units
    matrix = np.zeros((data.values.size, MAX_REGRESSORS))
    if columns:
        matrix[:, : len(columns)] = np.stack(columns, axis=1)
    return matrix, np.array(scales), units


def slot_prior(spec: ModelSpec, scales: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Location and scale of the normal prior on each slot (the term's own where it gives one,
    else log-normal around the Allan curve's bound, ``scales``:
    :func:`~bayescal.models._terms.reference_scales`), and the slots the model switches
    on."""
    priors = [p.prior or (math.log(scales[p.name]), PRIOR_LOG_SD) for p in SLOT_PARAMETERS]
    location, scale = (np.array(column) for column in zip(*priors, strict=True))
    mask = np.zeros(len(NOISE_SLOTS))
    for effect in spec.effects:
        if isinstance(effect, SlotTerm):
            mask[SLOT_OF[type(effect)]] = 1.0
    return location, scale, mask


class Design(eqx.Module):
    """The data of one model, ready for the compiled functions."""

    summary: object
    location: np.ndarray
    scale: np.ndarray
    mask: np.ndarray
    regressor_mask: np.ndarray
    ramp_scale: np.ndarray
    floor: np.ndarray
    """The rounding's known white floor, LSB^2 / (12 fs) (zero off a grid)."""


def summary_components(rate_hz: float, gauss_markov_s: float) -> tuple:
    """The extra components of a model's spectral summary beyond the noise terms': the
    Gauss-Markov term at its time constant, then the rounding floor (white, never shaped by
    the output filter: it comes after it)."""
    return (
        partial(GaussMarkov(gauss_markov_s).autocovariance, rate_hz=rate_hz),
        partial(White.autocovariance, rate_hz=rate_hz),
    )


def shaped(summary, gain: np.ndarray):
    """``summary`` with the white noise's two components through an output filter of |H|^2
    ``gain`` at the bins' nodes (3, bins); the mean increment's basis is left as it is (unit
    gain at zero frequency)."""
    basis = np.array(summary.basis)
    basis[summary.shaped] = basis[summary.shaped] * np.asarray(gain)[None]
    return eqx.tree_at(lambda s: s.basis, summary, basis)


def slot_values(theta, mask, ramp_scale) -> dict:
    """The slots' values in their units at coordinates ``theta`` (each its term's
    coordinate), zero where the mask switches a slot off."""
    context = Context(1.0, linear_scale=ramp_scale)
    on = mask.astype(theta.dtype) if hasattr(mask, "astype") else mask
    return {
        parameter.name: on[index] * parameter.natural(theta[..., index], context)
        for index, parameter in enumerate(SLOT_PARAMETERS)
    }


def slot_reference_scales(allan) -> dict[str, float]:
    """The level of each slot's parameter the classical Allan curve ``allan`` allows (the
    centre of its weakly informative prior; the ramp's scale)."""
    return {k: v for term in SLOT_TERMS for k, v in term.reference_scales(allan).items()}


def slot_variances(theta, mask, ramp_scale, floor):
    """Weights of the summary's components (the noise terms', the Gauss-Markov term's, the
    rounding floor's) and the ramp, for coordinates ``theta``."""
    values = slot_values(theta, mask, ramp_scale)
    weights = SLOT_COMPONENTS.weights(values)
    gauss_markov = values["gm_sigma"] ** 2
    rounding = jnp.broadcast_to(floor, gauss_markov.shape)
    variances = jnp.concatenate((weights, gauss_markov[..., None], rounding[..., None]), axis=-1)
    return variances, values["R"]


def profile(design: Design, theta):
    """Log-likelihood at the best regression coefficients given the noise, the coefficients
    and their precision."""
    variances, ramp = slot_variances(theta, design.mask, design.ramp_scale, design.floor)
    # Absent regressors are zero columns: a unit ridge pins their coefficients at zero.
    beta, precision = regression_coefficients(
        design.summary, variances, ramp, ridge=1.0 - design.regressor_mask
    )
    pointwise = whittle_log_likelihood(design.summary, variances, ramp, beta)
    return pointwise, beta, precision


def log_prior(design: Design, theta):
    return -0.5 * jnp.sum(((theta - design.location) / design.scale) ** 2)


def marginal_log_posterior(design: Design, theta):
    """Log posterior of the noise coordinates with the regression coefficients integrated
    out under a flat prior (exact: the likelihood is Gaussian in them)."""
    pointwise, _, precision = profile(design, theta)
    active = design.regressor_mask
    sign, log_det = jnp.linalg.slogdet(precision)
    value = (
        jnp.sum(pointwise)
        + log_prior(design, theta)
        + 0.5 * jnp.sum(active) * jnp.log(2 * jnp.pi)
        - 0.5 * log_det
    )
    return jnp.where(jnp.isfinite(value) & (sign > 0), value, -jnp.inf)


def profiled_log_posterior(design: Design, theta):
    """Log posterior of the noise coordinates with the regression coefficients at their best
    values given the noise: what the MAP maximises."""
    return jnp.sum(profile(design, theta)[0]) + log_prior(design, theta)


@eqx.filter_jit
def batch_profile(design: Design, theta):
    """Coefficients and their precision for each row of ``theta``."""
    return jax.vmap(lambda t: profile(design, t)[1:])(theta)


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
    design: Design
    hessian: np.ndarray
    lowpass: OutputFilter | None = None
    """The output filter shaping the white noise, decided before the search (None: none,
    or the one-tap F slot)."""
    lsb: float = 0.0
    """The grid the samples sit on (zero: none): its rounding floor is in every model."""

    @property
    def noise(self) -> dict:
        """Noise parameters at the MAP in the channel's units (absent terms: 0)."""
        values = slot_values(
            jnp.asarray(self.theta), np.asarray(self.design.mask), self.design.ramp_scale
        )
        return {name: float(value) for name, value in values.items()}


def slow_columns(spec: "ModelSpec") -> np.ndarray:
    """Indices of the regressors estimated from block means: those of the slow terms (all
    but the sinusoids)."""
    slow = [term.slow for term, index in spec.regression_terms() for _ in term.column_names(index)]
    return np.flatnonzero(np.array(slow, dtype=bool)).astype(int)


def padded(summary):
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


def level_design(values, regressors, rate_hz: float):
    """Block means of the data and of the regressors, and the blocks' covariance bases."""
    edges = np.linspace(0, values.size, LEVEL_BLOCKS + 1).round().astype(np.int64)
    start, stop = edges[:-1], edges[1:]
    means = block_means(values, start, stop)
    columns = np.array([block_means(column, start, stop) for column in regressors.T]).T.reshape(
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
    means, columns, start, stop = level_design(values, regressors, rate_hz)
    time = (start + stop) / 2 / rate_hz
    theta = np.atleast_2d(theta)
    variances, ramp = slot_variances(
        jnp.asarray(theta), fit_like.mask, fit_like.ramp_scale, fit_like.floor
    )
    variances, ramp = np.asarray(variances), np.asarray(ramp)
    covariance = np.einsum(
        "dt,tij->dij", variances, _block_basis(start, stop, rate_hz, fit_like.gauss_markov_s)
    )
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


def above_level_band(summary, duration_s: float) -> np.ndarray:
    """The Whittle bins above the band the block means already cover (up to their Nyquist
    frequency), so that no frequency is counted twice in a model's likelihood."""
    return summary.frequency_hz > LEVEL_BLOCKS / (2 * duration_s)


class LevelNoise(eqx.Module):
    mask: np.ndarray
    ramp_scale: np.ndarray
    floor: np.ndarray
    gauss_markov_s: float = eqx.field(static=True)


def _block_basis(start, stop, rate_hz: float, gauss_markov_s: float) -> np.ndarray:
    """(components, blocks, blocks): block-mean covariance per unit weight of every component
    of :func:`slot_variances` (a Gauss-Markov term's only when the model has one)."""
    gauss_markov = (
        GaussMarkov(gauss_markov_s).block_covariance(start, stop, rate_hz)
        if gauss_markov_s > 0
        else np.zeros((start.size, start.size))
    )
    return np.concatenate(
        (
            SLOT_COMPONENTS.block_covariances(start, stop, rate_hz),
            gauss_markov[None],
            White.block_covariance(start, stop, rate_hz)[None],
        )
    )


def fit_noise_model(fit: ModelFit) -> NoiseModel:
    """The stationary noise of a fit at its MAP but a Gauss-Markov term (whose correlation
    time the search holds: :func:`model_allan_variance`), as a :class:`NoiseModel`; the
    output filter decided before the search in place of the one-tap slot when it has
    another shape."""
    values = {n: v for n, v in fit.noise.items() if v != 0 and n != GaussMarkov.parameter}
    if fit.lowpass is not None:
        values |= {k: v for k, v in fit.lowpass.values.items() if v != 0}
    return NoiseModel(fit.design.summary.rate_hz, lsb=fit.lsb, **values)


def _gauss_markov(fit: ModelFit) -> dict | None:
    """The fit's Gauss-Markov term at its searched time constant, or None."""
    sigma = fit.noise[GaussMarkov.parameter]
    return {"gm_sigma": sigma, "gm_tau": fit.spec.gauss_markov_s} if sigma > 0 else None


def model_allan_variance(fit: ModelFit, tau) -> np.ndarray:
    """The Allan variance of a fit's noise at its MAP at ``tau`` (s)."""
    variance = np.asarray(fit_noise_model(fit).allan_variance(tau))
    term = _gauss_markov(fit)
    if term is not None:
        rate = fit.design.summary.rate_hz
        variance = variance + np.asarray(GaussMarkov.allan_variance(tau, term, rate))
    return variance


def model_allan_exponents(fit: ModelFit, tau) -> list[int]:
    """The power-law exponent of the term of the fit's noise that dominates the Allan
    variance at each ``tau`` (:meth:`NoiseModel.allan_exponents`, with the searched
    Gauss-Markov term's)."""
    model, term = fit_noise_model(fit), _gauss_markov(fit)
    if term is None:
        return model.allan_exponents(tau)
    tau = np.asarray(tau, dtype=float)
    pairs = [
        pair
        for piece in model.terms
        for pair in piece.allan_exponents(tau, model.values, model.rate_hz)
    ]
    pairs += GaussMarkov.allan_exponents(tau, term, model.rate_hz)
    exponents = np.array([alpha for alpha, _ in pairs])
    values = np.stack([np.broadcast_to(np.asarray(v), tau.shape) for _, v in pairs])
    return exponents[np.argmax(values, axis=0)].tolist()


def bin_ratios(fit: ModelFit) -> tuple[np.ndarray, np.ndarray]:
    """sum I / S in each frequency bin at the MAP (about the bin's count), and the model's
    expected periodogram (its mean over the bin)."""
    summary, design = fit.design.summary, fit.design
    variances, _ = slot_variances(
        jnp.asarray(fit.theta), design.mask, design.ramp_scale, design.floor
    )
    expected = np.asarray(expected_power(summary, variances)) / summary.count
    beta = np.zeros(MAX_REGRESSORS)
    beta[: fit.beta.size] = fit.beta
    power = (
        summary.power
        - 2 * np.einsum("p,kpb->b", beta, summary.cross)
        + np.einsum("p,q,kpqb->b", beta, beta, summary.gram)
    )
    return power / expected, expected


def block_covariance(fit: ModelFit, start, stop, rate_hz):
    design = fit.design
    variances, _ = slot_variances(
        jnp.asarray(fit.theta), design.mask, design.ramp_scale, design.floor
    )
    basis = _block_basis(start, stop, rate_hz, fit.spec.gauss_markov_s)
    return np.einsum("t,tij->ij", np.asarray(variances), basis)


def block_means(values, start, stop):
    return np.array([np.nanmean(values[a:b]) for a, b in zip(start, stop, strict=True)])
