"""The fits discovery compares (:mod:`._discovery_search`): the data of one static channel
(:class:`DiscoveryData`), what every fit of it shares (:class:`Context`: the prior scales, the
samples with clipped ones imputed and outliers replaced, the grid they sit on, the output
filter decided before the search), the MAP fit of one model by its Whittle likelihood
(:func:`fit_model`), the search of a time constant (:func:`search_time`), and the intervals of
the parameters a search located (profile likelihood, delta method, Cramér-Rao).
"""

import itertools
import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from scipy import stats

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._errors import InputError
from ..classical._allan import allan_deviation
from ..models._composite import (
    MAX_REGRESSORS,
    SCALE_SLOTS,
    SLOT_COMPONENTS,
    Design,
    LevelNoise,
    ModelFit,
    ModelSpec,
    above_level_band,
    bin_ratios,
    level_coefficients,
    padded,
    profile,
    profiled_log_posterior,
    regressor_columns,
    shaped,
    slot_prior,
    slot_reference_scales,
    slot_variances,
    slow_columns,
    summary_components,
)
from ..models._whittle import spectral_summary, whittle_log_likelihood
from ..models.effects._base import GRID_POINTS, PARABOLIC_STEPS, SHORTEST_DECAY_S
from ..models.effects.bias_step import PROFILE_DROP as STEP_PROFILE_DROP
from ..models.effects.bias_step import step_profile
from ..recording._levels import discrete_step
from ._checks import CHECK_LEVEL, line_search
from ._mcmc import summarize
from ._optimize import maximum_a_posteriori
from ._scans import level_scan, strongest_step

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
                fix="record longer or widen the window (start=/stop=)",
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
    (:class:`bayescal.models.effects._base.Search`).

    Its fields are set once (:meth:`of`; :meth:`with_lowpass` makes a new context for the
    output filter decided before the search). It keeps two memos that fill as the search
    runs, neither of which a caller sets: the spectral summaries already computed, by the
    parts of a spec they depend on (a pure cache), and the time constant each searched term
    was last located at, from which a later search of the same term starts
    (:func:`search_time`).
    """

    def __init__(
        self, data, prior_scales: dict, n_frequencies: int, unclipped, clean, lowpass=None
    ):
        self.data = data
        self.prior_scales = prior_scales
        self.n_frequencies = n_frequencies
        self.unclipped = unclipped
        """The data with clipped samples imputed (the data itself when nothing is clipped)."""
        self.clean = clean
        """``unclipped`` with the outliers replaced (itself when there are none)."""
        self.lsb = discrete_step(clean)
        """The grid the samples sit on (zero: none): its rounding floor is in every model."""
        self.lowpass = lowpass
        """The output filter decided before the search (:func:`decide_output_filter`), in
        every model of this context; None: none."""
        self.summaries = {}
        """Spectral summaries already computed, by :meth:`ModelSpec.summary_key`."""
        self.time_constants = {}
        """The time constant each searched term was located at, by its key."""

    @classmethod
    def of(cls, data, unclipped: np.ndarray, clean: np.ndarray) -> "Context":
        allan = allan_deviation(clean, data.rate_hz, "octave")
        scales = slot_reference_scales(allan)
        half = np.count_nonzero(np.isfinite(clean)) // 2
        return cls(data, scales, half, unclipped, clean)

    def with_lowpass(self, lowpass) -> "Context":
        """This context with the output filter ``lowpass`` in every model, and its memos
        empty (what they hold was computed without the filter)."""
        return Context(
            self.data, self.prior_scales, self.n_frequencies, self.unclipped, self.clean, lowpass
        )

    def fit(self, spec: ModelSpec) -> ModelFit:
        return fit_model(self, spec)

    def search_time(self, make_spec, key: str, shortest_s: float = SHORTEST_DECAY_S):
        return search_time(self, make_spec, key, shortest_s)

    def line_frequency(self, fit: ModelFit) -> float:
        return line_search(fit, self.data.rate_hz)[1]

    def level_event(self, fit: ModelFit, kind: str):
        """The strongest departure of ``kind`` (a step) the level scan of ``fit`` locates
        beyond its threshold: its time refined to a sample (the CUSUM profile over the two
        blocks either side of it) and the record of the search (the scan's z, the profile's
        90 % interval); None when the scan passes or locates none of that kind. ``kind``
        ``"switches"``: where the scan locates switching levels, the time of every level
        change among its departures (steps, and both ends of stretches), each refined so, in
        order (a tuple), and the record."""
        data = self.data
        scan = level_scan(fit, data.rate_hz, data.unit)
        if scan["p_value"] >= CHECK_LEVEL:
            return None
        block = scan["location"]["block_s"]
        if kind == "switches":
            if scan["location"]["shape"] != "switching levels":
                return None
            switches = self._switches(fit, block)
            if len(switches) < 2:
                return None
            return switches, {"scan_z": scan["location"]["z"], "switches": len(switches)}
        events = [event for event in scan["location"]["events"] if event["kind"] == kind]
        if not events:
            return None
        time_s, interval = self._refined(fit, events[0]["time_s"], block)
        return time_s, {"scan_z": events[0]["z"], "time_interval_s": interval}

    def strongest_step(self, fit: ModelFit):
        """The step the level scan's shapes see standing out most in ``fit``'s residual,
        however little (its scan passing or not: :func:`~._scans.strongest_step`), refined
        to a sample as :meth:`level_event` refines one, and the record of the search; None
        where the record has no step shape."""
        found = strongest_step(fit, self.data.rate_hz)
        if found is None:
            return None
        time_s, z, block_s = found
        time_s, interval = self._refined(fit, time_s, block_s)
        return time_s, {"scan_z": z, "time_interval_s": interval}

    def _switches(self, fit: ModelFit, block_s: float) -> tuple[float, ...]:
        """The times (s) where the residual of ``fit`` switches between two levels: binary
        segmentation by the CUSUM profile (each cut kept while its log-likelihood gain is
        decisive beyond the log of the samples it was chosen among, segments no shorter than
        ``block_s``), the segments' means split in two levels (the split of least
        within-level variance), the switches where the level changes."""
        residual = fit.residual
        size = residual.size
        sd = float(np.nanstd(np.diff(residual)) / math.sqrt(2))
        shortest = max(int(block_s * self.data.rate_hz), 2)
        enough = math.log(size) + math.log(100.0)
        cuts, pending = [], [(0, size)]
        while pending:
            first, last = pending.pop()
            if last - first < 2 * shortest:
                continue
            profile = step_profile(residual, first, last, sd)[shortest - 1 : -shortest + 1]
            if profile.size == 0 or profile.max() < enough:
                continue
            cut = first + shortest + int(np.argmax(profile))
            cuts.append(cut)
            pending += [(first, cut), (cut, last)]
        edges = np.array([0, *sorted(cuts), size])
        means = np.array([np.nanmean(residual[a:b]) for a, b in itertools.pairwise(edges)])
        order = np.sort(means)
        costs = [
            np.var(order[:k]) * k + np.var(order[k:]) * (order.size - k)
            for k in range(1, order.size)
        ]
        if not costs:
            return ()
        split = order[int(np.argmin(costs))]
        high = means > split
        changes = np.flatnonzero(high[1:] != high[:-1]) + 1
        return tuple(float(edges[k] / self.data.rate_hz) for k in changes)

    def _refined(self, fit: ModelFit, time_s: float, block_s: float) -> tuple[float, list]:
        """A level change located near ``time_s`` put on a sample by the CUSUM profile over
        the two blocks of ``block_s`` either side, with the profile's 90 % interval (s)."""
        rate = self.data.rate_hz
        block = block_s * rate
        centre = round(time_s * rate)
        first = max(centre - int(2 * block), 0)
        last = min(centre + int(2 * block), fit.residual.size)
        segment = fit.residual[first:last]
        sd = float(np.nanstd(np.diff(segment)) / math.sqrt(2))
        profile = step_profile(fit.residual, first, last, sd)
        best = int(np.argmax(profile))
        inside = np.flatnonzero(profile >= profile[best] - STEP_PROFILE_DROP)
        to_time = lambda k: float((first + 1 + k) / rate)  # noqa: E731
        return to_time(best), [to_time(inside.min()), to_time(inside.max())]

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


def _design(context: "Context", spec: ModelSpec, values, regressors, n_regressors: int) -> Design:
    """The likelihood's data and prior for ``spec``: the spectral summary of ``values`` with
    the regressors (computed once per :meth:`ModelSpec.summary_key`, shaped by the output
    filter decided before the search) and the noise slots' prior."""
    data = context.data
    key = spec.summary_key()
    if key not in context.summaries:
        summary = padded(
            spectral_summary(
                values,
                data.rate_hz,
                components=SLOT_COMPONENTS,
                regressors=regressors[:, : max(n_regressors, 1)],
                extra_components=summary_components(data.rate_hz, spec.gauss_markov_s or 1.0),
            )
        )
        if context.lowpass is not None:
            summary = shaped(
                summary, context.lowpass.shape_gain(summary.node_frequency, data.rate_hz)
            )
        context.summaries[key] = summary
    location, scale, mask = slot_prior(spec, context.prior_scales)
    return Design(
        context.summaries[key],
        location,
        scale,
        mask,
        (np.arange(MAX_REGRESSORS) < n_regressors).astype(float),
        np.asarray(context.prior_scales["R"]),
        np.asarray(context.lsb**2 / (12.0 * data.rate_hz)),
    )


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
    n_regressors = len(spec.regressor_names())
    design = _design(context, spec, values, regressors, n_regressors)
    summary, mask = design.summary, design.mask
    lowered = design.location - 3.0 * design.mask * SCALE_SLOTS
    mode = maximum_a_posteriori(profiled_log_posterior, design, (design.location, lowered))
    theta, hessian, converged = mode.theta, mode.hessian, mode.converged
    pointwise, beta, precision = _profile_at(design, jnp.asarray(theta))
    beta = np.array(beta)
    try:
        covariance = np.linalg.inv(np.asarray(precision))
    except np.linalg.LinAlgError:
        # A slow column (a step near the record's end) can hold no information in the bins
        # above the block means' band; its block of the covariance is the block means' own
        # (below), so the pseudo-inverse's zero there is replaced. A record of Gauss-Markov
        # noise and a walk (discovery_pairs' seed 1019) located a step at 588 s of 600 s and
        # stopped discovery with a traceback.
        covariance = np.linalg.pinv(np.asarray(precision), hermitian=True)
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


SHORTEST_SAMPLES = 20
"""Where a search's grid of time constants starts, in samples (at least): a best point there
extends the grid toward :data:`FLOOR_SAMPLES` (:func:`search_time`)."""
FLOOR_SAMPLES = 1
"""The shortest time constant a search extends to, in samples. A Gauss-Markov process of
tau_c = 16 samples (0.32 s at 50 Hz) is no white noise: its spectrum turns over at
1 / (2 pi tau_c), a hundredth of the rate, and the record's Schwarz score at 0.32 s was 12.7
above that at the grid's 20 samples, whose model failed the Allan check at 1.3-2.6 s (9 %
low, p = 0.001) and was withdrawn. Only at about a sample period does the corner
(0.16 fs) near Nyquist, where the process, averaged over each sample, becomes white noise to
the record."""


def _shortest_time_constant(data, shortest_s: float) -> float:
    """Where the grid of time constants starts, s: ``shortest_s``, and never below
    :data:`SHORTEST_SAMPLES` samples."""
    return max(shortest_s, SHORTEST_SAMPLES / data.rate_hz)


def _floor_time_constant(data, shortest_s: float) -> float:
    """The shortest time constant searched, s: ``shortest_s``, and never below
    :data:`FLOOR_SAMPLES` samples."""
    return max(shortest_s, FLOOR_SAMPLES / data.rate_hz)


def _time_grid(data, shortest_s: float) -> np.ndarray | None:
    """The searched time constants, up to a third of the record; None when that third is no
    longer than the shortest (a record of seconds: a pad window)."""
    shortest, longest = _shortest_time_constant(data, shortest_s), data.duration_s / 3.0
    if longest <= shortest:
        return None
    return np.geomspace(shortest, longest, GRID_POINTS)


def search_time(
    context: "Context", make_spec, key: str, shortest_s: float = SHORTEST_DECAY_S
) -> tuple[ModelFit, dict] | None:
    """The best fit over a log grid of time constants from ``shortest_s`` (s; at least
    :data:`SHORTEST_SAMPLES` samples) to a third of the record, refined around the best point by the
    midpoints to its neighbours and then by parabolic steps in log time constant (a
    deterministic term with a time constant off by a third leaves a residual that a noise
    term would take up); the profile (time constant, Schwarz score) is returned for the
    interval, sampled also where the parabola puts the ends of the 90 % interval (the profile
    is skewed, and the grid's neighbours of the peak can sit far out on it). A later step
    searches only around the time constant the previous step found for the same term. Where
    the best is the grid's longest time constant, the grid is extended by its own step until
    the score falls, up to the record's length (beyond it a decay is a ramp): a true value
    just past the grid's end would otherwise be located at the end with a zero-width
    interval. Where the best is its shortest, likewise downward, to ``shortest_s`` and at
    least :data:`FLOOR_SAMPLES` samples. None for a record too short to search
    (:func:`_time_grid`)."""
    previous = context.time_constants.get(key)
    if previous is None:
        grid = _time_grid(context.data, shortest_s)
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
    floor = _floor_time_constant(context.data, shortest_s)
    while best == grid[0] and best / step >= floor:
        grid.insert(0, best / step)
        fits[grid[0]] = fit_model(context, make_spec(float(grid[0])))
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
        low, high = floor, context.data.duration_s
        for log_end in (peak[0] - half, peak[0] + half):
            # Capped before exp, which overflows at such an end.
            clipped = min(max(math.exp(min(log_end, math.log(high))), low), high)
            if clipped not in fits:
                fits[clipped] = fit_model(context, make_spec(clipped))
    times = sorted(fits)
    winner = max(times, key=lambda t: fits[t].schwarz)
    context.time_constants[key] = winner
    return fits[winner], {
        "time_constant_s": times,
        "score": [fits[t].schwarz for t in times],
        "estimates": [
            {
                **dict(zip(fits[t].spec.regressor_names(), fits[t].beta, strict=True)),
                "gm_sigma": fits[t].noise["gm_sigma"],
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
