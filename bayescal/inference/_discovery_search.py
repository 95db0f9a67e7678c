"""Discovery: find the physics a model of a static channel left out, add it, show the fit
improve.

First, two effects of single samples are scanned for on the samples' distribution, each
accepted on a decisive Bayes factor: clipping at a rail (``saturation``,
:mod:`bayescal._saturation`; the clipped samples are imputed for what follows) and isolated
glitches (``outliers``, replaced by their neighbours' mean). Then the loop (documented for
users in docs/guide/discovery.md):

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
from dataclasses import dataclass, replace
from functools import partial

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from scipy import stats

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._errors import HealthCheckError, InputError
from ..classical._allan import allan_deviation
from ..inference._checks import CHECK_LEVEL, line_search, run_checks
from ..inference._mcmc import batch_log_density, diagnose, sample_ensemble, summarize, walker_count
from ..inference._optimize import maximum_a_posteriori
from ..inference._priors import allan_reference_scales, default_prior
from ..inference._selection import select_noise_terms
from ..models._composite import (
    MAX_REGRESSORS,
    NOISE_SLOTS,
    SLOT_OF,
    Design,
    LevelNoise,
    ModelFit,
    ModelSpec,
    above_level_band,
    batch_profile,
    bin_ratios,
    level_coefficients,
    marginal_log_posterior,
    padded,
    profile,
    profiled_log_posterior,
    regressor_columns,
    shaped,
    slot_prior,
    slot_variances,
    slow_columns,
    summary_components,
)
from ..models._level import level_summary
from ..models._noise_model import parameter_unit
from ..models._terms import (
    BASELINE_TERMS,
    CANDIDATE_TERMS,
    FILTER_SHAPE_OF_TERM,
    LOWPASS_PARAMETERS,
    PARAMETERS_OF_TERM,
)
from ..models._whittle import spectral_summary, whittle_log_likelihood
from ..models.effects._base import GRID_POINTS, PARABOLIC_STEPS, Effect, SlotTerm
from ..models.effects._catalogue import CATALOGUE, SEARCHED
from ..models.effects.outliers import Outliers, outlier_scan, without_outliers
from ..models.effects.output_filter import OutputFilter
from ..models.effects.quantization import Quantization
from ..models.effects.saturation import Saturation, impute_clipped, saturation_scan
from ..recording._levels import discrete_step

DECISIVE_LOG_BAYES_FACTOR = math.log(100.0)
"""Jeffreys' "decisive": odds of 100 to 1."""
AMBIGUOUS_LOG_BAYES_FACTOR = math.log(10.0)
"""A runner-up closer than this to the accepted term explains the mismatch about as well:
the two are reported as indistinguishable on this recording."""
UNMODELLED_CHECKS = ("timestamps", "rail")
"""Checks no term of the search answers — the time stamps, and a rail, which the saturation
scan decides before the search: they are reported, but do not start a search."""
MIN_SAMPLES = 256
"""Samples discovery needs: below this its checks have too few blocks and bins to say
anything."""
PROFILE_DROP = 0.5 * stats.chi2.ppf(0.90, 1)
"""Fall of a profile log-likelihood from its peak at the ends of a 90 % interval."""


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
            raise InputError(f"{self.channel}: discovery takes one channel, a 1-D array")
        finite = np.count_nonzero(np.isfinite(self.values))
        if finite < MIN_SAMPLES:
            raise InputError(
                f"{self.channel}: {finite} samples; discovery needs at least {MIN_SAMPLES}",
                fix="record longer or widen the window (--start/--stop)",
            )

    @property
    def time_s(self) -> np.ndarray:
        return np.arange(self.values.size) / self.rate_hz

    @property
    def duration_s(self) -> float:
        return self.values.size / self.rate_hz


@eqx.filter_jit
def _profile_at(design: Design, theta):
    return profile(design, theta)


class Context:
    """What every fit of one recording shares, and the search an effect proposing itself uses
    (:class:`bayescal.models.effects._base.Search`)."""

    def __init__(self, data, prior_scales: dict, n_frequencies: int, unclipped, clean):
        self.data = data
        self.prior_scales = prior_scales
        self.n_frequencies = n_frequencies
        self.unclipped = unclipped
        """The data with clipped samples imputed (the data itself when nothing is clipped)."""
        self.clean = clean
        """``unclipped`` with the outliers replaced (itself when there are none)."""
        self.summaries = {}
        self.lsb = discrete_step(clean)
        """The grid the samples sit on (zero: none): its rounding floor is in every model."""
        self.lowpass = None
        """The output filter decided before the search (:func:`decide_output_filter`)."""
        """Spectral summaries already computed, by the parts of a spec they depend on, and
        the time constants found by earlier searches."""

    @classmethod
    def of(cls, data, unclipped: np.ndarray, clean: np.ndarray) -> "Context":
        allan = allan_deviation(clean, data.rate_hz, "octave")
        scales = allan_reference_scales(allan)
        scales["G"] = float(np.nanmax(allan.deviation)) * 2.0
        half = np.count_nonzero(np.isfinite(clean)) // 2
        return cls(data, scales, half, unclipped, clean)

    def fit(self, spec: ModelSpec) -> ModelFit:
        return fit_model(self, spec)

    def search_time(self, make_spec, key: str):
        return search_time(self, make_spec, key)

    def line_frequency(self, fit: ModelFit) -> float:
        return line_search(fit, self.data.rate_hz)[1]

    @staticmethod
    def summarize(draws, unit: str) -> dict:
        return summarize(draws, unit)

    @staticmethod
    def profile_interval(search: dict) -> dict:
        return _profile_interval(search, "time_constant_s")

    @staticmethod
    def widened(summary, search, name, time_constant, log_scale: bool) -> dict:
        return _widened_for_time_constant(summary, search, name, time_constant, log_scale=log_scale)

    def frequency_interval(self, fit: ModelFit, index: int, amplitude: float) -> dict:
        return _frequency_interval(fit, index, amplitude, self.data.rate_hz)


def fit_model(context: "Context", spec: ModelSpec) -> ModelFit:
    """MAP fit of ``spec``: the noise by the Whittle likelihood of the increments with the
    regression profiled exactly; then the coefficients of the slow deterministic terms (all
    but sinusoids) by GLS on block means under that noise (:func:`level_coefficients`). The
    score (log-likelihood, Schwarz) takes the block means' exact likelihood for the band they
    cover and the Whittle bins above it, so that no frequency is counted twice."""
    data = context.data
    values = (
        context.clean if spec.outliers else context.unclipped if spec.saturation else data.values
    )
    regressors, _, _ = regressor_columns(spec, data)
    time_constant = spec.gauss_markov_s or 1.0
    n_regressors = len(spec.regressor_names())
    key = spec.summary_key()
    if key not in context.summaries:
        summary = padded(
            spectral_summary(
                values,
                data.rate_hz,
                regressors=regressors[:, : max(n_regressors, 1)],
                extra_components=summary_components(data.rate_hz, time_constant),
            )
        )
        if context.lowpass is not None:
            summary = shaped(summary, context.lowpass.gain(summary.node_frequency, data.rate_hz))
        context.summaries[key] = summary
    summary = context.summaries[key]
    location, scale, mask = slot_prior(spec, context.prior_scales)
    regressor_mask = (np.arange(MAX_REGRESSORS) < n_regressors).astype(float)
    design = Design(
        summary,
        location,
        scale,
        mask,
        regressor_mask,
        np.asarray(10.0 * context.prior_scales["R"]),
        np.asarray(context.lsb**2 / (12.0 * data.rate_hz)),
    )
    lowered = design.location - 3.0 * design.mask * np.array([1, 1, 1, 1, 1, 0, 0])
    mode = maximum_a_posteriori(profiled_log_posterior, design, (design.location, lowered))
    theta, hessian, converged = mode.theta, mode.hessian, mode.converged
    pointwise, beta, precision = _profile_at(design, jnp.asarray(theta))
    beta = np.array(beta)
    covariance = np.linalg.inv(np.asarray(precision))
    slow = slow_columns(spec)
    fast = np.setdiff1d(np.arange(n_regressors), slow)
    level_beta, level_covariance, level_pointwise = level_coefficients(
        LevelNoise(mask, design.ramp_scale, design.floor, spec.gauss_markov_s),
        values - regressors[:, fast] @ beta[fast],
        regressors[:, slow],
        data.rate_hz,
        np.asarray(theta),
    )
    if slow.size:
        beta[slow] = level_beta[0]
        covariance[np.ix_(slow, slow)] = level_covariance[0]
        pointwise = whittle_log_likelihood(
            summary,
            *slot_variances(jnp.asarray(theta), mask, design.ramp_scale, design.floor),
            beta,
        )
    pointwise = np.concatenate(
        (
            np.asarray(pointwise)[: summary.n_bins][above_level_band(summary, data.duration_s)],
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
        converged=converged,
        residual=values - fitted,
        clean=values,
        design=design,
        hessian=np.asarray(hessian),
        lowpass=context.lowpass,
        lsb=context.lsb,
    )


def _shortest_time_constant(data) -> float:
    """The shortest time constant searched, s: 5 s, or 20 samples (below it a decay or a
    Gauss-Markov process is white noise to the record)."""
    return max(5.0, 20.0 / data.rate_hz)


def _time_grid(data) -> np.ndarray | None:
    """The searched time constants, up to a third of the record; None when that third is no
    longer than the shortest (a record of seconds: a pad window)."""
    shortest, longest = _shortest_time_constant(data), data.duration_s / 3.0
    if longest <= shortest:
        return None
    return np.geomspace(shortest, longest, GRID_POINTS)


def search_time(context: "Context", make_spec, key: str) -> tuple[ModelFit, dict] | None:
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
    interval. None for a record too short to search (:func:`_time_grid`)."""
    previous = context.summaries.get(("best time", key))
    if previous is None:
        grid = _time_grid(context.data)
        if grid is None:
            return None
        grid = list(grid)
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
        # A flat profile puts the ends where the record tells nothing apart: past its length
        # a decay is a ramp, below the shortest time constant white noise (and a Gauss-Markov
        # block covariance at 10^35 s is rounding error, not a covariance).
        low, high = _shortest_time_constant(context.data), context.data.duration_s
        for log_end in (peak[0] - half, peak[0] + half):
            # Capped before exp, which overflows at such an end.
            clipped = min(max(math.exp(min(log_end, math.log(high))), low), high)
            if clipped not in fits:
                fits[clipped] = fit_model(context, make_spec(clipped))
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


def candidate_fits(context: Context, current: ModelFit) -> dict[str, tuple[ModelFit, dict]]:
    """Each catalogue effect not yet in the model (:data:`SEARCHED`, in order), added and
    fitted: name -> (fit, search record)."""
    candidates = {}
    for effect in SEARCHED:
        proposal = effect.propose(context, current)
        if proposal is not None:
            candidates[effect.name] = proposal
    return candidates


def _elpd_difference(new: ModelFit, old: ModelFit) -> tuple[float, float]:
    """AIC-penalised ELPD gain and its standard error, pointwise over frequency bins and
    block predictions."""
    difference = new.pointwise - old.pointwise
    gain = float(difference.sum()) - (new.n_parameters - old.n_parameters)
    return gain, float(math.sqrt(difference.size) * np.std(difference))


class Finding(eqx.Module):
    """One accepted effect: the effect, the fit with it, and the evidence."""

    effect: Effect
    fit: ModelFit
    log_bayes_factor: float
    delta_elpd: float
    delta_elpd_se: float
    runner_up: tuple
    search: dict

    @property
    def name(self) -> str:
        return self.effect.name


class SearchResult(eqx.Module):
    """What the search found (:func:`search_effects`): the fits, the findings, the checks."""

    context: Context
    """The search's shared state (summaries, priors): what the findings are described with."""

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


def search_effects(
    data: DiscoveryData,
    *,
    baseline: tuple[str, ...] = ("white",),
    max_effects: int = 4,
    progress: Callable[[str], None] | None = None,
    seed: int = 0,
) -> SearchResult:
    """Find, name and model what the ``baseline`` noise terms leave out of ``data``.

    Two sample-level effects are scanned for first, on the samples' distribution: clipped
    samples (``saturation``, imputed with ``seed`` for the fits that follow) and isolated
    glitches (``outliers``, replaced by their neighbours' mean)."""
    report = progress or (lambda message: None)
    unknown = [term for term in baseline if term not in BASELINE_TERMS]
    if unknown:
        raise InputError(
            f"--baseline: unknown term(s) {', '.join(unknown)}",
            fix=f"use terms among {', '.join(sorted(BASELINE_TERMS))}",
        )
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
    clean = without_outliers(unclipped, outliers["flagged"]) if outliers else unclipped
    context = Context.of(data, unclipped, clean)
    report("fitting the baseline")
    current = fit_model(context, ModelSpec.from_names(baseline))
    baseline_fit = current
    baseline_checks = run_checks(current, data)
    findings = []
    for effect, scan in ((Saturation(), saturation), (Outliers(), outliers)):
        if scan:
            current = fit_model(context, current.spec.with_effect(effect))
            findings.append(
                Finding(
                    effect,
                    current,
                    scan["log_bayes_factor"],
                    scan["delta_elpd"],
                    scan["delta_elpd_se"],
                    (),
                    {},
                )
            )
    if context.lsb > 0:
        findings.append(_grid_finding(context, current))
    if _high_band_deficit(baseline_checks, data.rate_hz) and not current.spec.has("output_filter"):
        decided = decide_output_filter(context, baseline)
        if decided is not None:
            effect, log_bayes_factor, record = decided
            context.lowpass = effect
            context.summaries.clear()  # every model from here on sees the filter
            fit = fit_model(context, current.spec)
            gain, gain_se = _elpd_difference(fit, current)
            findings.append(Finding(effect, fit, log_bayes_factor, gain, gain_se, (), record))
            current = fit
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
        findings.append(
            Finding(fit.spec.effects[-1], fit, log_bayes_factor, gain, gain_se, runner_up, search)
        )
        current = fit
        checks = run_checks(current, data)
    report("checking the final model")
    return SearchResult(
        context=context,
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


def _grid_finding(context: Context, current: ModelFit) -> Finding:
    """``quantization`` named from the samples: they all sit on a grid of levels, which no
    continuous noise does (the evidence is the samples themselves: no Bayes factor to
    compute). Its rounding is a known white floor in every model of the search."""
    levels = np.unique(context.clean[np.isfinite(context.clean)]).size
    record = {"lsb": context.lsb, "levels": int(levels)}
    return Finding(Quantization(lsb=context.lsb), current, math.inf, 0.0, 0.0, (), record)


def _high_band_deficit(checks: list[dict], rate_hz: float) -> bool:
    """Whether the spectrum check failed with less power than the model near Nyquist: the
    signature of an output filter (a low-pass takes power away, only at high frequency)."""
    (spectrum,) = [check for check in checks if check["name"] == "spectrum_bands"]
    bands = spectrum["bands"]
    return not spectrum["passed"] and any(
        band["frequency_hz"][0] >= HIGH_FREQUENCY_FRACTION * rate_hz
        and band["power_over_model"] < 1
        and band["p_value"] * len(bands) < CHECK_LEVEL
        for band in bands
    )


def decide_output_filter(context: Context, baseline: tuple[str, ...]):
    """The sensor's output filter, when the baseline's spectrum misfits: the shape (one-tap,
    decimation, Butterworth, biquad) the record holds decisive evidence for, chosen by Laplace
    evidence among every stationary term (:func:`select_noise_terms`), with its MAP
    parameters and their Laplace 90 % intervals; None when no shape is decisive. Its
    shape is then fixed for the search (its uncertainty is second order for the effects that
    follow)."""
    data = context.data
    values = context.clean
    allan = allan_deviation(values, data.rate_hz, "octave")
    selection = select_noise_terms(
        spectral_summary(values, data.rate_hz),
        level_summary(values, data.rate_hz),
        partial(default_prior, allan=allan),
        lsb=context.lsb,
        # Every stationary term competes: power a low-pass seems to take away near Nyquist
        # is often power a slow term added at low frequency, pulling the white level up.
        candidates=CANDIDATE_TERMS,
        base=tuple(term for term in baseline if term in PARAMETERS_OF_TERM),
    )
    chosen = [term for term in selection.terms if term in FILTER_SHAPE_OF_TERM]
    if not chosen:
        return None
    shape = FILTER_SHAPE_OF_TERM[chosen[0]]
    estimates = selection.estimates
    names = ("F",) if shape == "one_tap" else LOWPASS_PARAMETERS[shape]
    effect = OutputFilter.from_values(shape, {name: estimates[name][0] for name in names})
    parameters = {"shape": {"value": shape}}
    for name in names:
        value, sd = estimates[name]
        parameters[name] = {
            "mean": value,
            "sd": sd,
            "q05": value + stats.norm.ppf(0.05) * sd,
            "q95": value + stats.norm.ppf(0.95) * sd,
            "unit": parameter_unit(name, data.unit),
        }
    trial = next(trial for trial in selection.trials if trial.term == chosen[0])
    record = {"parameters": parameters, "shapes": selection.table}
    return effect, trial.log_bayes_factor, record


class FinalPosterior(eqx.Module):
    draws: dict
    """name -> (walkers, draws) in the channel's units."""
    units: dict = eqx.field(static=True)
    diagnostics: object


def _active_noise(spec: ModelSpec) -> list[int]:
    return [SLOT_OF[type(effect)] for effect in spec.effects if isinstance(effect, SlotTerm)]


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
    log_posterior = batch_log_density(marginal_log_posterior, fit.design)
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
    beta, precision = batch_profile(fit.design, jnp.asarray(flat))
    beta, precision = np.array(beta), np.asarray(precision)
    n_regressors = fit.beta.size
    noise_draw = rng.standard_normal((flat.shape[0], MAX_REGRESSORS))
    factor = np.linalg.cholesky(np.linalg.inv(precision))
    beta = beta + np.einsum("dij,dj->di", factor, noise_draw)
    slow = slow_columns(fit.spec)
    if slow.size:
        regressors, _, _ = regressor_columns(fit.spec, data)
        level_beta, level_covariance, _ = level_coefficients(
            LevelNoise(
                fit.design.mask, fit.design.ramp_scale, fit.design.floor, fit.spec.gauss_markov_s
            ),
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
        units[name] = parameter_unit(name, data.unit)
    _, scales, coefficient_units = regressor_columns(fit.spec, data)
    coefficient_names = fit.spec.regressor_names()
    coefficients = beta[:, :n_regressors] / np.where(scales > 0, scales, 1.0)
    for position, name in enumerate(coefficient_names):
        draws[name] = coefficients[:, position].reshape(shape)
        units[name] = coefficient_units[position]
    for term, index in fit.spec.regression_terms():
        term.derive(draws, units, index)
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
    frequency = fit.spec.regression_terms_of("sinusoid")[index].frequency_hz
    _, s0 = bin_ratios(fit)
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


# --- the public result -------------------------------------------------------------------


@dataclass(frozen=True)
class FoundEffect:
    """An effect discovery named: what it is, its parameters from the final posterior (each
    ``{mean, sd, q05, q95, unit}``, the 90 % interval), the evidence and where it was
    located."""

    name: str
    """The catalogue's name of the effect (``thermal_bias``, ``rate_random_walk``,
    ``sinusoid``, ``saturation`` ...)."""
    explanation: str
    """What it is and what it does to the record, in a sentence for the user."""
    parameters: dict
    """parameter -> ``{mean, sd, q05, q95, unit}`` from the final model's posterior."""
    evidence: dict
    """log Bayes factor against the model without it (and the threshold), the checks of the
    baseline it answers, the runner-up and whether it is indistinguishable from it."""
    location: dict
    """The baseline check that points to it, with where that check looked."""
    delta_elpd: float
    """Gain in expected log predictive density (nats; AIC-penalised)."""
    delta_elpd_se: float
    """Its standard error, nats (pointwise over frequency bins and block-mean predictions)."""


@dataclass(frozen=True)
class CheckResult:
    """One check of the baseline model, and of the final one.

    Attributes
    ----------
    name : str
        The check (``allan_deviation``, ``spectrum``, ``spectral_line``, ``residual_vs_time``,
        ``residual_vs_temperature``, ``tails``, ``rail``, ``levels``, ``time_stamps`` ...).
    statistic : float
        Its statistic on the baseline model's residual.
    p_value : float
        Its p-value, Bonferroni-corrected over the places it looked.
    location : dict
        Where it points (a tau range, a band, a frequency, a time window, a covariate).
    passed_before, passed_after : bool
        Whether it passed for the baseline model, and for the final one (p >= 0.01).
    p_value_after : float or None
        Its p-value for the final model.
    """

    name: str
    statistic: float
    p_value: float
    location: dict
    passed_before: bool
    passed_after: bool
    p_value_after: float | None = None


@dataclass(frozen=True)
class Discovery:
    """What :func:`discover` found: the effects named (``effects``), every check before and
    after (``checks``), the final model's terms and posterior, and what is left unexplained.

    ``passed`` is whether the final posterior passed its sampler checks (true when no effect
    was found and none was sampled); :meth:`check` raises when it did not.
    """

    channel: str
    """The channel's name."""
    unit: str
    """The channel's unit."""
    rate_hz: float
    """Sample rate, Hz."""
    duration_s: float
    """Length of the record, s."""
    baseline: tuple[str, ...]
    """The starting model's terms, the bias first."""
    effects: tuple[FoundEffect, ...]
    """The effects named, in the order they were accepted."""
    checks: tuple[CheckResult, ...]
    """Every check of the baseline model, with its result for the final one."""
    final_terms: tuple[str, ...]
    """The final model's terms: the baseline's and those of the effects named."""
    unexplained: dict | None
    """A mismatch left with no decisive term: the failing checks, the best candidate and its
    log Bayes factor, what to do."""
    posterior: FinalPosterior | None
    """The final model's posterior (None when nothing was found)."""
    result: SearchResult
    """The fits behind it (for figures and diagnostics)."""

    @property
    def passed(self) -> bool:
        """Whether the final posterior passed its sampler checks (True when nothing was
        found, so nothing was sampled)."""
        return self.posterior is None or bool(self.posterior.diagnostics.passed)

    def check(self) -> "Discovery":
        """Raise :class:`~bayescal.HealthCheckError` when the final posterior failed its
        checks.

        Returns
        -------
        Discovery
            This result, unchanged, when every check passed, so that the call chains
            (``result = capability(...).check()``).

        Raises
        ------
        HealthCheckError
            A check failed; the message names each.
        """
        if not self.passed:
            raise HealthCheckError(
                f"discovery on {self.channel}: the final posterior failed its checks: "
                + "; ".join(self.posterior.diagnostics.failures)
            )
        return self


def _evidence(finding: Finding, result: SearchResult, failed_before, after) -> tuple[dict, str]:
    effect = finding.effect
    evidence = {
        "log_bayes_factor": finding.log_bayes_factor,
        "decisive_above": DECISIVE_LOG_BAYES_FACTOR,
        "baseline_checks_failed": failed_before,
        "checks_passed_after": [
            name for name in failed_before if after.get(name, {}).get("passed")
        ],
    }
    explanation = effect.explanation
    if finding.runner_up:
        runner, runner_score = finding.runner_up
        evidence["runner_up"] = {"name": runner, "log_bayes_factor": runner_score}
        look_alike = CATALOGUE[runner].band == effect.band
        if look_alike and finding.log_bayes_factor - runner_score < AMBIGUOUS_LOG_BAYES_FACTOR:
            evidence["indistinguishable_from"] = runner
            explanation += (
                f" On this recording it cannot be told from {runner} (log Bayes factor "
                f"{finding.log_bayes_factor - runner_score:.1f} between them, below log 10): "
                "both explain the mismatch; a longer recording would decide."
            )
    if isinstance(effect, Quantization) and effect.lsb > 0:
        evidence["log_bayes_factor"] = None  # the samples themselves: no continuous noise
        evidence["grid"] = {
            "lsb": effect.lsb,
            "unit": result.data.unit,
            "levels": finding.search["levels"],
            "samples": int(np.count_nonzero(np.isfinite(result.data.values))),
        }
    if isinstance(effect, OutputFilter):
        evidence["shapes"] = finding.search["shapes"]
    if isinstance(effect, Outliers) and result.outliers:
        evidence["fraction"] = result.outliers["fraction"]
        evidence["flagged_samples"] = int(result.outliers["flagged"].sum())
    if isinstance(effect, Saturation) and result.saturation:
        evidence["rails"] = {
            side: {**rail, "unit": result.data.unit}
            for side, rail in result.saturation["rails"].items()
        }
        values = result.data.values
        evidence["unclipped_mean"] = result.saturation["mean"]
        evidence["unclipped_sd"] = result.saturation["sd"]
        evidence["clipped_mean"] = float(np.nanmean(values))
        evidence["clipped_sd"] = float(np.nanstd(values))
        evidence["unit"] = result.data.unit
    return evidence, explanation


_ADVICE = {
    "high": "the mismatch lies toward Nyquist, where the sensor's output filter, its rounding "
    "and aliasing from a faster internal rate shape the spectrum, and no shape of the "
    "catalogue explains it decisively — check the part's configured bandwidth and output "
    "rate; a record with the filter bypassed or at the internal rate tells the shapes apart "
    "(a longer record does not)",
    "line": "a line that no single sinusoid explains decisively (one that wanders in "
    "frequency or several close lines) — a longer record resolves close lines; a vibration "
    "source nearby shows in every axis",
    "low": "the recording holds too little evidence to name it — record longer, or with more "
    "of what the term needs (a wider temperature swing, a start from power-on)",
}
"""What to do about a mismatch no term explains, by the band it was located in."""
HIGH_FREQUENCY_FRACTION = 0.125
"""A mismatch above this fraction of the sample rate (or at averaging times below its
inverse) lies where the sensor's output filter and rounding act."""


def _located_band(checks: list[dict], failing: list[str], rate_hz: float) -> tuple[str, str]:
    """The band the failing checks located the mismatch in, and where, in words: a spectral
    line; high frequency (spectrum bands or Allan deviation only near Nyquist); else low."""
    located = {check["name"]: check["location"] for check in checks if check["name"] in failing}
    if "spectral_line" in located:
        return "line", f"a line at {located['spectral_line']['frequency_hz']:.6g} Hz"
    high = (
        [
            f"{low:.3g}-{top:.3g} Hz"
            for low, top in [located["spectrum_bands"]["frequency_hz"]]
            if low >= HIGH_FREQUENCY_FRACTION * rate_hz
        ]
        if "spectrum_bands" in located
        else []
    )
    allan = located.get("allan_deviation", {})
    longest = max(allan.get("tau_range_s", [allan.get("tau_s", 0.0)]))
    slow = set(located) - {"spectrum_bands", "allan_deviation"}
    if high and not slow and longest <= 1.0 / (HIGH_FREQUENCY_FRACTION * rate_hz):
        return "high", f"located at {high[0]}"
    where = []
    if "spectrum_bands" in located:
        low, top = located["spectrum_bands"]["frequency_hz"]
        where.append(f"spectrum {low:.3g}-{top:.3g} Hz")
    if allan:
        where.append(f"Allan deviation at tau = {allan['tau_s']:.3g} s")
    return "low", ", ".join(where) or "in the slow residual"


def _merged(effects: list[FoundEffect]) -> list[FoundEffect]:
    """One entry per catalogue name: the grid and the white angle noise Q beyond it are both
    ``quantization``, reported apart within one entry (the grid's LSB and rounding, then Q
    with the evidence the spectrum gave it)."""
    merged: dict[str, FoundEffect] = {}
    for effect in effects:
        first = merged.get(effect.name)
        if first is None:
            merged[effect.name] = effect
            continue
        evidence = dict(first.evidence)
        evidence["white_angle_noise"] = {
            "log_bayes_factor": effect.evidence["log_bayes_factor"],
            "decisive_above": effect.evidence["decisive_above"],
        }
        merged[effect.name] = replace(
            first,
            parameters={**first.parameters, **effect.parameters},
            evidence=evidence,
            delta_elpd=first.delta_elpd + effect.delta_elpd,
            delta_elpd_se=math.hypot(first.delta_elpd_se, effect.delta_elpd_se),
        )
    return list(merged.values())


def describe(result: SearchResult, posterior: FinalPosterior | None) -> Discovery:
    """The public result of a search and its final posterior."""
    after = {check["name"]: check for check in result.final_checks}
    baseline_checks = {check["name"]: check for check in result.baseline_checks}
    failed_before = [c["name"] for c in result.baseline_checks if not c["passed"]]
    effects = []
    for finding in result.findings:
        evidence, explanation = _evidence(finding, result, failed_before, after)
        effects.append(
            FoundEffect(
                name=finding.name,
                explanation=explanation,
                parameters=finding.effect.describe(finding, posterior, result.context)
                if posterior or finding.effect.decided_before_search
                else {},
                evidence=evidence,
                location=finding.effect.location(finding, baseline_checks),
                delta_elpd=finding.delta_elpd,
                delta_elpd_se=finding.delta_elpd_se,
            )
        )
    effects = _merged(effects)
    checks = []
    for check in result.baseline_checks:
        final = after.get(check["name"]) if result.findings else None
        checks.append(
            CheckResult(
                name=check["name"],
                statistic=check["statistic"],
                p_value=check["p_value"],
                location=check["location"],
                passed_before=check["passed"],
                passed_after=final["passed"] if final else check["passed"],
                p_value_after=final["p_value"] if final else None,
            )
        )
    still_failing = [
        check["name"]
        for check in result.final_checks
        if not check["passed"] and check["name"] not in UNMODELLED_CHECKS
    ]
    unexplained = None
    if still_failing and result.undecided:
        name, score = result.undecided
        band, where = _located_band(result.final_checks, still_failing, result.data.rate_hz)
        unexplained = {
            "checks": still_failing,
            "band": band,
            "where": where,
            "best_candidate": name,
            "log_bayes_factor": score,
            "decisive_above": DECISIVE_LOG_BAYES_FACTOR,
            "explanation": f"a mismatch remains ({', '.join(still_failing)}; {where}); the "
            f"term that would explain it best, {name}, is not decisive (log Bayes factor "
            f"{score:.1f}): {_ADVICE[band]}",
        }
    data = result.data
    # The grid's rounding and the output filter are in every model without being its terms.
    spec_terms = result.final.spec.terms()
    return Discovery(
        channel=data.channel,
        unit=data.unit,
        rate_hz=data.rate_hz,
        duration_s=data.duration_s,
        baseline=("bias", *result.baseline.spec.noise),
        effects=tuple(effects),
        checks=tuple(checks),
        final_terms=tuple(dict.fromkeys((*spec_terms, *(f.name for f in result.findings)))),
        unexplained=unexplained,
        posterior=posterior,
        result=result,
    )


def discover(
    y,
    rate_hz: float | None = None,
    *,
    temperature=None,
    accelerometers: dict | None = None,
    baseline=("white",),
    unit: str = "unit",
    temperature_unit: str = "degC",
    accelerometer_unit: str | dict = "m/s^2",
    channel: str = "channel",
    max_effects: int = 4,
    posterior: bool = True,
    seed: int = 0,
    notes: tuple[str, ...] = (),
    progress: Callable[[str], None] | None = None,
) -> Discovery:
    """Find the physics a model of a static channel left out: locate the mismatch, name the
    effect of the catalogue that explains it, model it, and show the fit improve.

    Parameters
    ----------
    y : array_like or Channel
        The channel (NaN marks a missing sample); a :class:`~bayescal.Channel` brings its
        rate, unit and name.
    rate_hz : float
        Sample rate, Hz (from the channel when ``y`` is one).
    temperature : array_like, optional
        The temperature on the same grid (``temperature_unit``), for a thermal bias.
    accelerometers : dict of str to array_like, optional
        Accelerometer channels on the same grid, for a gyro's g-sensitivity; their unit is
        ``accelerometer_unit`` (one for all, or one per name).
    baseline : str or tuple of str
        The noise terms of the starting model besides the bias (white noise always among
        them): what the recording is expected to hold.
    unit, channel : str
        The channel's unit and name, for the parameters and the report.
    max_effects : int
        Stop after this many effects.
    posterior : bool
        Sample the final model's posterior for the effects' parameters (when an effect was
        named); without it, the effects come with their evidence but no parameters.
    seed : int
        Seed of the final posterior's sampler and of the imputation of clipped samples.

    Returns
    -------
    Discovery
        ``effects`` (each with its name, parameters with 90 % intervals and units, and
        evidence), ``checks`` before and after, the final terms and posterior.

    Examples
    --------
    >>> import numpy as np
    >>> import bayescal as bc
    >>> rate, n = 50.0, 2**14
    >>> t = np.arange(n) / rate  # s
    >>> temperature = 25 + 10 * (1 - np.exp(-t / 100))  # degC, warming up
    >>> y = bc.NoiseModel(rate_hz=rate, N=0.007).simulate(n, seed=2) + 0.002 * temperature
    >>> found = bc.discover(y, rate, temperature=temperature, unit="deg/s")
    >>> [effect.name for effect in found.effects]
    ['thermal_bias']
    """
    if hasattr(y, "values") and hasattr(y, "rate_hz"):
        if rate_hz is not None and abs(rate_hz / y.rate_hz - 1) > 1e-9:
            raise InputError(
                f"rate_hz={rate_hz} but the channel {y.channel} is sampled at {y.rate_hz:g} Hz",
                fix="leave rate_hz out for a Channel",
            )
        rate_hz, unit, channel, notes = y.rate_hz, y.unit, y.channel, (*y.notes, *notes)
        if temperature is None and y.temperature is not None:
            temperature = y.temperature
        y = y.values
    if rate_hz is None or not rate_hz > 0:
        raise InputError(f"rate_hz={rate_hz!r} must be a positive sample rate in Hz")
    baseline = (
        tuple(part.strip() for part in baseline.split(","))
        if isinstance(baseline, str)
        else tuple(baseline)
    )
    if max_effects < 1:
        raise InputError(f"--max-effects {max_effects} must be at least 1")
    values = np.asarray(y, dtype=float)
    if temperature is not None:
        temperature = np.asarray(temperature, dtype=float)
        finite = temperature[np.isfinite(temperature)]
        if finite.size == 0 or np.ptp(finite) == 0:
            temperature = None
    accelerometers = {
        name: np.asarray(series, dtype=float) for name, series in (accelerometers or {}).items()
    }
    data = DiscoveryData(
        values=values,
        rate_hz=float(rate_hz),
        channel=channel,
        unit=unit,
        temperature=temperature,
        temperature_unit=temperature_unit,
        covariates=accelerometers,
        covariate_units=(
            dict(accelerometer_unit)
            if isinstance(accelerometer_unit, dict)
            else dict.fromkeys(accelerometers, accelerometer_unit)
        ),
        notes=tuple(notes),
    )
    result = search_effects(
        data, baseline=baseline or ("white",), max_effects=max_effects, progress=progress, seed=seed
    )
    final = sample_final(result.final, data, seed=seed) if result.findings and posterior else None
    return describe(result, final)
