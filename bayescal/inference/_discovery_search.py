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
   report which located mismatches are gone. Once a term is accepted, an earlier
   Gauss-Markov term whose round did not decide it against its runner-up gives way to the
   best other candidate beside the rest where that scores higher (:func:`_revisited`; the
   findings after it are judged again in the model that holds them); where
   the search stops on a candidate that is not decisive but closes every check, the findings
   are judged beside it (:func:`_closing`). Where every check passes, or no term is decisive
   and the level scan is the one check failing, one more round tries a bias step where the
   level scan sees one standing out most, named only on its own decisive Bayes factor with
   every check passing with it: a slow term (a random walk) allows a change of level
   anywhere, so the checks pass beside a step they do not locate, or the level scan locates
   it as a stretch that ends at the step, for which no step is proposed.

Because the candidates compete on the same data, the signatures decide between effects that
raise the same statistic: a thermal polynomial only explains what follows the temperature, a
warm-up only what decays from power-on, a random walk what is spread over the spectrum as
1/f^2, a Gauss-Markov term what flattens below its corner frequency.
"""

import dataclasses
import math
from collections.abc import Callable
from functools import partial

import equinox as eqx
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .._errors import InputError
from ..classical._allan import allan_deviation
from ..models._composite import BASELINE_TERMS, ModelFit, ModelSpec, bin_ratios
from ..models._noise_problem import noise_summaries
from ..models._terms import (
    CANDIDATE_TERMS,
    FILTER_SHAPE_OF_TERM,
    PARAMETERS_OF_TERM,
    parameter_unit,
)
from ..models.effects._base import Effect, SlotTerm
from ..models.effects._catalogue import SEARCHED
from ..models.effects.bias_step import BiasStep
from ..models.effects.gauss_markov import GaussMarkov
from ..models.effects.noise_burst import NoiseBurst
from ..models.effects.outliers import Outliers, outlier_scan, without_outliers
from ..models.effects.output_filter import OutputFilter
from ..models.effects.quantization import Quantization
from ..models.effects.rate_random_walk import RateRandomWalk
from ..models.effects.saturation import Saturation, impute_clipped, saturation_scan
from ..models.effects.spectral_lines import SpectralLines
from ._checks import CHECK_LEVEL, run_checks, spectrum_check
from ._discovery_fit import Context, DiscoveryData, fit_model
from ._located import located_alternative
from ._priors import default_prior
from ._scans import variance_scan
from ._selection import select_noise_terms

DECISIVE_LOG_BAYES_FACTOR = math.log(100.0)
"""Jeffreys' "decisive": odds of 100 to 1."""


UNMODELLED_CHECKS = ("timestamps", "rail")
"""Checks no term of the search answers — the time stamps, and a rail, which the saturation
scan decides before the search: they are reported, but do not start a search."""


HIGH_FREQUENCY_FRACTION = 0.125
"""A mismatch above this fraction of the sample rate (or at averaging times below its
inverse) lies where the sensor's output filter and rounding act."""


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


@dataclasses.dataclass(frozen=True)
class Undecided:
    """The best candidate where the search stopped with a check still failing and no term
    named for it (:func:`_search`): either no candidate was decisive, or the best lost to a
    departure the level scan located (:func:`_named_against`)."""

    name: str
    """The candidate's effect."""
    log_bayes_factor: float
    """Its log Bayes factor: against the model without it, or (with ``against``) against
    that model with the located departure in its place."""
    against: Effect | None = None
    """The located departure
    (:class:`~bayescal.inference._located.LocatedDeparture`) it did not beat; None where it
    was not decisive."""
    closing: Effect | None = None
    """Its term, where it was not decisive but its evidence favours it and every check
    passes with it (:func:`_closing`); None otherwise."""

    @property
    def beside(self) -> tuple[Effect, ...]:
        """What the findings are judged beside (:func:`search_effects`): the departure the
        candidate lost to, or the candidate's term where it closes every check; empty
        otherwise."""
        return tuple(effect for effect in (self.against, self.closing) if effect is not None)


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
    undecided: Undecided | None = None
    """The best candidate when the search stopped with a check still failing and no term
    named for it; None otherwise."""
    saturation: dict | None = None
    withdrawn: tuple = ()
    """Findings the search accepted and then withdrew: a check of their band still failed
    with them in the model (:func:`withdrawn_findings`)."""
    disagreeing: tuple = ()
    """Findings left out of the model because their evidence disagrees with itself: a
    decisive log Bayes factor (from elsewhere than the fits' shared likelihood: an output
    filter's Laplace evidence) beside a negative ELPD gain. Not named; their mismatch is
    reported unexplained with both numbers."""


def check_band(check: dict, rate_hz: float) -> str | None:
    """The band a failing check locates its mismatch in, in the catalogue's words (an
    effect's :attr:`~bayescal.models.effects._base.Effect.band`): "line", "high" (the
    spectrum or the Allan deviation only toward Nyquist), "noise" (the local power over
    time), "samples" (tails, a grid), else "low"; None for a check no term answers."""
    name, location = check["name"], check["location"]
    if name in UNMODELLED_CHECKS:
        return None
    if name == "spectral_line":
        return "line"
    if name == "spectrum_bands":
        return "high" if location["frequency_hz"][0] >= HIGH_FREQUENCY_FRACTION * rate_hz else "low"
    if name == "allan_deviation":
        longest = max(location.get("tau_range_s", [location.get("tau_s", math.inf)]))
        return "high" if longest <= 1.0 / (HIGH_FREQUENCY_FRACTION * rate_hz) else "low"
    if name == "variance_scan":
        return "noise"
    if name in ("tails", "discrete_levels"):
        return "samples"
    return "low"


def withdrawn_findings(
    findings, checks: list[dict], data, answers: Callable[[Finding], bool]
) -> list:
    """The search's findings that are not named, because the model with them still fails a
    check they should have answered: the check that locates them (unless it now locates a
    mismatch apart from the effect, :meth:`~bayescal.models.effects._base.Effect.apart`: a
    line of another source beside a fitted sinusoid); a stationary noise term when the local
    power departs over time (a variance that changes is not a stationary term's) or (for a
    term not tied to a covariate) when any check of its band fails, unless the term alone
    ``answers`` a check (without it, a check that passes would fail: it explains a mismatch
    of its own, and what is left beside it is reported unexplained); and, where any located
    check still fails, any term that answers none. A catalogue entry that absorbs part of a
    mismatch it does not explain is the nearest wrong name."""
    failing = {check["name"]: check for check in checks if not check["passed"]}
    bands = {check_band(check, data.rate_hz) for check in failing.values()} - {None}
    withdrawn = []
    for finding in findings:
        effect = finding.effect
        own = failing.get(effect.located_by)
        covariate = effect.located_by.startswith("residual_vs_")
        in_band = effect.band in bands and not covariate
        stationary = isinstance(effect, SlotTerm) and "noise" in bands
        if own is not None:
            unexplained = not effect.apart(own, data.duration_s)
        else:
            # Beside a mismatch left unexplained, every name must carry its own weight: a
            # check that passes only with it (a name that explains no check of its own is
            # the nearest catalogue entry absorbing part of that mismatch).
            unexplained = (in_band or stationary or bool(bands)) and not answers(finding)
        if unexplained:
            withdrawn.append(finding)
    return withdrawn


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
            f"baseline={baseline!r}: unknown term(s) {', '.join(unknown)}",
            fix=f"use terms among {', '.join(sorted(BASELINE_TERMS))}",
        )
    if "white" not in baseline:
        baseline = ("white", *baseline)
    saturation, unclipped = _saturation(data.values, seed)
    report("fitting the baseline")
    context = Context.of(data, unclipped, unclipped)
    baseline_fit = fit_model(context, ModelSpec.from_names(baseline))
    baseline_checks = run_checks(baseline_fit, data)
    burst = _burst(baseline_checks, data, unclipped, baseline)
    descaled = burst[0].descaled(unclipped, data.rate_hz) if burst else unclipped
    # A noise level that changes and stays (no burst) makes the samples' distribution a
    # mixture of two spreads, which the glitch scan would take for glitches: it is left to
    # the variance scan, which reports it unexplained.
    changing = not burst and _failed(baseline_checks, "variance_scan")
    outliers = None if changing else _decisive(outlier_scan(descaled))
    clean = without_outliers(descaled, outliers["flagged"]) if outliers else descaled
    if burst or outliers:
        context = Context.of(data, unclipped, clean)
        baseline_fit = fit_model(context, ModelSpec.from_names(baseline))
    context, current, findings, disagreeing = _decided_before_search(
        context, baseline_fit, baseline, baseline_checks, saturation, outliers, burst
    )
    checks = baseline_checks if not findings else run_checks(current, data)
    before_search = current
    current, checks, searched, undecided = _search(context, current, checks, max_effects, report)
    # Where a name lost to a located departure (_located), the findings are judged on what
    # is left beside that departure (it is reported unexplained, not held against them);
    # where the best candidate was not decisive but closes every check (_closing), beside
    # that candidate (it is reported undecided, not held against them either).
    beside = undecided.beside if undecided else ()
    judged = (
        run_checks(fit_model(context, current.spec.with_effect(*beside)), data)
        if beside
        else checks
    )

    def answers(finding: Finding) -> bool:
        """Whether the final model without ``finding`` fails a check that passes with it."""
        passing = {check["name"] for check in judged if check["passed"]}
        spec = before_search.spec
        for other in (*searched, *beside):
            if other is not finding:
                spec = spec.with_effect(getattr(other, "effect", other))
        without = run_checks(fit_model(context, spec), data)
        return any(not check["passed"] for check in without if check["name"] in passing)

    # Until what is left stands on the checks of the model without what was withdrawn: a
    # withdrawn term can have hidden what the others leave (a Gauss-Markov term that took
    # a sawtooth's harmonic, beside a sinusoid at its fundamental).
    withdrawn, accepted = [], list(searched)
    while newly := withdrawn_findings(searched, judged, data, answers):
        report(f"withdrawing {', '.join(f.name for f in newly)}: checks still fail there")
        withdrawn += newly
        searched = [finding for finding in searched if finding not in newly]
        spec = before_search.spec
        for finding in searched:
            spec = spec.with_effect(finding.effect)
        current = fit_model(context, spec)
        checks = run_checks(current, data)
        judged = (
            run_checks(fit_model(context, current.spec.with_effect(*beside)), data)
            if beside
            else checks
        )
    searched = _judged_in_final(context, accepted, withdrawn, current)
    report("checking the final model")
    return SearchResult(
        context=context,
        data=data,
        baseline=baseline_fit,
        final=current,
        findings=(*findings, *searched),
        baseline_checks=baseline_checks,
        final_checks=checks,
        outliers=outliers,
        undecided=undecided,
        saturation=saturation,
        withdrawn=tuple(withdrawn),
        disagreeing=tuple(disagreeing),
    )


def _decisive(scan: dict | None) -> dict | None:
    """A sample-level scan when its log Bayes factor is decisive, else None."""
    return scan if scan and scan["log_bayes_factor"] > DECISIVE_LOG_BAYES_FACTOR else None


def _saturation(values: np.ndarray, seed: int):
    """The saturation scan (None where it is not decisive) and the samples with the clipped
    ones imputed."""
    saturation = _decisive(saturation_scan(values))
    unclipped = (
        impute_clipped(values, saturation, np.random.default_rng(seed)) if saturation else values
    )
    return saturation, unclipped


def _failed(checks: list[dict], name: str) -> bool:
    return any(check["name"] == name and not check["passed"] for check in checks)


def _burst(checks: list[dict], data, values: np.ndarray, baseline) -> tuple | None:
    """A noise burst the baseline's variance scan located, with its scan as a decision
    (:func:`_decisive`): log Bayes factor the likelihood ratio less the Schwarz cost of the
    ratio and the log of the stretches tried; ELPD gain the ratio less its AIC cost (start,
    duration, ratio). Decided before the glitch scan, which would take a burst's samples for
    glitches. None where there is none, it is not decisive, or the ``baseline`` refitted to
    ``values`` with the burst scaled down still fails the variance scan (the burst does not
    explain the change in local power)."""
    (scan,) = [check for check in checks if check["name"] == "variance_scan"]
    if scan["passed"] or "places" not in scan:
        return None
    effect = NoiseBurst.from_scan(scan, data.duration_s)
    if effect is None:
        return None
    # A burst that leaves the local power still departing (a noise level that steps and
    # stays, or a change in one band beside it) is not the record's burst: not named.
    descaled = effect.descaled(values, data.rate_hz)
    context = Context.of(data, values, descaled)
    fit = fit_model(context, ModelSpec.from_names(baseline).with_effect(effect))
    if variance_scan(fit, data.rate_hz, data.unit)["p_value"] < CHECK_LEVEL:
        return None
    ratio = scan["log_likelihood_ratio"]
    n_frequencies = np.count_nonzero(np.isfinite(data.values)) // 2
    decision = _decisive(
        {
            "log_bayes_factor": ratio - 0.5 * math.log(n_frequencies) - math.log(scan["places"]),
            "delta_elpd": ratio - 3.0,
            "delta_elpd_se": math.sqrt(2 * ratio),
            "shape_in": scan["shapes"][0],
            "shape_out": scan["shapes"][1],
            "block_s": scan["location"]["block_s"],
            "band_hz": scan["location"]["band_hz"],
        }
    )
    return (effect, decision) if decision else None


def _decided_before_search(
    context: Context, current: ModelFit, baseline, baseline_checks, saturation, outliers, burst
) -> tuple[Context, ModelFit, list, list]:
    """The effects named before the search: clipping, a noise burst and glitches (from their
    scans), the
    grid the samples sit on, and the output filter when the baseline misses power near
    Nyquist. Returns the context (with the filter, if one was decided), the model with them,
    their findings, and the filter's finding where its decisive evidence disagrees with its
    ELPD gain (then left out of the model: :attr:`SearchResult.disagreeing`)."""
    findings, disagreeing = [], []
    burst_effect, burst_scan = burst or (None, None)
    for effect, scan in (
        (Saturation(), saturation),
        (burst_effect, burst_scan),
        (Outliers(), outliers),
    ):
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
                    scan if effect is burst_effect else {},
                )
            )
    if context.lsb > 0:
        findings.append(_grid_finding(context, current))
    rate_hz = context.data.rate_hz
    if _high_band_deficit(baseline_checks, rate_hz) and not current.spec.has("output_filter"):
        decided = decide_output_filter(_less_lines(context), baseline)
        if decided is not None:
            effect, log_bayes_factor, record = decided
            filtered = context.with_lowpass(effect)
            fit = fit_model(filtered, current.spec)
            gain, gain_se = _elpd_difference(fit, current)
            finding = Finding(effect, fit, log_bayes_factor, gain, gain_se, (), record)
            # Decisive Laplace evidence with worse predictions is no evidence: a name needs
            # both (the filter's evidence does not come from the search's likelihood).
            if gain < 0:
                disagreeing.append(finding)
            else:
                context = filtered  # every model from here on sees the filter
                findings.append(finding)
                current = fit
    return context, current, findings, disagreeing


def _search(context: Context, current: ModelFit, checks, max_effects: int, report):
    """Steps 2-4 of the loop (module docstring): while a located check fails, the decisive
    best candidate is added; once every check passes, or no candidate is decisive with the
    level scan the one check failing, a step at the level scan's strongest
    (:func:`_step_beside`). Returns the final model, its checks,
    the findings added and :class:`Undecided` where the search stopped with a check failing
    and no term named for it (else None)."""
    findings, undecided = [], None
    for _ in range(max_effects):
        if not _failing(checks):
            break  # nothing located: nothing left to explain
        report(f"trying terms beyond {', '.join(current.spec.terms())}")
        candidates = _beside_time_constant(context, current, candidate_fits(context, current))
        if not candidates:
            break
        ranked = sorted(candidates.items(), key=lambda item: item[1][0].schwarz, reverse=True)
        name, (fit, search) = ranked[0]
        log_bayes_factor = fit.schwarz - current.schwarz
        if not log_bayes_factor > DECISIVE_LOG_BAYES_FACTOR:
            closing = _closing(context, fit, log_bayes_factor)
            undecided = Undecided(name, float(log_bayes_factor), closing=closing)
            break
        located = located_alternative(context, current, fit.spec.effects[-1])
        if located is not None and not _named_against(context, fit, located):
            # A slow term that absorbs one located departure is the nearest name, not the
            # physics: it must beat the departure itself (module _located).
            against = located.spec.effects[-1]
            undecided = Undecided(name, float(fit.schwarz - located.schwarz), against=against)
            break
        gain, gain_se = _elpd_difference(fit, current)
        runner_up = (
            (ranked[1][0], float(ranked[1][1][0].schwarz - current.schwarz))
            if len(ranked) > 1
            else ()
        )
        findings = [_moved(finding, fit.spec, search) for finding in findings]
        findings.append(
            Finding(fit.spec.effects[-1], fit, log_bayes_factor, gain, gain_se, runner_up, search)
        )
        current = fit
        findings, current = _revisited(context, findings, current, report)
        checks = run_checks(current, context.data)
    # Also where no term was decisive and the level scan is the one check left failing: it
    # can locate a step beside a walk as a stretch that ends at it, which no step is proposed
    # for. Not beside another failing check (a step that makes it pass covers a mismatch of
    # another shape: a sawtooth's Allan deviation at 164 s beside a Gauss-Markov term), nor
    # where a name lost to a located departure (_located judges that one).
    failing = _failing(checks)
    stuck = undecided is not None and undecided.against is None and failing == {BiasStep.located_by}
    if len(findings) < max_effects and (not failing or stuck):
        stepped = _step_beside(context, current)
        if stepped is not None:
            findings.append(stepped[0])
            current, checks, undecided = stepped[0].fit, stepped[1], None
    return current, checks, findings, undecided


def _named_against(context: Context, fit: ModelFit, located: ModelFit) -> bool:
    """Whether the slow term ``fit`` adds is named against the located departure
    (``located``: the current model with it, :func:`located_alternative`): where its log
    Bayes factor against the departure is decisive;
    or, where the evidence does not decide between the two, where with both in the model the
    departure gains nothing decisive beside the term (the term explains it) and the term
    still improves the predictions beside the departure (a positive AIC-penalised ELPD
    gain: the departure does not explain the term away).

    A random walk's realisation can look like one drift or one stretch: beside flicker, a
    walk the truth holds 20.7 nats (expected) beat the drift the level scan located from
    389 s by 4.2 only (the pair study's seed 2; a stretch, 2.6 on seed 4), yet beside that
    drift it still gained 2.0 in ELPD: its wandering is spread over the record, not in the
    one event. A kink that a scale factor puts in a slow ramp is one event: beside it a walk
    or a warm-up that absorbed it gains nothing (ELPD -1.1 to -2.1 on the unknowns'
    records, though the departure beside them was not decisive either, -10.1 to +0.8): it
    is not named. Both numbers are the search's own: the decisive log 100 and the ELPD gain
    it reports beside every finding."""
    if fit.schwarz - located.schwarz > DECISIVE_LOG_BAYES_FACTOR:
        return True
    both = fit_model(context, fit.spec.with_effect(located.spec.effects[-1]))
    explained = not both.schwarz - fit.schwarz > DECISIVE_LOG_BAYES_FACTOR
    return explained and _elpd_difference(both, located)[0] > 0


def _closing(context: Context, fit: ModelFit, log_bayes_factor: float) -> Effect | None:
    """The term ``fit`` adds, where the search stopped on it as the best candidate but not
    decisive: when its evidence still favours it (a positive log Bayes factor) and every
    check passes with it; None otherwise. The findings are then judged
    beside it (:func:`search_effects`): what they leave failing is the term that did not
    reach decisive evidence, reported undecided, not a mismatch they absorbed part of.

    Flicker and a walk whose realisation holds less than its charge beside flicker (the pair
    study's seeds 12 and 15: log Bayes factor 1.7 and 2.1 beside flicker, a realised log
    likelihood ratio of 6.5 and 6.9 nats against its charge of 9.4): flicker alone leaves the
    Allan deviation failing at 20-41 s, where the walk rises, and was withdrawn though it
    was decisive by some 3000 (nothing named); with the walk every check passes."""
    if not log_bayes_factor > 0:
        return None
    if _failing(run_checks(fit, context.data)):
        return None
    return fit.spec.effects[-1]


def _revisited(
    context: Context, findings: list, current: ModelFit, report
) -> tuple[list, ModelFit]:
    """``findings`` and ``current`` (the model with the term just accepted, the last of
    ``findings``) with each earlier Gauss-Markov finding whose round did not decide it
    against its runner-up (their log Bayes factors within the decisive log 100) replaced by
    the best other candidate beside the rest of the model, where that scores higher than
    ``current`` and is decisive beside the rest.

    Only a Gauss-Markov term: its time constant lets it stand in for a walk, or for flicker
    over a band, and moves beside a walk (:func:`_beside_time_constant`). Revisited too, a
    walk accepted first beside a step gave way to a Gauss-Markov term of a long time
    constant (the step pair's seeds 4031 and 4042: over the record the same process as the
    walk, scoring a little higher), two misses where the pair was named.

    The search adds one term a round: a term accepted on a near tie can take what belongs to
    a term that comes later, and the model it ends on score below the pair it should have
    found. Flicker and a walk (the pair study's seeds 14 and 30 as first drawn): the first
    round's best, a Gauss-Markov term (tau 31 s, 33 s), led the walk by 0.1 and 0.2 and
    flicker by 3.8 and 1.3; beside the walk its time constant moved to 0.27 s and 0.20 s
    (:func:`_beside_time_constant`) to take flicker's power at high frequency, and the search
    ended on Gauss-Markov and the walk, 3.3 and 7.1 below flicker and the walk. On seed 0 as
    redrawn the Gauss-Markov term led the walk by 1.3, and flicker (log BF 7.2) came beside
    it where the walk belonged.

    The findings accepted after the one replaced were judged beside it: each is judged again
    in the new model (:func:`_judged_in`), so that its numbers are those of the model that
    holds it (on seed 14 as first drawn the walk's runner-up was flicker, and its log Bayes
    factor was taken beside the Gauss-Markov term). The model holds one Gauss-Markov term at
    most, so a call replaces one finding at most."""
    for index, finding in enumerate(findings[:-1]):
        runner_up = finding.runner_up
        if not isinstance(finding.effect, GaussMarkov) or not runner_up:
            continue
        if finding.log_bayes_factor - runner_up[1] > DECISIVE_LOG_BAYES_FACTOR:
            continue
        rest, alternatives = _others_beside_rest(context, current, finding)
        if not alternatives:
            continue
        _, (fit, search) = max(alternatives.items(), key=lambda item: item[1][0].schwarz)
        log_bayes_factor = float(fit.schwarz - rest.schwarz)
        if not (fit.schwarz > current.schwarz and log_bayes_factor > DECISIVE_LOG_BAYES_FACTOR):
            continue
        effect = fit.spec.effects[-1]
        report(f"{effect.name} in place of {finding.name}: it scores higher beside the rest")
        gain, gain_se = _elpd_difference(fit, rest)
        replaced = (finding.name, float(current.schwarz - rest.schwarz))
        findings[index] = Finding(effect, fit, log_bayes_factor, gain, gain_se, replaced, search)
        current = fit
        findings[index + 1 :] = [
            _judged_in(context, later, current) for later in findings[index + 1 :]
        ]
    return findings, current


def _others_beside_rest(
    context: Context, current: ModelFit, finding: Finding
) -> tuple[ModelFit, dict[str, tuple[ModelFit, dict]]]:
    """``current`` without ``finding``'s term (the rest), and every other catalogue effect
    fitted beside the rest (:func:`candidate_fits`, less ``finding``'s own)."""
    rest = context.fit(ModelSpec(tuple(e for e in current.spec.effects if e is not finding.effect)))
    candidates = candidate_fits(context, rest)
    return rest, {name: proposal for name, proposal in candidates.items() if name != finding.name}


def _judged_in(context: Context, finding: Finding, current: ModelFit) -> Finding:
    """``finding`` judged in ``current``, a model that holds its term, as :func:`_revisited`
    judges the term it puts in place of another: its log Bayes factor and ELPD gain against
    ``current`` without it (the rest), and its runner-up the best other candidate beside the
    rest (none where there is none). These fits only report: the time constants they
    locate are not kept for the search's later rounds, whose search of a term starts where
    its last one ended (:func:`~bayescal.inference._discovery_fit.search_time`)."""
    held = dict(context.time_constants)
    rest, others = _others_beside_rest(context, current, finding)
    context.time_constants = held
    gain, gain_se = _elpd_difference(current, rest)
    runner_up = ()
    if others:
        name, (best, _) = max(others.items(), key=lambda item: item[1][0].schwarz)
        runner_up = (name, float(best.schwarz - rest.schwarz))
    return dataclasses.replace(
        finding,
        fit=current,
        log_bayes_factor=float(current.schwarz - rest.schwarz),
        delta_elpd=gain,
        delta_elpd_se=gain_se,
        runner_up=runner_up,
    )


def _judged_in_final(context: Context, accepted: list, withdrawn: list, current: ModelFit) -> list:
    """The findings ``accepted`` (in the search's order) less those ``withdrawn``, each from
    the first whose round's numbers the final model ``current`` does not stand behind judged
    again in it (:func:`_judged_in`): the first accepted after one withdrawn (its log Bayes
    factor and runner-up were taken beside a term the final model does not hold), or the
    first whose round's model no longer holds its term (a Gauss-Markov term whose time
    constant a later round moved, :func:`_moved`: its numbers were of the term at the time
    constant it had then). Those before it keep their round's numbers, which nothing since
    has changed. Judged at the end, not when the time constant moves: the search's own
    decisions (:func:`_revisited`) read each round's numbers."""
    stale = [accepted.index(finding) + 1 for finding in withdrawn]
    stale += [
        index
        for index, finding in enumerate(accepted)
        if finding not in withdrawn and not finding.fit.spec.has_instance(finding.effect)
    ]
    first = min(stale, default=len(accepted))
    return [
        _judged_in(context, finding, current) if index >= first else finding
        for index, finding in enumerate(accepted)
        if finding not in withdrawn
    ]


def _failing(checks: list[dict]) -> set[str]:
    """The failing checks that a term of the search answers (those not unmodelled)."""
    return {
        check["name"]
        for check in checks
        if not check["passed"] and check["name"] not in UNMODELLED_CHECKS
    }


def _step_beside(context: Context, current: ModelFit) -> tuple[Finding, list] | None:
    """A step at the time the level scan sees standing out most beside ``current`` (a model
    that leaves every check passing, or only the level scan failing with no term decisive
    beside it), with the checks of
    the model with it: where its log Bayes factor is decisive (charged as in the search, the
    log of the samples it was located among included) and every check passes with it; None
    otherwise.

    A slow term's predictive distribution allows a change of level anywhere: a walk fitted
    to a record that also holds a step (a mode change on a wandering bias) leaves the level
    scan passing, and the search, which stops once every check passes, would never look for
    the step beside it (a step of 0.75 sample sd beside a walk of 1.1 over a 10-minute
    record: log Bayes factor 5.7 beside the walk, the log of the samples paid). Or the scan
    fails on a stretch that ends at the step (a step is proposed only where it locates one),
    no term is decisive, and the search stops there (a step of 0.82 sample sd beside a walk
    of 0.62: log Bayes factor 17.2, every check passing with it)."""
    proposal = BiasStep.propose(context, current, anywhere=True)
    if proposal is None:
        return None
    fit, search = proposal
    log_bayes_factor = fit.schwarz - current.schwarz
    if not log_bayes_factor > DECISIVE_LOG_BAYES_FACTOR:
        return None
    checks = run_checks(fit, context.data)
    if _failing(checks):
        return None
    gain, gain_se = _elpd_difference(fit, current)
    effect = fit.spec.effects[-1]
    return Finding(effect, fit, log_bayes_factor, gain, gain_se, (), search), checks


def _beside_time_constant(context: Context, current: ModelFit, candidates: dict) -> dict:
    """``candidates`` with the rate random walk fitted beside the model's Gauss-Markov term
    with its correlation time searched again, where that scores higher.

    Above its corner 1 / (2 pi tau_c) a Gauss-Markov term's spectrum is a random walk's,
    K^2 / (2 pi f)^2 with K^2 = 2 sigma^2 / tau_c: the two differ only below the corner. The
    search fixes a correlation time when it accepts the term; accepted first on a record that
    also holds a random walk, the Gauss-Markov term moves its corner down to take the walk's
    power below it (15 s where the truth was 3.8 s, in a 19-minute record), and beside it at
    that time constant the walk gains nothing (log BF 0.3, where the truth of both expects
    20-30 nats). The model's score with the walk is the maximum over every nonlinear
    parameter, the held one among them. Only the walk: it is the one term whose spectrum is
    the Gauss-Markov term's own tail, so the only one whose evidence the held time constant
    took; re-searched beside any slow term (a flicker, a ramp), the held term let them absorb
    an out-of-catalogue sawtooth (log BF 8.1, 8.2: d61c596, withdrawn). The candidate's record
    says so (``gauss_markov_s``: the searched profile, from which the term's interval is then
    read)."""
    (held,) = [e for e in current.spec.effects if isinstance(e, GaussMarkov)] or [None]
    if held is None or RateRandomWalk.name not in candidates:
        return candidates
    fit, search = candidates[RateRandomWalk.name]

    def make_spec(time_constant):
        return ModelSpec(
            tuple(GaussMarkov(time_constant) if e is held else e for e in fit.spec.effects)
        )

    # Its own profile, kept apart from the held term's (a walk not accepted leaves the held
    # term's time constant where it was).
    found = context.search_time(
        make_spec, f"{held.name} beside {RateRandomWalk.name}", shortest_s=0.0
    )
    if found is None or not found[0].schwarz > fit.schwarz:
        return candidates
    return {**candidates, RateRandomWalk.name: (found[0], {**search, "gauss_markov_s": found[1]})}


def _moved(finding: Finding, spec: ModelSpec, search: dict) -> Finding:
    """``finding`` with its Gauss-Markov term at the correlation time the accepted model
    ``spec`` holds, and the profile searched there (:func:`_beside_time_constant`); itself
    otherwise."""
    if not isinstance(finding.effect, GaussMarkov) or spec.has_instance(finding.effect):
        return finding
    (effect,) = [e for e in spec.effects if isinstance(e, GaussMarkov)]
    return dataclasses.replace(finding, effect=effect, search=search["gauss_markov_s"])


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
    return spectrum["p_value"] < CHECK_LEVEL and any(
        band["frequency_hz"][0] >= HIGH_FREQUENCY_FRACTION * rate_hz
        and band["power_over_model"] < 1
        and band["p_value"] * len(bands) < CHECK_LEVEL
        for band in bands
    )


def _less_lines(context: Context) -> Context:
    """The context of the record less its spectral lines, found as the noise fit finds them
    (the ``spectral_lines`` term, :func:`~bayescal.classical._lines.find_lines`): the
    coherent ones removed, a broadened one's band brought down to its local floor
    (:meth:`~bayescal.classical._lines.LineSearch.flattened`); ``context`` itself when there
    are none. The output filter is decided there: a line, coherent or broadened (a vibration
    sampled by a clock that wanders), lifts the white level a baseline fits to the record (a
    deficit near Nyquist that is none), and a biquad's resonance takes a line for its peak.
    The grid the samples sit on is the record's (the lines' removal takes the samples off
    it)."""
    data = context.data
    lines = SpectralLines.find(context.clean, data.rate_hz)
    if not lines.found:
        return context
    values = lines.flattened(context.clean)
    free = Context.of(eqx.tree_at(lambda d: d.values, data, values), values, values)
    free.lsb = context.lsb
    return free


def decide_output_filter(context: Context, baseline: tuple[str, ...]):
    """The sensor's output filter, when the ``baseline`` fitted to ``context`` (the record
    less its lines, :func:`_less_lines`) misses power near Nyquist: the shape (one-tap,
    decimation, Butterworth, biquad) the record holds decisive evidence for, chosen by Laplace
    evidence among every stationary term (:func:`select_noise_terms`), with its MAP
    parameters and their Laplace 90 % intervals; None when there is no deficit or no shape is
    decisive. Its shape is then fixed for the search (its uncertainty is second order for the
    effects that follow)."""
    data = context.data
    fit = fit_model(context, ModelSpec.from_names(baseline))
    if not _high_band_deficit([spectrum_check(fit.design.summary, *bin_ratios(fit))], data.rate_hz):
        return None
    values = context.clean
    allan = allan_deviation(values, data.rate_hz, "octave")
    selection = select_noise_terms(
        *noise_summaries(values, data.rate_hz, ("white", *CANDIDATE_TERMS)),
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
    names = PARAMETERS_OF_TERM[chosen[0]]
    effect = OutputFilter.from_values(shape, {name: estimates[name][0] for name in names})
    parameters = {"shape": {"value": shape}}
    for name in names:
        value, sd = estimates[name]
        low, high = selection.interval(name)
        parameters[name] = {
            "mean": value,
            "sd": sd,
            "q05": low,
            "q95": high,
            "unit": parameter_unit(name, data.unit),
        }
    trial = next(trial for trial in selection.trials if trial.term == chosen[0])
    record = {"parameters": parameters, "shapes": selection.table}
    return effect, trial.log_bayes_factor, record
