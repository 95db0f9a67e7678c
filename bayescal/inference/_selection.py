"""Which noise terms a record holds: the model chosen by its evidence (``terms="auto"``).

Why evidence, and how it is computed: each candidate term costs parameters the record may not
constrain; the marginal likelihood p(y | model) weighs the fit it buys against the prior
volume it spends (the Occam factor), so a term the record holds no trace of loses evidence and
a flicker, a random walk or a low-pass that shapes the spectrum wins it by many units of log.
The evidence is the Laplace approximation at the MAP — log p(y | theta*) + log p(theta*) +
(d/2) log 2 pi - (1/2) log det H with the prior normalised — the same MAP and Hessian every fit
computes (:func:`~bayescal.inference._optimize.maximum_a_posteriori`).

Search: forward from white noise (the rounding floor of a gridded record included, it is
known), adding at each step a candidate whose Bayes factor is decisive (log BF >= log 100,
Jeffreys' scale; the bar discovery uses too): of those within that bar of the largest, the one
of fewest parameters — the evidence does not tell them apart decisively, and the simpler term
is the one the record asks for (a Gauss-Markov whose correlation time runs past the record is
a random walk to it: on a 10^8-sample record of white noise and a random walk, the Gauss-Markov
term beat the random walk by 0.1 nat, was kept, and misfit the Allan deviation at its longest
tau, 3.2x under the record's); then backward,
dropping any kept term whose Bayes factor against the model without it fell below the bar.
The output filter's shapes (one-tap, decimation, Butterworth, biquad) compete for one place:
the chosen model's filter finally takes the shape of the largest evidence beside its other
terms.

Fit: evidence alone is not enough. A term whose trace lies in the few lowest bins of a short
record (a bias instability under a white floor, 25 minutes long) wins less than log 100 from
the Whittle bins, yet the model without it may misfit the record's Allan deviation at its
longest taus, where its checks look: on 24 simulated 25-minute records with N, B and K, the
evidence alone chose white noise for six that then failed their checks, the true model none.
A chosen model that misfits (``misfit``, the posterior-predictive checks) therefore takes on
left-out terms in the order of their evidence until it fits, and each term so kept says why.
A model that no term mends stays as the evidence chose it, and its misfit is reported.

Cost: every model of a family shares one compiled optimiser. A family is a
:class:`~bayescal.models._noise_problem.NoiseProblem` holding every candidate's parameters;
a model is a mask switching some off (a masked noise scale is zero, a masked filter passes
everything). A masked coordinate's posterior is its normal prior, whose normalised density and
Hessian cancel exactly in the Laplace evidence, so the evidence of a masked model is that of
the model without those coordinates. A family whose models lack a grid term (the Gauss-Markov
term's correlation times, most of the components) leaves the grid out of its summaries and
keeps its parameters, masked: the same log density, at the cost of its few components.
"""

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import equinox as eqx
import numpy as np
from scipy import stats

from .._errors import InputError
from .._threads import in_threads
from ..models._level import LevelSummary
from ..models._noise_model import NoiseModel
from ..models._noise_problem import NoisePrior, NoiseProblem
from ..models._terms import (
    ALL_TERMS,
    CANDIDATE_TERMS,
    FILTER_SHAPE_OF_TERM,
    FOUND_TERMS,
    PARAMETERS,
    PARAMETERS_OF_TERM,
)
from ..models._whittle import SpectralSummary
from ..models.effects._parameter import Context
from ._noise_posterior import map_summary, noise_mode, noise_model
from ._optimize import Mode

DECISIVE_LOG_BAYES_FACTOR = math.log(100.0)
"""The evidence a term must add to be kept: decisive on Jeffreys' scale."""
MAX_REFUSED = 2
"""The most terms refused, one after another, for a posterior the sampler cannot explore."""


@dataclass(frozen=True)
class TermTrial:
    """What the evidence said of one candidate term.

    ``log_bayes_factor`` is for the chosen model against it without the term (a kept term) or
    for the chosen model with the term against it (a term left out); ``reason`` says so in
    words."""

    term: str
    log_bayes_factor: float
    kept: bool
    reason: str


@dataclass(frozen=True)
class TermSelection:
    """The terms chosen for a record (:func:`select_noise_terms`), and why."""

    terms: tuple[str, ...]
    """The chosen terms, white noise first in the canonical order."""
    trials: tuple[TermTrial, ...]
    """Every candidate, with its Bayes factor against the chosen model and the reason."""
    log_evidence: float
    """Laplace log evidence of the chosen model (up to the data's constant)."""
    estimates: dict
    """The chosen model's parameters at its MAP: name -> (value, Laplace sd), in their
    units."""
    context: Context
    """What the parameters' ranges depend on (the record's rate and length, the ramp's
    scale)."""
    threshold: float = DECISIVE_LOG_BAYES_FACTOR

    def interval(self, name: str, level: float = 0.90) -> tuple[float, float]:
        """The Laplace interval of parameter ``name`` at ``level``, taken in its coordinate
        (:meth:`~bayescal.models.effects._parameter.Parameter.interval`): inside its range."""
        value, sd = self.estimates[name]
        z = float(stats.norm.ppf(0.5 + level / 2))
        return PARAMETERS[name].interval(value, sd, self.context, z)

    @property
    def table(self) -> list[dict]:
        """One row per candidate: term, log Bayes factor, kept, reason."""
        return [dataclasses.asdict(trial) for trial in self.trials]

    def with_refused(self, refused: dict[str, TermTrial]) -> "TermSelection":
        """This selection (of a search without the terms ``refused``) with a row for each of
        them — name -> its row when the evidence kept it, its ``reason`` why the sampler
        failed (:func:`refused_term`) — in the canonical order."""
        rows = {trial.term: trial for trial in self.trials}
        for term, kept in refused.items():
            rows[term] = TermTrial(
                term,
                kept.log_bayes_factor,
                False,
                f"refused: the evidence kept it (log BF {kept.log_bayes_factor:.1f}), but the "
                f"sampler could not explore its posterior ({kept.reason}); the model without "
                "it is the one reported",
            )
        trials = tuple(rows[term] for term in ALL_TERMS if term in rows)
        return dataclasses.replace(self, trials=trials)


class _Families:
    """The models of a record's term search, each fitted once: one compiled problem per
    family (the output filter's shape, and whether it holds a grid term), a mask per model."""

    def __init__(self, spectral, level, prior_of, lsb: float):
        self.spectral, self.level = spectral, level
        self.prior_of, self.lsb = prior_of, lsb
        self.problems: dict[tuple[str, ...], NoiseProblem] = {}
        self.evidence: dict[frozenset, float] = {}
        self.fits: dict[frozenset, tuple[NoiseProblem, Mode]] = {}
        components = spectral.components
        self.grids = {
            t.name for t, n in zip(components.terms, components.counts, strict=True) if n > 1
        }

    def _family(self, terms) -> tuple[str, ...]:
        """Every candidate's term, with the output filter of ``terms`` (one-tap by default)."""
        filters = [t for t in terms if t in FILTER_SHAPE_OF_TERM] or ["output_filter"]
        return ("white", *(t for t in CANDIDATE_TERMS if t not in FILTER_SHAPE_OF_TERM), *filters)

    def _problem(self, terms: frozenset) -> NoiseProblem:
        """The problem of the family of ``terms`` (made at its first model). Its summaries
        leave out the components of the grid terms ``terms`` does not hold (the Gauss-Markov
        term's correlation times: 52 of 57 components at 2^20 samples), which weigh zero in
        its models (:meth:`NoiseProblem.of_own_terms`): a solve then costs a fraction, and
        its trace does not depend on the record's duration. Their parameters stay, masked,
        so that the optimiser takes the same path."""
        family = self._family(terms)
        summarised = tuple(t for t in family if t in terms or t not in self.grids)
        if summarised not in self.problems:
            prior = self.prior_of(family)
            self.problems[summarised] = NoiseProblem(
                self.spectral,
                self.level,
                prior,
                lsb=np.asarray(self.lsb),
                mask=np.ones(len(prior.parameters)),
            ).of_own_terms(summarised)
        return self.problems[summarised]

    def log_evidence(self, terms: frozenset) -> float:
        """The Laplace log evidence of the model ``terms`` (fitted at its first asking)."""
        self.fit_all([terms])
        return self.evidence[terms]

    def fit_all(self, models) -> None:
        """Fit each of ``models`` not fitted yet, on :func:`~bayescal._threads.usable_cores`
        threads: the solves are independent (the forward search's candidates, the trials'
        models), and each compiled solve runs outside Python's lock, so two cores take the
        19 solves of a 2^23-sample record's term search from 0.21 s to 0.11-0.12 s. Each
        model's numbers are those of a solve on its own, whatever the thread count."""
        masked = {}
        for terms in dict.fromkeys(models):
            if terms not in self.evidence:
                problem = self._problem(terms)
                active = {p for term in terms for p in PARAMETERS_OF_TERM[term]}
                mask = np.array([float(p in active) for p in problem.parameters])
                masked[terms] = eqx.tree_at(lambda p: p.mask, problem, mask)
        for terms, mode in zip(masked, in_threads(noise_mode, masked.values()), strict=True):
            self.fits[terms] = masked[terms], mode
            self.evidence[terms] = laplace_log_evidence(masked[terms], mode)

    def estimates(self, terms: frozenset) -> dict:
        """name -> (MAP value, Laplace sd) of the parameters of model ``terms``."""
        problem, mode = self.fits[terms]
        values, spread = map_summary(problem, mode)
        active = {p for term in terms for p in PARAMETERS_OF_TERM[term]}
        return {name: (values[name], spread[name]) for name in values if name in active}

    def model(self, terms: frozenset) -> NoiseModel:
        """The noise model ``terms`` at its MAP."""
        values = {name: value for name, (value, _) in self.estimates(terms).items()}
        return noise_model(self.fits[terms][0], values)


def laplace_log_evidence(problem: NoiseProblem, mode: Mode) -> float:
    """The Laplace approximation of log p(y | model) at the MAP ``mode`` (module docstring);
    minus infinity when the MAP did not converge or its Hessian is not positive definite.

    log p(y | theta*) + log p(theta*) with the prior normalised is the log density the
    optimiser maximised (the prior's unnormalised part, -z^2 / 2, is in it) less the log of
    the prior's scales: ``mode.log_density`` serves, with no second pass over the bins."""
    # An optimiser that ran off (a Hessian of NaN) has no evidence: asked for it, slogdet
    # prints a RuntimeWarning on the user's terminal.
    if not mode.converged or not np.all(np.isfinite(mode.hessian)):
        return -math.inf
    sign, log_det = np.linalg.slogdet(mode.hessian)
    if sign <= 0:
        return -math.inf
    return mode.log_density - float(np.sum(np.log(problem.prior.scale))) - 0.5 * float(log_det)


def select_noise_terms(
    spectral: SpectralSummary,
    level: LevelSummary,
    prior_of: Callable[[tuple[str, ...]], NoisePrior],
    *,
    lsb: float = 0.0,
    candidates: tuple[str, ...] = CANDIDATE_TERMS,
    base: tuple[str, ...] = ("white",),
    threshold: float = DECISIVE_LOG_BAYES_FACTOR,
    misfit: Callable[[NoiseModel], str] | None = None,
    found: dict | None = None,
) -> TermSelection:
    """The noise terms a record holds decisive evidence for (module docstring).

    Parameters
    ----------
    spectral, level : SpectralSummary, LevelSummary
        The record's summaries (:func:`~bayescal.models._whittle.spectral_summary`,
        :func:`~bayescal.models._level.level_summary`).
    prior_of : callable
        terms -> the :class:`NoisePrior` of a model with those terms; every model of the
        search gives each parameter the same prior.
    lsb : float
        The resolution the record's samples are rounded to (zero: none), channel unit: its
        white floor LSB^2 / (12 fs) is known and in every model.
    candidates : tuple of str
        The terms tried (:data:`~bayescal.models._terms.CANDIDATE_TERMS`).
    base : tuple of str
        The terms every model holds (white noise always among them).
    threshold : float
        The log Bayes factor a term must add to be kept.
    misfit : callable, optional
        model at its MAP -> where it misfits the record, in words (empty: it fits), e.g. the
        posterior-predictive checks of
        :func:`~bayescal.inference._checks.noise_model_checker`. Given, a chosen model that
        misfits takes on left-out terms, in the order of their evidence, until it fits
        (module docstring).
    found : dict, optional
        What the terms found in the record found there (name -> finding,
        :func:`~bayescal.models._terms.find_in_record`; the summaries are of the record less
        it): such a term is in the model where it found something, by its own test, and its
        row says what that test found. A candidate found in the record that is not in
        ``found`` is neither searched nor listed.

    Returns
    -------
    TermSelection
        The chosen terms, and for every candidate its Bayes factor and why it was kept or
        left out.
    """
    unknown = [t for t in candidates if t not in CANDIDATE_TERMS]
    if unknown:
        raise InputError(f"candidates: {unknown[0]!r} is not a candidate term ({CANDIDATE_TERMS})")
    found = {t: finding for t, finding in (found or {}).items() if t in candidates}
    candidates = tuple(t for t in candidates if t not in FOUND_TERMS)
    families = _Families(spectral, level, prior_of, lsb)

    def gains(model: frozenset, terms) -> dict[str, float]:
        """term -> log BF of ``model`` with ``term`` (in place of its output filter, for a
        filter) against ``model``, the models fitted at once (:meth:`_Families.fit_all`)."""
        families.fit_all([model, *(_with(model, term) for term in terms)])
        chosen = families.log_evidence(model)
        return {term: families.log_evidence(_with(model, term)) - chosen for term in terms}

    model = frozenset({"white", *base}) - set(candidates)
    while True:
        tried = gains(model, [t for t in candidates if t not in model and _fits_in(model, t)])
        best = _simplest_decisive(tried, threshold)
        if best is None:
            break
        model = _with(model, best)
    kept = sorted(model & set(candidates))
    families.fit_all([model - {term} for term in kept])
    for term in kept:  # backward: each kept term still decisive?
        if families.log_evidence(model) - families.log_evidence(model - {term}) < threshold:
            model = model - {term}
    model = _best_shape(model, candidates, gains)
    model, reasons = _shape_n_does_not_bend(families, model, candidates, threshold)
    if misfit is not None:
        model, kept_for_fit = _until_it_fits(families, model, candidates, misfit, gains, threshold)
        reasons |= {
            term: f"kept for the fit (log BF {{factor}}): without it, {misfit_without}"
            for term, misfit_without in kept_for_fit.items()
        }
        # The fit may have swapped a shape back: a reason holds only for where its term is.
        reasons = {t: r for t, r in reasons.items() if (t in model) == r.startswith("kept")}
    present = {t for t, finding in found.items() if finding.found}
    families.fit_all([model - {t} if t in model else _with(model, t) for t in candidates])
    return TermSelection(
        terms=tuple(t for t in ALL_TERMS if t in model | present),
        trials=(
            *(_trial(families, model, t, threshold, reasons.get(t, "")) for t in candidates),
            *(_found_trial(t, finding) for t, finding in found.items()),
        ),
        log_evidence=families.log_evidence(model),
        estimates=families.estimates(model),
        context=families.fits[model][0].context,
        threshold=threshold,
    )


def _simplest_decisive(gains: dict[str, float], threshold: float) -> str | None:
    """The term to add (module docstring, Search): of the terms whose log Bayes factor is at
    least ``threshold``, those within ``threshold`` of the largest, and of them the one of
    fewest parameters (then the largest evidence); None where no term is decisive. The output
    filter's shapes are one term whose shape the evidence chooses at the end
    (:func:`_best_shape`): here each counts as the simplest, the one-tap filter."""
    decisive = {t: g for t, g in gains.items() if g >= threshold}
    if not decisive:
        return None
    top = max(decisive.values())
    rivals = [t for t, g in decisive.items() if g >= top - threshold]
    return min(rivals, key=lambda t: (_parameter_count(t), -decisive[t]))


def _parameter_count(term: str) -> int:
    """The parameters ``term`` adds, for :func:`_simplest_decisive` (a filter shape: one)."""
    return 1 if term in FILTER_SHAPE_OF_TERM else len(PARAMETERS_OF_TERM[term])


def _best_shape(model: frozenset, candidates, gains) -> frozenset:
    """``model`` with its output filter in the shape of the largest evidence. The shapes are
    one term, not rivals for a place to be won decisively: the first shape the forward search
    took was the best beside the terms it had then, and the terms it took later (a rounding
    floor, a slow term) can favour another."""
    if not model & set(FILTER_SHAPE_OF_TERM):
        return model
    shapes = gains(model, [t for t in candidates if t in FILTER_SHAPE_OF_TERM and t not in model])
    best = max(shapes, key=shapes.get, default=None)
    return _with(model, best) if best is not None and shapes[best] > 0 else model


SHAPE_TEST_Z = 2.576
"""|z| of the difference in N between the chosen filter shape and the biquad beyond which the
shape is taken to bend N (two-sided p < 0.01, the checks' level)."""


def _shape_n_does_not_bend(
    families, model: frozenset, candidates, threshold: float
) -> tuple[frozenset, dict]:
    """``model`` with its output filter a biquad where the shape the evidence chose moves N.

    A filter shape with fewer parameters can win the evidence (the Occam factor of the
    biquad's four) while it misshapes the band below the cutoff, where N is read, by a few
    percent: within the fit checks' materiality, yet many of N's sds (a second-order
    Butterworth run at 1 kHz, read at 200 Hz: a one-tap filter won, N 4 % high with a 0.8 %
    sd). The biquad holds the one-tap filter (F up to 0.9) and a second-order filter read
    below its rate, and comes near the others: a digital Butterworth at the output rate only
    to its radius (its zeros at Nyquist within 0.9 of the origin, a notch 25 dB deep, not an
    infinite one), so there the test assumes what holds only nearly. Where the chosen shape
    is right, both estimate N alike, and the biquad's sd is the larger. Hausman's test
    (1978): z = (N_chosen - N_biquad) / sqrt(sd_biquad^2 - sd_chosen^2), the variance of
    the difference of a consistent and an efficient estimator under the simpler model;
    beyond :data:`SHAPE_TEST_Z` the biquad is kept, and says why. Only between shapes the
    evidence does not tell apart decisively: where it does, the biquad is not the
    consistent one."""
    chosen = next((t for t in model if t in FILTER_SHAPE_OF_TERM), None)
    flexible = "biquad_filter"
    if chosen in (None, flexible) or flexible not in candidates:
        return model, {}
    rival = _with(model, flexible)
    # The test needs the biquad consistent, which it is only where it holds the truth: a
    # shape the evidence prefers decisively (a decimation filter's sinc^2, whose zeros a
    # second-order section cannot all place) is not one the biquad may overrule.
    margin = families.log_evidence(model) - families.log_evidence(rival)
    if not margin < threshold:
        return model, {}
    (n_chosen, sd_chosen), (n_rival, sd_rival) = (
        families.estimates(terms)["N"] for terms in (model, rival)
    )
    spread = sd_rival**2 - sd_chosen**2
    if not spread > 0:
        return model, {}
    z = (n_chosen - n_rival) / math.sqrt(spread)
    if abs(z) <= SHAPE_TEST_Z:
        return model, {}
    kept = (
        f"kept (log BF {{factor}}): with {chosen} in its place N is {n_chosen / n_rival:.3f}x "
        f"this shape's, z = {z:+.1f} (Hausman): that shape bends N"
    )
    left_out = f"left out for {flexible} (log BF {{factor}} for this shape): it bends N"
    return rival, {flexible: kept, chosen: left_out}


def _until_it_fits(
    families, model, candidates, misfit, gains, threshold: float
) -> tuple[frozenset, dict]:
    """``model`` with left-out terms added, one at a time, until it fits, and for each term
    added the misfit without it. Greedy, not the fewest terms: at each step the term of the
    largest evidence whose model fits or, where none fits alone, the term of the largest
    evidence when it adds some. Never a term the evidence rejects decisively (log BF below
    -``threshold`` against the model it would join): a filter shape that fits the whole band
    far worse can still mend one check by moving N (a decimation shape, log BF -151 against
    the Butterworth it replaced, mended a chance excess at 0.05-0.1 Hz with N 8.8 % high and
    every check passed). A model that still misfits when no term is left gives way to
    ``model`` as the evidence chose it: its misfit is then reported, not patched by terms that
    do not mend it."""
    chosen, added = model, {}
    problem = misfit(families.model(model))
    while problem:
        # A filter's other shapes too: the shape the evidence chose may be the misfit.
        tried = gains(model, [t for t in candidates if t not in model])
        ranked = sorted(
            (t for t in tried if math.isfinite(tried[t]) and tried[t] > -threshold),
            key=tried.get,
            reverse=True,
        )
        if not ranked:
            return chosen, {}
        term = next((t for t in ranked if not misfit(families.model(_with(model, t)))), None)
        if term is None:
            if not tried[ranked[0]] > 0:
                return chosen, {}
            term = ranked[0]
        added[term] = problem
        model = _with(model, term)
        problem = misfit(families.model(model))
    return model, added


def _fits_in(model: frozenset, term: str) -> bool:
    """Whether ``term`` can be added to ``model`` (one output filter at a time)."""
    return term not in FILTER_SHAPE_OF_TERM or not model & set(FILTER_SHAPE_OF_TERM)


def _with(model: frozenset, term: str) -> frozenset:
    """``model`` with ``term``; a filter shape replaces the model's."""
    if term in FILTER_SHAPE_OF_TERM:
        model = model - set(FILTER_SHAPE_OF_TERM)
    return model | {term}


def _found_trial(term: str, finding) -> TermTrial:
    """The row of a term found in the record: what its own test found."""
    if finding.found:
        return TermTrial(term, finding.log_bayes_factor, True, f"kept: {finding.verdict}")
    return TermTrial(term, finding.log_bayes_factor, False, f"left out: {finding.verdict}")


def _trial(
    families: _Families, model: frozenset, term: str, threshold: float, why_kept: str
) -> TermTrial:
    """The trial of ``term`` against the chosen ``model``; ``why_kept``, a reason the search
    gave for keeping it or leaving it out, with ``{factor}`` where its log Bayes factor goes
    (replaced, not formatted: the misfit it quotes is free text)."""
    bar = f"log {math.exp(threshold):.0f}"
    chosen = families.log_evidence(model)
    if term in model:
        factor = chosen - families.log_evidence(model - {term})
        if why_kept:
            reason = why_kept.replace("{factor}", f"{factor:.1f}")
        else:
            reason = f"kept: log BF {factor:.1f} >= {bar} against the model without it"
        return TermTrial(term, factor, True, reason)
    factor = families.log_evidence(_with(model, term)) - chosen
    rival = next((t for t in model if t in FILTER_SHAPE_OF_TERM), None)
    if why_kept:  # a reason the search gave (a shape that bends N)
        reason = why_kept.replace("{factor}", f"{factor:.1f}")
    elif rival is not None and term in FILTER_SHAPE_OF_TERM and factor > 0:
        # The fit-mending search added terms after the shapes were weighed.
        reason = f"left out: {rival} holds the filter's place (log BF {factor:.1f} for this shape)"
    elif rival is not None and term in FILTER_SHAPE_OF_TERM:
        reason = f"left out: {rival} fits better (log BF {-factor:.1f} against this shape)"
    elif not math.isfinite(factor):
        reason = "left out: its fit did not converge"
    else:
        reason = f"left out: log BF {factor:.1f} < {bar} for adding it"
    return TermTrial(term, factor, False, reason)


def refused_term(posterior, selection: TermSelection) -> TermTrial | None:
    """The term of a posterior whose sampler failed its checks that the search refuses, with
    its row as the evidence kept it and why (in its ``reason``); None when none can be:
    the candidate term (not white noise, not one found in the record) whose parameters have
    the longest autocorrelation time — where a ridge or a second mode holds the walkers."""
    diagnostics = posterior.diagnostics
    if diagnostics.passed:
        return None
    kept = {trial.term: trial for trial in selection.trials if trial.kept}
    longest = {
        term: max(diagnostics.autocorr_time.get(p, 0.0) for p in PARAMETERS_OF_TERM[term])
        for term in selection.terms
        if term in kept and term not in FOUND_TERMS and PARAMETERS_OF_TERM[term]
    }
    if not longest:
        return None
    term = max(longest, key=longest.get)
    failures = "; ".join(diagnostics.failures)
    why = f"{failures}; its parameters' autocorrelation time {longest[term]:.0f} steps"
    return dataclasses.replace(kept[term], reason=why)
