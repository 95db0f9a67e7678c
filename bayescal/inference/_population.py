"""The posterior of a fleet's population from its recordings' stored posterior draws: the
weighted points of each unit, the MAP and emcee over the population's parameters (checked like
every posterior), and what follows from them — per-unit estimates shrunk toward the
population, the predictive distribution of the next unit, the probability that a unit meets a
specification, and the units the population does not predict.

The model and its likelihood are :mod:`bayescal.models._population`. Here:

- **Which noise scales enter.** Those the recordings resolve: a noise scale whose posterior sd
  of its natural log is at most RESOLVED_LOG_SD (a factor e; the fitting prior's is 4) in at
  least half of the recordings. One that few recordings resolve has no population the fleet
  can estimate; it stays in each recording's own fit, marginalised over (its fitting prior is
  not divided out).
- **A unit's points.** With one run, its stored draws (at most MAX_POINTS, evenly spaced), each
  weighted 1 / pi_0 by its fitting prior (Hogg et al. 2010, eq. 9). With several runs, which
  share the unit's noise scales, the pooled draws of its runs, each weighted by
  prod_r p_r(x) / pi_r(x) over the pooled density q(x) = mean_r p_r(x), where p_r is a
  Gaussian kernel density estimate of run r's posterior (Scott's bandwidth on the run's own
  covariance) and each run's bias given the noise at x is its draws' Gaussian conditional,
  averaged with the same kernel (Nadaraya-Watson, with the law of total variance). The
  kernel widens each run's posterior by about sqrt(1 + h^2), h = K^(-1/(d + 4)) (3 % for
  d = 1 and K = 2000 draws): a unit's runs are combined very slightly conservatively.
- **Checks.** The sampler's (R-hat, ESS, autocorrelation, acceptance, a converged MAP;
  :mod:`._mcmc`), and the importance sampling's: the effective number of points of every unit
  at the posterior's median, (sum w)^2 / sum w^2, must be at least MIN_POINT_ESS. Fewer means
  that a unit's runs disagree (its noise is not the same from run to run) or that the
  population is far narrower than what one recording can tell, and the population's
  likelihood of that unit rests on a handful of draws.
- **More points where a fleet needs them** (:func:`fit_population`). A unit whose own
  posterior holds the population only in its tail (a 41 s record pins ln K to 15-30 %, and a
  unit 2 of those sds off the fleet) has few of its MAX_POINTS points where the population
  is. Its effective number grows with the points, not with anything else: where a unit falls
  short of MIN_POINT_ESS, the population is sampled again with every stored draw as a point
  (2,000, about eight times the effective number; measured on a fleet of 11 units: 18 -> 123,
  sampling 5 s -> 26 s). Only a fleet that needs it pays; the draws a recording sends back
  are the same either way.
- **Outliers.** A unit the population does not predict: its own estimate (its runs alone) lies
  in the tail of the predictive distribution of a unit of the population fitted without it
  (leave-one-out by truncated importance sampling, Ionides 2008), two-sided, with its own
  uncertainty added; flagged below OUTLIER_FAMILY_RATE / (units x parameters), a 5 % chance of
  any false flag in a fleet the population describes (Bonferroni).
"""

import math
from dataclasses import dataclass, field, replace

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.special import logsumexp
from scipy.special import ndtr

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._errors import InputError
from ..models._population import PopulationModel
from ..recording._units import parse_unit
from ._mcmc import (
    Diagnostics,
    batch_log_density,
    diagnose,
    sample_ensemble,
    walker_count,
)
from ._optimize import maximum_a_posteriori
from ._sampler import Sampler

POPULATION_PARAMETERS = ("N", "B", "K")
RESOLVED_LOG_SD = 1.0
MAX_POINTS = 256
POOLED_PER_RUN = 1024
UNIT_BLOCK = 8
MIN_POINT_ESS = 20.0
OUTLIER_FAMILY_RATE = 0.05
_CHUNK = 64


@dataclass(frozen=True)
class RecordingDraws:
    """What the population needs of one recording's noise fit, and no more (a few tens of
    kilobytes, where the fit itself carries the data's summaries): the posterior draws of the
    natural logs of N, B and K as fitted, the bias's Gaussian posterior given the noise at
    each draw, the fitting prior of those logs, and the fit's health."""

    source: str
    unit: str
    """The unit's id (manifest column ``unit``)."""
    run: str
    """The run's id within its unit (manifest column ``run``)."""
    channel: str
    channel_unit: str
    rate_hz: float
    n_samples: int
    terms: tuple[str, ...]
    log_draws: dict = field(repr=False)
    """N, B, K as fitted -> (S,) posterior draws of the natural log."""
    prior_location: dict
    """N, B, K as fitted -> the fitting prior's mean of the natural log (normal)."""
    prior_scale: dict
    """... and its sd."""
    bias_mean: np.ndarray = field(repr=False)
    """(S,) mean of the bias given the noise at each draw (flat fitting prior)."""
    bias_sd: np.ndarray = field(repr=False)
    """(S,) its sd."""
    prior: str = ""
    seed: int = 0
    passed: bool = True
    failures: tuple[str, ...] = ()
    checks: dict = field(default_factory=dict)
    """A digest of the sampler's checks: steps, walkers, max R-hat, min ESS, acceptance."""
    notes: tuple[str, ...] = ()
    row: int = 0
    """Data row of the manifest (1 = first row under the header)."""
    temperature_c: float | None = None
    seconds: float = 0.0
    """Wall time of the task that made it (load and fit)."""

    @property
    def n_draws(self) -> int:
        return int(self.bias_mean.size)

    def log_sd(self, parameter: str) -> float:
        """Posterior sd of the natural log of ``parameter``."""
        return float(np.std(self.log_draws[parameter], ddof=1))

    def in_unit(self, unit: str) -> "RecordingDraws":
        """The same draws in another unit of the same quantity (deg/s -> rad/s ...)."""
        if unit == self.channel_unit:
            return self
        have, want = parse_unit(self.channel_unit), parse_unit(unit)
        if not (have.known and want.known and have.quantity == want.quantity):
            raise InputError(
                f"channel {self.channel} is in {self.channel_unit}, the fleet's in {unit}",
                source=self.source,
                fix="give every recording the same unit (unit=, or the header)",
            )
        factor = have.to_si / want.to_si
        shift = math.log(factor)
        return replace(
            self,
            channel_unit=unit,
            log_draws={p: value + shift for p, value in self.log_draws.items()},
            prior_location={p: value + shift for p, value in self.prior_location.items()},
            bias_mean=self.bias_mean * factor,
            bias_sd=self.bias_sd * factor,
        )


def resolved_parameters(recordings) -> tuple[tuple[str, ...], list[str]]:
    """The noise scales that enter the population (resolved by at least half the
    recordings), and a note for each fitted one that does not."""
    chosen, notes = [], []
    for parameter in POPULATION_PARAMETERS:
        fitted = [r for r in recordings if parameter in r.log_draws]
        if len(fitted) < len(recordings):
            continue
        resolving = sum(r.log_sd(parameter) <= RESOLVED_LOG_SD for r in fitted)
        if 2 * resolving >= len(fitted):
            chosen.append(parameter)
        else:
            notes.append(
                f"{parameter} is resolved by {resolving} of {len(fitted)} recordings "
                f"(posterior sd of ln {parameter} <= {RESOLVED_LOG_SD:g}): no population of it "
                "is estimated; each recording keeps its own"
            )
    return tuple(chosen), notes


def _log_normal_density(x, mean, sd):
    return -0.5 * ((x - mean) / sd) ** 2 - np.log(sd) - 0.5 * math.log(2 * math.pi)


def _stacked(run: RecordingDraws, parameters) -> np.ndarray:
    """(S, d) draws of the natural logs of ``parameters``."""
    if not parameters:
        return np.empty((run.n_draws, 0))
    return np.stack([run.log_draws[p] for p in parameters], -1)


def _fitting_log_prior(run: RecordingDraws, parameters, x) -> np.ndarray:
    total = np.zeros(x.shape[0])
    for i, p in enumerate(parameters):
        total += _log_normal_density(x[:, i], run.prior_location[p], run.prior_scale[p])
    return total


def _kernel_moments(run: RecordingDraws, parameters, x, chunk: int = 1024):
    """At points x (n, d): the log of run's Gaussian kernel density estimate (Scott's
    bandwidth on the run's posterior covariance), and its bias's conditional mean and
    variance averaged with the same kernel (Nadaraya-Watson, law of total variance)."""
    draws = _stacked(run, parameters)
    count, d = draws.shape
    if d == 0:
        mean = float(np.mean(run.bias_mean))
        variance = float(np.mean(run.bias_sd**2) + np.var(run.bias_mean))
        return np.zeros(x.shape[0]), np.full(x.shape[0], mean), np.full(x.shape[0], variance)
    bandwidth = count ** (-1.0 / (d + 4))
    factor = np.linalg.cholesky(np.atleast_2d(np.cov(draws, rowvar=False)) * bandwidth**2)
    centres = np.linalg.solve(factor, draws.T).T
    log_norm = -np.sum(np.log(np.diag(factor))) - 0.5 * d * math.log(2 * math.pi)
    second = run.bias_sd**2 + run.bias_mean**2
    log_density, mean, variance = (np.empty(x.shape[0]) for _ in range(3))
    for start in range(0, x.shape[0], chunk):
        part = slice(start, start + chunk)
        scaled = np.linalg.solve(factor, x[part].T).T
        squared = (
            np.sum(scaled**2, 1)[:, None] - 2 * scaled @ centres.T + np.sum(centres**2, 1)[None, :]
        )
        log_kernel = -0.5 * np.maximum(squared, 0.0)
        top = log_kernel.max(axis=1, keepdims=True)
        kernel = np.exp(log_kernel - top)
        total = kernel.sum(axis=1)
        log_density[part] = np.log(total) + top[:, 0] + log_norm - math.log(count)
        mean[part] = kernel @ run.bias_mean / total
        variance[part] = kernel @ second / total - mean[part] ** 2
    return log_density, mean, np.maximum(variance, np.min(run.bias_sd**2))


def _systematic_resample(log_weight, size: int, rng) -> np.ndarray:
    weight = np.exp(log_weight - np.max(log_weight))
    edges = np.cumsum(weight / weight.sum())
    edges[-1] = 1.0
    return np.searchsorted(edges, (rng.random() + np.arange(size)) / size)


def _effective_count(log_weight) -> float:
    """Kish's effective sample size of importance weights, (sum w)^2 / sum w^2."""
    weight = np.exp(log_weight - np.max(log_weight))
    return float(weight.sum() ** 2 / np.sum(weight**2))


def unit_points(runs, parameters, rng, max_points: int = MAX_POINTS) -> dict:
    """The weighted points of one unit (module docstring): log_weight (J,), points (J, d),
    bias_mean and bias_variance (J, R), own_log_weight (J,), the weights of its own posterior
    (its runs alone, one fitting prior), and combined_ess, the effective number of its runs'
    pooled draws under their product (all of them with one run)."""
    if len(runs) == 1:
        (run,) = runs
        keep = np.unique(np.linspace(0, run.n_draws - 1, min(max_points, run.n_draws)).round())
        keep = keep.astype(int)
        x = _stacked(run, parameters)[keep]
        return {
            "log_weight": -_fitting_log_prior(run, parameters, x),
            "points": x,
            "bias_mean": run.bias_mean[keep, None],
            "bias_variance": run.bias_sd[keep, None] ** 2,
            "own_log_weight": np.zeros(keep.size),
            "combined_ess": float(run.n_draws),
        }
    # Several runs: weigh their pooled draws by the product of the runs' likelihoods times one
    # (geometric mean) fitting prior, which makes them draws of the unit's own posterior, as
    # one run's are; resample them to equal weights; each point then carries 1 / that prior.
    pooled = np.concatenate(
        [
            _stacked(run, parameters)[
                np.linspace(0, run.n_draws - 1, min(POOLED_PER_RUN, run.n_draws)).astype(int)
            ]
            for run in runs
        ]
    )
    densities = np.array([_kernel_moments(run, parameters, pooled)[0] for run in runs])
    priors = np.array([_fitting_log_prior(run, parameters, pooled) for run in runs])
    pooled_density = np.logaddexp.reduce(densities, axis=0) - math.log(len(runs))
    prior = np.mean(priors, axis=0)
    own = np.sum(densities - priors, axis=0) + prior - pooled_density
    chosen = _systematic_resample(own, max_points, rng)
    x = pooled[chosen]
    moments = [_kernel_moments(run, parameters, x)[1:] for run in runs]
    level = np.logaddexp.reduce(own) - math.log(own.size)
    return {
        "log_weight": level - prior[chosen],
        "points": x,
        "bias_mean": np.stack([mean for mean, _ in moments], -1),
        "bias_variance": np.stack([variance for _, variance in moments], -1),
        "own_log_weight": np.zeros(chosen.size),
        "combined_ess": _effective_count(own),
    }


def _pad(arrays, fill, shape):
    out = np.full(shape, fill, dtype=float)
    for i, array in enumerate(arrays):
        out[(i, *tuple(slice(0, n) for n in array.shape))] = array
    return out


@dataclass(frozen=True)
class FleetData:
    """The fleet, grouped by unit (in manifest order), ready for the population model."""

    units: tuple[str, ...]
    runs: tuple[tuple[RecordingDraws, ...], ...]
    parameters: tuple[str, ...]
    points: tuple[dict, ...] = field(repr=False)
    max_points: int = MAX_POINTS
    """The most points of a unit (the model pads every unit to it)."""

    @property
    def run_counts(self) -> np.ndarray:
        return np.array([len(runs) for runs in self.runs])


def fleet_data(recordings, parameters, *, seed: int = 0, max_points: int = MAX_POINTS) -> FleetData:
    """Group recordings by unit and build each unit's weighted points (at most
    ``max_points`` each)."""
    grouped: dict[str, list[RecordingDraws]] = {}
    for recording in recordings:
        grouped.setdefault(recording.unit, []).append(recording)
    rng = np.random.default_rng(seed)
    points = tuple(unit_points(runs, parameters, rng, max_points) for runs in grouped.values())
    return FleetData(
        tuple(grouped),
        tuple(tuple(runs) for runs in grouped.values()),
        parameters,
        points,
        max_points,
    )


def bias_spread(recordings) -> float:
    """The fleet's own spread of turn-on biases, or the typical uncertainty of one where they
    agree: the unit of the priors of the bias's sds (models/_population.py)."""
    means = np.array([np.mean(r.bias_mean) for r in recordings])
    sds = np.array([math.sqrt(np.mean(r.bias_sd**2) + np.var(r.bias_mean)) for r in recordings])
    spread = float(np.std(means, ddof=1)) if means.size > 1 else 0.0
    return max(spread, float(np.median(sds)))


def population_model(data: FleetData, spread: float) -> PopulationModel:
    """The population model of a fleet's weighted points, padded to common sizes: the data's
    most points, the most runs of a unit, and a multiple of UNIT_BLOCK units (a padded unit is one
    run at one point, with weight 1, masked out of the likelihood)."""
    count = len(data.points)
    units = -(-count // UNIT_BLOCK) * UNIT_BLOCK
    runs = int(data.run_counts.max())
    d = len(data.parameters)
    dummy = {
        "log_weight": np.zeros(1),
        "points": np.zeros((1, d)),
        "bias_mean": np.zeros((1, 1)),
        "bias_variance": np.ones((1, 1)),
    }
    points = [*data.points, *[dummy] * (units - count)]
    run_counts = [*data.run_counts, *[1] * (units - count)]

    def leading(key, fill, depth):
        """Parameters or runs first: (depth, units, points)."""
        padded = _pad([p[key] for p in points], fill, (units, data.max_points, depth))
        return jnp.asarray(np.moveaxis(padded, -1, 0))

    return PopulationModel(
        log_weight=jnp.asarray(
            _pad([p["log_weight"] for p in points], -np.inf, (units, data.max_points))
        ),
        points=leading("points", 0.0, d),
        bias_mean=leading("bias_mean", 0.0, runs),
        bias_variance=leading("bias_variance", 1.0, runs),
        unit_mask=jnp.asarray(np.arange(units) < count, dtype=float),
        run_mask=jnp.asarray(_pad([np.ones(n) for n in run_counts], 0.0, (units, runs)).T),
        bias_spread=jnp.asarray(spread),
        parameters=data.parameters,
        unit_spread=count > 1,
        run_spread=runs > 1,
    )


def _weighted(log_weight, values) -> dict:
    """Mean, variance, 5 % and 95 % quantiles of weighted values."""
    weight = np.exp(log_weight - np.max(log_weight))
    weight /= weight.sum()
    mean = float(weight @ values)
    order = np.argsort(values)
    cumulative = np.cumsum(weight[order]) - 0.5 * weight[order]
    q05, q95 = np.interp([0.05, 0.95], cumulative, values[order])
    return {"mean": mean, "var": float(weight @ (values - mean) ** 2), "q05": q05, "q95": q95}


def own_estimates(data: FleetData) -> list[dict]:
    """Each unit's own estimate, from its runs alone (its fitting prior, no population): for
    each noise scale the mean and variance of its natural log (``log_mean``, ``log_var``) and
    its mean, 5 % and 95 % quantiles; for the unit's mean turn-on bias (the average of its
    runs') its mean, variance and 90 % interval; and each run's bias (``run_bias``)."""
    normal_90 = 1.6448536269514722
    estimates = []
    for points in data.points:
        weight = points["own_log_weight"]
        estimate = {}
        for i, p in enumerate(data.parameters):
            logs = _weighted(weight, points["points"][:, i])
            natural = _weighted(weight, np.exp(points["points"][:, i]))
            estimate[p] = {
                "log_mean": logs["mean"],
                "log_var": logs["var"],
                **{key: natural[key] for key in ("mean", "q05", "q95")},
            }
        runs = points["bias_mean"].shape[1]
        level = _weighted(weight, points["bias_mean"].mean(axis=1))
        noise = _weighted(weight, points["bias_variance"].sum(axis=1) / runs**2)["mean"]
        sd = math.sqrt(level["var"] + noise)
        estimate["bias"] = {
            "mean": level["mean"],
            "var": sd**2,
            "q05": level["mean"] - normal_90 * sd,
            "q95": level["mean"] + normal_90 * sd,
        }
        estimate["run_bias"] = [
            _weighted(weight, points["bias_mean"][:, r])["mean"] for r in range(runs)
        ]
        estimates.append(estimate)
    return estimates


def _start(model: PopulationModel, own: list[dict], data: FleetData) -> np.ndarray:
    """A start for the MAP from the units' own estimates."""
    floor = 0.1 * float(model.bias_spread)
    biases = np.array([estimate["bias"]["mean"] for estimate in own])
    theta = []
    if model.unit_spread:
        logs = np.array([[estimate[p]["log_mean"] for p in data.parameters] for estimate in own])
        theta += list(logs.mean(axis=0)) if logs.size else []
        theta += list(np.log(np.maximum(logs.std(axis=0, ddof=1), 0.05))) if logs.size else []
    theta.append(biases.mean())
    if model.unit_spread:
        theta.append(math.log(max(float(np.std(biases, ddof=1)), floor)))
    if model.run_spread:
        within = [
            np.var(estimate["run_bias"], ddof=1)
            for estimate in own
            if len(estimate["run_bias"]) > 1
        ]
        theta.append(0.5 * math.log(max(float(np.mean(within)), floor**2)))
    return np.array(theta, dtype=float)


@eqx.filter_jit
def _at_draws(model: PopulationModel, theta, key):
    """For a chunk of posterior draws: each unit's log-likelihood, its points' effective
    number, one shrunk draw of its noise scales' logs and of its mean bias, and the expected
    value of those logs given the draw (the weighted mean over all of the unit's points, where
    the draw above picks one: the same expectation without the picking's Monte Carlo noise)."""
    weights = jax.vmap(model.point_log_weights)(theta)  # (S, U, J)
    log_likelihood = logsumexp(weights, axis=-1)
    ess = jnp.exp(2 * log_likelihood - logsumexp(2 * weights, axis=-1))
    expected = jnp.einsum("suj,duj->sud", jax.nn.softmax(weights, axis=-1), model.points)
    pick_key, bias_key = jax.random.split(key)
    pick = jax.random.categorical(pick_key, weights, axis=-1)  # (S, U)

    def at_pick(array):  # (depth, U, J) -> (S, U, depth)
        return jnp.moveaxis(
            jnp.take_along_axis(array[:, None], pick[None, :, :, None], axis=-1)[..., 0], 0, -1
        )

    points = at_pick(model.points)
    values = model.unpack(theta)
    precision = model.run_mask.T[None] / (
        at_pick(model.bias_variance) + values["tau_run"][:, None, None] ** 2
    )
    total = jnp.sum(precision, -1)
    pooled = jnp.sum(precision * at_pick(model.bias_mean), -1)
    if model.unit_spread:
        prior_precision = 1.0 / values["tau_unit"][:, None] ** 2
        level_precision = prior_precision + total
        level_mean = (prior_precision * values["mu_bias"][:, None] + pooled) / level_precision
        level = level_mean + jax.random.normal(bias_key, level_mean.shape) / jnp.sqrt(
            level_precision
        )
    else:
        level = jnp.broadcast_to(values["mu_bias"][:, None], total.shape)
    return log_likelihood, ess, points, level, expected


class PopulationPosterior(eqx.Module):
    """The posterior of a fleet's population, with the per-unit quantities that follow."""

    names: tuple[str, ...] = eqx.field(static=True)
    parameters: tuple[str, ...] = eqx.field(static=True)
    units: tuple[str, ...] = eqx.field(static=True)
    draws: np.ndarray
    """(walkers, draws, coordinates) posterior draws of the sampled coordinates."""
    values: dict
    """mu (S, d), sigma (S, d), mu_bias, tau_unit, tau_run (S,): the population's parameters
    at each draw (S = walkers x draws, flattened)."""
    unit_draws: dict
    """unit -> {parameter: (S,) natural logs, "bias": (S,) mean turn-on bias}, shrunk."""
    unit_log_means: dict
    """unit -> {parameter: posterior mean of its natural log}, shrunk: the mean over the
    population's draws of the unit's expected log given each (Rao-Blackwellised), which
    ``unit_draws`` estimates with the added noise of picking one point per draw."""
    unit_log_likelihood: np.ndarray
    """(S, U) log p(d_u | population) at each draw."""
    point_ess: np.ndarray
    """(U,) effective number of points of each unit at the posterior's median draw."""
    combined_ess: np.ndarray
    """(U,) effective number of a unit's pooled draws under its runs' product (its draws
    with one run)."""
    own: tuple
    """Each unit's own estimate (:func:`own_estimates`)."""
    run_counts: np.ndarray
    diagnostics: Diagnostics
    points_per_unit: int = eqx.field(static=True)
    """The most points of a unit it was sampled with."""
    map_theta: np.ndarray
    seed: int = eqx.field(static=True)

    @property
    def unit_spread(self) -> bool:
        return len(self.units) > 1

    @property
    def run_spread(self) -> bool:
        return bool(np.max(self.run_counts) > 1)

    @property
    def passed(self) -> bool:
        return bool(self.diagnostics.passed) and not self.importance_failures

    @property
    def importance_failures(self) -> tuple[str, ...]:
        failures = []
        for unit, combined, ess, runs in zip(
            self.units, self.combined_ess, self.point_ess, self.run_counts, strict=True
        ):
            if not combined >= MIN_POINT_ESS:
                failures.append(
                    f"unit {unit}: its {runs} runs disagree on its noise ({combined:.1f} "
                    f"effective draws where their posteriors overlap, < {MIN_POINT_ESS:g}): "
                    "its noise is not the same from run to run"
                )
            elif not ess >= MIN_POINT_ESS:
                failures.append(
                    f"unit {unit}: the population's likelihood of it rests on {ess:.1f} "
                    f"effective draws (< {MIN_POINT_ESS:g}): the population is far narrower "
                    "than what its recordings tell of it"
                )
        return tuple(failures)

    @property
    def failures(self) -> tuple[str, ...]:
        return (*self.diagnostics.failures, *self.importance_failures)


def sample_population(
    data: FleetData,
    *,
    seed: int = 0,
    sampler: Sampler = Sampler(),
) -> PopulationPosterior:
    """MAP, then emcee over the population's parameters, checked; then each unit's shrunk
    draws, its log-likelihood at every draw and its points' effective number."""
    recordings = [run for runs in data.runs for run in runs]
    model = population_model(data, bias_spread(recordings))
    own = own_estimates(data)
    rng = np.random.default_rng(seed)
    start = jnp.asarray(_start(model, own, data))
    mode = maximum_a_posteriori(PopulationModel.log_density, model, start)
    ensemble, converged = sample_ensemble(
        batch_log_density(PopulationModel.log_density, model),
        mode.theta,
        mode.covariance,
        rng,
        walker_count(mode.theta.size, sampler.n_walkers),
        sampler.max_steps,
        sampler.progress,
    )
    diagnostics, kept = diagnose(ensemble, model.names, converged, mode.converged)
    flat = kept.reshape(-1, kept.shape[-1])
    key = jax.random.PRNGKey(int(rng.integers(2**31)))
    pieces = []
    for start_at in range(0, flat.shape[0], _CHUNK):
        key, chunk_key = jax.random.split(key)
        pieces.append(_at_draws(model, jnp.asarray(flat[start_at : start_at + _CHUNK]), chunk_key))
    count = len(data.units)
    log_likelihood, _, points, level, expected = (
        np.concatenate([np.asarray(piece[i]) for piece in pieces])[:, :count] for i in range(5)
    )
    median = jnp.asarray(np.median(flat, axis=0))[None]
    point_ess = np.asarray(_at_draws(model, median, key)[1])[0, :count]
    values = {name: np.asarray(value) for name, value in model.unpack(jnp.asarray(flat)).items()}
    unit_draws = {
        unit: {
            **{p: points[:, u, i] for i, p in enumerate(data.parameters)},
            "bias": level[:, u],
        }
        for u, unit in enumerate(data.units)
    }
    unit_log_means = {
        unit: {p: float(np.mean(expected[:, u, i])) for i, p in enumerate(data.parameters)}
        for u, unit in enumerate(data.units)
    }
    return PopulationPosterior(
        names=model.names,
        parameters=data.parameters,
        units=data.units,
        draws=kept,
        values=values,
        unit_draws=unit_draws,
        unit_log_means=unit_log_means,
        unit_log_likelihood=log_likelihood,
        point_ess=point_ess,
        combined_ess=np.array([points["combined_ess"] for points in data.points]),
        own=tuple(own),
        run_counts=data.run_counts,
        diagnostics=diagnostics,
        points_per_unit=data.max_points,
        map_theta=mode.theta,
        seed=seed,
    )


def fit_population(
    recordings,
    parameters,
    *,
    seed: int = 0,
    sampler: Sampler = Sampler(),
) -> PopulationPosterior:
    """The population's posterior from its recordings' draws: with MAX_POINTS points per
    unit, and again with every stored draw as a point where a unit's points fall short of
    MIN_POINT_ESS at the posterior's median (module docstring). A unit whose runs disagree
    is not helped by more points; its check stays as it is."""
    data = fleet_data(recordings, parameters, seed=seed)
    posterior = sample_population(data, seed=seed, sampler=sampler)
    stored = max(recording.n_draws for recording in recordings)
    if stored <= data.max_points or np.all(posterior.point_ess >= MIN_POINT_ESS):
        return posterior
    data = fleet_data(recordings, parameters, seed=seed, max_points=stored)
    return sample_population(data, seed=seed, sampler=sampler)


# ---------------------------------------------------------------------------------------------
# What follows from the population


def predictive(posterior: PopulationPosterior, seed: int = 0) -> dict:
    """Draws of the next unit of the population: the natural log of each noise scale and the
    turn-on bias of its first run, (S,) each; empty with one unit (no spread across units)."""
    if not posterior.unit_spread:
        return {}
    rng = np.random.default_rng(seed)
    values = posterior.values
    size = values["mu_bias"].size
    draws = {
        p: values["mu"][:, i] + values["sigma"][:, i] * rng.standard_normal(size)
        for i, p in enumerate(posterior.parameters)
    }
    spread = np.sqrt(values["tau_unit"] ** 2 + values["tau_run"] ** 2)
    draws["bias"] = values["mu_bias"] + spread * rng.standard_normal(size)
    return draws


@dataclass(frozen=True)
class Limit:
    """An upper limit on a noise scale (N, B, K: the unit meets it at or below) or on the
    turn-on bias's magnitude (``bias``), in the parameter's unit for the fleet's channel."""

    parameter: str
    value: float
    unit: str
    source: str
    """Where it comes from: the user, or a sensor card's line."""
    label: str = ""
    """How it reads, e.g. ``N<0.3 deg/sqrt(h)`` or ``|bias|<0.5 deg/s``."""


def _meets_noise(log_limit, mean, sd):
    return ndtr((log_limit - mean) / sd)


def _meets_bias(limit, mean, sd):
    return ndtr((limit - mean) / sd) - ndtr((-limit - mean) / sd)


def spec_probabilities(posterior: PopulationPosterior, limits) -> dict:
    """The probability that a unit meets each limit, and all of them, as draws over the
    posterior: ``next_unit`` (one array per limit) and ``next_unit_all`` for a unit drawn from
    the population (None with one unit: no spread across units), ``units`` and ``units_all``
    for each unit of the fleet (its shrunk posterior; for the bias, its next run). All of
    them: the population's noise scales and bias are independent, so the product over
    parameters of meeting each parameter's tightest limit."""
    values = posterior.values
    run_sd = values["tau_run"]
    next_unit, per_unit = [], {unit: [] for unit in posterior.units}
    tightest = {}
    for limit in limits:
        name = limit.parameter
        if name == "bias":
            if posterior.unit_spread:
                spread = np.sqrt(values["tau_unit"] ** 2 + run_sd**2)
                next_unit.append(_meets_bias(limit.value, values["mu_bias"], spread))
            for unit in posterior.units:
                level = posterior.unit_draws[unit]["bias"]
                per_unit[unit].append(_meets_bias(limit.value, level, np.maximum(run_sd, 1e-300)))
        else:
            index = posterior.parameters.index(name)
            if posterior.unit_spread:
                next_unit.append(
                    _meets_noise(
                        math.log(limit.value), values["mu"][:, index], values["sigma"][:, index]
                    )
                )
            for unit in posterior.units:
                draws = posterior.unit_draws[unit][name]
                per_unit[unit].append((draws <= math.log(limit.value)).astype(float))
        if name not in tightest or limit.value < limits[tightest[name]].value:
            tightest[name] = limits.index(limit)
    chosen = sorted(tightest.values())
    result = {"next_unit": None, "next_unit_all": None, "units": per_unit, "units_all": {}}
    if posterior.unit_spread:
        result["next_unit"] = next_unit
        result["next_unit_all"] = np.prod([next_unit[i] for i in chosen], axis=0)
    for unit, by_limit in per_unit.items():
        result["units_all"][unit] = np.prod([by_limit[i] for i in chosen], axis=0)
    return result


def outliers(posterior: PopulationPosterior) -> dict:
    """For each unit and each parameter (noise scales' logs, mean bias), the two-sided tail
    probability of its own estimate under the leave-one-out predictive distribution of a
    unit of the population; empty with one unit."""
    if not posterior.unit_spread:
        return {}
    values = posterior.values
    tail = {}
    for u, unit in enumerate(posterior.units):
        log_weight = -posterior.unit_log_likelihood[:, u]
        weight = np.exp(log_weight - np.max(log_weight))
        weight = np.minimum(weight, np.mean(weight) * math.sqrt(weight.size))  # Ionides 2008
        weight /= weight.sum()
        own = posterior.own[u]
        tail[unit] = {}
        for i, p in enumerate(posterior.parameters):
            sd = np.sqrt(values["sigma"][:, i] ** 2 + own[p]["log_var"])
            z = np.abs(own[p]["log_mean"] - values["mu"][:, i]) / sd
            tail[unit][p] = float(weight @ (2 * ndtr(-z)))
        mean, variance = own["bias"]["mean"], own["bias"]["var"]
        runs = posterior.run_counts[u]
        sd = np.sqrt(values["tau_unit"] ** 2 + values["tau_run"] ** 2 / runs + variance)
        tail[unit]["bias"] = float(weight @ (2 * ndtr(-np.abs(mean - values["mu_bias"]) / sd)))
    return tail


def outlier_threshold(posterior: PopulationPosterior) -> float:
    tests = len(posterior.units) * (len(posterior.parameters) + 1)
    return OUTLIER_FAMILY_RATE / tests


def population_datatree(posterior: PopulationPosterior, unit: str, *, source: str, channel: str):
    """The population's posterior as ArviZ data: per walker (chain) and draw, the population
    median and log-sd of each noise scale, the bias's mean and spreads (those the fleet
    identifies), and each unit's shrunk noise scales and mean bias (dimension ``unit``)."""
    import json
    from importlib.metadata import version

    import arviz_base

    from ..models._terms import parameter_unit

    shape = posterior.draws.shape[:2]
    values = posterior.values
    draws, units = {}, {}
    for i, p in enumerate(posterior.parameters):
        if posterior.unit_spread:
            draws[f"median_{p}"] = np.exp(values["mu"][:, i]).reshape(shape)
            draws[f"log_sd_{p}"] = values["sigma"][:, i].reshape(shape)
            units[f"median_{p}"], units[f"log_sd_{p}"] = parameter_unit(p, unit), "1"
        draws[f"unit_{p}"] = np.stack(
            [np.exp(posterior.unit_draws[u][p]) for u in posterior.units], -1
        ).reshape(*shape, -1)
        units[f"unit_{p}"] = parameter_unit(p, unit)
    draws["bias_mean"] = values["mu_bias"].reshape(shape)
    if posterior.unit_spread:
        draws["bias_unit_to_unit_sd"] = values["tau_unit"].reshape(shape)
    if posterior.run_spread:
        draws["bias_run_to_run_sd"] = values["tau_run"].reshape(shape)
    draws["unit_bias"] = np.stack(
        [posterior.unit_draws[u]["bias"] for u in posterior.units], -1
    ).reshape(*shape, -1)
    for name in draws:
        units.setdefault(name, unit)
    tree = arviz_base.from_dict(
        {"posterior": draws},
        coords={"unit": list(posterior.units)},
        dims={name: ["unit"] for name in draws if name.startswith("unit_")},
        attrs={
            "/": {
                "bayescal_version": version("bayescal"),
                "inference_library": "emcee",
                "inference_library_version": version("emcee"),
                "source": source,
                "channel": channel,
                "unit": unit,
                "seed": posterior.seed,
                "diagnostics": json.dumps(posterior.diagnostics.as_dict()),
            }
        },
    )
    for name, value in units.items():
        tree["posterior"][name].attrs["units"] = value
    return tree
