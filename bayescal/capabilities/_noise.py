"""The noise of one static channel: the classical numbers (:mod:`bayescal.classical._noise`)
and, beside them, the posterior of the noise model (:mod:`bayescal.inference._noise_posterior`)."""

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property, partial

import numpy as np

from .._caches import release_compiled_code
from .._errors import InputError
from .._stages import stage
from ..classical._noise import ClassicalNoise, classical_noise
from ..classical._periodogram import longest_run_transform
from ..inference._checks import FitCheck, noise_model_checker
from ..inference._lines_posterior import SpectralLinesFit, lines_posterior
from ..inference._noise_posterior import NoisePosterior, sample_noise
from ..inference._priors import card_prior, default_prior
from ..inference._sampler import Sampler, sampler_of
from ..inference._selection import MAX_REFUSED, TermSelection, refused_term, select_noise_terms
from ..inference._traced import announcing
from ..models._noise_model import NoiseModel
from ..models._noise_problem import NoiseProblem, noise_summaries
from ..models._terms import (
    AUTO,
    CANDIDATE_TERMS,
    DEFAULT_TERMS,
    READINGS,
    check_terms,
    excluded_bands,
    find_in_record,
    left_in,
    parameter_unit,
    parse_terms,
    without_found,
)
from ..models._whittle import MAX_SEGMENT
from ..models.effects.spectral_lines import SpectralLines
from ..recording._inputs import channel_input
from ..recording._levels import discrete_step
from ..recording._sensor_cards import SensorCard, find_card
from ._checked import Checked


@dataclass(frozen=True)
class NoiseFit(Checked):
    """The noise of one static channel: the classical block beside the posterior of the
    noise model (:func:`fit_noise`), and whether that model fits the record.

    ``posterior`` is the ArviZ DataTree of the draws (its ``posterior`` group has one variable
    per parameter: ``bias``, ``N``, ``B``, ``K``, ``Q``, ``R``, ``F`` as fitted, each with its
    unit); :attr:`summary` gives mean, sd, 5 % and 95 % quantiles, the MAP and its Laplace sd
    with units; :attr:`checks` are the model's checks against the record (a posterior of a
    model that does not fit is not healthy, whatever its sampler says); :meth:`check` raises
    when the sampler's checks or the fit's failed.
    """

    @property
    def _check_subject(self) -> str:
        return f"{self.channel}: posterior checks failed"

    channel: str
    """The channel's name."""
    unit: str
    """The channel's unit U; each parameter's unit derives from it (N in U/√Hz ...)."""
    rate_hz: float
    """Sample rate, Hz."""
    classical: ClassicalNoise
    """Student-t bias, sd, Allan deviation with intervals, IEEE 952 readings."""
    fit: NoisePosterior = field(repr=False)
    """The posterior itself (draws, diagnostics, the likelihood's data)."""
    checks: tuple[FitCheck, ...] = ()
    """The checks of the fitted model against the record (Allan deviation, spectrum in octave
    bands, lag-1 autocorrelation: :func:`~bayescal.inference._checks.noise_model_checker`),
    each a :class:`~bayescal.FitCheck` with its place, p-value and whether it passed."""
    selection: TermSelection | None = None
    """How the terms were chosen (``terms="auto"``): every candidate with its Bayes factor
    and why it was kept or left out; None for terms given."""
    lsb: float = 0.0
    """The resolution the samples sit on (zero: none found), channel unit: its rounding error,
    LSB^2 / 12 per sample, is a known white floor in the model, so N is the sensor's white
    noise without it (:attr:`output_white_level` adds it back)."""
    source: str = "<array>"
    """The recording it comes from."""
    notes: tuple[str, ...] = ()
    """What was inferred or noticed (units assumed, a sensor card without the term ...)."""
    lines: SpectralLinesFit | None = None
    """The record's spectral lines, each with its frequency, amplitude (or power and width)
    and intervals, when the model holds the spectral-lines term (``terms="auto"`` always
    looks for them); the noise parameters are then those of the floor between them (the
    record less the lines is what the noise model was fitted to and checked against)."""

    @property
    def terms(self) -> tuple[str, ...]:
        """The noise terms of the fitted model (white noise first)."""
        return self.fit.terms

    @property
    def output_white_level(self) -> float:
        """The white level of the output, rounding included: sqrt(N^2 + LSB^2 / (12 fs)) at
        the posterior mean of N, unit/√Hz — what the Allan curve reads at short tau."""
        return math.sqrt(self.fit.parameters["N"].mean ** 2 + self.lsb**2 / (12 * self.rate_hz))

    @property
    def parameters(self) -> dict:
        """parameter -> its posterior summary (mean, sd, q05, q95, map, map_sd), in the
        parameter's unit (:attr:`summary` gives the unit beside each)."""
        return self.fit.parameters

    @property
    def draws(self) -> dict:
        """parameter -> (walkers, draws) posterior draws."""
        return self.fit.draws

    @property
    def diagnostics(self):
        """The sampler's checks (R-hat, ESS, autocorrelation time, acceptance, MAP)."""
        return self.fit.diagnostics

    @property
    def fits(self) -> bool:
        """Whether the model fits the record: every check of :attr:`checks` passed."""
        return all(check.passed for check in self.checks)

    @property
    def misfits(self) -> tuple[str, ...]:
        """Where the model does not fit the record, and by how much."""
        return tuple(check.misfit for check in self.checks if not check.passed)

    @property
    def passed(self) -> bool:
        """Whether the posterior passed its sampler checks (R-hat, ESS, autocorrelation,
        acceptance, a converged MAP) and the model fits the record."""
        return bool(self.fit.diagnostics.passed) and self.fits

    @property
    def failures(self) -> tuple[str, ...]:
        """The failed sampler checks, then the misfits."""
        return (*self.fit.diagnostics.failures, *(f"model misfit: {m}" for m in self.misfits))

    @property
    def summary(self) -> dict:
        """parameter -> {mean, sd, q05, q95, map, map_sd, unit}: the posterior's 90 %
        interval and the MAP with its Laplace sd, in the parameter's unit."""
        return {
            name: {
                "mean": s.mean,
                "sd": s.sd,
                "q05": s.q05,
                "q95": s.q95,
                "map": s.map,
                "map_sd": s.map_sd,
                "unit": parameter_unit(name, self.unit),
            }
            for name, s in self.fit.parameters.items()
        }

    @cached_property
    def posterior(self):
        """The posterior as an ArviZ DataTree (groups posterior, sample_stats,
        log_likelihood, observed_data)."""
        from ..inference._datatree import noise_datatree

        return noise_datatree(self.fit, self.unit, channel=self.channel, source=self.source)


def noise_priors(
    terms, classical: ClassicalNoise, unit: str, sensor: SensorCard | str | None, fallback: bool
) -> tuple[Callable, tuple[str, ...]]:
    """terms -> the prior of a model with those terms (the weakly informative default, or a
    sensor card's datasheet figures where it gives them), and the notes to pass on. The card
    is checked against ``terms`` (every candidate, for ``auto``): with ``fallback``, a card
    that says nothing of them gives way to the default, with a note; else InputError."""
    if sensor is None:
        return partial(default_prior, allan=classical.allan), ()
    card = find_card(sensor) if isinstance(sensor, str) else sensor
    try:
        card_prior(card, terms, unit, classical.allan)
    except InputError as error:
        if not fallback:
            raise
        note = f"sensor card not used as prior: {error.problem}"
        return partial(default_prior, allan=classical.allan), (note,)
    return partial(card_prior, card, unit=unit, allan=classical.allan, require=False), ()


@dataclass(frozen=True)
class NoisePosteriorFit:
    """A record's noise posterior (:func:`noise_posterior`) with how its terms were chosen
    and how its MAP fits the record."""

    posterior: NoisePosterior
    selection: TermSelection | None
    """How the terms were chosen (``terms="auto"``), else None."""
    lsb: float
    """The resolution the samples are rounded to (zero: none), channel unit."""
    checks: tuple[FitCheck, ...]
    """The posterior-predictive checks of the MAP against the record
    (:func:`~bayescal.inference._checks.noise_model_checker`)."""
    lines: SpectralLinesFit | None = None
    """The record's spectral lines with their intervals, when looked for."""


def _with_what_is_left(checker: Callable, found: dict) -> Callable:
    """``checker`` of models that hold what the terms found in the record leave in it (a
    broadened line, which the record less the sinusoids still carries)."""
    extra = left_in(found)
    if not extra:
        return checker

    def check(model: NoiseModel) -> list[FitCheck]:
        return checker(
            NoiseModel(model.rate_hz, model.bias, lsb=model.lsb, **model.values, **extra)
        )

    return check


def noise_posterior(
    values: np.ndarray,
    rate_hz: float,
    *,
    terms,
    prior_of: Callable,
    unit: str,
    level_values: np.ndarray | None = None,
    allan=None,
    seed: int = 0,
    sampler: Sampler = Sampler(),
) -> NoisePosteriorFit:
    """The posterior of the noise model of ``values`` (NaN: a gap), with its terms chosen by
    evidence among the models that fit when ``terms`` is ``"auto"`` and the grid the samples
    sit on (its rounding a known floor), and its checks. ``level_values`` are the samples
    whose level the bias is (``values`` by default): what a calibration's static sections
    give; ``allan``: the Allan deviation of ``values`` at octave taus when already computed."""
    setup = noise_setup(values, rate_hz, terms, unit, level_values, allan)
    spectral, level, lsb, found = setup.spectral, setup.level, setup.lsb, setup.found
    selection, refused, chosen = None, {}, terms

    def misfit(model) -> str:
        return "; ".join(check.misfit for check in setup.checker(model) if not check.passed)

    # A first run on a machine traces the optimisers: said beside the progress bar.
    with announcing(sampler.progress):
        while True:
            if terms == AUTO:
                # A term whose posterior the sampler could not explore is refused: the search
                # runs again without it.
                candidates = tuple(t for t in CANDIDATE_TERMS if t not in refused)
                with stage("term selection (MAP and Laplace evidence per model)"):
                    selection = select_noise_terms(
                        spectral,
                        level,
                        prior_of,
                        lsb=lsb,
                        misfit=misfit,
                        found=found,
                        candidates=candidates,
                    )
                chosen = selection.terms
            problem = setup.problem(chosen, prior_of)
            with stage("posterior (MAP, emcee, draws)"):
                fit = sample_noise(
                    problem,
                    terms=chosen,
                    seed=seed,
                    n_walkers=sampler.n_walkers,
                    max_steps=sampler.max_steps,
                    progress=sampler.progress,
                )
            culprit = refused_term(fit, selection) if selection is not None else None
            if culprit is None or len(refused) == MAX_REFUSED:
                break
            refused[culprit.term] = culprit
    if refused:
        selection = selection.with_refused(refused)
    return noise_posterior_fit(setup, fit, selection, unit, seed)


@dataclass(frozen=True)
class NoiseSetup:
    """What a record's noise posterior is fitted to and checked against, before any term is
    chosen (:func:`noise_setup`)."""

    lsb: float
    """The resolution the samples are rounded to (zero: none), channel unit."""
    found: dict
    """The terms found in the record (spectral lines), taken out of it."""
    spectral: object
    """The spectral summary (:class:`~bayescal.models._whittle.SpectralSummary`)."""
    level: object
    """The level summary (:class:`~bayescal.models._level.LevelSummary`)."""
    checker: Callable
    """A model -> its checks against the record."""

    def problem(self, terms: tuple[str, ...], prior_of: Callable) -> NoiseProblem:
        """The noise problem of ``terms`` (named, not ``auto``) with the prior of them."""
        return NoiseProblem(self.spectral, self.level, prior_of(terms), lsb=np.asarray(self.lsb))


def noise_setup(values, rate_hz: float, terms, unit: str, level_values=None, allan=None):
    """The :class:`NoiseSetup` of ``values`` (:func:`noise_posterior`'s arguments): the grid
    the samples sit on, the terms found in the record taken out, the summaries of the terms'
    family and the checks."""
    lsb = discrete_step(values)
    family = ("white", *CANDIDATE_TERMS) if terms == AUTO else terms
    # Terms found in the record (spectral lines) are taken out before the noise is fitted:
    # the noise model, its checks and N are of what they leave.
    # The line scan's periodogram of the record and the summaries' are one transform (of its
    # longest gap-free run) where no line is taken out and the summaries take that run in one
    # piece: taken once here and handed to both.
    transform = None
    with stage("spectral lines (periodogram scan)"):
        if SpectralLines.name in family:
            transform = longest_run_transform(values)
        found = find_in_record(family, values, rate_hz, transform)
    if any(finding.found for finding in found.values()):
        values = without_found(found, values)
        if level_values is not None and np.shape(level_values) == np.shape(values):
            level_values = without_found(found, level_values)
        allan, transform = None, None
    if transform is not None and transform.stop - transform.start > MAX_SEGMENT:
        # The summaries take that run in pieces: nothing of it serves them (its increments
        # and transform, 200 MB at 2^23 samples, are let go before they start).
        transform = None
    with stage("summaries (binned periodogram, block means)"):
        spectral, level = noise_summaries(
            values, rate_hz, family, level_values, excluded_bands(found), transform
        )
    checker = _with_what_is_left(noise_model_checker(spectral, values, unit, allan), found)
    return NoiseSetup(lsb, found, spectral, level, checker)


def noise_posterior_fit(
    setup: NoiseSetup, fit: NoisePosterior, selection, unit: str, seed: int
) -> NoisePosteriorFit:
    """A record's :class:`NoisePosteriorFit` from its posterior ``fit``: the spectral lines'
    posterior where the model holds them, and the checks of the MAP against the record."""
    lines = None
    if SpectralLines.name in setup.found and SpectralLines.name in fit.terms:
        with stage("spectral lines' posterior"):
            lines = lines_posterior(setup.found[SpectralLines.name], fit, unit, seed=seed)
    with stage("fit checks (Allan deviation, spectrum, lag-1)"):
        checks = tuple(setup.checker(fit.model_at_map()))
    return NoisePosteriorFit(fit, selection, setup.lsb, checks, lines)


def fit_noise(
    y,
    rate_hz: float | None = None,
    *,
    terms=DEFAULT_TERMS,
    sensor: str | SensorCard | None = None,
    seed: int = 0,
    unit: str | None = None,
    channel: str | None = None,
    confidence: float = 0.95,
    taus="octave",
    sampler: Sampler = Sampler(),
    sensor_fallback: bool = False,
) -> NoiseFit:
    """The noise of a static channel: classical numbers and the posterior of the noise model.

    Parameters
    ----------
    y : array_like or Channel
        The samples (NaN marks a missing one); a :class:`~bayescal.Channel` brings its rate,
        unit and name.
    rate_hz : float
        Sample rate, Hz (from the channel when ``y`` is one).
    terms : str or tuple of str
        ``"auto"`` (the default): white noise and every candidate term the record holds
        decisive evidence for — bias instability, rate random walk, rate ramp, white angle
        noise (quantization), a Gauss-Markov bias and the output filter in one of its shapes
        (one-tap, decimation, Butterworth, biquad) — chosen as
        :func:`~bayescal.inference.select_noise_terms` describes and reported in
        :attr:`NoiseFit.selection`, and the spectral lines a periodogram test finds (taken out
        of the record first: N is then the floor between them; :attr:`NoiseFit.lines`). A
        term whose posterior the sampler cannot explore is refused, and the table says so. Or
        the terms themselves: white, bias_instability, rate_random_walk, quantization,
        rate_ramp, output_filter, decimation_filter, butterworth_filter, biquad_filter,
        gauss_markov, spectral_lines (aliases such as ``rrw``, ``lines`` and ``all`` as on the
        command line).
    sensor : str or SensorCard, optional
        A sensor card (``bayescal sensors``) whose datasheet figures become priors.
    seed : int
        The same inputs and seed give the same posterior.
    unit : str, optional
        The channel's unit (deg/s, m/s^2 ...); parameters are reported in units derived from
        it (IEEE Std 952: N in unit/√Hz, B in unit, K in unit·√Hz ...). A Channel brings
        its own.
    channel : str, optional
        The channel's name, for the result (a Channel's own, else ``"channel"``).
    confidence : float
        Confidence of the classical intervals.
    taus : str, int or array
        Averaging times of the classical Allan deviation (:func:`~bayescal.allan_deviation`).
    sampler : Sampler
        How the posterior is sampled (walkers, most steps, a progress bar):
        :class:`~bayescal.Sampler`.
    sensor_fallback : bool
        When the card says nothing of this kind of channel (or of the fitted terms), use the
        weakly informative prior and say so in ``notes`` instead of raising.

    Returns
    -------
    NoiseFit
        Classical block, posterior (ArviZ DataTree), summary with units, health status.

    Raises
    ------
    InputError
        An unknown term, a card that gives none of the fitted terms, too few samples.

    Examples
    --------
    >>> import bayescal as bc
    >>> model = bc.NoiseModel(rate_hz=100.0, bias=0.4, N=0.0035, K=4e-5)
    >>> y = model.simulate(2**14, seed=3)  # 164 s at 100 Hz
    >>> fit = bc.fit_noise(y, 100.0, terms="white,rrw", unit="deg/s")
    >>> fit.passed, sorted(fit.summary)
    (True, ['K', 'N', 'bias'])
    >>> fit.summary["N"]["unit"]
    'deg/s/sqrt(Hz)'
    """
    release_compiled_code()
    front = _noise_input(
        y, rate_hz, terms, sensor, unit, channel, confidence, taus, sensor_fallback
    )
    posterior = noise_posterior(
        front.data.values,
        front.data.rate_hz,
        terms=front.terms,
        prior_of=front.prior_of,
        unit=front.data.unit,
        allan=front.allan,
        seed=seed,
        sampler=sampler_of(sampler),
    )
    return _noise_fit(front, posterior)


@dataclass(frozen=True)
class NoiseInput:
    """A record's noise fit before its posterior (:func:`prepare_noise`): the channel, its
    classical block, the priors of its terms and, for named terms, the problem to sample."""

    data: object
    """The channel's samples, rate, unit, name and source
    (:func:`~bayescal.recording._inputs.channel_input`)."""
    terms: object
    """The terms (named, or ``auto``)."""
    classical: ClassicalNoise
    prior_of: Callable
    notes: tuple[str, ...]
    allan: object
    """The classical Allan deviation at octave taus, which the checks read (None: other
    taus, computed again)."""
    setup: NoiseSetup | None = None
    """The summaries and checks (:func:`noise_setup`), for named terms."""

    @property
    def problem(self) -> NoiseProblem:
        """The noise problem of the named terms."""
        return self.setup.problem(self.terms, self.prior_of)


def _noise_input(y, rate_hz, terms, sensor, unit, channel, confidence, taus, sensor_fallback):
    data = channel_input(y, rate_hz, unit=unit, channel=channel)
    values, rate_hz, unit, channel = data.values, data.rate_hz, data.unit, data.channel
    terms = parse_terms(terms) if isinstance(terms, str) else check_terms(tuple(terms))
    try:
        with stage("classical (bias, Allan deviation with intervals, readings)"):
            classical = classical_noise(
                values, rate_hz, confidence=confidence, taus=taus, readings=READINGS
            )
    except InputError as error:
        if data.source == "<array>":
            raise
        raise InputError(error.problem, source=data.source, column=channel, fix=error.fix) from None
    family = ("white", *CANDIDATE_TERMS) if terms == AUTO else terms
    prior_of, prior_notes = noise_priors(family, classical, unit, sensor, sensor_fallback)
    # The classical Allan deviation at octave taus is the one the checks read: not again.
    allan = classical.allan if isinstance(taus, str) and taus == "octave" else None
    return NoiseInput(data, terms, classical, prior_of, (*data.notes, *prior_notes), allan)


def prepare_noise(y, rate_hz: float | None = None, *, terms, sensor=None, unit=None):
    """:func:`fit_noise` of named ``terms`` up to its posterior: the :class:`NoiseInput`
    whose problem :func:`finish_noise` takes back with its posterior, sampled elsewhere (a
    fleet's, batched over recordings)."""
    front = _noise_input(y, rate_hz, terms, sensor, unit, None, 0.95, "octave", False)
    if front.terms == AUTO:
        raise ValueError("prepare_noise takes named terms")
    setup = noise_setup(
        front.data.values, front.data.rate_hz, front.terms, front.data.unit, None, front.allan
    )
    return replace(front, setup=setup)


def finish_noise(front: NoiseInput, posterior: NoisePosterior, seed: int) -> NoiseFit:
    """The :class:`NoiseFit` of a :func:`prepare_noise` and the posterior of its problem,
    checked against the record as :func:`fit_noise` checks it."""
    fit = noise_posterior_fit(front.setup, posterior, None, front.data.unit, seed)
    return _noise_fit(front, fit)


def _noise_fit(front: NoiseInput, posterior: NoisePosteriorFit) -> NoiseFit:
    data = front.data
    return NoiseFit(
        channel=data.channel,
        unit=data.unit,
        rate_hz=data.rate_hz,
        classical=front.classical,
        fit=posterior.posterior,
        checks=posterior.checks,
        selection=posterior.selection,
        lsb=posterior.lsb,
        source=data.source,
        notes=front.notes,
        lines=posterior.lines,
    )
