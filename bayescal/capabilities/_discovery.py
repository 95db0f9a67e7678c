"""Discovery: find the physics a model of a static channel left out, add it, show the fit
improve (:func:`discover`; documented for users in docs/guide/discovery.md).

The search itself — the sample-level scans, the fits, the checks, the candidates compared by
their Bayes factors — is :mod:`bayescal.inference._discovery_search`; the final model's
posterior is :mod:`bayescal.inference._discovery_posterior`. Here the channel is checked and
put into the search's data, and what the search found is described for a user: each effect
named with its parameters, evidence and location (:class:`FoundEffect`), every check before
and after (:class:`CheckResult`), and what is left unexplained with the advice that follows
from where it was located (:class:`Discovery`).
"""

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from .._caches import release_compiled_code
from .._errors import InputError
from ..inference._discovery_fit import DiscoveryData
from ..inference._discovery_posterior import FinalPosterior, sample_final
from ..inference._discovery_search import (
    DECISIVE_LOG_BAYES_FACTOR,
    UNMODELLED_CHECKS,
    Finding,
    SearchResult,
    search_effects,
)
from ..inference._sampler import Sampler, sampler_of
from ..models.effects._catalogue import CATALOGUE
from ..models.effects.outliers import Outliers
from ..models.effects.output_filter import OutputFilter
from ..models.effects.quantization import Quantization
from ..models.effects.saturation import Saturation
from ..recording._inputs import channel_input, check_same_length, samples
from ..recording._recording import Channel
from ._checked import Checked
from ._discovery_unexplained import unexplained_of

AMBIGUOUS_LOG_BAYES_FACTOR = math.log(10.0)
"""A runner-up closer than this to the accepted term explains the mismatch about as well:
the two are reported as indistinguishable on this recording."""


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
class Discovery(Checked):
    """What :func:`discover` found: the effects named (``effects``), every check before and
    after (``checks``), the final model's terms and posterior, and what is left unexplained.

    ``passed`` is whether the final posterior passed its sampler checks (true when no effect
    was found and none was sampled); :meth:`check` raises when it did not.
    """

    @property
    def _check_subject(self) -> str:
        return f"discovery on {self.channel}"

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
    def summary(self) -> dict:
        """effect name -> its parameters, each ``{mean, sd, q05, q95, unit}`` (the 90 %
        interval; empty without a final posterior); empty when nothing was found. A second
        effect of one name (a second sinusoid) is ``name_2``."""
        summary, seen = {}, {}
        for effect in self.effects:
            seen[effect.name] = seen.get(effect.name, 0) + 1
            key = effect.name if seen[effect.name] == 1 else f"{effect.name}_{seen[effect.name]}"
            summary[key] = effect.parameters
        return summary

    @property
    def failures(self) -> list[str]:
        """What makes this result fail its checks, in words: the final posterior's sampler
        checks, and each named effect whose log Bayes factor and ELPD gain disagree (decisive
        evidence for it, yet worse predictions with it)."""
        failures = []
        if self.posterior is not None and not self.posterior.diagnostics.passed:
            failures += [f"the final posterior: {f}" for f in self.posterior.diagnostics.failures]
        for finding in self.result.disagreeing:
            failures.append(
                f"{finding.name}: log Bayes factor {finding.log_bayes_factor:.1f} is decisive "
                f"but its ELPD gain is {finding.delta_elpd:.1f} nats: the evidence disagrees "
                "with itself, so it is not named and its mismatch is reported unexplained"
            )
        for effect in self.effects:
            if effect.evidence.get("consistent") is False:
                failures.append(
                    f"{effect.name}: log Bayes factor {effect.evidence['log_bayes_factor']:.1f} "
                    f"is decisive but its ELPD gain is {effect.delta_elpd:.1f} nats: the "
                    "evidence disagrees with itself, so the effect is not established"
                )
        return failures


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
    # The Schwarz score and the AIC-penalised ELPD share the fits' log-likelihood, so they
    # can only disagree where the evidence came from elsewhere (an output filter's Laplace
    # evidence, a scan's): decisive evidence with worse predictions is no evidence.
    decisive = (finding.log_bayes_factor or 0) > DECISIVE_LOG_BAYES_FACTOR
    evidence["consistent"] = not (decisive and finding.delta_elpd < 0)
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


def _merged(effects: list[FoundEffect]) -> list[FoundEffect]:
    """One entry per finding, but one for ``quantization``: the grid and the white angle
    noise Q beyond it are both ``quantization``, reported apart within one entry (the grid's
    LSB and rounding, then Q with the evidence the spectrum gave it)."""
    merged: dict[str, FoundEffect] = {}
    for number, effect in enumerate(effects):
        first = merged.get(effect.name) if effect.name == "quantization" else None
        if first is None:  # every other effect is its own entry (two sinusoids: two lines)
            merged[effect.name if effect.name == "quantization" else str(number)] = effect
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
    unexplained = (
        unexplained_of(result, still_failing) if still_failing or result.disagreeing else None
    )
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
    unit: str | None = None,
    temperature_unit: str = "degC",
    accelerometer_unit: str | dict = "m/s^2",
    channel: str | None = None,
    max_effects: int = 4,
    posterior: bool = True,
    seed: int = 0,
    sampler: Sampler = Sampler(),
    notes: tuple[str, ...] = (),
    log: Callable[[str], None] | None = None,
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
    temperature : array_like or Channel, optional
        The temperature on the same grid, one value per sample of ``y``, for a thermal bias
        (default: the temperature a Channel was prepared with, if any).
    accelerometers : dict of str to array_like or Channel, optional
        Accelerometer channels on the same grid, for a gyro's g-sensitivity.
    baseline : str or tuple of str
        The noise terms of the starting model besides the bias (white noise always among
        them): what the recording is expected to hold.
    unit : str, optional
        The channel's unit, for the parameters and the report (a Channel's own, else
        ``"unit"``).
    temperature_unit : str
        The temperature's unit.
    accelerometer_unit : str or dict of str to str
        The accelerometers' unit, one for all (a Channel's own where it is one) or one per
        name.
    channel : str, optional
        The channel's name (a Channel's own, else ``"channel"``).
    max_effects : int
        Stop after this many effects.
    posterior : bool
        Sample the final model's posterior for the effects' parameters (when an effect was
        named); without it, the effects come with their evidence but no parameters.
    seed : int
        Seed of the final posterior's sampler and of the imputation of clipped samples.
    sampler : Sampler
        How the final posterior is sampled (:class:`~bayescal.Sampler`).
    notes : tuple of str
        Notes to carry into the result (a :class:`~bayescal.Channel` brings its own).
    log : callable, optional
        Called with a line of text at each stage of the search (the command line prints
        them).

    Returns
    -------
    Discovery
        ``effects`` (each with its name, parameters with 90 % intervals and units, and
        evidence), ``checks`` before and after, the final terms and posterior.

    Raises
    ------
    InputError
        Too few samples, a rate or unit that disagrees with a Channel's, a temperature or
        accelerometer series of another length than ``y``, an unknown baseline term.

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
    release_compiled_code()
    sampler = sampler_of(sampler)
    given = channel_input(y, rate_hz, unit=unit, channel=channel)
    if temperature is None:
        temperature = given.temperature
    baseline = (
        tuple(part.strip() for part in baseline.split(","))
        if isinstance(baseline, str)
        else tuple(baseline)
    )
    if max_effects < 1:
        raise InputError(f"max_effects={max_effects} must be at least 1")
    covariates = {name: samples(series, name) for name, series in (accelerometers or {}).items()}
    check_same_length(
        ("y", given.values),
        ("temperature", None if temperature is None else samples(temperature, "temperature")),
        *((f"accelerometers[{name!r}]", series) for name, series in covariates.items()),
    )
    data = DiscoveryData(
        values=given.values,
        rate_hz=given.rate_hz,
        channel=given.channel,
        unit=given.unit,
        temperature=_varying(temperature),
        temperature_unit=temperature_unit,
        covariates=covariates,
        covariate_units=_accelerometer_units(accelerometers or {}, accelerometer_unit),
        notes=(*given.notes, *notes),
    )
    result = search_effects(
        data, baseline=baseline or ("white",), max_effects=max_effects, progress=log, seed=seed
    )
    final = (
        sample_final(result.final, data, seed=seed, sampler=sampler)
        if result.findings and posterior
        else None
    )
    return describe(result, final)


def _varying(temperature) -> np.ndarray | None:
    """The temperature as samples, or None where it is absent or never changes (no thermal
    term can be fitted to it)."""
    if temperature is None:
        return None
    values = samples(temperature, "temperature")
    finite = values[np.isfinite(values)]
    return None if finite.size == 0 or np.ptp(finite) == 0 else values


def _accelerometer_units(accelerometers: dict, given: str | dict) -> dict:
    """name -> unit of each accelerometer series: ``given`` (one for all, or per name), a
    Channel's own where one unit is given for all."""
    if isinstance(given, dict):
        return dict(given)
    return {
        name: series.unit if isinstance(series, Channel) else given
        for name, series in accelerometers.items()
    }
